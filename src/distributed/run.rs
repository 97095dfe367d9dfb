//! A linear case on the ranks of a [`Comm`], from case to report: every rank
//! sets up and solves its share ([`RankSetup`], [`solve_rank`]); the body's
//! counts and measures, the reactions and the error norms are summed over
//! the ranks' bricks; every rank returns the same report, with one row per
//! rank ([`RankRow`]). The Newton path is refused on more than one rank.

use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

use super::backend::DistBackend;
use super::halo::{owner_cell, Reach};
use super::solve::{solve_rank, RankSolution, RankSolver};
use super::surface::gather_surface;
use super::RankSetup;
use crate::case::Case;
use crate::cells::CellKind;
use crate::comm::agree;
use crate::comm::Comm;
use crate::driver::fixed_point::FixedPointReport;
use crate::driver::output::{write_piece, ParaView};
use crate::driver::surface_output::write_surface;
use crate::element::ElementOrder;
use crate::error::{Error, Result};
use crate::gpu::{GpuBackend, GpuContext, GpuOperator, Precision};
use crate::grid::peak_resident_bytes;
use crate::output::Written;
use crate::progress::Progress;
use crate::report::newton::ReactionRow;
use crate::report::{BodyReport, FixedPoint, Krylov, RankRow, Report};
use crate::solver::Preconditioner;
use crate::vtu::write_pvtu;

/// Where a run writes its solution, into `dir` (one file system for all
/// ranks), and which files (`paraview.files`): the volume as each rank's
/// piece `solution_<rank>.vtu` and rank 0's `solution.pvtu` listing them;
/// the surface as one `surface.vtp` from rank 0 ([`gather_surface`]).
#[derive(Clone, Copy, Debug)]
pub struct Pieces<'a> {
    pub dir: &'a Path,
    pub paraview: ParaView,
}

/// What a run gives every rank: the report (the same on every rank), the
/// files written beside it (on rank 0: the `.pvtu` and every piece), and
/// whether the run succeeded (the report then says why it did not).
pub struct RunOutcome {
    pub report: Report,
    pub files: Vec<String>,
    pub result: Result<()>,
}

/// Runs `case` at `level` (default: the case's) on `comm`'s ranks, writing
/// the solution's pieces where `pieces` says. Collective.
pub fn run(
    case: &Case,
    level: Option<u32>,
    comm: &dyn Comm,
    progress: &dyn Progress,
    pieces: Option<Pieces>,
    gpu: Option<Arc<GpuContext>>,
) -> RunOutcome {
    let mut report = Report::new(case);
    report.backend = match &gpu {
        Some(ctx) => format!("gpu:{}×{}", ctx.adapter.name, comm.size()),
        None => format!("cpu×{}", comm.size()),
    };
    let mut files = Vec::new();
    let result = run_into(
        case,
        level,
        comm,
        progress,
        pieces,
        gpu,
        &mut report,
        &mut files,
    );
    if let Err(e) = &result {
        report.fail(e);
    }
    RunOutcome {
        report,
        files,
        result,
    }
}

#[allow(clippy::too_many_arguments)]
fn run_into(
    case: &Case,
    level: Option<u32>,
    comm: &dyn Comm,
    progress: &dyn Progress,
    pieces: Option<Pieces>,
    gpu: Option<Arc<GpuContext>>,
    report: &mut Report,
    files: &mut Vec<String>,
) -> Result<()> {
    if case.require_linear().is_err() {
        return Err(Error::UnsupportedOnBackend {
            backend: format!("distributed ({} ranks)", comm.size()),
            what: "the Newton path (contact, hyperelastic bodies)".into(),
            hint: "run it as one process (without mpirun)".into(),
        });
    }
    let on_gpu;
    let case = match &gpu {
        Some(ctx) => {
            on_gpu = for_gpu_ranks(case, ctx, comm.size())?;
            &on_gpu
        }
        None => case,
    };
    let t = Instant::now();
    let rs = RankSetup::new(case, level, comm, progress)?;
    let setup_seconds = t.elapsed().as_secs_f64();
    report.push_body(body_row(case, &rs, comm));
    report.timings.extend(rs.setup.timings.iter().cloned());
    report.timings.insert("setup".into(), setup_seconds);
    let t = Instant::now();
    let mut fp = FixedPointReport::default();
    let solved = match gpu {
        None => {
            let mut solver = RankSolver::new(&rs, comm);
            solve_rank(&rs, case, comm, &mut solver, &mut fp, progress)
        }
        Some(ctx) => {
            let be = GpuBackend::new(ctx);
            let local = agree(comm, GpuOperator::new(&be, &rs.setup.op))?;
            let mut solver = RankSolver::with(DistBackend::on(be, comm), &local, &rs.halo, None);
            solve_rank(&rs, case, comm, &mut solver, &mut fp, progress)
        }
    };
    let solve_seconds = t.elapsed().as_secs_f64();
    report.timings.insert("solve".into(), solve_seconds);
    report.timings.extend(fp.timings());
    let mut spec = case.spec.solver.clone();
    if spec.preconditioner == Preconditioner::Auto {
        // `auto` is the V-cycle on the ranks' CPUs.
        spec.preconditioner = Preconditioner::Multigrid;
    }
    report.krylov = Some(Krylov::of(&spec, &fp));
    report.fixed_point = Some(FixedPoint::of(&spec, &fp));
    let row = RankRow {
        rank: comm.rank(),
        brick: [rs.bricks[comm.rank()].lo, rs.bricks[comm.rank()].hi],
        inside: 0,
        cut: 0,
        owned_dofs: 3 * rs.halo.num_owned(),
        ghost_dofs: rs.setup.op.dofs.ndofs() - 3 * rs.halo.num_owned(),
        halo_bytes_per_apply: rs.halo.bytes_per_fill(Reach::Near),
        setup_seconds,
        solve_seconds,
        peak_bytes: peak_resident_bytes(),
    };
    report.ranks = gather_rows(comm, row, &rs);
    let solution = solved?;
    record_solution(case, &solution, report);
    if let Some(p) = pieces {
        let t = Instant::now();
        *files = write_pieces(case, &rs, &solution.u, comm, p)?;
        report
            .timings
            .insert("output".into(), t.elapsed().as_secs_f64());
    }
    Ok(())
}

