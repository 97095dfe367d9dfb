//! The linear path of a run (one linear body): set-up, optional condition
//! numbers, the fixed point on the chosen backend (with progress and
//! Ctrl-C), error norms, reactions, and the outputs (report.json; the
//! ParaView files: solution.vtu, surface.vtp, solution.pvd listing them;
//! with plots residuals.svg and deformed.svg), each written atomically.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

use super::{notes, RunOptions, RunOutcome};
use crate::case::physics::SolverSpec;
use crate::case::Case;
use crate::condition::{condition_number, ConditionOptions};
use crate::discrete::boundary_mesh::BoundaryMesh;
use crate::discrete::field::solution_and_interpolant_errors;
use crate::driver::fixed_point::FixedPointReport;
use crate::driver::linear::{CpuSolver, LinearSolver};
use crate::driver::output::write_paraview;
use crate::driver::setup::Setup;
use crate::driver::share::Whole;
use crate::driver::solve::{reactions_by_tag, solve_with_progress};
use crate::driver::surface_output::SurfaceFields;
use crate::error::{Error, Result};
use crate::gpu::linear::{GpuSolver, Scalars};
use crate::gpu::{BackendChoice, GpuBackend, GpuContext, Precision};
use crate::output::{write_atomic, Written};
use crate::plot::{deformed_svg, SurfacePicture};
use crate::progress::Progress;
use crate::report::newton::ReactionRow;
use crate::report::{BodyReport, Condition, FixedPoint, Krylov, Report};
use crate::solver::Preconditioner;
use crate::spatial::Aabb;

/// Writes, with `plots`, DIR/residuals.svg from the loop's history, then
/// DIR/report.json listing the files `written`.
fn write_report(
    report: &Report,
    fp: &FixedPointReport,
    plots: bool,
    written: &mut Written,
) -> Result<()> {
    if plots {
        super::create_dir(written.dir())?;
        let title = format!("{}: fixed-point convergence", report.case);
        let svg = fp.residual_chart(&title).to_svg()?;
        written.write("residuals.svg", |path| write_atomic(path, svg.as_bytes()))?;
    }
    super::write_report(written.dir(), report, &written.files)
}

/// Writes DIR/deformed.svg: the boundary surface at `X + s u_h(X)`, `s`
/// magnifying the largest displacement to 5% of the surface's box diagonal,
/// coloured by von Mises.
fn write_deformed(
    name: &str,
    mesh: &BoundaryMesh,
    fields: &SurfaceFields,
    written: &mut Written,
) -> Result<()> {
    let b = Aabb::around(&mesh.points);
    let diagonal = (0..3)
        .map(|a| (b.hi[a] - b.lo[a]).powi(2))
        .sum::<f64>()
        .sqrt();
    let largest = fields
        .displacement
        .iter()
        .map(|u| (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]).sqrt())
        .fold(0.0, f64::max);
    let s = if largest > 0.0 && diagonal.is_finite() {
        0.05 * diagonal / largest
    } else {
        1.0
    };
    let points: Vec<[f64; 3]> = mesh
        .points
        .iter()
        .zip(&fields.displacement)
        .map(|(x, u)| [0, 1, 2].map(|a| x[a] + s * u[a]))
        .collect();
    let title = format!("{name}: deformed surface (displacement ×{s:.3}), von Mises");
    let svg = deformed_svg(&SurfacePicture {
        title: &title,
        points: &points,
        triangles: &mesh.triangles,
        values: &fields.von_mises,
        label: "von Mises",
    })?;
    written.write("deformed.svg", |path| write_atomic(path, svg.as_bytes()))
}

/// κ and Jacobi-scaled κ of the assembled operator.
fn condition_numbers(setup: &Setup) -> Result<Condition> {
    let a = setup.op.assemble();
    let opts = ConditionOptions::default();
    let plain = condition_number(&a, false, &opts)?;
    let scaled = condition_number(&a, true, &opts)?;
    Ok(Condition {
        kappa: plain.kappa,
        kappa_jacobi: scaled.kappa,
        kappa_is_lower_bound: plain.kappa_is_lower_bound,
        kappa_jacobi_is_lower_bound: scaled.kappa_is_lower_bound,
        method: format!("plain: {}; jacobi: {}", plain.method, scaled.method),
    })
}

