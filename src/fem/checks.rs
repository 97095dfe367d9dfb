//! Finite data on the grid: a case can parse and still give loads that are
//! not finite where they are used (`log(x)` at negative x, `1/z` on z = 0) or
//! stiffnesses that overflow (E near the largest float). The setup calls
//! [`check_finite`], which names the case key and a point where a value is
//! not finite, instead of letting NaN reach the solver.

use super::problem::{Boundary, Problem};
use super::rhs::DirichletPoint;
use crate::case::boundary::DirichletValue;
use crate::case::physics::FieldValue;
use crate::case::Case;
use crate::cells::{CellKind, Cells};
use crate::discrete::dofs::{node_cells, DofMap};
use crate::element::tensor_gauss_rule;
use crate::error::{Error, Result};
use crate::grid::Grid;

/// What a setup produced, to be checked.
pub struct Assembled<'a> {
    pub grid: &'a Grid,
    pub cells: &'a Cells,
    pub dofs: &'a DofMap,
    pub problem: &'a Problem,
    pub beta: f64,
    pub s_factor: f64,
    pub diagonal: &'a [f64],
    pub dirichlet: &'a [DirichletPoint],
    pub fixed_rhs: &'a [f64],
}

fn finite(v: [f64; 3]) -> bool {
    v.iter().all(|c| c.is_finite())
}

/// The key a field comes from: its own, or the exact field it is derived from.
fn source(from_exact: bool, key: String, derived: &str) -> String {
    match from_exact {
        false => key,
        true => format!("exact.displacement (the {derived} of {key})"),
    }
}

/// Ok when the operator's diagonal and the fixed right-hand side are finite;
/// otherwise an error naming the key at fault and a point.
pub fn check_finite(case: &Case, a: &Assembled) -> Result<()> {
    let bad = |key: String, reason: String| Error::CaseFile {
        file: case.file.clone(),
        key,
        reason,
    };
    let m = &case.body().spec.material;
    let st = &case.spec.stabilisation;
    if !a.beta.is_finite() {
        return Err(bad(
            "stabilisation.k1".into(),
            format!("the penalty k1 E = {} · {} overflows", st.k1, m.young),
        ));
    }
    if !a.s_factor.is_finite() {
        return Err(bad(
            "stabilisation.k2".into(),
            format!("the S-term weight k2 E / h² overflows (h = {})", a.grid.h),
        ));
    }
    if !a.diagonal.iter().all(|v| v.is_finite()) {
        return Err(bad(
            "material.young".into(),
            format!(
                "the stiffness overflows (E = {}, cell size h = {})",
                m.young, a.grid.h
            ),
        ));
    }
    if a.fixed_rhs.iter().all(|v| v.is_finite()) {
        return Ok(());
    }
    let s = &case.body().spec;
    let tag = |t: u16| case.body().geometry.tag_name(t).to_string();
    for p in a.dirichlet {
        if !finite(p.g) {
            let t = tag(p.tag);
            let exact = s.dirichlet.get(&t).map(|d| &d.value) == Some(&DirichletValue::Exact);
            let key = source(exact, format!("dirichlet.{t}.value"), "value");
            return Err(bad(key, format!("not finite at {:?}: {:?}", p.x, p.g)));
        }
    }
    for (i, _) in a.cells.cut.iter().enumerate() {
        for q in a.cells.surface_points(i) {
            if let Boundary::Neumann(_) = a.problem.boundary[q.tag as usize] {
                let t = a.problem.traction(q.tag, q.x, q.n);
                if !finite(t) {
                    let name = tag(q.tag);
                    let spec = s.neumann.get(&name);
                    let key = match spec.is_some_and(|n| n.pressure.is_some()) {
                        true => format!("neumann.{name}.pressure"),
                        false => {
                            let exact = spec.is_some_and(|n| n.is_exact());
                            source(exact, format!("neumann.{name}.traction"), "traction")
                        }
                    };
                    return Err(bad(key, format!("not finite at {:?}: {t:?}", q.x)));
                }
            }
        }
    }
    let body_key = || {
        let given = matches!(&s.body_load, Some(b) if matches!(b.value, FieldValue::Given(_)));
        source(!given, "body_load.value".into(), "body load")
    };
    let body_at = |x: [f64; 3]| -> Result<()> {
        let b = a.problem.body_load(x);
        if finite(b) {
            Ok(())
        } else {
            Err(bad(body_key(), format!("not finite at {x:?}: {b:?}")))
        }
    };
    for i in 0..a.cells.cut.len() {
        for q in a.cells.volume_points(i) {
            body_at(q.x)?;
        }
    }
    let rule = tensor_gauss_rule(a.dofs.order.gauss_points_per_axis() + 1);
    for (c, kind) in a.cells.kinds.iter().enumerate() {
        if *kind == CellKind::Inside {
            let lo = a.grid.cell_box(c).lo;
            for (xi, _) in &rule {
                body_at([0, 1, 2].map(|k| lo[k] + a.grid.h * xi[k]))?;
            }
        }
    }
    Err(bad(
        "material".into(),
        "the load vector overflows: the loads, the Dirichlet data or the penalty k1 E are too large"
            .into(),
    ))
}

/// A diagonal entry below this fraction of the largest, negated, is not
/// round-off: the merged slivers' entries are about −1e-20 of it
/// ([`crate::cells::NEGLIGIBLE_FRACTION`]).
const NEGATIVE_DIAGONAL: f64 = 1e-8;

