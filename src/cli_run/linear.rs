//! The linear path of `cgfem-gpu run` (one linear body): set-up, optional
//! condition numbers, the fixed point on the chosen backend (with progress
//! and Ctrl-C), error norms, reactions, and the outputs (report.json; the
//! ParaView files of `--output`: solution.vtu, surface.vtp, solution.pvd
//! listing them; with --plots residuals.svg and deformed.svg), each written
//! atomically.

use std::collections::BTreeMap;
use std::path::Path;
use std::time::Instant;

use anyhow::Context;

use cgfem_gpu::case::Case;
use cgfem_gpu::condition::{condition_number, ConditionOptions};
use cgfem_gpu::discrete::boundary_mesh::BoundaryMesh;
use cgfem_gpu::discrete::field::solution_and_interpolant_errors;
use cgfem_gpu::driver::fixed_point::FixedPointReport;
use cgfem_gpu::driver::linear::{CpuSolver, LinearSolver};
use cgfem_gpu::driver::output::write_paraview;
use cgfem_gpu::driver::setup::Setup;
use cgfem_gpu::driver::share::Whole;
use cgfem_gpu::driver::solve::{reactions_by_tag, solve_with_progress};
use cgfem_gpu::driver::surface_output::SurfaceFields;
use cgfem_gpu::gpu::linear::{GpuSolver, Scalars};
use cgfem_gpu::gpu::{BackendChoice, GpuBackend, GpuContext, Precision};
use cgfem_gpu::output::{write_atomic, Written};
use cgfem_gpu::plot::{deformed_svg, SurfacePicture};
use cgfem_gpu::report::newton::ReactionRow;
use cgfem_gpu::report::{BodyReport, Condition, FixedPoint, Krylov, Report};
use cgfem_gpu::solver::Preconditioner;
use cgfem_gpu::spatial::Aabb;

use super::{Device, Outputs};
use crate::cli_progress::Terminal;

/// Writes, with `plots`, DIR/residuals.svg from the loop's history, then
/// DIR/report.json listing the files `written`.
fn write_report(
    dir: &Path,
    report: &Report,
    fp: &FixedPointReport,
    plots: bool,
    written: &mut Written,
) -> anyhow::Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    if plots {
        let title = format!("{}: fixed-point convergence", report.case);
        let svg = fp.residual_chart(&title).to_svg()?;
        written.write("residuals.svg", |path| write_atomic(path, svg.as_bytes()))?;
    }
    super::write_report(dir, report, &written.files)
}

/// Writes DIR/deformed.svg: the boundary surface at `X + s u_h(X)`, `s`
/// magnifying the largest displacement to 5% of the surface's box diagonal,
/// coloured by von Mises.
fn write_deformed(
    name: &str,
    mesh: &BoundaryMesh,
    fields: &SurfaceFields,
    written: &mut Written,
) -> anyhow::Result<()> {
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
    written.write("deformed.svg", |path| write_atomic(path, svg.as_bytes()))?;
    Ok(())
}

