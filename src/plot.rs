//! SVG plots (plotters): the log–log convergence plots and the log-scale κ
//! plots that `reproduce` writes (and, in `plot/deformed.rs`, the deformed
//! surface of `run --plots`). One routine draws any set of named series
//! on a log or linear x axis and a log y axis, so every figure of the
//! program looks the same.

mod deformed;

pub use deformed::{deformed_svg, SurfacePicture};

use plotters::coord::ranged1d::ValueFormatter;
use plotters::prelude::*;

use crate::error::{Error, Result};

/// One named polyline (with markers) of a chart.
#[derive(Clone, Debug)]
pub struct Series {
    pub label: String,
    pub points: Vec<(f64, f64)>,
    /// Drawn dashed-looking (thin, no markers): reference slopes, the paper's values.
    pub reference: bool,
}

/// A chart: title, axis labels, whether x is logarithmic (y always is).
#[derive(Clone, Debug)]
pub struct Chart {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub x_log: bool,
    pub series: Vec<Series>,
}

const COLOURS: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(255, 127, 14),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
];

/// The range `[lo, hi]` of positive values widened to whole decades (log) or
/// by 5% (linear).
fn range(values: impl Iterator<Item = f64>, log: bool) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite() && (!log || *v > 0.0))
        .fold((f64::MAX, f64::MIN), |(a, b), v| (a.min(v), b.max(v)));
    if lo > hi {
        return (1.0, 10.0);
    }
    if log {
        let (l, h) = (lo.log10().floor(), hi.log10().ceil());
        (10f64.powf(l), 10f64.powf(h.max(l + 1.0)))
    } else {
        let pad = 0.05 * (hi - lo).max(1e-12);
        (lo - pad, hi + pad)
    }
}

impl Chart {
    /// The chart as an SVG document.
    pub fn to_svg(&self) -> Result<String> {
        let plot_error = |e: &dyn std::fmt::Display| Error::Plot {
            title: self.title.clone(),
            reason: e.to_string(),
        };
        let mut svg = String::new();
        {
            let root = SVGBackend::with_string(&mut svg, (720, 480)).into_drawing_area();
            root.fill(&WHITE).map_err(|e| plot_error(&e))?;
            let all = || self.series.iter().flat_map(|s| s.points.iter());
            let (x0, x1) = range(all().map(|p| p.0), self.x_log);
            let (y0, y1) = range(all().map(|p| p.1), true);
            let mut builder = ChartBuilder::on(&root);
            builder
                .caption(&self.title, ("sans-serif", 18))
                .margin(12)
                .x_label_area_size(40)
                .y_label_area_size(70);
            if self.x_log {
                let mut chart = builder
                    .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
                    .map_err(|e| plot_error(&e))?;
                self.draw(&mut chart).map_err(|e| plot_error(&e))?;
            } else {
                let mut chart = builder
                    .build_cartesian_2d(x0..x1, (y0..y1).log_scale())
                    .map_err(|e| plot_error(&e))?;
                self.draw(&mut chart).map_err(|e| plot_error(&e))?;
            }
            root.present().map_err(|e| plot_error(&e))?;
        }
        Ok(svg)
    }

    fn draw<'a, X, Y>(
        &self,
        chart: &mut ChartContext<'a, SVGBackend<'a>, Cartesian2d<X, Y>>,
    ) -> std::result::Result<(), String>
    where
        X: Ranged<ValueType = f64> + ValueFormatter<f64>,
        Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
    {
        // A linear axis of whole numbers (levels, indices) gets one label per
        // whole number (at most 20), without decimals.
        let xs = || {
            self.series
                .iter()
                .flat_map(|s| s.points.iter().map(|p| p.0))
        };
        let integral = !self.x_log && xs().all(|x| x.fract() == 0.0);
        let span = xs().fold(f64::MIN, f64::max) - xs().fold(f64::MAX, f64::min);
        let mut mesh = chart.configure_mesh();
        mesh.x_desc(&self.x_label)
            .y_desc(&self.y_label)
            .y_label_formatter(&|v| format!("{v:.0e}"));
        let integer_label = |v: &f64| {
            if v.fract().abs() < 1e-9 {
                format!("{v:.0}")
            } else {
                String::new()
            }
        };
        if integral {
            mesh.x_labels((span as usize + 1).clamp(2, 20))
                .x_label_formatter(&integer_label);
        }
        mesh.draw().map_err(|e| e.to_string())?;
        for (i, s) in self.series.iter().enumerate() {
            let colour = COLOURS[i % COLOURS.len()];
            let width = if s.reference { 1 } else { 2 };
            let style = colour.stroke_width(width);
            chart
                .draw_series(LineSeries::new(s.points.iter().copied(), style))
                .map_err(|e| e.to_string())?
                .label(&s.label)
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], style));
            if !s.reference {
                chart
                    .draw_series(s.points.iter().map(|&p| Circle::new(p, 3, colour.filled())))
                    .map_err(|e| e.to_string())?;
            }
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()
            .map_err(|e| e.to_string())?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_log_log_chart_has_its_title_labels_and_one_path_per_series() {
        let chart = Chart {
            title: "energy error".into(),
            x_label: "dofs".into(),
            y_label: "error".into(),
            x_log: true,
            series: vec![
                Series {
                    label: "with S".into(),
                    points: vec![(1e2, 0.5), (1e3, 0.2), (1e4, 0.05)],
                    reference: false,
                },
                Series {
                    label: "slope −1/3".into(),
                    points: vec![(1e2, 0.4), (1e4, 0.4 * 0.01f64.powf(1.0 / 3.0))],
                    reference: true,
                },
            ],
        };
        let svg = chart.to_svg().unwrap();
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
        for text in ["energy error", "dofs", "with S", "slope −1/3"] {
            assert!(svg.contains(text), "{text} missing");
        }
        // Each series: its line and its legend sample, in its own colour.
        for colour in ["#1F77B4", "#D62728"] {
            let lines = svg
                .lines()
                .filter(|l| l.starts_with("<polyline") && l.contains(colour))
                .count();
            assert_eq!(lines, 2, "{colour}");
        }
        assert_eq!(svg.matches("<circle").count(), 3);
    }
}