/// Ok when no diagonal entry of the operator is negative beyond round-off.
/// A clean surface gives every cell a rule of positive stiffness; a negative
/// entry means a cut-cell rule of negative volume somewhere, from a surface
/// that is not closed or intersects itself in that cell: the error names the
/// cells around the entry and what the mesh check found. The multigrid's
/// coarser levels, classified on their own grids, are checked the same way.
pub fn check_rules(
    case: &Case,
    grid: &Grid,
    cells: &Cells,
    dofs: &DofMap,
    diagonal: &[f64],
) -> Result<()> {
    let largest = diagonal.iter().cloned().fold(0.0, f64::max);
    let Some(dof) = diagonal
        .iter()
        .position(|&d| d < -NEGATIVE_DIAGONAL * largest)
    else {
        return Ok(());
    };
    let node = dofs.active_to_node[dof / 3] as usize;
    let mut around = Vec::new();
    node_cells(grid, dofs.order, node, &mut around);
    let cut: Vec<String> = around
        .iter()
        .filter(|&&(c, _)| cells.kinds[c] == CellKind::Cut)
        .map(|&(c, _)| {
            let b = grid.cell_box(c);
            let f = |v: [f64; 3]| format!("({:.4}, {:.4}, {:.4})", v[0], v[1], v[2]);
            format!("{}..{}", f(b.lo), f(b.hi))
        })
        .collect();
    let meshes: Vec<String> = case
        .body()
        .geometry
        .meshes()
        .iter()
        .map(|m| m.diagnostics().summary())
        .collect();
    let x = grid.node_position(dofs.order, node);
    Err(Error::CaseFile {
        file: case.file.clone(),
        key: "geometry".into(),
        reason: format!(
            "the stiffness at the node ({:.4}, {:.4}, {:.4}) is negative ({:.3e}): a cut cell \
             there has a quadrature rule of negative volume, which a closed surface that does \
             not cross itself never gives (cut cells at the node: {}){}",
            x[0],
            x[1],
            x[2],
            diagonal[dof],
            cut.join(", "),
            match meshes.is_empty() {
                true => String::new(),
                false => format!("; mesh: {}", meshes.join("; ")),
            }
        ),
    })
}

#[cfg(test)]
mod tests {
    use crate::case::Case;
    use crate::driver::setup::Setup;
    use crate::error::Error;

    const STEEL: &str = "young = 1000\npoisson = 0.3";
    const CLAMP: &str = "[dirichlet.xmin]\nvalue = [\"0\", \"0\", \"0\"]\n";

    /// The key named by the setup of a cube on [-1, 1]³ with `material` and
    /// `extra` tables.
    fn setup_key(material: &str, extra: &str) -> String {
        let text = format!(
            "[geometry]\ntype = \"cuboid\"\nmin = [-1, -1, -1]\nmax = [1, 1, 1]\n\
             [grid]\noffset = [0.3, 0.3, 0.3]\n[material]\n{material}\n{extra}"
        );
        let case = Case::from_str("cube.toml", &text).unwrap();
        match Setup::new(&case, Some(2)) {
            Err(Error::CaseFile { file, key, reason }) => {
                assert_eq!(file, "cube.toml");
                assert!(reason.contains("not finite") || reason.contains("overflows"));
                key
            }
            Err(e) => panic!("untyped error {e}"),
            Ok(_) => panic!("set up: {extra}"),
        }
    }

    #[test]
    fn names_the_key_of_data_that_is_not_finite() {
        let key = setup_key(
            STEEL,
            "[dirichlet.xmin]\nvalue = [\"log(x)\", \"0\", \"0\"]\n",
        );
        assert_eq!(key, "dirichlet.xmin.value");
        let neumann = "[neumann.xmax]\ntraction = [\"0\", \"1/(x-1)\", \"0\"]\n";
        assert_eq!(
            setup_key(STEEL, &format!("{CLAMP}{neumann}")),
            "neumann.xmax.traction"
        );
        let body = "[body_load]\nvalue = [\"0\", \"0\", \"sqrt(z)\"]\n";
        assert_eq!(
            setup_key(STEEL, &format!("{CLAMP}{body}")),
            "body_load.value"
        );
        // Derived from the exact field: the exact field is named.
        let exact = "[dirichlet.xmin]\nvalue = \"exact\"\n\
                     [exact]\ndisplacement = [\"x\", \"0\", \"sqrt(z)\"]\n";
        let key = setup_key(STEEL, exact);
        assert!(key.starts_with("exact.displacement"), "{key}");
    }

    #[test]
    fn names_the_key_of_an_overflow() {
        let k1 = format!("{CLAMP}[stabilisation]\nk1 = 1e3\n");
        assert_eq!(
            setup_key("young = 1e306\npoisson = 0.3", &k1),
            "stabilisation.k1"
        );
        let k2 = format!("{CLAMP}[stabilisation]\nk2 = 1e306\n");
        assert_eq!(setup_key(STEEL, &k2), "stabilisation.k2");
        // λ = E ν / ((1 + ν)(1 − 2ν)) overflows.
        let k1 = format!("{CLAMP}[stabilisation]\nk1 = 1e-300\n");
        let key = setup_key("young = 1.7e308\npoisson = 0.49", &k1);
        assert_eq!(key, "material.young");
    }
}