/// The case as the ranks' GPUs solve it: Jacobi for `auto` (the V-cycle
/// on the ranks runs on their CPUs). The multigrid preconditioner, and a
/// device without f64, are refused (exit code 2).
fn for_gpu_ranks(case: &Case, ctx: &GpuContext, ranks: usize) -> Result<Case> {
    let refuse = |what: &str, hint: &str| Error::UnsupportedOnBackend {
        backend: format!("distributed GPU ({ranks} ranks)"),
        what: what.into(),
        hint: hint.into(),
    };
    if ctx.precision != Precision::F64 {
        return Err(refuse(
            "a device without f64",
            "use --backend cpu, or run as one process",
        ));
    }
    let mut case = case.clone();
    match case.spec.solver.preconditioner {
        Preconditioner::Multigrid => {
            return Err(refuse(
                "the multigrid preconditioner",
                "set solver.preconditioner = \"jacobi\" (or \"auto\"), or use --backend cpu",
            ))
        }
        Preconditioner::Auto => case.spec.solver.preconditioner = Preconditioner::Jacobi,
        Preconditioner::Jacobi | Preconditioner::None => {}
    }
    Ok(case)
}

/// Writes the files `p` asks for: this rank's piece and, on rank 0, the
/// `.pvtu` listing every rank's; the surface gathered on rank 0. Returns
/// the files rank 0 wrote. Collective.
fn write_pieces(
    case: &Case,
    rs: &RankSetup,
    u: &[f64],
    comm: &dyn Comm,
    p: Pieces,
) -> Result<Vec<String>> {
    let mut written = Written::new(p.dir);
    let geometry = &case.body().geometry;
    let made = std::fs::create_dir_all(p.dir).map_err(|e| Error::Io {
        path: p.dir.display().to_string(),
        reason: e.to_string(),
    });
    agree(comm, made)?;
    let lead = comm.rank() == 0;
    let encoding = p.paraview.encoding;
    // The surface is computed before any file is written, so that a
    // failed recovery leaves none.
    let surface = match p.paraview.files.surface() {
        true => Some(gather_surface(rs, geometry, u, comm)?),
        false => None,
    };
    let mut listed = Vec::new();
    if p.paraview.files.volume() {
        let brick = rs.bricks[comm.rank()];
        let grid = &rs.setup.grid;
        let counts = |c: usize| brick.contains(grid.cell_ijk(c));
        let name = |r: usize| format!("solution_{r}.vtu");
        let piece = write_piece(
            &rs.setup,
            geometry,
            u,
            &counts,
            &name(comm.rank()),
            encoding,
            &mut written,
        );
        let (point_data, cell_data) = agree(comm, piece)?;
        if lead {
            let names: Vec<String> = (0..comm.size()).map(name).collect();
            written.write("solution.pvtu", |path| {
                write_pvtu(path, &point_data, &cell_data, &names)
            })?;
            listed.push("solution.pvtu".to_string());
            listed.extend(names);
        }
    }
    if let (true, Some((mesh, fields))) = (lead, &surface) {
        written.write("surface.vtp", |path| {
            write_surface(path, mesh, fields, encoding)
        })?;
        listed.push("surface.vtp".to_string());
    }
    Ok(listed)
}

