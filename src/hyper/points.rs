//! Quadrature points of one body stored flat: per point its physical shape
//! gradients `∇_X N_a` (one per node of the element) and its weight, with
//! the element's nodes per cell as the stride ([`super::problem`] holds one
//! set for the shared inside rule and one for the cut cells' points).

use crate::element::{shape_gradients, ElementOrder};

/// A volume quadrature point: physical shape gradients `∇_X N_a` (one per
/// node of the cell) and weight.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QuadPoint<'a> {
    pub grads: &'a [[f64; 3]],
    pub w: f64,
}

/// Quadrature points stored flat: `grads` holds `stride` gradients per point.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PointSet {
    stride: usize,
    grads: Vec<[f64; 3]>,
    w: Vec<f64>,
}

impl PointSet {
    pub(super) fn new(stride: usize) -> PointSet {
        PointSet {
            stride,
            ..PointSet::default()
        }
    }

    /// Adds the point at reference coordinates `xi` with weight `w`.
    pub(super) fn push(&mut self, order: ElementOrder, xi: [f64; 3], w: f64, inv_h: f64) {
        let start = self.grads.len();
        self.grads.resize(start + self.stride, [0.0; 3]);
        let grads = &mut self.grads[start..];
        shape_gradients(order, xi, grads);
        for g in grads.iter_mut() {
            *g = g.map(|v| v * inv_h);
        }
        self.w.push(w);
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.w.len()
    }

    /// Whether there is no point.
    pub fn is_empty(&self) -> bool {
        self.w.is_empty()
    }

    /// Point `q`.
    pub fn get(&self, q: usize) -> QuadPoint<'_> {
        QuadPoint {
            grads: &self.grads[q * self.stride..(q + 1) * self.stride],
            w: self.w[q],
        }
    }

    /// Points `range`.
    pub fn range(
        &self,
        range: std::ops::Range<usize>,
    ) -> impl ExactSizeIterator<Item = QuadPoint<'_>> + Clone {
        range.map(|q| self.get(q))
    }
}
