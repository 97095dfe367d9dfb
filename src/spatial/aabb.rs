//! Axis-aligned boxes.

/// An axis-aligned box; components may be infinite (half-spaces).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub lo: [f64; 3],
    pub hi: [f64; 3],
}

impl Aabb {
    pub fn new(lo: [f64; 3], hi: [f64; 3]) -> Self {
        Aabb { lo, hi }
    }
    /// The smallest box holding `points` (empty for none).
    pub fn around<'a>(points: impl IntoIterator<Item = &'a [f64; 3]>) -> Aabb {
        let mut b = Aabb::new([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for p in points {
            for i in 0..3 {
                b.lo[i] = b.lo[i].min(p[i]);
                b.hi[i] = b.hi[i].max(p[i]);
            }
        }
        b
    }
    pub const EVERYTHING: Aabb = Aabb {
        lo: [f64::NEG_INFINITY; 3],
        hi: [f64::INFINITY; 3],
    };
    pub fn is_finite(&self) -> bool {
        self.lo.iter().chain(&self.hi).all(|v| v.is_finite())
    }
    pub fn is_empty(&self) -> bool {
        (0..3).any(|i| self.lo[i] > self.hi[i])
    }
    pub fn union(&self, o: &Aabb) -> Aabb {
        let mut b = *self;
        for i in 0..3 {
            b.lo[i] = b.lo[i].min(o.lo[i]);
            b.hi[i] = b.hi[i].max(o.hi[i]);
        }
        b
    }
    pub fn intersection(&self, o: &Aabb) -> Aabb {
        let mut b = *self;
        for i in 0..3 {
            b.lo[i] = b.lo[i].max(o.lo[i]);
            b.hi[i] = b.hi[i].min(o.hi[i]);
        }
        b
    }
}
