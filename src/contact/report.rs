//! The report's `contact` rows: per contact pair and load step, the
//! resultant normal force, contact area, peak pressure and largest
//! penetration, from the slave points' quadrature weights, gaps and
//! pressures.
//!
//! With slave points `k` of current surface weight `w_k`, gap `g_k` and
//! contact pressure `p_k = −λ_N,k ≥ 0` (compression positive):
//! `normal_force = Σ_k w_k p_k`, `contact_area = Σ_{k: p_k > 0} w_k`,
//! `peak_pressure = max_k p_k` and `max_penetration = max(0, max_k −g_k)`
//! (all 0 for a pair without points). `stick_area = Σ_{k sticking} w_k` is
//! the area where friction holds the surfaces together (`|t_T| < μ p`; 0
//! without friction, and on points touching for the first time).
//!
//! `peak_recovered_pressure = max_k −T̂_N,k` is the largest recovered normal
//! traction of the points, the smooth SPR estimate of the peak
//! pressure (0 with the pure penalty method, `T̂_N = 0`); set by
//! [`ContactRow::with_recovered_peak`].
//!
//! The same two measures in the reference configuration, per reference
//! area `dΓ_0 = w_k / J_s,k` (set by [`ContactRow::with_reference_measures`]):
//! `reference_contact_area = Σ_{k: p_k > 0} w_k / J_s,k` and
//! `peak_recovered_nominal_pressure = max_k −T̂_N,k J_s,k` (force per
//! reference area). A small-strain theory (Hertz) does not tell the two
//! configurations apart; under a contact the surface is compressed
//! laterally (`J_s < 1`), so the current measures differ from the
//! reference ones by the surface strain, a few per cent at `p/E ≈ 0.1`.
//!
//! `slave_force` and `master_force` are the resultants `Σ R_c` of the contact
//! residual over each body's dofs, per component (the force the contact
//! exerts on the body is minus that): they balance, `slave_force +
//! master_force = 0`, when the contact forces are equal and opposite; 0 until
//! set by [`ContactRow::with_forces`].

use serde::Serialize;

/// One slave point's contribution: current weight, gap and pressure.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlaveSample {
    pub weight: f64,
    pub gap: f64,
    /// Contact pressure, compression positive.
    pub pressure: f64,
    /// Friction applies and holds (stick).
    pub sticking: bool,
}

/// The slave points of one pair at a converged state, for the ParaView
/// output: current position and normal, gap (`NaN` where the search found
/// no master within its radius), pressure `−λ_N`, recovered pressure
/// `−T̂_N` (compression positive) and friction state (0 off, 1 stick, 2 slip).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ContactPoints {
    pub pair: String,
    pub x: Vec<[f64; 3]>,
    pub normal: Vec<[f64; 3]>,
    pub gap: Vec<f64>,
    pub pressure: Vec<f64>,
    pub recovered_pressure: Vec<f64>,
    pub friction: Vec<f64>,
}

/// `contact {pair, step, normal_force, contact_area, stick_area,
/// peak_pressure, max_penetration, …}` in `report.json`.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct ContactRow {
    pub pair: String,
    pub step: usize,
    pub normal_force: f64,
    pub contact_area: f64,
    pub stick_area: f64,
    pub peak_pressure: f64,
    pub max_penetration: f64,
    pub peak_recovered_pressure: f64,
    pub reference_contact_area: f64,
    pub peak_recovered_nominal_pressure: f64,
    pub slave_force: [f64; 3],
    pub master_force: [f64; 3],
}

impl ContactRow {
    /// The row of pair `pair` at load step `step` from its slave samples.
    pub fn from_samples(pair: &str, step: usize, samples: &[SlaveSample]) -> ContactRow {
        // Sums folded from +0 (an empty float `sum` is −0).
        let area_where = |on: fn(&SlaveSample) -> bool| {
            let weights = samples.iter().filter(|s| on(s)).map(|s| s.weight);
            weights.fold(0.0, |a, w| a + w)
        };
        let forces = samples.iter().map(|s| s.weight * s.pressure);
        ContactRow {
            pair: pair.to_string(),
            step,
            normal_force: forces.fold(0.0, |a, f| a + f),
            contact_area: area_where(|s| s.pressure > 0.0),
            stick_area: area_where(|s| s.sticking),
            peak_pressure: samples.iter().map(|s| s.pressure).fold(0.0, f64::max),
            max_penetration: samples.iter().map(|s| -s.gap).fold(0.0, f64::max),
            peak_recovered_pressure: 0.0,
            reference_contact_area: 0.0,
            peak_recovered_nominal_pressure: 0.0,
            slave_force: [0.0; 3],
            master_force: [0.0; 3],
        }
    }

    /// The row with the reference configuration's contact area and largest
    /// recovered pressure per reference area (module doc).
    pub fn with_reference_measures(
        self,
        reference_contact_area: f64,
        peak_recovered_nominal_pressure: f64,
    ) -> ContactRow {
        ContactRow {
            reference_contact_area,
            peak_recovered_nominal_pressure,
            ..self
        }
    }

    /// The row with the contact residual's resultants on the slave and the
    /// master body.
    pub fn with_forces(self, slave_force: [f64; 3], master_force: [f64; 3]) -> ContactRow {
        ContactRow {
            slave_force,
            master_force,
            ..self
        }
    }

    /// The row with the largest recovered pressure `max_k −T̂_N,k`.
    pub fn with_recovered_peak(self, peak_recovered_pressure: f64) -> ContactRow {
        ContactRow {
            peak_recovered_pressure,
            ..self
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_hand_made_row() {
        let s = |weight, gap, pressure, sticking| SlaveSample {
            weight,
            gap,
            pressure,
            sticking,
        };
        let samples = [
            s(0.5, -0.002, 10.0, true),
            s(0.25, -0.001, 4.0, false),
            s(0.125, 0.0, 0.0, false),
            s(1.0, 0.3, 0.0, false),
        ];
        let row = ContactRow::from_samples("ring", 3, &samples);
        assert_eq!(
            row,
            ContactRow {
                pair: "ring".into(),
                step: 3,
                normal_force: 6.0,
                contact_area: 0.75,
                stick_area: 0.5,
                peak_pressure: 10.0,
                max_penetration: 0.002,
                peak_recovered_pressure: 0.0,
                reference_contact_area: 0.0,
                peak_recovered_nominal_pressure: 0.0,
                slave_force: [0.0; 3],
                master_force: [0.0; 3],
            }
        );
        let json = serde_json::to_string(&row).unwrap();
        assert_eq!(
            json,
            r#"{"pair":"ring","step":3,"normal_force":6.0,"contact_area":0.75,"stick_area":0.5,"peak_pressure":10.0,"max_penetration":0.002,"peak_recovered_pressure":0.0,"reference_contact_area":0.0,"peak_recovered_nominal_pressure":0.0,"slave_force":[0.0,0.0,0.0],"master_force":[0.0,0.0,0.0]}"#
        );
        let empty = ContactRow::from_samples("none", 0, &[]);
        assert_eq!(
            (
                empty.normal_force,
                empty.contact_area,
                empty.peak_pressure,
                empty.max_penetration
            ),
            (0.0, 0.0, 0.0, 0.0)
        );
        let forced = row.with_forces([1.0, 2.0, 3.0], [-1.0, -2.0, -3.0]);
        assert_eq!(
            (forced.slave_force, forced.master_force, forced.normal_force),
            ([1.0, 2.0, 3.0], [-1.0, -2.0, -3.0], 6.0)
        );
        assert_eq!(forced.with_recovered_peak(9.5).peak_recovered_pressure, 9.5);
    }
}
