//! Seeded random images through the whole run: random sizes (2 to 9
//! samples per axis), sample types, encodings, values (noise, a blob,
//! a constant), thresholds (inside and outside the values' range), sides and
//! smoothing, and a third of them with a corrupted file (data truncated,
//! padded or flipped, a header line dropped, changed or added). Each is set
//! up and solved at level 2 or 3, clamped on its whole surface under its own
//! weight: no panic, no cut cell with a volume outside `[0, h³]`, and either
//! a solve, or a refusal that names the case file and the key, or (a noisy
//! image whose fragments are too small for the grid) the recovery's named
//! failure that asks for a higher level (exit code 3). 30 images by
//! default, 2 000 in the long tier (`CGFEM_LONG=1`), or
//! `CGFEM_IMAGE_FUZZ_CASES`; `CGFEM_IMAGE_FUZZ_SEED` changes the seed.

use std::panic::{catch_unwind, AssertUnwindSafe};

use cgfem_gpu::case::Case;
use cgfem_gpu::driver::fixed_point::FixedPointReport;
use cgfem_gpu::driver::setup::Setup;
use cgfem_gpu::driver::solve::solve;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::image::{gzip, nrrd, temp_dir};

fn images() -> usize {
    let tier = match std::env::var_os("CGFEM_LONG") {
        Some(_) => 2_000,
        None => 30,
    };
    std::env::var("CGFEM_IMAGE_FUZZ_CASES").map_or(tier, |n| n.parse().unwrap())
}

/// A random image file and a description of it.
fn random_image(rng: &mut ChaCha8Rng) -> (Vec<u8>, f64, f64, String) {
    let size = [0, 1, 2].map(|_| rng.gen_range(2..=9usize));
    let count = size.iter().product::<usize>();
    let (ty, lo, hi) = [
        ("uint8", 0.0, 255.0),
        ("short", -3e4, 3e4),
        ("uint16", 0.0, 6e4),
        ("float", -1.0, 1.0),
        ("double", -1e3, 1e3),
    ][rng.gen_range(0..5)];
    let mode = [0, 0, 1, 1, 1, 2][rng.gen_range(0..6)];
    let c = [0, 1, 2].map(|a| rng.gen_range(0.0..size[a] as f64));
    let radius = rng.gen_range(0.5..4.0);
    let values: Vec<f64> = (0..count)
        .map(|n| {
            let s = [n % size[0], n / size[0] % size[1], n / (size[0] * size[1])];
            let v = match mode {
                0 => rng.gen_range(lo..hi),
                1 => {
                    let r = (0..3)
                        .map(|a| (s[a] as f64 - c[a]).powi(2))
                        .sum::<f64>()
                        .sqrt();
                    let t = (1.0 - r / radius).clamp(-1.0, 1.0) + rng.gen_range(-0.05..0.05);
                    lo + (hi - lo) * 0.5 * (1.0 + t)
                }
                _ => 0.5 * (lo + hi),
            };
            if ty == "float" || ty == "double" {
                v
            } else {
                v.round().clamp(lo, hi)
            }
        })
        .collect();
    let bytes: Vec<u8> = values
        .iter()
        .flat_map(|&v| match ty {
            "uint8" => vec![v as u8],
            "short" => (v as i16).to_le_bytes().to_vec(),
            "uint16" => (v as u16).to_le_bytes().to_vec(),
            "float" => (v as f32).to_le_bytes().to_vec(),
            _ => v.to_le_bytes().to_vec(),
        })
        .collect();
    let encoding = ["raw", "gzip", "ascii"][rng.gen_range(0..3)];
    let data = match encoding {
        "raw" => bytes,
        "gzip" => gzip(&bytes),
        _ => values
            .iter()
            .map(|v| format!("{v} "))
            .collect::<String>()
            .into_bytes(),
    };
    let sizes = format!("sizes: {} {} {}", size[0], size[1], size[2]);
    let spacing = rng.gen_range(0.05..0.5);
    let placement = if rng.gen_bool(0.5) {
        format!("space directions: ({spacing},0,0) (0,{spacing},0) (0,0,{spacing})")
    } else {
        format!("spacings: {spacing} {spacing} {spacing}")
    };
    let mut header = vec![
        format!("type: {ty}"),
        "dimension: 3".into(),
        sizes,
        "endian: little".into(),
        format!("encoding: {encoding}"),
        placement,
        "space origin: (0.1,0.2,0.3)".into(),
    ];
    let mut data = data;
    let mut what = format!("{size:?} {ty} {encoding} mode {mode}");
    if rng.gen_bool(1.0 / 3.0) {
        let corruption = rng.gen_range(0..6);
        match corruption {
            0 => data.truncate(rng.gen_range(0..data.len().max(1))),
            1 => data.extend((0..rng.gen_range(1..9)).map(|_| rng.gen::<u8>())),
            2 => {
                let i = rng.gen_range(0..data.len());
                data[i] ^= 1 << rng.gen_range(0..8);
            }
            3 => {
                header.remove(rng.gen_range(0..header.len()));
            }
            4 => {
                let i = rng.gen_range(0..header.len());
                header[i] = [
                    "type: int64",
                    "sizes: 0 2 2",
                    "encoding: hex",
                    "dimension: 4",
                    "endian: middle",
                    "space directions: (1,0) (0,1)",
                ][rng.gen_range(0..6)]
                .into();
            }
            _ => header.push(
                [
                    "line skip: 2",
                    "data file: LIST",
                    "colour: red",
                    "spacings: nan 1 1",
                    "sizes 2 2 2",
                ][rng.gen_range(0..5)]
                .into(),
            ),
        }
        what += &format!(", corruption {corruption}");
    }
    let lines: Vec<&str> = header.iter().map(String::as_str).collect();
    (nrrd(&lines, &data), lo, hi, what)
}

