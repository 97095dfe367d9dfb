//! The distributed set-up and solve against one rank's: the same owned
//! rows, the same right-hand side and the same Jacobi-CG solution on 2, 3
//! and 4 ranks (threads), on the sphere and the bracket.

use std::collections::HashMap;
use std::path::Path;

use super::*;
use crate::backend::{Backend, CpuBackend, LinearOperator};
use crate::comm::threads;
use crate::discrete::field::error_norms;
use crate::driver::output::{OutputFiles, ParaView};
use crate::driver::share::Whole;
use crate::driver::solve::reactions_by_tag;
use crate::driver::surface_output::{surface_fields, write_surface};
use crate::progress::Silent;
use crate::solver::{solve, KrylovMethod, KrylovOptions, Preconditioner};

fn case(name: &str) -> Case {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("cases")
        .join(name);
    Case::from_file(&path).unwrap()
}

/// A smooth, nonzero field of the lattice node and component.
fn field(node: u32, comp: usize) -> f64 {
    (0.37 * node as f64 + 1.3 * comp as f64).sin() + 0.5
}

/// The whole grid's vector as lattice node → its three entries.
fn by_node(setup: &Setup, v: &[f64]) -> HashMap<u32, [f64; 3]> {
    let nodes = &setup.op.dofs.active_to_node;
    nodes
        .iter()
        .enumerate()
        .map(|(a, &n)| (n, [v[3 * a], v[3 * a + 1], v[3 * a + 2]]))
        .collect()
}

/// A rank's owned entries as (lattice node, its three entries).
fn owned(rs: &RankSetup, v: &[f64]) -> Vec<(u32, [f64; 3])> {
    let nodes = &rs.setup.op.dofs.active_to_node;
    (0..nodes.len())
        .filter(|&a| rs.halo.owns(a))
        .map(|a| (nodes[a], [v[3 * a], v[3 * a + 1], v[3 * a + 2]]))
        .collect()
}

/// Largest difference between the ranks' owned entries and the whole
/// grid's, relative to the whole grid's largest; and whether every active
/// node is owned by exactly one rank.
fn compare(whole: &HashMap<u32, [f64; 3]>, ranks: &[Vec<(u32, [f64; 3])>]) -> (f64, bool) {
    let scale = whole
        .values()
        .flatten()
        .fold(0.0_f64, |m, v| m.max(v.abs()));
    let mut seen = HashMap::new();
    let mut diff = 0.0_f64;
    for (n, v) in ranks.iter().flatten() {
        *seen.entry(*n).or_insert(0) += 1;
        let w = whole
            .get(n)
            .expect("an owned node is active in the whole grid");
        for c in 0..3 {
            diff = diff.max((v[c] - w[c]).abs() / scale);
        }
    }
    let once = seen.len() == whole.len() && seen.values().all(|&k| k == 1);
    (diff, once)
}

const JACOBI_CG: KrylovOptions = KrylovOptions {
    method: KrylovMethod::Cg,
    preconditioner: Preconditioner::Jacobi,
    rel_tol: 1e-12,
    max_iterations: 20_000,
};

#[test]
fn bricks_cover_the_grid_once_and_share_the_work() {
    let case = case("sphere.toml");
    let grid = case.grid(Some(5)).unwrap();
    let work = partition::cell_work(&Cells::rough_kinds(&grid, &case.body().geometry));
    for parts in 1..=7 {
        let bricks = partition::bricks(&grid, &work, parts, ALIGN).unwrap();
        assert_eq!(bricks.len(), parts);
        let mut load = vec![0.0; parts];
        for c in 0..grid.num_cells() {
            let ijk = grid.cell_ijk(c);
            let holders: Vec<usize> = (0..parts).filter(|&r| bricks[r].contains(ijk)).collect();
            assert_eq!(holders.len(), 1, "cell {ijk:?} in bricks {holders:?}");
            load[holders[0]] += work[c];
        }
        let mean = load.iter().sum::<f64>() / parts as f64;
        let worst = load.iter().fold(0.0_f64, |m, &l| m.max(l)) / mean;
        assert!(
            worst < 1.1,
            "{parts} bricks: the heaviest has {worst} × the mean"
        );
    }
}

#[test]
fn too_many_ranks_for_the_grid_is_an_error() {
    let case = case("sphere.toml");
    let grid = case.grid(Some(1)).unwrap();
    let work = vec![1.0; grid.num_cells()];
    assert!(matches!(
        partition::bricks(&grid, &work, 9, ALIGN),
        Err(Error::InvalidGrid { .. })
    ));
}

