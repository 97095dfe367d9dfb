//! Seeded mutations of real STL parts (the re-entrant 7/8 cube and the
//! embossed calibration cube of `cases/parts/`): facets deleted (holes),
//! flipped, duplicated, cracked apart (a corner moved), slivers added, and
//! boxes added overlapping the part, outward or inside out. Each mutant is
//! set up and solved at level 3 (random offset), clamped at its bottom
//! under its own weight: no panic, no cut cell with a volume outside
//! `[0, h³]`, no negative stiffness, and either a solve whose reaction
//! balances the weight the rules integrate, or a refusal that names the case
//! file (exit code 2). 40 mutants by default, 10 000 in the long tier
//! (`CGFEM_LONG=1`), or `CGFEM_STL_FUZZ_CASES`; `CGFEM_STL_FUZZ_SEED`
//! changes the seed.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::PathBuf;

use cgfem_gpu::case::Case;
use cgfem_gpu::driver::fixed_point::FixedPointReport;
use cgfem_gpu::driver::setup::Setup;
use cgfem_gpu::driver::solve::solve;
use cgfem_gpu::mesh::box_triangles;
use cgfem_gpu::mesh::stl::{read_stl, write_binary_stl};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

type Triangle = [[f64; 3]; 3];

fn part(name: &str) -> Vec<Triangle> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("cases/parts")
        .join(name);
    read_stl(&path)
        .unwrap()
        .into_iter()
        .flat_map(|s| s.triangles)
        .collect()
}

/// The 12 facets of the box `lo`–`hi`, outward or inside out.
fn box_facets(lo: [f64; 3], hi: [f64; 3], inverted: bool) -> Vec<Triangle> {
    box_triangles(lo, hi)
        .into_iter()
        .map(|t| if inverted { [t[0], t[2], t[1]] } else { t })
        .collect()
}

/// One to three seeded mutations of `tris`, whose box is `lo`–`hi`; their
/// names.
fn mutate(rng: &mut ChaCha8Rng, tris: &mut Vec<Triangle>, lo: [f64; 3], hi: [f64; 3]) -> String {
    let size = [0, 1, 2].map(|a| hi[a] - lo[a]);
    let point = |rng: &mut ChaCha8Rng| [0, 1, 2].map(|a| lo[a] + size[a] * rng.gen_range(0.0..1.0));
    let mut what = Vec::new();
    for _ in 0..rng.gen_range(1..=3) {
        let n = tris.len();
        match rng.gen_range(0..6) {
            0 => {
                for _ in 0..rng.gen_range(1..=3.min(n - 1)) {
                    tris.swap_remove(rng.gen_range(0..tris.len()));
                }
                what.push("hole");
            }
            1 => {
                let t = rng.gen_range(0..n);
                tris[t].swap(1, 2);
                what.push("flipped facet");
            }
            2 => {
                let t = tris[rng.gen_range(0..n)];
                tris.push(t);
                what.push("duplicated facet");
            }
            3 => {
                let t = rng.gen_range(0..n);
                let k = rng.gen_range(0..3);
                for a in 0..3 {
                    tris[t][k][a] += 0.02 * size[a] * rng.gen_range(-1.0..1.0);
                }
                what.push("crack");
            }
            4 => {
                let p = point(rng);
                let d = [0, 1, 2].map(|a| 1e-4 * size[a] * rng.gen_range(-1.0..1.0));
                let e = [0, 1, 2].map(|a| 0.2 * size[a] * rng.gen_range(-1.0..1.0));
                tris.push([
                    p,
                    [p[0] + e[0], p[1] + e[1], p[2] + e[2]],
                    [p[0] + d[0], p[1] + d[1], p[2] + d[2]],
                ]);
                what.push("sliver");
            }
            _ => {
                let c = point(rng);
                let half = [0, 1, 2].map(|a| size[a] * rng.gen_range(0.05..0.2));
                let inverted = rng.gen_bool(0.5);
                tris.extend(box_facets(
                    [0, 1, 2].map(|a| c[a] - half[a]),
                    [0, 1, 2].map(|a| c[a] + half[a]),
                    inverted,
                ));
                what.push(if inverted {
                    "inverted box"
                } else {
                    "overlapping box"
                });
            }
        }
    }
    what.join(", ")
}

