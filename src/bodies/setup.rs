//! From a [`Case`] to a [`BodiesProblem`]: per body its grid (`--level`
//! sets every body's), its solid (clipped for plane strain), the cell
//! classification with its element's cut rules, the element (Q1 or Q2), the
//! hyperelastic material, the
//! penalty `β = k1 E`, the S-term of the pathological cells (`k2`, `A`; off
//! for `k2 = 0`), the Dirichlet conditions per component (restricted to
//! their region at the surface quadrature points), the tractions, and the
//! held `u_z` of plane-strain bodies and the held normal displacement on
//! symmetry planes ([`super::symmetry`]); and the Newton options of the case.
//! The case's contact pairs, if any, are the problem's coupling
//! ([`super::contact::ContactCoupling`]).

use std::sync::Arc;

use super::contact::{ContactCoupling, ContactSide};
use super::problem::BodiesProblem;
use super::symmetry::{self, SymmetryPlane};
use crate::case::boundary::RampSpec;
use crate::case::{Case, Model};
use crate::cells::pieces::{held_pieces, HeldPoint, Naming};
use crate::cells::{CellKind, Cells};
use crate::error::Result;
use crate::geometry::Geometry;
use crate::grid::Grid;
use crate::hyper::material::{Material, MaterialModel};
use crate::hyper::newton::NewtonOptions;
use crate::hyper::problem::{
    Conditions, DirichletCondition, HyperProblem, Loads, Ramp, Region, TractionField, TractionLoad,
};
use crate::progress::Progress;
use crate::solver::KrylovOptions;

/// One body, set up.
pub struct BodySetup {
    pub name: String,
    pub grid: Grid,
    /// The solid on the grid (clipped for plane strain).
    pub solid: Geometry,
    pub cells: Cells,
    /// Its symmetry planes, the normal displacement held on them.
    pub symmetry: Vec<SymmetryPlane>,
}

/// Every body of a case and the stacked problem.
pub struct BodiesSetup {
    pub bodies: Vec<BodySetup>,
    pub problem: BodiesProblem,
    pub newton: NewtonOptions,
}

impl BodiesSetup {
    /// Sets the case up at its levels, or every body at `level`.
    pub fn new(case: &Case, level: Option<u32>, progress: &dyn Progress) -> Result<Self> {
        let grids = case.grids(level)?;
        let mut bodies = Vec::with_capacity(grids.len());
        let mut problems = Vec::with_capacity(grids.len());
        for (i, grid) in grids.into_iter().enumerate() {
            let spec = &case.bodies[i].spec;
            let solid = case.solid(i, &grid)?;
            let cells = case.classify_body(i, &grid, &solid, progress)?;
            problems.push(body_problem(case, i, &grid, &solid, &cells)?);
            let key = case.body_key(i, "symmetry");
            let symmetry =
                symmetry::planes(&case.file, &key, &grid, &cells, &solid, &spec.symmetry)?;
            check_held(case, i, &grid, &cells, &solid, &symmetry)?;
            bodies.push(BodySetup {
                name: spec.name.clone(),
                grid,
                solid,
                cells,
                symmetry,
            });
        }
        let mut problem = BodiesProblem::new(problems);
        for (b, body) in case.bodies.iter().enumerate() {
            if body.spec.plane_strain {
                for a in 0..problem.bodies[b].dofs.num_active() {
                    problem.hold(b, 3 * a + 2);
                }
            }
            let s = &bodies[b];
            for &plane in &s.symmetry {
                for d in symmetry::held_dofs(&s.grid, &problem.bodies[b].dofs, plane) {
                    problem.hold(b, d);
                }
            }
            if let Some(s_term) = problem.bodies[b].s_term.as_mut() {
                s_term.mirror = symmetry::mirror(&s.symmetry);
            }
        }
        if !case.pairs.is_empty() {
            let sides: Vec<ContactSide> = bodies
                .iter()
                .zip(&problem.bodies)
                .map(|(b, p)| ContactSide {
                    grid: &b.grid,
                    dofs: &p.dofs,
                    solid: &b.solid,
                    cells: &b.cells,
                    mirror: symmetry::mirror(&b.symmetry),
                })
                .collect();
            let coupling = ContactCoupling::new(case, &sides, &problem.offsets);
            problem.set_coupling(Box::new(coupling));
        }
        Ok(BodiesSetup {
            bodies,
            problem,
            newton: newton_options(case),
        })
    }
}