/// The ranks' owned rows of the operator, its diagonal and the fixed
/// right-hand side equal the whole grid's, bit for bit, on `name` at
/// `level`.
fn owned_rows_equal_the_whole_grids(name: &str, level: u32) {
    let case = case(name);
    let whole = Setup::new(&case, Some(level)).unwrap();
    let x: Vec<f64> = (0..whole.op.nrows())
        .map(|d| field(whole.op.dofs.active_to_node[d / 3], d % 3))
        .collect();
    let mut y = vec![0.0; x.len()];
    whole.op.apply(&x, &mut y);
    let (ay, ab, ad) = (
        by_node(&whole, &y),
        by_node(&whole, &whole.fixed_rhs),
        by_node(&whole, &whole.op.diagonal()),
    );
    for ranks in [2, 3, 4] {
        let got = threads::run(ranks, |comm| {
            let rs = RankSetup::new(&case, Some(level), comm, &Silent).unwrap();
            let dofs = &rs.setup.op.dofs;
            // The ghosts start at zero: the apply brings them.
            let mut x: Vec<f64> = (0..rs.setup.op.nrows())
                .map(|d| field(dofs.active_to_node[d / 3], d % 3))
                .collect();
            rs.halo.zero_ghosts(&mut x);
            let be = DistBackend::new(comm);
            let op = DistOperator::new(&be, &rs.setup.op, &rs.halo);
            let mut y = be.zeros(x.len());
            be.apply(&op, &x, &mut y);
            let d = be.diagonal(&op);
            (owned(&rs, &y), owned(&rs, &rs.fixed_rhs()), owned(&rs, &d))
        });
        let (ys, bs, ds): (Vec<_>, Vec<_>, Vec<_>) = got.into_iter().fold(
            (vec![], vec![], vec![]),
            |(mut a, mut b, mut c), (y, f, d)| {
                a.push(y);
                b.push(f);
                c.push(d);
                (a, b, c)
            },
        );
        for (what, whole, ranks_v) in [("A x", &ay, &ys), ("rhs", &ab, &bs), ("diag", &ad, &ds)] {
            let (diff, once) = compare(whole, ranks_v);
            assert!(once, "{name}, {ranks} ranks: a node is not owned once");
            assert!(
                diff == 0.0,
                "{name}, {ranks} ranks: {what} differs by {diff:e}"
            );
        }
    }
}

#[test]
fn owned_rows_equal_the_whole_grids_on_the_sphere() {
    owned_rows_equal_the_whole_grids("sphere.toml", 4);
}

#[test]
fn owned_rows_equal_the_whole_grids_on_the_bracket() {
    owned_rows_equal_the_whole_grids("bracket.toml", 4);
}

/// Jacobi CG on 1–4 ranks takes the one-rank iterations to the same bits.
#[test]
fn jacobi_cg_on_several_ranks_solves_as_one() {
    let case = case("sphere.toml");
    let whole = Setup::new(&case, Some(4)).unwrap();
    let cpu = CpuBackend::new();
    let mut u = vec![0.0; whole.op.nrows()];
    let op: &dyn LinearOperator = &whole.op;
    let one = solve(&cpu, op, None, &whole.fixed_rhs, &mut u, &JACOBI_CG).unwrap();
    let wu = by_node(&whole, &u);
    for ranks in [1, 2, 3, 4] {
        let got = threads::run(ranks, |comm| {
            let rs = RankSetup::new(&case, Some(4), comm, &Silent).unwrap();
            let be = DistBackend::new(comm);
            let op = DistOperator::new(&be, &rs.setup.op, &rs.halo);
            let b = rs.fixed_rhs();
            let mut u = be.zeros(b.len());
            let stats = solve(&be, &op, None, &b, &mut u, &JACOBI_CG).unwrap();
            (owned(&rs, &u), stats.iterations)
        });
        let (values, iterations): (Vec<_>, Vec<_>) = got.into_iter().unzip();
        assert!(
            iterations.iter().all(|&k| k == one.iterations),
            "{ranks} ranks: {iterations:?} iterations, one rank {}",
            one.iterations
        );
        let (diff, once) = compare(&wu, &values);
        assert!(once);
        assert!(
            diff == 0.0,
            "{ranks} ranks: the solutions differ by {diff:e}"
        );
    }
}