/// The preconditioner `auto` stands for on the device at hand: the
/// multigrid V-cycle on the CPU and on an f64 GPU, Jacobi on an f32-only GPU
/// (its V-cycle runs in f64). `multigrid` asked of an f32 GPU is
/// [`Error::UnsupportedOnBackend`] (exit code 2).
fn resolve_preconditioner(case: &mut Case, gpu: Option<&GpuContext>) -> Result<()> {
    let f32_gpu = gpu.is_some_and(|ctx| ctx.precision == Precision::F32);
    let pre = &mut case.spec.solver.preconditioner;
    match *pre {
        Preconditioner::Auto if f32_gpu => *pre = Preconditioner::Jacobi,
        Preconditioner::Auto => *pre = Preconditioner::Multigrid,
        Preconditioner::Multigrid if f32_gpu => {
            return Err(Error::UnsupportedOnBackend {
                backend: "gpu (f32)".into(),
                what: "the multigrid preconditioner".into(),
                hint: "use --precision f64, --backend cpu, or solver.preconditioner = \"jacobi\""
                    .into(),
            })
        }
        _ => {}
    }
    Ok(())
}

/// The device the set-up can be solved on: `gpu` unless its kernels cannot
/// take the set-up, which `auto` answers with the CPU (said) and `gpu`
/// with an error.
fn usable_device(
    gpu: Option<Arc<GpuContext>>,
    setup: &Setup,
    options: &RunOptions,
    progress: &dyn Progress,
) -> Result<Option<Arc<GpuContext>>> {
    let Some(ctx) = gpu else { return Ok(None) };
    let auto = BackendChoice::resolve(options.device.backend)? == BackendChoice::Auto;
    if setup.op.dofs.has_copies() {
        if auto {
            progress
                .say("note: the GPU kernels do not take split cells; solving on the CPU".into());
            return Ok(None);
        }
        return Err(Error::UnsupportedOnBackend {
            backend: "gpu".into(),
            what: "cells split into pieces at walls thinner than a cell".into(),
            hint: "use --backend cpu (or auto), or a level that resolves the walls".into(),
        });
    }
    match ctx.check_vector_len(setup.op.dofs.ndofs()) {
        Ok(()) => Ok(Some(ctx)),
        Err(e) if auto => {
            progress.say(format!("note: {e}; solving on the CPU"));
            Ok(None)
        }
        Err(e) => Err(e),
    }
}

/// Solves the one linear body of `case` and writes its outputs into the
/// options' folder.
pub(super) fn run(
    mut case: Case,
    options: &RunOptions,
    dir: PathBuf,
    progress: &dyn Progress,
) -> Result<RunOutcome> {
    let gpu = super::open_device(&options.device, progress)?;
    let auto = case.spec.solver.preconditioner == Preconditioner::Auto;
    resolve_preconditioner(&mut case, gpu.as_deref())?;
    let mut solver_spec = case.spec.solver.clone();
    let mut report = Report::new(&case);
    let mut fp = FixedPointReport::default();
    let mut written = Written::new(&dir);
    // Every step after the case is read; a solver failure on the way (the
    // set-up's multigrid, the solve, the output's recovery) still leaves a
    // report.
    let result = solve_and_write(
        &case,
        options,
        gpu,
        auto,
        &mut solver_spec,
        &mut report,
        &mut fp,
        &mut written,
        progress,
    );
    match result {
        Ok(()) => Ok(RunOutcome {
            dir,
            report,
            files: written.files,
            result: Ok(()),
        }),
        Err(e) if matches!(e.exit_code(), 3 | 130) => {
            report.fail(&e);
            write_report(&report, &fp, options.plots, &mut written)?;
            Ok(RunOutcome {
                dir,
                report,
                files: written.files,
                result: Err(e),
            })
        }
        Err(e) => Err(e),
    }
}

