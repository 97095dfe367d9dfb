//! One body of a case (`[[body]]`, or the top-level keys of a one-body case):
//! its geometry, grid, element, material, boundary conditions and, for the
//! linear path, an exact field and a body load.
//!
//! ```toml
//! [[body]]
//! name = "lower"                # letters, digits and '_' (used in `body.tag`)
//! element = "q1"                # or "q2"
//! geometry = { type = "cuboid", min = [-1, -1, -1], max = [1, 1, 0] }
//! grid = { level = 3, offset = [0.3, 0.6, 0.45] }
//! quadrature = { points = 4 }   # Gauss points per segment of the cut-cell rules
//! material = { model = "linear", young = 1000.0, poisson = 0.3 }
//! plane_strain = false          # a slab one cell thick, u_z = 0 (Newton path)
//! symmetry = ["cut_x"]          # symmetry planes: u·n = 0 held on them (Newton path)
//! exact.displacement = ["x", "0", "0"]   # linear path: data and error norms
//! body_load.value = "exact"              # linear path
//! dirichlet.zmin = { value = ["0", "0", "0"] }
//! neumann.top = { pressure = "10" }
//! ```

use serde::{Deserialize, Serialize};

use super::boundary::{DirichletTable, NeumannTable};
use super::geometry::GeometrySpec;
use super::physics::{BodyLoadSpec, ExactSpec};
use crate::element::ElementOrder;
use crate::geometry::Geometry;

/// One body as written in its file.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct BodySpec {
    /// The body's name; a one-body case written without `[[body]]` names it
    /// [`SHORTHAND_BODY`].
    pub name: String,
    /// Element order, `"q1"` (default) or `"q2"`.
    #[serde(default = "default_element")]
    pub element: ElementOrder,
    pub geometry: GeometrySpec,
    #[serde(default)]
    pub grid: GridSpec,
    /// `quadrature.points`: Gauss points per segment of the cut-cell rules
    /// (default: [`crate::cells::cut_rule_points`] of the element).
    #[serde(default)]
    pub quadrature: Option<QuadratureSpec>,
    pub material: MaterialSpec,
    #[serde(default)]
    pub exact: Option<ExactSpec>,
    #[serde(default)]
    pub body_load: Option<BodyLoadSpec>,
    #[serde(default)]
    pub dirichlet: DirichletTable,
    #[serde(default)]
    pub neumann: NeumannTable,
    /// Solve as a plane-strain slab (see [`super::plane_strain`]).
    #[serde(default)]
    pub plane_strain: bool,
    /// Boundary parts that are planes of mirror symmetry: the normal
    /// displacement held at the nodes on them (`crate::bodies::symmetry`).
    #[serde(default)]
    pub symmetry: Vec<String>,
}

/// The name of the body of a one-body case written without `[[body]]`.
pub const SHORTHAND_BODY: &str = "body";

/// The tag of the two caps of a plane-strain slab.
pub const PLANE_STRAIN_CAP: &str = "plane_strain_cap";

fn default_element() -> ElementOrder {
    ElementOrder::Q1
}

/// The `grid` table.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct GridSpec {
    /// Level L: the longest side of the box is split into 2^L cells (default 4).
    #[serde(default = "default_level")]
    pub level: u32,
    /// Grid box corners; default the geometry's bounding box.
    #[serde(default)]
    pub box_min: Option<[f64; 3]>,
    #[serde(default)]
    pub box_max: Option<[f64; 3]>,
    /// Shift of the grid origin in cells, each component in [0, 1).
    #[serde(default)]
    pub offset: [f64; 3],
}

fn default_level() -> u32 {
    4
}

impl Default for GridSpec {
    fn default() -> Self {
        GridSpec {
            level: default_level(),
            box_min: None,
            box_max: None,
            offset: [0.0; 3],
        }
    }
}

/// The `quadrature` table.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct QuadratureSpec {
    pub points: usize,
}

/// The `material` table: an isotropic material.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct MaterialSpec {
    /// The strain energy; `None`: [`Model::default_for`] the case.
    #[serde(default)]
    pub model: Option<Model>,
    /// E, in the case's stress unit.
    pub young: f64,
    /// ν, in (−1, 0.5).
    pub poisson: f64,
}

/// The strain energy of a body.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Model {
    /// Small-strain linear elasticity, `W = λ/2 (tr ε)² + μ ε:ε`,
    /// `ε = sym(∇u)`.
    Linear,
    /// `W = μ/2 (tr C − 3) − μ ln J + λ/2 (ln J)²`.
    NeoHookean,
    /// `W = λ/2 (tr E)² + μ E:E`.
    StVenantKirchhoff,
}

impl Model {
    /// The model of a body that names none: linear, except in a case with
    /// contact pairs, where the gap is measured on the deformed bodies and
    /// the default is neo-Hookean.
    pub fn default_for(has_contact: bool) -> Model {
        match has_contact {
            true => Model::NeoHookean,
            false => Model::Linear,
        }
    }
}

/// A body of a checked case: its spec, its solid and its resolved model.
#[derive(Clone, Debug)]
pub struct Body {
    pub spec: BodySpec,
    pub geometry: Geometry,
    pub model: Model,
}
