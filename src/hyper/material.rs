//! Hyperelastic materials of the total Lagrangian formulation: the first
//! Piola–Kirchhoff stress `P(F) = ∂W/∂F` and its tangent `A = ∂P/∂F`, given as
//! its action `dP = A : dF` on a gradient increment (what the matrix-free
//! tangent needs) and, for checks and assembly, as the full 3×3×3×3 array.
//!
//! # Compressible neo-Hookean
//! `W = μ/2 (tr C − 3) − μ ln J + λ/2 (ln J)²`, `C = FᵀF`, `J = det F`:
//! ```text
//! P  = μ F + (λ ln J − μ) F⁻ᵀ
//! dP = μ dF + λ tr(F⁻¹ dF) F⁻ᵀ + (μ − λ ln J) F⁻ᵀ dFᵀ F⁻ᵀ
//! ```
//! using `d ln J = tr(F⁻¹ dF)` and `d(F⁻ᵀ) = −F⁻ᵀ dFᵀ F⁻ᵀ`.
//!
//! # St Venant–Kirchhoff
//! `W = λ/2 (tr E)² + μ E : E`, `E = (C − I)/2`, `S = λ tr(E) I + 2 μ E`:
//! ```text
//! P  = F S
//! dP = dF S + F (λ tr(dE) I + 2 μ dE),   dE = sym(Fᵀ dF)
//! ```
//!
//! # Linear (small strain)
//! `W = λ/2 (tr ε)² + μ ε : ε`, `ε = sym(F) − I` (the small strain of
//! `u`, not frame invariant: for small displacements and rotations):
//! ```text
//! P  = λ tr(ε) I + 2 μ ε
//! dP = λ tr(dF) I + μ (dF + dFᵀ)
//! ```
//! a constant tangent: Newton converges in one iteration where nothing else
//! is nonlinear (contact is).
//!
//! At `F = I` all three are linear elasticity,
//! `dP = λ tr(dF) I + μ (dF + dFᵀ)` — the `D` of
//! [`crate::element::reference::elasticity_matrix`].

use nalgebra::Matrix3;

use crate::element::reference::lame;

/// The full tangent `A[i][J][k][L] = ∂P_iJ / ∂F_kL`.
pub type Tangent4 = [[[[f64; 3]; 3]; 3]; 3];

/// The kind of strain energy.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MaterialModel {
    NeoHookean,
    StVenantKirchhoff,
    /// Small-strain linear elasticity.
    Linear,
}

/// A hyperelastic material: a model with its Lamé parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    pub model: MaterialModel,
    pub lambda: f64,
    pub mu: f64,
}

/// The kinematic quantities of one point that stress and tangent share:
/// `F`, and for neo-Hookean `F⁻ᵀ` and `ln J`.
#[derive(Clone, Copy, Debug)]
pub struct PointState {
    pub f: Matrix3<f64>,
    pub f_inv_t: Matrix3<f64>,
    pub ln_j: f64,
}

impl PointState {
    /// The state at deformation gradient `f`; `None` when `det F ≤ 0` (an
    /// inverted or collapsed element: the energy is undefined there).
    pub fn new(f: Matrix3<f64>) -> Option<PointState> {
        let j = f.determinant();
        if !(j > 0.0 && j.is_finite()) {
            return None;
        }
        let f_inv_t = f.try_inverse()?.transpose();
        Some(PointState {
            f,
            f_inv_t,
            ln_j: j.ln(),
        })
    }
}

impl Material {
    /// A material of `model` from Young's modulus and Poisson's ratio.
    pub fn from_young_poisson(model: MaterialModel, young: f64, poisson: f64) -> Material {
        let (lambda, mu) = lame(young, poisson);
        Material { model, lambda, mu }
    }

    /// The neo-Hookean material of `E`, `ν`.
    pub fn neo_hookean(young: f64, poisson: f64) -> Material {
        Material::from_young_poisson(MaterialModel::NeoHookean, young, poisson)
    }

    /// The small-strain linear material of `E`, `ν`.
    pub fn linear(young: f64, poisson: f64) -> Material {
        Material::from_young_poisson(MaterialModel::Linear, young, poisson)
    }

    /// The St Venant–Kirchhoff material of `E`, `ν`.
    pub fn st_venant_kirchhoff(young: f64, poisson: f64) -> Material {
        Material::from_young_poisson(MaterialModel::StVenantKirchhoff, young, poisson)
    }

    /// The strain energy density `W(F)`.
    pub fn energy(&self, s: &PointState) -> f64 {
        let (l, m) = (self.lambda, self.mu);
        match self.model {
            MaterialModel::NeoHookean => {
                let tr_c = s.f.norm_squared();
                m / 2.0 * (tr_c - 3.0) - m * s.ln_j + l / 2.0 * s.ln_j * s.ln_j
            }
            MaterialModel::StVenantKirchhoff => {
                let e = green_lagrange(&s.f);
                l / 2.0 * e.trace().powi(2) + m * e.norm_squared()
            }
            MaterialModel::Linear => {
                let e = small_strain(&s.f);
                l / 2.0 * e.trace().powi(2) + m * e.norm_squared()
            }
        }
    }