/// The case with the Krylov solves preconditioned by Jacobi (what the
/// ranks run).
fn case_with(name: &str, set: &[&str]) -> Case {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("cases")
        .join(name);
    let set: Vec<String> = set.iter().map(|s| s.to_string()).collect();
    Case::from_file_with(&path, &set).unwrap()
}

fn jacobi_case(name: &str) -> Case {
    case_with(name, &["solver.preconditioner=jacobi"])
}

/// The whole solve (the recovered load's fixed point, the S-term on) on 2,
/// 3 and 4 ranks against one: the same outer iterations, the same Krylov
/// iterations in every solve, and the same displacement, reactions and
/// energy and L2 errors to the bit (the dot products, the S-term's fits and
/// the sums over the body are exact, and every rank's rows are the
/// one-rank rows).
fn fixed_point_on_ranks_equals_one_rank(name: &str, level: u32) {
    let (_, cycles) = ranks_repeat_one_rank(&jacobi_case(name), name, level, &[2, 3, 4]);
    assert_eq!(cycles, 0);
}

/// [`fixed_point_on_ranks_equals_one_rank`] for `case` on each of `counts`
/// ranks; returns the one-rank run's multigrid levels and V-cycles (0
/// without multigrid).
fn ranks_repeat_one_rank(case: &Case, name: &str, level: u32, counts: &[usize]) -> (usize, usize) {
    let spec = &case.spec.solver;
    let whole = Setup::new(case, Some(level)).unwrap();
    let mut report = crate::driver::fixed_point::FixedPointReport::default();
    let one = crate::driver::solve::solve(&whole, spec, &mut report).unwrap();
    let wu = by_node(&whole, &one.u);
    let tags = case.body().geometry.tag_names().len();
    let whole_reactions = reactions_by_tag(&whole.dirichlet, &one.reactions, tags, &Whole);
    let whole_error = whole.problem.exact.as_ref().map(|exact| {
        let (l, m) = (whole.problem.lambda, whole.problem.mu);
        error_norms(
            &whole.grid,
            &whole.cells,
            &whole.op.dofs,
            &one.u,
            exact,
            l,
            m,
        )
    });
    let whole_levels = whole.multigrid.as_ref().map(|h| h.num_levels());
    let whole_cycles = report.v_cycles.map(|(n, _)| n);
    for &ranks in counts {
        let got = threads::run(ranks, |comm| {
            let rs = RankSetup::new(case, Some(level), comm, &Silent).unwrap();
            let mut r = crate::driver::fixed_point::FixedPointReport::default();
            let mut solver = solve::RankSolver::new(&rs, comm);
            let sol = solve::solve_rank(&rs, case, comm, &mut solver, &mut r, &Silent).unwrap();
            let levels = rs.multigrid.as_ref().map(|h| h.num_levels());
            (owned(&rs, &sol.u), (r, sol.reactions, sol.error, levels))
        });
        let (values, reports): (Vec<_>, Vec<_>) = got.into_iter().unzip();
        for (r, reactions, error, levels) in &reports {
            assert_eq!(levels, &whole_levels, "{name}, {ranks} ranks: levels");
            assert_eq!(
                r.v_cycles.map(|(n, _)| n),
                whole_cycles,
                "{name}, {ranks} ranks: V-cycles"
            );
            assert_eq!(
                reactions, &whole_reactions,
                "{name}, {ranks} ranks: reactions"
            );
            if let (Some(a), Some(b)) = (error, &whole_error) {
                assert_eq!(
                    (a.energy, a.l2),
                    (b.energy, b.l2),
                    "{name}, {ranks} ranks: energy and L2 errors"
                );
            }
            assert_eq!(error.is_some(), whole_error.is_some());
            assert_eq!(
                r.iterations, report.iterations,
                "{name}, {ranks} ranks: outer"
            );
            assert_eq!(
                r.iterations_per_solve, report.iterations_per_solve,
                "{name}, {ranks} ranks: Krylov iterations per solve"
            );
        }
        let (diff, once) = compare(&wu, &values);
        assert!(once);
        assert!(
            diff == 0.0,
            "{name}, {ranks} ranks: the displacements differ by {diff:e}"
        );
    }
    (whole_levels.unwrap_or(0), whole_cycles.unwrap_or(0))
}

#[test]
fn fixed_point_on_ranks_equals_one_rank_on_the_sphere() {
    fixed_point_on_ranks_equals_one_rank("sphere.toml", 4);
}