/// The reactions by Dirichlet part and the body's error norms.
fn record_solution(case: &Case, solution: &RankSolution, report: &mut Report) {
    let body = case.body();
    let names = body.geometry.tag_names();
    report.reactions = solution
        .reactions
        .iter()
        .enumerate()
        .filter_map(|(t, force)| {
            force.map(|force| ReactionRow {
                body: body.spec.name.clone(),
                part: names[t].clone(),
                step: 1,
                force,
            })
        })
        .collect();
    report.bodies[0].error = solution.error;
}

/// Every rank's row, in rank order, with the brick's cell counts.
fn gather_rows(comm: &dyn Comm, mut row: RankRow, rs: &RankSetup) -> Vec<RankRow> {
    let brick = rs.bricks[comm.rank()];
    let grid = &rs.setup.grid;
    let in_brick = |c: &usize| brick.contains(grid.cell_ijk(*c));
    let kinds = &rs.setup.cells.kinds;
    row.inside = (0..kinds.len())
        .filter(|c| kinds[*c] == CellKind::Inside && in_brick(c))
        .count();
    row.cut = rs.setup.cells.cut.iter().filter(|c| in_brick(c)).count();
    let numbers = [
        row.inside as f64,
        row.cut as f64,
        row.owned_dofs as f64,
        row.ghost_dofs as f64,
        row.halo_bytes_per_apply as f64,
        row.setup_seconds,
        row.solve_seconds,
        row.peak_bytes as f64,
    ];
    comm.all_gather(&numbers)
        .iter()
        .enumerate()
        .map(|(rank, v)| RankRow {
            rank,
            brick: [rs.bricks[rank].lo, rs.bricks[rank].hi],
            inside: v[0] as usize,
            cut: v[1] as usize,
            owned_dofs: v[2] as usize,
            ghost_dofs: v[3] as usize,
            halo_bytes_per_apply: v[4] as usize,
            setup_seconds: v[5],
            solve_seconds: v[6],
            peak_bytes: v[7] as u64,
        })
        .collect()
}

/// The body's row: its grid, and its cells, unknowns and measures summed
/// over the ranks' bricks.
fn body_row(case: &Case, rs: &RankSetup, comm: &dyn Comm) -> BodyReport {
    let body = case.body();
    let (grid, cells) = (&rs.setup.grid, &rs.setup.cells);
    let brick = rs.bricks[comm.rank()];
    let mut row = BodyReport::new(
        &body.spec.name,
        body.model,
        body.spec.element,
        &body.geometry,
        grid,
        cells,
        false,
    );
    let in_brick = |c: usize| brick.contains(grid.cell_ijk(c));
    row.cells
        .keep_glued(grid, |v| in_brick(owner_cell(grid, ElementOrder::Q1, v)));
    let names = body.geometry.tag_names();
    let mut sums = vec![0.0; 8 + names.len()];
    for (c, k) in cells.kinds.iter().enumerate() {
        if *k == CellKind::Inside && in_brick(c) {
            sums[0] += 1.0;
        }
    }
    sums[4] = sums[0] * grid.h.powi(3);
    for (i, _) in cells.cut.iter().enumerate().filter(|(_, c)| in_brick(**c)) {
        sums[1] += 1.0;
        sums[4] += cells.volume_points(i).iter().map(|p| p.w).sum::<f64>();
        for p in cells.surface_points(i) {
            sums[8 + p.tag as usize] += p.w;
        }
    }
    sums[2] = cells.merged.iter().filter(|&&c| in_brick(c)).count() as f64;
    sums[3] = cells.repaired.iter().filter(|&&c| in_brick(c)).count() as f64;
    sums[5] = rs.setup.omega_star.iter().filter(|&&c| in_brick(c)).count() as f64;
    sums[6] = 3.0 * rs.halo.num_owned() as f64;
    sums[7] = row.cells.glued_nodes as f64;
    comm.sum(&mut sums);
    let boxes = comm.all_gather(&row.cells.glued_box.map_or([f64::NAN; 6], |[lo, hi]| {
        [lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]]
    }));
    row.cells.glued_box = boxes
        .iter()
        .filter(|b| !b[0].is_nan())
        .map(|b| [[b[0], b[1], b[2]], [b[3], b[4], b[5]]])
        .reduce(|a, b| {
            [
                [0, 1, 2].map(|k| a[0][k].min(b[0][k])),
                [0, 1, 2].map(|k| a[1][k].max(b[1][k])),
            ]
        });
    let c = &mut row.cells;
    c.inside = sums[0] as usize;
    c.cut = sums[1] as usize;
    c.outside = grid.num_cells() - c.inside - c.cut;
    c.merged = sums[2] as usize;
    c.repaired = sums[3] as usize;
    c.repaired_box = None;
    c.pathological = Some(sums[5] as usize);
    c.glued_nodes = sums[7] as usize;
    row.dofs = sums[6] as usize;
    row.domain.volume = sums[4];
    row.domain.boundary_area = sums[8..].iter().sum();
    for (name, area) in names.iter().zip(&sums[8..]) {
        row.domain.boundary_area_by_tag.insert(name.clone(), *area);
    }
    row
}