/// 40, 10 000 with `CGFEM_LONG=1`, or `CGFEM_STL_FUZZ_CASES`.
fn mutants() -> usize {
    let tier = match std::env::var_os("CGFEM_LONG") {
        Some(_) => 10_000,
        None => 40,
    };
    std::env::var("CGFEM_STL_FUZZ_CASES").map_or(tier, |n| n.parse().unwrap())
}

#[test]
fn mutated_stl_parts_solve_or_are_refused_by_name() {
    let seed: u64 = std::env::var("CGFEM_STL_FUZZ_SEED").map_or(20_261_127, |s| s.parse().unwrap());
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let parts = [part("7_8ths_cube.stl"), part("20mm-xyz-cube.stl")];
    let dir = std::env::temp_dir().join(format!("cgfem-stl-fuzz-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (mut solved, mut refused) = (0, 0);
    for k in 0..mutants() {
        let mut tris = parts[k % 2].clone();
        let b = tris
            .iter()
            .flatten()
            .fold(([f64::MAX; 3], [f64::MIN; 3]), |(lo, hi), p| {
                (
                    [0, 1, 2].map(|a| lo[a].min(p[a])),
                    [0, 1, 2].map(|a| hi[a].max(p[a])),
                )
            });
        let what = mutate(&mut rng, &mut tris, b.0, b.1);
        let path = dir.join(format!("m{k}.stl"));
        write_binary_stl(&path, &tris).unwrap();
        let offset = [0, 1, 2].map(|_| rng.gen_range(0.0..1.0));
        let z_hold = b.0[2] + 0.05 * (b.1[2] - b.0[2]);
        let text = format!(
            "[geometry]\ntype = \"stl\"\npath = \"{}\"\n[grid]\nlevel = 3\noffset = [{}, {}, {}]\n\
             [material]\nyoung = 1000.0\npoisson = 0.3\n[body_load]\nvalue = [\"0\", \"0\", \"-1\"]\n\
             [dirichlet.surface]\nvalue = [\"0\", \"0\", \"0\"]\n\
             region = {{ min = [-1e9, -1e9, -1e9], max = [1e9, 1e9, {z_hold}] }}\n",
            path.display(),
            offset[0],
            offset[1],
            offset[2]
        );
        let label = format!("mutant {k} ({what}) of part {}", k % 2);
        let outcome = catch_unwind(AssertUnwindSafe(|| {
            let case = Case::from_str("fuzz.toml", &text)?;
            let setup = Setup::new(&case, None)?;
            let h3 = setup.grid.h.powi(3);
            for i in 0..setup.cells.cut.len() {
                let v: f64 = setup.cells.volume_points(i).iter().map(|p| p.w).sum();
                assert!(
                    v > -1e-9 * h3 && v < (1.0 + 1e-9) * h3,
                    "{label}: cut cell {} has volume {:e} h³",
                    setup.cells.cut[i],
                    v / h3
                );
            }
            let mut report = FixedPointReport::default();
            let solution = solve(&setup, &case.spec.solver, &mut report)?;
            // The clamp carries the weight the rules integrate.
            let weight = setup.cells.volume(&setup.grid);
            let reaction: f64 = setup
                .dirichlet
                .iter()
                .zip(&solution.reactions)
                .map(|(p, r)| p.w * r[2])
                .sum();
            assert!(
                (reaction - weight).abs() <= 1e-6 * weight,
                "{label}: reaction {reaction} against the weight {weight}"
            );
            Ok::<(), cgfem_gpu::Error>(())
        }));
        match outcome {
            Err(_) => panic!("{label} panicked: {}", path.display()),
            Ok(Ok(())) => solved += 1,
            Ok(Err(cgfem_gpu::Error::CaseFile { file, key, reason })) => {
                assert_eq!(file, "fuzz.toml", "{label}");
                println!("{label}: refused: {key}: {reason}");
                refused += 1;
            }
            Ok(Err(e)) => panic!("{label}: {e} ({})", path.display()),
        }
    }
    println!("{solved} solved, {refused} refused by name");
    let _ = std::fs::remove_dir_all(&dir);
}
