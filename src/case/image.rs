//! The `image` node of the `[geometry]` table: a solid cut out of a 3D
//! voxel image (a CT or micro-CT scan) at an iso-value.
//!
//! ```toml
//! [geometry]
//! type = "image"
//! file = "scans/part.nrrd"     # relative to the case file; or a .nhdr header
//! threshold = 127.5            # the iso-value
//! inside = "above"             # material where the value is above it (default); or "below"
//! spacing = [0.05, 0.05, 0.05] # replaces the header's sample spacing (default: the header's, else 1)
//! origin = [0, 0, 0]           # replaces the header's first-sample position (default: the header's, else 0)
//! smooth = 1.0                 # Gaussian sigma in voxels before thresholding (default 0: none)
//! tag = "surface"              # the boundary part's name (default surface)
//! ```
//! The level set is the trilinear interpolant of the (smoothed) samples
//! minus the threshold, negative on the `inside` side, and outside beyond
//! the image ([`crate::geometry::voxels`]). Files: NRRD (`.nrrd`, or a
//! detached header `.nhdr` with its data file, [`crate::geometry::nrrd`]). Errors name the case file and the key: a
//! file that cannot be read or is not a supported image under `file`, a
//! threshold that leaves the solid empty or the whole image under
//! `threshold`.

use std::path::Path;

use serde::Deserialize;

use crate::error::{Error, Result};
use crate::geometry::nrrd::read_nrrd;
use crate::geometry::voxels::{gaussian, Inside, Voxels};
use crate::geometry::Geometry;

/// Largest `smooth` (voxels): a wider kernel blurs any scan into a blob.
const MAX_SMOOTH: f64 = 16.0;

/// Which side of the threshold is material, as written.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "lowercase")]
pub enum InsideSpec {
    #[default]
    Above,
    Below,
}

/// The `image` node as written.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ImageSpec {
    pub file: String,
    pub threshold: f64,
    #[serde(default)]
    pub inside: InsideSpec,
    #[serde(default)]
    pub spacing: Option<[f64; 3]>,
    #[serde(default)]
    pub origin: Option<[f64; 3]>,
    #[serde(default)]
    pub smooth: Option<f64>,
    #[serde(default)]
    pub tag: Option<String>,
}

impl ImageSpec {
    /// Reads the image (relative to the case file `file`) and builds the
    /// solid; errors name `file` and the key under `path`.
    pub fn build(&self, file: &str, path: &str) -> Result<Geometry> {
        let err = |key: &str, reason: String| Error::CaseFile {
            file: file.into(),
            key: format!("{path}.{key}"),
            reason,
        };
        if let Some(s) = self.spacing {
            if !s.iter().all(|v| v.is_finite() && *v > 0.0) {
                return Err(err(
                    "spacing",
                    format!("must be positive and finite, got {s:?}"),
                ));
            }
        }
        if let Some(o) = self.origin {
            if !o.iter().all(|v| v.is_finite()) {
                return Err(err("origin", format!("must be finite, got {o:?}")));
            }
        }
        let sigma = self.smooth.unwrap_or(0.0);
        if !(0.0..=MAX_SMOOTH).contains(&sigma) {
            return Err(err(
                "smooth",
                format!("must be a number of voxels in [0, {MAX_SMOOTH}], got {sigma}"),
            ));
        }
        if !self.threshold.is_finite() {
            return Err(err(
                "threshold",
                format!("must be finite, got {}", self.threshold),
            ));
        }
        let base = Path::new(file).parent().unwrap_or(Path::new(""));
        let full = base.join(&self.file);
        let ext = full
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase());
        let image = match ext.as_deref() {
            Some("nrrd" | "nhdr") => read_nrrd(&full).map_err(|e| err("file", e.to_string()))?,
            _ => {
                return Err(err(
                    "file",
                    format!(
                        "{}: unsupported image format (.nrrd, .nhdr)",
                        full.display()
                    ),
                ))
            }
        };
        if image.size.iter().any(|&n| n < 2) {
            return Err(err(
                "file",
                format!(
                    "{}: needs at least 2 samples per axis, got {:?}",
                    full.display(),
                    image.size
                ),
            ));
        }
        let values = gaussian(image.size, &image.values, sigma);
        let (lo, hi) = values
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                (a.min(v), b.max(v))
            });
        let t = self.threshold;
        if !(t > lo && t < hi) {
            let inside = matches!(
                (t <= lo, self.inside),
                (true, InsideSpec::Above) | (false, InsideSpec::Below)
            );
            return Err(err(
                "threshold",
                format!(
                    "{t} is outside the range of the image's values{} ({lo} to {hi}): the solid would be {}",
                    if sigma > 0.0 { " after smoothing" } else { "" },
                    if inside { "the whole image" } else { "empty" }
                ),
            ));
        }
        let inside = match self.inside {
            InsideSpec::Above => Inside::Above,
            InsideSpec::Below => Inside::Below,
        };
        let spacing = self.spacing.or(image.spacing).unwrap_or([1.0; 3]);
        let voxels = Voxels::new(image.size, &values, spacing, t, inside)
            .map_err(|e| err("file", format!("{}: {e}", full.display())))?;
        let origin = self.origin.or(image.origin).unwrap_or([0.0; 3]);
        let axes = image
            .axes
            .unwrap_or([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]);
        let g = Geometry::image(voxels, origin, axes)
            .map_err(|e| err("file", format!("{}: {e}", full.display())))?;
        Ok(match &self.tag {
            Some(tag) => g.with_tag(tag),
            None => g,
        })
    }
}