#[test]
fn random_images_solve_or_are_refused_by_name() {
    let seed: u64 =
        std::env::var("CGFEM_IMAGE_FUZZ_SEED").map_or(20_261_128, |s| s.parse().unwrap());
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let dir = temp_dir("fuzz");
    let file = dir.join("fuzz.toml").display().to_string();
    let (mut solved, mut refused, mut coarse) = (0, 0, 0);
    for k in 0..images() {
        let (bytes, lo, hi, what) = random_image(&mut rng);
        std::fs::write(dir.join(format!("i{k}.nrrd")), bytes).unwrap();
        let threshold = lo + (hi - lo) * rng.gen_range(-0.1..1.1);
        let inside = ["above", "below"][rng.gen_range(0..2)];
        let smooth = [0.0, 0.0, 0.7, 2.0][rng.gen_range(0..4)];
        let level = rng.gen_range(2..=3);
        let offset = [0, 1, 2].map(|_| rng.gen_range(0.0..1.0));
        let text = format!(
            "[geometry]\ntype = \"image\"\nfile = \"i{k}.nrrd\"\nthreshold = {threshold}\ninside = \"{inside}\"\nsmooth = {smooth}\n\
             [grid]\nlevel = {level}\noffset = [{}, {}, {}]\n[material]\nyoung = 1000.0\npoisson = 0.3\n\
             [body_load]\nvalue = [\"0\", \"0\", \"-1\"]\n[dirichlet.surface]\nvalue = [\"0\", \"0\", \"0\"]\n",
            offset[0], offset[1], offset[2]
        );
        let label = format!("image {k} ({what}; threshold {threshold:.4}, {inside}, smooth {smooth}, level {level})");
        let outcome = catch_unwind(AssertUnwindSafe(|| {
            let case = Case::from_str(&file, &text)?;
            let setup = Setup::new(&case, None)?;
            let h3 = setup.grid.h.powi(3);
            for i in 0..setup.cells.cut.len() {
                let v: f64 = setup.cells.volume_points(i).iter().map(|p| p.w).sum();
                assert!(
                    v > -1e-9 * h3 && v < (1.0 + 1e-9) * h3,
                    "{label}: cut cell volume {:e} h³",
                    v / h3
                );
            }
            let mut report = FixedPointReport::default();
            solve(&setup, &case.spec.solver, &mut report)?;
            Ok::<(), cgfem_gpu::Error>(())
        }));
        match outcome {
            Err(_) => panic!("{label} panicked"),
            Ok(Ok(())) => solved += 1,
            Ok(Err(cgfem_gpu::Error::CaseFile {
                file: f,
                key,
                reason,
            })) => {
                assert_eq!(f, file, "{label}");
                assert!(key.starts_with("geometry"), "{label}: {key}: {reason}");
                println!("{label}: refused: {key}: {reason}");
                refused += 1;
            }
            Ok(Err(e @ cgfem_gpu::Error::Recovery { .. })) => {
                assert_eq!(e.exit_code(), 3);
                println!("{label}: too coarse: {e}");
                coarse += 1;
            }
            Ok(Err(e)) => panic!("{label}: {e}"),
        }
    }
    println!("{solved} solved, {refused} refused by name, {coarse} too coarse for the grid");
    assert!(
        solved > 0 && refused > 0,
        "{solved} solved, {refused} refused"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