/// κ and Jacobi-scaled κ of the assembled operator.
fn condition_numbers(setup: &Setup) -> anyhow::Result<Condition> {
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
/// [`cgfem_gpu::Error::UnsupportedOnBackend`] (exit code 2).
fn resolve_preconditioner(case: &mut Case, gpu: Option<&GpuContext>) -> anyhow::Result<()> {
    let f32_gpu = gpu.is_some_and(|ctx| ctx.precision == Precision::F32);
    let pre = &mut case.spec.solver.preconditioner;
    match *pre {
        Preconditioner::Auto if f32_gpu => *pre = Preconditioner::Jacobi,
        Preconditioner::Auto => *pre = Preconditioner::Multigrid,
        Preconditioner::Multigrid if f32_gpu => {
            return Err(cgfem_gpu::Error::UnsupportedOnBackend {
                backend: "gpu (f32)".into(),
                what: "the multigrid preconditioner".into(),
                hint: "use --precision f64, --backend cpu, or solver.preconditioner = \"jacobi\""
                    .into(),
            }
            .into())
        }
        _ => {}
    }
    Ok(())
}

/// Solves the one linear body of `case` and writes its outputs into `dir`.
pub fn run(
    mut case: Case,
    level: Option<u32>,
    dir: &Path,
    outputs: &Outputs,
    condition: bool,
    device: &Device,
    progress: &Terminal,
) -> anyhow::Result<()> {
    let gpu = super::open_device(device)?;
    let auto = case.spec.solver.preconditioner == Preconditioner::Auto;
    resolve_preconditioner(&mut case, gpu.as_deref())?;
    let mut solver_spec = case.spec.solver.clone();
    let mut report = Report::new(&case);
    let mut fp = FixedPointReport::default();
    let mut written = Written::new(dir);
    // Every step after the case is read; a solver failure on the way (the
    // set-up's multigrid, the solve, the output's recovery) still leaves a
    // report.
    let result = (|| -> anyhow::Result<()> {
        let report = &mut report;
        let fp = &mut fp;
        let written = &mut written;
        let name = case.spec.name.clone().unwrap_or_else(|| "case".into());
        let setup = Setup::new_with_progress(&case, level, progress);
        progress.finish();
        let setup = setup?;
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
        println!(
            "case {name} ({}): level {}, {order:?}, {} dofs; {} inside, {} cut cells",
            case.file, setup.grid.level, report.dofs, b.cells.inside, b.cells.cut
        );
        super::repaired_note(b);
        super::glued_note(b);
        super::split_note(b);

        if condition {
            let t = Instant::now();
            report.condition = Some(condition_numbers(&setup)?);
            report
                .timings
                .insert("condition".into(), t.elapsed().as_secs_f64());
            if let Some(c) = &report.condition {
                let bound = |b: bool| if b { "≥ " } else { "" };
                println!(
                    "  κ = {}{:.3e}, Jacobi-scaled κ = {}{:.3e}",
                    bound(c.kappa_is_lower_bound),
                    c.kappa,
                    bound(c.kappa_jacobi_is_lower_bound),
                    c.kappa_jacobi
                );
            }
        }

        let t = Instant::now();
        let (mut cpu_solver, mut gpu_solver);
        let gpu =
            match gpu {
                Some(_) if setup.op.dofs.has_copies() => {
                    match BackendChoice::resolve(device.backend)? {
                        BackendChoice::Auto => {
                            println!(
                                "note: the GPU kernels do not take split cells; solving on the CPU"
                            );
                            None
                        }
                        _ => return Err(cgfem_gpu::Error::UnsupportedOnBackend {
                            backend: "gpu".into(),
                            what: "cells split into pieces at walls thinner than a cell".into(),
                            hint: "use --backend cpu (or auto), or a level that resolves the walls"
                                .into(),
                        }
                        .into()),
                    }
                }
                Some(ctx) => match ctx.check_vector_len(setup.op.dofs.ndofs()) {
                    Ok(()) => Some(ctx),
                    Err(e) if BackendChoice::resolve(device.backend)? == BackendChoice::Auto => {
                        println!("note: {e}; solving on the CPU");
                        None
                    }
                    Err(e) => return Err(e.into()),
                },
                None => None,
            };
        let solver: &mut dyn LinearSolver = match &gpu {
            Some(ctx) => {
                let be = GpuBackend::new(ctx.clone());
                let (solver, too_small) = GpuSolver::for_setup(be, &setup, Scalars::Device, auto)?;
                if let Some(e) = too_small {
                    println!("note: {e}; Jacobi on the GPU instead");
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
        println!(
            "  backend {}{} ({})",
            report.backend,
            report
                .adapter
                .as_ref()
                .map_or(String::new(), |a| format!(": {a}")),
            report.precision
        );
        let t = Instant::now();
        let result = solve_with_progress(&setup, &solver_spec, solver, fp, progress);
        progress.finish();
        report
            .timings
            .insert("solve".into(), t.elapsed().as_secs_f64());
        report.timings.extend(fp.timings());
        let so = &solver_spec;
        report.krylov = Some(Krylov::of(so, fp));
        report.fixed_point = Some(FixedPoint::of(so, fp));
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
        // Σ_q w_q λ_q per Dirichlet part, one load step.
        let geometry = &case.body().geometry;
        let tags = geometry.tag_names().len();
        let by_tag = reactions_by_tag(&setup.dirichlet, &solution.reactions, tags, &Whole);
        let mut by_part: BTreeMap<&str, [f64; 3]> = BTreeMap::new();
        for (tag, force) in by_tag.iter().enumerate() {
            if let Some(force) = force {
                let sum = by_part.entry(geometry.tag_name(tag as u16)).or_default();
                for (s, f) in sum.iter_mut().zip(force) {
                    *s += f;
                }
            }
        }
        let reactions = by_part
            .into_iter()
            .map(|(part, force)| ReactionRow {
                body: case.body().spec.name.clone(),
                part: part.to_string(),
                step: 1,
                force,
            })
            .collect();
        report.reactions = reactions;
        report
            .timings
            .insert("error_norms".into(), t.elapsed().as_secs_f64());

        let t = Instant::now();
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        let (geometry, u) = (&case.body().geometry, &solution.u);
        let surface = write_paraview(
            &setup,
            geometry,
            u,
            Some(&solution.stress),
            outputs.paraview,
            outputs.plots,
            written,
        )?;
        report
            .timings
            .insert("output".into(), t.elapsed().as_secs_f64());
        report
            .timings
            .insert("output_write".into(), written.seconds);
        if let Some((mesh, fields)) = surface.filter(|_| outputs.plots) {
            write_deformed(&name, &mesh, &fields, written)?;
        }
        write_report(dir, report, fp, outputs.plots, written)?;

        println!(
            "  {} {}: {} fixed-point iterations, Krylov iterations {:?} (total {}), final residual {:.2e}",
            so.method.name(),
            format!("{:?}", so.preconditioner).to_lowercase(),
            fp.iterations,
            fp.iterations_per_solve,
            fp.total_iterations,
            fp.final_relative_residual
        );
        if fp.floored_diagonal_entries > 0 {
            println!(
                "  note: Jacobi floored {} diagonal entries at round-off level (cut artefacts)",
                fp.floored_diagonal_entries
            );
        }
        let row = &report.bodies[0];
        if let Some(e) = &row.error {
            let interpolant = match &row.interpolant_error {
                Some(Some(ei)) => format!("; interpolant {:.4e}", ei.energy_relative),
                _ => String::new(),
            };
            println!(
                "  energy error {:.4e} (relative {:.4e}{interpolant}), L2 relative {:.4e}",
                e.energy, e.energy_relative, e.l2_relative
            );
            if let Some(why) = &row.interpolant_error_note {
                println!("  interpolant error not reported: {why}");
            }
        }
        for r in &report.reactions {
            let f = r.force;
            println!(
                "  reaction on '{}': [{:.6e}, {:.6e}, {:.6e}]",
                r.part, f[0], f[1], f[2]
            );
        }
        println!(
            "  wrote {}{}",
            &dir.join("report.json").display(),
            written
                .files
                .iter()
                .map(|f| format!(", {f}"))
                .collect::<String>()
        );
        Ok(())
    })();
    if let Err(e) = &result {
        if let Some(e) = e.downcast_ref::<cgfem_gpu::Error>() {
            if matches!(e.exit_code(), 3 | 130) {
                report.fail(e);
                write_report(dir, &report, &fp, outputs.plots, &mut written)?;
                eprintln!(
                    "report (marked {}): {}",
                    report.status,
                    &dir.join("report.json").display()
                );
            }
        }
    }
    result
}