/// Checks that every piece of body `i` is held ([`held_pieces`]): by its
/// Dirichlet conditions (their held components, in their regions), its
/// symmetry planes (the normal component), plane strain (`u_z` everywhere)
/// or a contact pair (a piece with a contact boundary counts as held).
fn check_held(
    case: &Case,
    i: usize,
    grid: &Grid,
    cells: &Cells,
    solid: &Geometry,
    symmetry: &[SymmetryPlane],
) -> Result<()> {
    let spec = &case.bodies[i].spec;
    let tag = |name: &str| solid.tag_id(name).expect("tags checked with the case");
    let dirichlet: Vec<_> = spec.dirichlet.iter().map(|(n, d)| (tag(n), d)).collect();
    let mut held = Vec::new();
    for (k, &cell) in cells.cut.iter().enumerate() {
        for q in cells.surface_points(k) {
            let mut mask = [0.0; 3];
            for (_, d) in dirichlet
                .iter()
                .filter(|(t, d)| *t == q.tag && d.applies_at(q.x))
            {
                for (m, held) in mask.iter_mut().zip(d.mask()) {
                    *m = f64::max(*m, held as u8 as f64);
                }
            }
            for plane in symmetry.iter().filter(|p| p.tag == q.tag) {
                mask[plane.axis] = 1.0;
            }
            if mask != [0.0; 3] {
                held.push(HeldPoint {
                    cell,
                    x: q.x,
                    w: q.w,
                    mask,
                });
            }
        }
    }
    if spec.plane_strain {
        let w = grid.h.powi(3);
        for (cell, _) in cells
            .kinds
            .iter()
            .enumerate()
            .filter(|(_, k)| **k != CellKind::Outside)
        {
            let b = grid.cell_box(cell);
            let x = [0, 1, 2].map(|a| 0.5 * (b.lo[a] + b.hi[a]));
            held.push(HeldPoint {
                cell,
                x,
                w,
                mask: [0.0, 0.0, 1.0],
            });
        }
    }
    let body = &case.bodies[i];
    let contact: Vec<u16> = case
        .pairs
        .iter()
        .flat_map(|p| [p.slave, p.master])
        .filter(|side| side.body == i)
        .filter_map(|side| solid.tag_id(body.geometry.tag_name(side.tag)))
        .collect();
    let naming = Naming {
        file: &case.file,
        key: &case.body_key(i, "dirichlet"),
        body: &spec.name,
    };
    match held_pieces(
        grid,
        cells,
        &Default::default(),
        solid,
        held,
        &contact,
        &naming,
    ) {
        (_, Some(e)) => Err(e),
        (_, None) => Ok(()),
    }
}

/// The Newton options of `[load]`, `[newton]` and `[solver]`.
pub fn newton_options(case: &Case) -> NewtonOptions {
    let s = &case.spec;
    NewtonOptions {
        steps: s.load.steps,
        max_iterations: s.newton.max_iterations,
        residual_tol: s.newton.rel_tol,
        energy_tol: s.newton.energy_tol,
        max_cuts: s.newton.max_cuts,
        line_search: s.newton.line_search,
        fixed_point_tol: s.newton.fixed_point_tol,
        max_fixed_point: s.newton.max_fixed_point,
        recovery: s.newton.recovery,
        forcing: s.newton.forcing,
        krylov: KrylovOptions {
            method: s.solver.method,
            preconditioner: s.solver.preconditioner,
            rel_tol: s.solver.rel_tol,
            max_iterations: s.solver.max_iterations,
        },
        ..NewtonOptions::default()
    }
}

/// Body `i`'s material.
pub fn material(case: &Case, i: usize) -> Material {
    let m = &case.bodies[i].spec.material;
    let model = match case.bodies[i].model {
        Model::NeoHookean => MaterialModel::NeoHookean,
        Model::StVenantKirchhoff => MaterialModel::StVenantKirchhoff,
        Model::Linear => MaterialModel::Linear,
    };
    Material::from_young_poisson(model, m.young, m.poisson)
}

/// The [`Ramp`]s of an optional `ramp` of the case file.
fn ramps(ramp: Option<&RampSpec>) -> [Ramp; 3] {
    RampSpec::or_linear(ramp).map(|[start, end]| Ramp { start, end })
}

/// Body `i` as a [`HyperProblem`] on its grid and cells.
fn body_problem(
    case: &Case,
    i: usize,
    grid: &Grid,
    solid: &Geometry,
    cells: &Cells,
) -> Result<HyperProblem> {
    let spec = &case.bodies[i].spec;
    let tag = |name: &str| solid.tag_id(name).expect("tags checked with the case");
    let mut dirichlet = Vec::new();
    let mut regions: Vec<Option<Region>> = Vec::new();
    for (name, d) in &spec.dirichlet {
        let spec = d.clone();
        dirichlet.push(DirichletCondition {
            tag: tag(name),
            components: d.mask(),
            // "exact" is refused in [[body]] cases (no exact field).
            value: Arc::new(move |x: [f64; 3]| spec.value_at(x, || [0.0; 3])),
            ramps: ramps(d.ramp.as_ref()),
        });
        regions.push(
            d.region
                .clone()
                .map(|r| Arc::new(move |x| r.contains(x)) as Region),
        );
    }
    let tractions = spec
        .neumann
        .iter()
        .map(|(name, n)| {
            let ramps = ramps(n.ramp.as_ref());
            let n = n.clone();
            // "exact" is refused in [[body]] cases (no exact field).
            let field = move |x: [f64; 3], normal: [f64; 3]| n.eval(x, normal, |_, _| [0.0; 3]);
            TractionLoad {
                tag: tag(name),
                field: Arc::new(field) as TractionField,
                ramps,
            }
        })
        .collect();
    let loads = Loads {
        body: None,
        tractions,
    };
    let st = &case.spec.stabilisation;
    let beta = st.k1 * spec.material.young;
    let m = material(case, i);
    let conditions = Conditions {
        dirichlet: &dirichlet,
        regions: &regions,
        loads: &loads,
    };
    let order = spec.element;
    let mut p = HyperProblem::new_restricted(grid, cells, order, m, beta, &conditions)?;
    let a = st.threshold(order);
    p.set_s_term(cells, solid, st.k2, spec.material.young, a);
    Ok(p)
}