#[test]
fn fixed_point_on_ranks_equals_one_rank_on_the_bracket() {
    fixed_point_on_ranks_equals_one_rank("bracket.toml", 4);
}

/// The V-cycle on P ranks is the one-rank V-cycle: the multigrid solves of
/// the sphere (three levels, the S-term's Galerkin product on each) repeat
/// the one-rank run to the bit. (One rank count per case here;
/// `scripts/ranks_check.sh` runs 2, 3 and 4 ranks of every case under MPI.)
#[test]
fn multigrid_on_ranks_equals_one_rank_on_the_sphere() {
    let case = case_with("sphere.toml", &["solver.preconditioner=multigrid"]);
    let (levels, cycles) = ranks_repeat_one_rank(&case, "sphere.toml", 5, &[3]);
    assert!(
        levels == 3 && cycles > 0,
        "{levels} levels, {cycles} V-cycles"
    );
}

/// The same for Q2, whose first level below is the Q1 operator of the same
/// cells, and for the bracket's cut band.
#[test]
fn multigrid_on_ranks_equals_one_rank_on_the_q2_sphere_and_the_bracket() {
    let q2 = case_with(
        "sphere.toml",
        &["solver.preconditioner=multigrid", "element=\"q2\""],
    );
    let (levels, cycles) = ranks_repeat_one_rank(&q2, "sphere.toml (Q2)", 3, &[2]);
    assert!(
        levels == 2 && cycles > 0,
        "Q2: {levels} levels, {cycles} V-cycles"
    );
    let bracket = case_with("bracket.toml", &["solver.preconditioner=multigrid"]);
    let (levels, cycles) = ranks_repeat_one_rank(&bracket, "bracket.toml", 5, &[4]);
    assert!(
        levels >= 2 && cycles > 0,
        "bracket: {levels} levels, {cycles} V-cycles"
    );
}

/// The report of a run on 3 ranks counts and measures the body as one
/// rank's set-up does, and has a row per rank whose owned unknowns add up
/// to the body's.
#[test]
fn a_run_on_ranks_reports_the_body_as_one_rank() {
    let case = jacobi_case("bracket.toml");
    let whole = Setup::new(&case, Some(4)).unwrap();
    let body = case.body();
    let one = crate::report::BodyReport::new(
        &body.spec.name,
        body.model,
        body.spec.element,
        &body.geometry,
        &whole.grid,
        &whole.cells,
        false,
    );
    let reports = threads::run(3, |comm| {
        let run::RunOutcome {
            mut report, result, ..
        } = run::run(&case, Some(4), comm, &Silent, None, None);
        // Each rank's own seconds.
        report.timings.clear();
        (report, result)
    });
    for (report, result) in &reports {
        result.as_ref().unwrap();
        assert_eq!(report, &reports[0].0, "every rank has the same report");
        let row = &report.bodies[0];
        let (a, b) = (&row.cells, &one.cells);
        assert_eq!(
            (
                a.inside,
                a.cut,
                a.outside,
                a.merged,
                a.repaired,
                a.glued_nodes
            ),
            (
                b.inside,
                b.cut,
                b.outside,
                b.merged,
                b.repaired,
                b.glued_nodes
            )
        );
        assert_eq!(a.pathological, Some(whole.omega_star.len()));
        assert_eq!(row.dofs, whole.op.dofs.ndofs());
        assert_eq!(report.dofs, whole.op.dofs.ndofs());
        let rel = |x: f64, y: f64| (x - y).abs() / y.abs();
        assert!(rel(row.domain.volume, one.domain.volume) < 1e-12);
        for (tag, area) in &one.domain.boundary_area_by_tag {
            let got = row.domain.boundary_area_by_tag[tag];
            assert!(
                (got - area).abs() <= 1e-12 * one.domain.boundary_area,
                "{tag}"
            );
        }
        assert_eq!(report.ranks.len(), 3);
        let owned: usize = report.ranks.iter().map(|r| r.owned_dofs).sum();
        assert_eq!(owned, whole.op.dofs.ndofs());
        assert!(report.ranks.iter().all(|r| r.halo_bytes_per_apply > 0));
        assert_eq!(report.reactions.len(), 1, "the bolt holes' reaction");
    }
}

