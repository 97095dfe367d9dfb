//! What the image's values go through before they are a level set: the
//! Gaussian smoothing of the `smooth` key, and the mean gradient that
//! scales ψ.

/// The mean of `|∇v|` (per unit length) at the centres of the voxel cells
/// whose corners straddle `t`; 1 when no cell does.
pub(super) fn mean_slope(size: [usize; 3], v: &[f64], spacing: [f64; 3], t: f64) -> f64 {
    let at = |i: usize, j: usize, k: usize| v[i + size[0] * (j + size[1] * k)];
    let (mut sum, mut count) = (0.0, 0usize);
    for k in 0..size[2] - 1 {
        for j in 0..size[1] - 1 {
            for i in 0..size[0] - 1 {
                let c = [0, 1].map(|a| [0, 1].map(|b| [0, 1].map(|d| at(i + d, j + b, k + a))));
                let flat = c.iter().flatten().flatten();
                let above = flat.clone().filter(|&&x| x > t).count();
                if above == 0 || above == 8 {
                    continue;
                }
                let mut g = [0.0; 3];
                for a in 0..2 {
                    for b in 0..2 {
                        g[0] += c[a][b][1] - c[a][b][0];
                        g[1] += c[a][1][b] - c[a][0][b];
                        g[2] += c[1][a][b] - c[0][a][b];
                    }
                }
                let g = [0, 1, 2].map(|a| 0.25 * g[a] / spacing[a]);
                let m = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
                if m.is_finite() && m > 0.0 {
                    sum += m;
                    count += 1;
                }
            }
        }
    }
    if count == 0 {
        1.0
    } else {
        sum / count as f64
    }
}

/// The values smoothed by a Gaussian of standard deviation `sigma` voxels
/// (separable, truncated at 3σ, the edge samples repeated beyond the image).
pub fn gaussian(size: [usize; 3], values: &[f64], sigma: f64) -> Vec<f64> {
    if sigma <= 0.0 {
        return values.to_vec();
    }
    let radius = (3.0 * sigma).ceil() as isize;
    let w: Vec<f64> = (-radius..=radius)
        .map(|d| (-0.5 * (d as f64 / sigma).powi(2)).exp())
        .collect();
    let total: f64 = w.iter().sum();
    let w: Vec<f64> = w.iter().map(|x| x / total).collect();
    let mut cur = values.to_vec();
    let stride = [1, size[0], size[0] * size[1]];
    for a in 0..3 {
        let mut next = vec![0.0; cur.len()];
        let len = size[a] as isize;
        for (idx, out) in next.iter_mut().enumerate() {
            let s = (idx / stride[a]) % size[a];
            let base = idx - s * stride[a];
            *out = w
                .iter()
                .enumerate()
                .map(|(m, wm)| {
                    let q = (s as isize + m as isize - radius).clamp(0, len - 1) as usize;
                    wm * cur[base + q * stride[a]]
                })
                .sum();
        }
        cur = next;
    }
    cur
}
