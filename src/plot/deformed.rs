//! `deformed.svg` (`run --plots`): the body's boundary surface in its
//! deformed shape, seen orthographically, coloured by a scalar (von Mises)
//! with a colour bar.
//!
//! **View.** The eye looks along `−e`, `e = (1, −1.5, 1.2)/|·|` (from the
//! front right, above), with `z` up: a point `x` is drawn at the screen
//! coordinates `(x·r, x·v)`, `r = normalize(ẑ × e)`, `v = e × r`, scaled to
//! fit the picture with equal scales, and its depth is `x·e` (larger is
//! nearer). **Painter's algorithm.** Triangles are filled far to near, by the
//! depth of their centroid, so nearer ones cover farther ones (exact for a
//! convex surface, close for others). **Colour.** A triangle gets the mean of
//! its vertices' values mapped linearly from `[min, max]` onto a
//! viridis-like ramp (piecewise linear through five colours), darkened by
//! `0.55 + 0.45 |n·e|` (`n` its unit normal) so that the shape reads.

use plotters::prelude::*;

use crate::error::{Error, Result};

/// What [`deformed_svg`] draws: triangles on deformed positions with one
/// value per vertex.
#[derive(Clone, Copy, Debug)]
pub struct SurfacePicture<'a> {
    pub title: &'a str,
    /// The deformed vertex positions.
    pub points: &'a [[f64; 3]],
    pub triangles: &'a [[u32; 3]],
    /// One value per vertex (von Mises).
    pub values: &'a [f64],
    /// The name of the values, on the colour bar.
    pub label: &'a str,
}

/// Picture size in pixels and the width of the colour-bar panel.
const SIZE: (u32, u32) = (760, 600);
const BAR_PANEL: u32 = 140;

/// Anchor colours of the ramp, from the lowest value to the highest.
const RAMP: [(f64, f64, f64); 5] = [
    (68.0, 1.0, 84.0),
    (59.0, 82.0, 139.0),
    (33.0, 145.0, 140.0),
    (94.0, 201.0, 98.0),
    (253.0, 231.0, 37.0),
];