/// Two unit cubes along x, `gap` apart, the first clamped at x = 0 (and the
/// second at its far face with `both`), under their weight.
fn two_cubes(both: bool) -> Case {
    let clamp_b = match both {
        true => "[dirichlet.clamp_b]\nvalue = [\"0\", \"0\", \"0\"]\n",
        false => "",
    };
    let text = format!(
        r#"[geometry]
type = "union"
of = [
  {{ type = "retag", from = "xmin", to = "clamp_a", of = {{ type = "cuboid", min = [0, 0, 0], max = [1, 1, 1] }} }},
  {{ type = "retag", from = "xmax", to = "clamp_b", of = {{ type = "cuboid", min = [1.5, 0, 0], max = [2.5, 1, 1] }} }},
]
[grid]
level = 4
offset = [0.3, 0.6, 0.45]
[material]
young = 1000.0
poisson = 0.3
[body_load]
value = ["0", "0", "-1"]
[dirichlet.clamp_a]
value = ["0", "0", "0"]
{clamp_b}
[solver]
preconditioner = "jacobi"
"#
    );
    Case::from_str("two_cubes.toml", &text).unwrap()
}

/// A piece that nothing holds is refused on 2 and 3 ranks with the one-rank
/// message (exit code 2), each brick holding part of the free cube or none;
/// held, each cube's reaction is its own weight on every rank count.
#[test]
fn a_free_piece_is_refused_on_ranks_as_on_one() {
    let free = two_cubes(false);
    let one = Setup::new(&free, None).unwrap().check_held().unwrap_err();
    assert_eq!(one.exit_code(), 2);
    for ranks in [2, 3] {
        let got = threads::run(ranks, |comm| {
            RankSetup::new(&free, None, comm, &Silent)
                .err()
                .map(|e| e.to_string())
        });
        for e in got {
            assert_eq!(
                e.as_deref(),
                Some(one.to_string().as_str()),
                "{ranks} ranks"
            );
        }
    }
    let held = two_cubes(true);
    for ranks in [1, 2, 3] {
        let reports = threads::run(ranks, |comm| {
            run::run(&held, None, comm, &Silent, None, None).report
        });
        let weights: Vec<f64> = reports[0].reactions.iter().map(|r| r.force[2]).collect();
        assert_eq!(
            weights.len(),
            2,
            "{ranks} ranks: {:?}",
            reports[0].reactions
        );
        for w in weights {
            assert!(
                (w - 1.0).abs() < 1e-8,
                "{ranks} ranks: a cube's reaction {w}"
            );
        }
    }
}

/// The arrays of a `.vtu` file by name.
fn arrays(path: &Path) -> HashMap<String, crate::vtu::DataArray> {
    crate::vtu::read(path)
        .unwrap()
        .into_iter()
        .map(|a| (a.name.clone(), a))
        .collect()
}

fn f64s(a: &crate::vtu::DataArray) -> &[f64] {
    match &a.values {
        crate::vtu::DataValues::F64(v) => v,
        _ => panic!("{} is not Float64", a.name),
    }
}