/// The run after the case is read: set-up, solve, norms, outputs and the
/// report, filled in as it goes.
#[allow(clippy::too_many_arguments)]
fn solve_and_write(
    case: &Case,
    options: &RunOptions,
    gpu: Option<Arc<GpuContext>>,
    auto: bool,
    solver_spec: &mut SolverSpec,
    report: &mut Report,
    fp: &mut FixedPointReport,
    written: &mut Written,
    progress: &dyn Progress,
) -> Result<()> {
    let name = case.spec.name.clone().unwrap_or_else(|| "case".into());
    let setup = Setup::new_with_progress(case, options.level, progress)?;
    let order = case.body().spec.element;
    let body = case.body();
    let mut row = BodyReport::new(
        &body.spec.name,
        body.model,
        order,
        &body.geometry,
        &setup.grid,
        &setup.cells,
        false,
    );
    row.cells.pathological = Some(setup.omega_star.len());
    row.cells.record_split(&setup.grid, &setup.op.dofs);
    row.dofs = setup.op.dofs.ndofs();
    report.push_body(row);
    report.timings.extend(setup.timings.iter().cloned());
    let b = &report.bodies[0];
    progress.say(format!(
        "case {name} ({}): level {}, {order:?}, {} dofs; {} inside, {} cut cells",
        case.file, setup.grid.level, report.dofs, b.cells.inside, b.cells.cut
    ));
    for notice in [notes::repaired(b), notes::glued(b)].into_iter().flatten() {
        progress.notice(notice);
    }
    if let Some(split) = notes::split(b) {
        progress.say(split);
    }

    if options.condition {
        let t = Instant::now();
        let c = condition_numbers(&setup)?;
        report
            .timings
            .insert("condition".into(), t.elapsed().as_secs_f64());
        let bound = |b: bool| if b { "≥ " } else { "" };
        progress.say(format!(
            "  κ = {}{:.3e}, Jacobi-scaled κ = {}{:.3e}",
            bound(c.kappa_is_lower_bound),
            c.kappa,
            bound(c.kappa_jacobi_is_lower_bound),
            c.kappa_jacobi
        ));
        report.condition = Some(c);
    }

    let t = Instant::now();
    let (mut cpu_solver, mut gpu_solver);
    let solver: &mut dyn LinearSolver = match usable_device(gpu, &setup, options, progress)? {
        Some(ctx) => {
            let be = GpuBackend::new(ctx.clone());
            let (solver, too_small) = GpuSolver::for_setup(be, &setup, Scalars::Device, auto)?;
            if let Some(e) = too_small {
                progress.say(format!("note: {e}; Jacobi on the GPU instead"));
                solver_spec.preconditioner = Preconditioner::Jacobi;
            }
            gpu_solver = solver;
            report.backend = "gpu".into();
            report.adapter = Some(ctx.adapter.name.clone());
            report.precision = ctx.precision.name().into();
            &mut gpu_solver
        }
        None => {
            cpu_solver = CpuSolver::for_setup(&setup);
            &mut cpu_solver
        }
    };
    report
        .timings
        .insert("upload".into(), t.elapsed().as_secs_f64());
    progress.say(format!(
        "  backend {}{} ({})",
        report.backend,
        report
            .adapter
            .as_ref()
            .map_or(String::new(), |a| format!(": {a}")),
        report.precision
    ));
    let t = Instant::now();
    let result = solve_with_progress(&setup, solver_spec, solver, fp, progress);
    report
        .timings
        .insert("solve".into(), t.elapsed().as_secs_f64());
    report.timings.extend(fp.timings());
    report.krylov = Some(Krylov::of(solver_spec, fp));
    report.fixed_point = Some(FixedPoint::of(solver_spec, fp));
    let solution = result?;

    let t = Instant::now();
    let row = &mut report.bodies[0];
    if let Some(exact) = &setup.problem.exact {
        let (l, m) = (setup.problem.lambda, setup.problem.mu);
        let dofs = &setup.op.dofs;
        let (grid, cells, u) = (&setup.grid, &setup.cells, &solution.u);
        let (error, interpolant) =
            solution_and_interpolant_errors(grid, cells, dofs, u, exact, l, m);
        row.error = Some(error);
        match interpolant {
            Ok(e) => row.interpolant_error = Some(Some(e)),
            Err(why) => {
                row.interpolant_error = Some(None);
                row.interpolant_error_note = Some(why);
            }
        }
    }
    report.reactions = reaction_rows(case, &setup, &solution.reactions);
    report
        .timings
        .insert("error_norms".into(), t.elapsed().as_secs_f64());

    let t = Instant::now();
    super::create_dir(written.dir())?;
    let (geometry, u) = (&case.body().geometry, &solution.u);
    let paraview = options.paraview;
    let stress = Some(&solution.stress);
    let surface = write_paraview(
        &setup,
        geometry,
        u,
        stress,
        paraview,
        options.plots,
        written,
    )?;
    report
        .timings
        .insert("output".into(), t.elapsed().as_secs_f64());
    report
        .timings
        .insert("output_write".into(), written.seconds);
    if let Some((mesh, fields)) = surface.filter(|_| options.plots) {
        write_deformed(&name, &mesh, &fields, written)?;
    }
    write_report(report, fp, options.plots, written)
}

/// `Σ_q w_q λ_q` per Dirichlet part of the case's body, one load step.
fn reaction_rows(case: &Case, setup: &Setup, reactions: &[[f64; 3]]) -> Vec<ReactionRow> {
    let geometry = &case.body().geometry;
    let tags = geometry.tag_names().len();
    let by_tag = reactions_by_tag(&setup.dirichlet, reactions, tags, &Whole);
    let mut by_part: BTreeMap<&str, [f64; 3]> = BTreeMap::new();
    for (tag, force) in by_tag.iter().enumerate() {
        if let Some(force) = force {
            let sum = by_part.entry(geometry.tag_name(tag as u16)).or_default();
            for (s, f) in sum.iter_mut().zip(force) {
                *s += f;
            }
        }
    }
    by_part
        .into_iter()
        .map(|(part, force)| ReactionRow {
            body: case.body().spec.name.clone(),
            part: part.to_string(),
            step: 1,
            force,
        })
        .collect()
}