/// The ramp's colour at `s ∈ [0, 1]` (clamped), darkened by `shade ∈ [0, 1]`.
fn ramp(s: f64, shade: f64) -> RGBColor {
    let s = if s.is_finite() {
        s.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let t = s * (RAMP.len() - 1) as f64;
    let i = (t.floor() as usize).min(RAMP.len() - 2);
    let f = t - i as f64;
    let (a, b) = (RAMP[i], RAMP[i + 1]);
    let mix = |p: f64, q: f64| ((p + f * (q - p)) * shade).round().clamp(0.0, 255.0) as u8;
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn normalize(a: [f64; 3]) -> [f64; 3] {
    let n = dot(a, a).sqrt();
    if n > 0.0 {
        a.map(|x| x / n)
    } else {
        a
    }
}

/// The eye direction `e` and the screen axes `r`, `v` (see the module doc).
fn view() -> ([f64; 3], [f64; 3], [f64; 3]) {
    let e = normalize([1.0, -1.5, 1.2]);
    let r = normalize(cross([0.0, 0.0, 1.0], e));
    let v = cross(e, r);
    (e, r, v)
}

/// The triangles' indices far to near (by the depth of their centroids).
fn painter_order(points: &[[f64; 3]], triangles: &[[u32; 3]], e: [f64; 3]) -> Vec<usize> {
    let depth: Vec<f64> = triangles
        .iter()
        .map(|t| t.iter().map(|&i| dot(points[i as usize], e)).sum::<f64>() / 3.0)
        .collect();
    let mut order: Vec<usize> = (0..triangles.len()).collect();
    order.sort_by(|&a, &b| depth[a].total_cmp(&depth[b]));
    order
}

/// The picture as an SVG document. Fails with [`Error::Plot`] when drawing
/// fails.
pub fn deformed_svg(p: &SurfacePicture) -> Result<String> {
    let plot_error = |e: &dyn std::fmt::Display| Error::Plot {
        title: p.title.to_string(),
        reason: e.to_string(),
    };
    let (e, r, v) = view();
    let finite = p.values.iter().copied().filter(|x| x.is_finite());
    let lo = finite.clone().fold(f64::INFINITY, f64::min);
    let hi = finite.fold(f64::NEG_INFINITY, f64::max);
    let (lo, hi) = if lo <= hi { (lo, hi) } else { (0.0, 0.0) };
    let span = if hi > lo { hi - lo } else { 1.0 };
    // Screen coordinates and the scale that fits them into the view panel.
    let screen: Vec<(f64, f64)> = p.points.iter().map(|&x| (dot(x, r), dot(x, v))).collect();
    let (mut s0, mut s1) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for &(a, b) in &screen {
        s0 = [s0[0].min(a), s0[1].min(b)];
        s1 = [s1[0].max(a), s1[1].max(b)];
    }
    let (w, h) = ((SIZE.0 - BAR_PANEL) as f64, SIZE.1 as f64);
    let (top, margin) = (40.0, 20.0);
    let extent = ((s1[0] - s0[0]) / (w - 2.0 * margin)).max((s1[1] - s0[1]) / (h - top - margin));
    let scale = if extent > 0.0 { 1.0 / extent } else { 1.0 };
    let centre = [0.5 * (s0[0] + s1[0]), 0.5 * (s0[1] + s1[1])];
    let pixel = |i: u32| {
        let (a, b) = screen[i as usize];
        (
            (0.5 * w + (a - centre[0]) * scale).round() as i32,
            (0.5 * (h + top - margin) - (b - centre[1]) * scale).round() as i32,
        )
    };
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(|e| plot_error(&e))?;
        root.draw(&Text::new(p.title, (12, 12), ("sans-serif", 18)))
            .map_err(|e| plot_error(&e))?;
        for t in painter_order(p.points, p.triangles, e) {
            let tri = p.triangles[t];
            let x = tri.map(|i| p.points[i as usize]);
            let n = normalize(cross(
                [0, 1, 2].map(|a| x[1][a] - x[0][a]),
                [0, 1, 2].map(|a| x[2][a] - x[0][a]),
            ));
            let mean = tri.iter().map(|&i| p.values[i as usize]).sum::<f64>() / 3.0;
            let colour = ramp((mean - lo) / span, 0.55 + 0.45 * dot(n, e).abs());
            let corners: Vec<(i32, i32)> = tri.iter().map(|&i| pixel(i)).collect();
            root.draw(&Polygon::new(corners, colour.filled()))
                .map_err(|e| plot_error(&e))?;
        }
        // The colour bar: 64 bands from the lowest value (bottom) up.
        let x0 = (SIZE.0 - BAR_PANEL) as i32 + 20;
        let x1 = x0 + 24;
        let (y0, y1) = (70, SIZE.1 as i32 - 50);
        let bands = 64;
        for k in 0..bands {
            let ya = y1 - (y1 - y0) * k / bands;
            let yb = y1 - (y1 - y0) * (k + 1) / bands;
            let colour = ramp((k as f64 + 0.5) / bands as f64, 1.0);
            root.draw(&Rectangle::new([(x0, yb), (x1, ya)], colour.filled()))
                .map_err(|e| plot_error(&e))?;
        }
        root.draw(&Rectangle::new([(x0, y0), (x1, y1)], BLACK.stroke_width(1)))
            .map_err(|e| plot_error(&e))?;
        root.draw(&Text::new(p.label, (x0 - 4, y0 - 30), ("sans-serif", 14)))
            .map_err(|e| plot_error(&e))?;
        for k in 0..=4 {
            let y = y1 - (y1 - y0) * k / 4;
            let value = lo + (hi - lo) * k as f64 / 4.0;
            let text = format!("{value:.3e}");
            root.draw(&Text::new(text, (x1 + 6, y - 7), ("sans-serif", 12)))
                .map_err(|e| plot_error(&e))?;
        }
        root.present().map_err(|e| plot_error(&e))?;
    }
    Ok(svg)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearer_triangles_are_drawn_later_and_the_ramp_spans_the_values() {
        let (e, _, _) = view();
        // Two parallel triangles, the first one nearer the eye by 1.
        let base = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]];
        let near = base.map(|x| [0, 1, 2].map(|a| x[a] + e[a]));
        let points: Vec<[f64; 3]> = near.iter().chain(&base).copied().collect();
        let triangles = [[0, 1, 2], [3, 4, 5]];
        assert_eq!(painter_order(&points, &triangles, e), [1, 0]);
        let values = [2.0, 2.0, 2.0, 1.0, 1.0, 1.0];
        let picture = SurfacePicture {
            title: "two triangles",
            points: &points,
            triangles: &triangles,
            values: &values,
            label: "von Mises",
        };
        let svg = deformed_svg(&picture).unwrap();
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
        for text in ["two triangles", "von Mises", "1.000e0", "2.000e0"] {
            assert!(svg.contains(text), "{text} missing");
        }
        // The far triangle (lowest value) first, the near one (highest) last,
        // both shaded by |n·e| with n = (0, −1, 0).
        let polygons: Vec<&str> = svg.lines().filter(|l| l.starts_with("<polygon")).collect();
        assert_eq!(polygons.len(), 2);
        let hex = |c: RGBColor| format!("#{:02X}{:02X}{:02X}", c.0, c.1, c.2);
        assert_eq!(hex(ramp(0.0, 1.0)), "#440154");
        assert_eq!(hex(ramp(1.0, 1.0)), "#FDE725");
        let shade = 0.55 + 0.45 * e[1].abs();
        assert!(
            polygons[0].contains(&hex(ramp(0.0, shade))),
            "{}",
            polygons[0]
        );
        assert!(
            polygons[1].contains(&hex(ramp(1.0, shade))),
            "{}",
            polygons[1]
        );
    }
}