/// The pieces a run on 3 ranks writes are the one-rank solution.vtu cut by
/// bricks: as many cells in all, each point's displacement the one-rank
/// file's at the same point; the `.pvtu` lists them and declares their
/// arrays.
#[test]
fn the_pieces_of_three_ranks_make_the_one_rank_solution() {
    let case = jacobi_case("sphere.toml");
    let whole = Setup::new(&case, Some(3)).unwrap();
    let mut report = crate::driver::fixed_point::FixedPointReport::default();
    let one = crate::driver::solve::solve(&whole, &case.spec.solver, &mut report).unwrap();
    let dir = std::env::temp_dir().join(format!("cgfem-pieces-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let geometry = &case.body().geometry;
    crate::driver::output::write_solution(&whole, geometry, &one.u, &dir.join("one.vtu")).unwrap();
    let pieces = run::Pieces {
        dir: &dir,
        paraview: ParaView {
            files: OutputFiles::Volume,
            encoding: crate::vtu::VtuEncoding::Appended,
        },
    };
    let files = threads::run(3, |comm| {
        let out = run::run(&case, Some(3), comm, &Silent, Some(pieces), None);
        out.result.unwrap();
        out.files
    });
    assert_eq!(
        files[0],
        [
            "solution.pvtu",
            "solution_0.vtu",
            "solution_1.vtu",
            "solution_2.vtu"
        ]
    );
    let pvtu = std::fs::read_to_string(dir.join("solution.pvtu")).unwrap();
    let key = |x: &[f64]| {
        x.iter()
            .map(|v| format!("{v:.12e}"))
            .collect::<Vec<_>>()
            .join(",")
    };
    let one = arrays(&dir.join("one.vtu"));
    let at: HashMap<String, &[f64]> = f64s(&one["Points"])
        .chunks_exact(3)
        .zip(f64s(&one["displacement"]).chunks_exact(3))
        .map(|(x, u)| (key(x), u))
        .collect();
    let mut cells = 0;
    for piece in &files[0][1..] {
        assert!(pvtu.contains(&format!("<Piece Source=\"{piece}\"/>")));
        let a = arrays(&dir.join(piece));
        for name in a
            .keys()
            .filter(|n| !["Points", "connectivity", "offsets", "types"].contains(&n.as_str()))
        {
            assert!(
                pvtu.contains(&format!("Name=\"{name}\"")),
                "{name} declared"
            );
        }
        cells += a["volume_fraction"].values.len();
        for (x, u) in f64s(&a["Points"])
            .chunks_exact(3)
            .zip(f64s(&a["displacement"]).chunks_exact(3))
        {
            let w = at[&key(x)];
            for k in 0..3 {
                assert!(
                    (u[k] - w[k]).abs() <= 1e-9 * (1.0 + w[k].abs()),
                    "{piece}: u at {x:?}"
                );
            }
        }
    }
    assert_eq!(cells, one["volume_fraction"].values.len());
    let _ = std::fs::remove_dir_all(&dir);
}

/// The surface of a run on 3 ranks (gathered on rank 0) is the one-rank
/// `surface.vtp`: the same points and triangles, the displacement to the
/// bit and the stress to round-off; on the sphere (marching tetrahedra)
/// and on an STL part, whose triangles cross the bricks.
fn the_surface_of_three_ranks_is_the_one_rank_surface(name: &str, level: u32) {
    let case = jacobi_case(name);
    let whole = Setup::new(&case, Some(level)).unwrap();
    let mut report = crate::driver::fixed_point::FixedPointReport::default();
    let one = crate::driver::solve::solve(&whole, &case.spec.solver, &mut report).unwrap();
    let stem = name.trim_end_matches(".toml");
    let dir = std::env::temp_dir().join(format!("cgfem-surface-{stem}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let geometry = &case.body().geometry;
    let (mesh, fields) = surface_fields(&whole, geometry, &one.u, None).unwrap();
    let encoding = crate::vtu::VtuEncoding::Appended;
    write_surface(&dir.join("one.vtp"), &mesh, &fields, encoding).unwrap();
    let pieces = run::Pieces {
        dir: &dir,
        paraview: ParaView {
            files: OutputFiles::Surface,
            encoding,
        },
    };
    let files = threads::run(3, |comm| {
        let out = run::run(&case, Some(level), comm, &Silent, Some(pieces), None);
        out.result.unwrap();
        out.files
    });
    assert_eq!(files[0], ["surface.vtp"]);
    assert!(files[1].is_empty() && files[2].is_empty());
    let (a, b) = (
        arrays(&dir.join("one.vtp")),
        arrays(&dir.join("surface.vtp")),
    );
    assert!(!f64s(&a["Points"]).is_empty());
    for key in ["Points", "displacement"] {
        assert_eq!(f64s(&a[key]), f64s(&b[key]), "{name}: {key}");
    }
    assert_eq!(a["connectivity"].values, b["connectivity"].values);
    assert_eq!(a["tag"].values, b["tag"].values);
    let (sa, sb) = (f64s(&a["stress"]), f64s(&b["stress"]));
    let scale = sa.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    let off = sa
        .iter()
        .zip(sb)
        .fold(0.0_f64, |m, (x, y)| m.max((x - y).abs()));
    assert!(
        off <= 1e-12 * scale,
        "{name}: stress off by {off:e} of {scale:e}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_surface_of_three_ranks_is_the_one_rank_surface_on_the_sphere() {
    the_surface_of_three_ranks_is_the_one_rank_surface("sphere.toml", 3);
}

#[test]
fn the_surface_of_three_ranks_is_the_one_rank_surface_on_an_stl_part() {
    the_surface_of_three_ranks_is_the_one_rank_surface("plate_holes.toml", 3);
}

/// A progress that asks to stop from its `after`-th poll on.
struct StopAfter {
    polls: std::sync::atomic::AtomicUsize,
    after: usize,
}

impl crate::progress::Progress for StopAfter {
    fn event(&self, _event: &crate::progress::Event) {}

    fn should_stop(&self) -> bool {
        let n = self.polls.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
        n + 1 >= self.after
    }
}

/// An interrupt on one rank stops every rank at the same iteration
/// boundary (none waits in a collective step for one that left), and
/// every rank reports the run interrupted there.
#[test]
fn an_interrupt_on_one_rank_stops_every_rank_together() {
    let case = jacobi_case("bracket.toml");
    let outcomes = threads::run(3, |comm| {
        let progress = StopAfter {
            polls: 0.into(),
            after: if comm.rank() == 1 { 3 } else { usize::MAX },
        };
        let out = run::run(&case, Some(3), comm, &progress, None, None);
        (out.result, out.report.status)
    });
    let mut stopped_at = Vec::new();
    for (result, status) in outcomes {
        match result {
            Err(Error::Interrupted { iterations }) => stopped_at.push(iterations),
            other => panic!("expected an interrupt, got {other:?}"),
        }
        assert_eq!(status, "interrupted");
    }
    assert!(stopped_at.iter().all(|&k| k == stopped_at[0]));
    assert!(stopped_at[0] >= 1, "stopped after a solve: {stopped_at:?}");
}

/// Each rank on its GPU (lavapipe here, one device shared by the threads):
/// the Jacobi fixed point of the sphere on 2 and 3 ranks against the CPU's
/// one-rank run. The device's dot products are rounded on the device (each
/// rank's part is added exactly over the ranks), so a solve may take one
/// iteration more or less; the outer iterations, the displacement (to the
/// outer tolerance) and the energy error may not move.
#[test]
fn gpu_ranks_solve_as_one_cpu_rank() {
    let Some(ctx) = crate::gpu::context_or_skip(crate::gpu::PrecisionChoice::F64) else {
        return;
    };
    let (case, level) = (jacobi_case("sphere.toml"), 4);
    let whole = Setup::new(&case, Some(level)).unwrap();
    let mut report = crate::driver::fixed_point::FixedPointReport::default();
    let one = crate::driver::solve::solve(&whole, &case.spec.solver, &mut report).unwrap();
    let wu = by_node(&whole, &one.u);
    let (l, m) = (whole.problem.lambda, whole.problem.mu);
    let exact = whole.problem.exact.as_ref().unwrap();
    let (g, c, d) = (&whole.grid, &whole.cells, &whole.op.dofs);
    let whole_error = error_norms(g, c, d, &one.u, exact, l, m);
    for ranks in [2, 3] {
        let got = threads::run(ranks, |comm| {
            let rs = RankSetup::new(&case, Some(level), comm, &Silent).unwrap();
            let be = crate::gpu::GpuBackend::new(ctx.clone());
            let local = crate::gpu::GpuOperator::new(&be, &rs.setup.op).unwrap();
            let mut solver =
                solve::RankSolver::with(DistBackend::on(be, comm), &local, &rs.halo, None);
            let mut r = crate::driver::fixed_point::FixedPointReport::default();
            let sol = solve::solve_rank(&rs, &case, comm, &mut solver, &mut r, &Silent).unwrap();
            (owned(&rs, &sol.u), (r, sol.error.unwrap()))
        });
        let (values, reports): (Vec<_>, Vec<_>) = got.into_iter().unzip();
        for (r, error) in &reports {
            assert_eq!(r.iterations, report.iterations, "{ranks} ranks: outer");
            let per_solve = r
                .iterations_per_solve
                .iter()
                .zip(&report.iterations_per_solve);
            for (k, (a, b)) in per_solve.enumerate() {
                assert!(
                    a.abs_diff(*b) <= 1,
                    "{ranks} ranks, solve {k}: {a} against {b}"
                );
            }
            let (a, b): (usize, usize) = (
                r.iterations_per_solve.iter().sum(),
                report.iterations_per_solve.iter().sum(),
            );
            let rel = (error.energy - whole_error.energy).abs() / whole_error.energy;
            assert!(rel < 1e-8, "{ranks} ranks: energy error {rel:e} apart");
            eprintln!("{ranks} GPU ranks: Krylov {a} (CPU {b}), energy error {rel:.1e} apart");
        }
        let (diff, once) = compare(&wu, &values);
        assert!(once);
        assert!(diff < 1e-9, "{ranks} ranks: displacements {diff:e} apart");
    }
}