    /// The first Piola–Kirchhoff stress `P(F)`.
    pub fn stress(&self, s: &PointState) -> Matrix3<f64> {
        let (l, m) = (self.lambda, self.mu);
        match self.model {
            MaterialModel::NeoHookean => s.f * m + s.f_inv_t * (l * s.ln_j - m),
            MaterialModel::StVenantKirchhoff => s.f * self.svk_second_pk(&green_lagrange(&s.f)),
            MaterialModel::Linear => self.svk_second_pk(&small_strain(&s.f)),
        }
    }

    /// `dP = A(F) : dF`, the tangent's action on a gradient increment.
    pub fn tangent_action(&self, s: &PointState, df: &Matrix3<f64>) -> Matrix3<f64> {
        let (l, m) = (self.lambda, self.mu);
        match self.model {
            MaterialModel::NeoHookean => {
                // tr(F⁻¹ dF) = F⁻ᵀ : dF.
                let tr = s.f_inv_t.component_mul(df).sum();
                df * m
                    + s.f_inv_t * (l * tr)
                    + s.f_inv_t * df.transpose() * s.f_inv_t * (m - l * s.ln_j)
            }
            MaterialModel::StVenantKirchhoff => {
                let stress = self.svk_second_pk(&green_lagrange(&s.f));
                let fd = s.f.transpose() * df;
                let de = (fd + fd.transpose()) * 0.5;
                let ds = Matrix3::identity() * (l * de.trace()) + de * (2.0 * m);
                df * stress + s.f * ds
            }
            MaterialModel::Linear => {
                Matrix3::identity() * (l * df.trace()) + (df + df.transpose()) * m
            }
        }
    }

    /// The tangent in the form the models share, which the GPU kernel
    /// evaluates from 28 numbers per point (see [`TangentCoefficients`]).
    pub fn tangent_coefficients(&self, s: &PointState) -> TangentCoefficients {
        let (l, m) = (self.lambda, self.mu);
        match self.model {
            MaterialModel::NeoHookean => TangentCoefficients {
                sigma: Matrix3::identity() * m,
                m: Matrix3::zeros(),
                g: s.f_inv_t,
                c: m - l * s.ln_j,
            },
            MaterialModel::StVenantKirchhoff => TangentCoefficients {
                sigma: self.svk_second_pk(&green_lagrange(&s.f)),
                m: s.f * s.f.transpose() * m,
                g: s.f,
                c: m,
            },
            MaterialModel::Linear => TangentCoefficients {
                sigma: Matrix3::identity() * m,
                m: Matrix3::zeros(),
                g: Matrix3::identity(),
                c: m,
            },
        }
    }

    /// The full tangent `A[i][J][k][L]`, from the action on the nine unit
    /// increments `e_k ⊗ e_L`.
    pub fn tangent(&self, s: &PointState) -> Tangent4 {
        let mut a = [[[[0.0; 3]; 3]; 3]; 3];
        for k in 0..3 {
            for ll in 0..3 {
                let mut df = Matrix3::zeros();
                df[(k, ll)] = 1.0;
                let dp = self.tangent_action(s, &df);
                for i in 0..3 {
                    for j in 0..3 {
                        a[i][j][k][ll] = dp[(i, j)];
                    }
                }
            }
        }
        a
    }

    /// `S = λ tr(E) I + 2 μ E`.
    fn svk_second_pk(&self, e: &Matrix3<f64>) -> Matrix3<f64> {
        Matrix3::identity() * (self.lambda * e.trace()) + e * (2.0 * self.mu)
    }
}

/// The tangent action written as
/// ```text
/// dP = dF Σ + M dF + λ (G : dF) G + c G dFᵀ G
/// ```
/// neo-Hookean: `Σ = μ I`, `M = 0`, `G = F⁻ᵀ`, `c = μ − λ ln J`;
/// St Venant–Kirchhoff: `Σ = S`, `M = μ F Fᵀ`, `G = F`, `c = μ`
/// (from `F dS = λ (F : dF) F + μ F Fᵀ dF + μ F dFᵀ F`);
/// linear: `Σ = μ I`, `M = 0`, `G = I`, `c = μ`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TangentCoefficients {
    pub sigma: Matrix3<f64>,
    pub m: Matrix3<f64>,
    pub g: Matrix3<f64>,
    pub c: f64,
}

impl TangentCoefficients {
    /// `dP` for the material's `λ`.
    pub fn apply(&self, lambda: f64, df: &Matrix3<f64>) -> Matrix3<f64> {
        let g_df = self.g.component_mul(df).sum();
        df * self.sigma
            + self.m * df
            + self.g * (lambda * g_df)
            + self.g * df.transpose() * self.g * self.c
    }
}

/// `ε = (F + Fᵀ) / 2 − I`.
fn small_strain(f: &Matrix3<f64>) -> Matrix3<f64> {
    (f + f.transpose()) * 0.5 - Matrix3::identity()
}

/// `E = (FᵀF − I) / 2`.
fn green_lagrange(f: &Matrix3<f64>) -> Matrix3<f64> {
    (f.transpose() * f - Matrix3::identity()) * 0.5
}

#[cfg(test)]
#[path = "material_tests.rs"]
mod tests;
