//! Voxel images as geometry: the NRRD reader on hand-made files, the level
//! set against a trilinear interpolant written here, its bounds, bad files
//! refused by case file and key (the scanned shell: `image_shell.rs`; random
//! images: `image_fuzz.rs`).

use std::io::Write;
use std::path::{Path, PathBuf};

use cgfem_gpu::case::geometry::GeometrySpec;
use cgfem_gpu::case::Case;
use cgfem_gpu::driver::setup::Setup;
use cgfem_gpu::geometry::nrrd::read_nrrd;
use cgfem_gpu::geometry::scalar::Interval;
use cgfem_gpu::geometry::surface::Shape;
use cgfem_gpu::geometry::Geometry;
use cgfem_gpu::spatial::Aabb;
use cgfem_gpu::Error;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A fresh folder under the system's temporary one.
pub fn temp_dir(what: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("cgfem-image-{what}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A NRRD file: the header lines, an empty line, the data.
pub fn nrrd(header: &[&str], data: &[u8]) -> Vec<u8> {
    let mut out = b"NRRD0004\n".to_vec();
    for line in header {
        out.extend_from_slice(line.as_bytes());
        out.push(b'\n');
    }
    out.push(b'\n');
    out.extend_from_slice(data);
    out
}

pub fn gzip(data: &[u8]) -> Vec<u8> {
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    e.write_all(data).unwrap();
    e.finish().unwrap()
}

/// `values` (x fastest) as little-endian doubles, gzip.
fn double_image(size: [usize; 3], values: &[f64], extra: &[&str]) -> Vec<u8> {
    let sizes = format!("sizes: {} {} {}", size[0], size[1], size[2]);
    let mut header = vec![
        "type: double",
        "dimension: 3",
        &sizes,
        "endian: little",
        "encoding: gzip",
    ];
    header.extend_from_slice(extra);
    let raw: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
    nrrd(&header, &gzip(&raw))
}

#[test]
fn the_reader_reads_hand_made_files() {
    let dir = temp_dir("reader");
    // ascii, placed by spacings (no direction, no origin).
    let ascii = nrrd(
        &[
            "# hand made",
            "type: float",
            "dimension: 3",
            "sizes: 2 3 2",
            "spacings: 0.5 0.25 2",
            "encoding: ascii",
            "key:=value",
        ],
        b"0 1 2 3 4 5\n6 7 8 9 10 11\n",
    );
    std::fs::write(dir.join("a.nrrd"), ascii).unwrap();
    let a = read_nrrd(&dir.join("a.nrrd")).unwrap();
    assert_eq!(a.size, [2, 3, 2]);
    assert_eq!(a.values, (0..12).map(f64::from).collect::<Vec<_>>());
    assert_eq!(a.spacing, Some([0.5, 0.25, 2.0]));
    assert_eq!((a.axes, a.origin), (None, None));
    // raw big-endian int16, placed by directions and origin.
    let v: [i16; 8] = [-300, 7, 0, 1, 2, 3, 4, 32767];
    let raw: Vec<u8> = v.iter().flat_map(|x| x.to_be_bytes()).collect();
    let b = nrrd(
        &[
            "type: short",
            "dimension: 3",
            "sizes: 2 2 2",
            "endian: big",
            "encoding: raw",
            "space directions: (0,0.5,0) (-2,0,0) (0,0,3)",
            "space origin: (1,-2,0.5)",
            "kinds: domain domain domain",
        ],
        &raw,
    );
    std::fs::write(dir.join("b.nrrd"), b).unwrap();
    let b = read_nrrd(&dir.join("b.nrrd")).unwrap();
    assert_eq!(
        b.values,
        v.iter().map(|&x| f64::from(x)).collect::<Vec<_>>()
    );
    assert_eq!(b.spacing, Some([0.5, 2.0, 3.0]));
    assert_eq!(
        b.axes,
        Some([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    );
    assert_eq!(b.origin, Some([1.0, -2.0, 0.5]));
    // gzip uint8 and uint16.
    let c = nrrd(
        &[
            "type: uint8",
            "dimension: 3",
            "sizes: 2 2 2",
            "encoding: gzip",
        ],
        &gzip(&[0, 255, 3, 4, 5, 6, 7, 8]),
    );
    std::fs::write(dir.join("c.nrrd"), c).unwrap();
    assert_eq!(read_nrrd(&dir.join("c.nrrd")).unwrap().values[1], 255.0);
    let u: Vec<u8> = [65535u16, 1, 2, 3, 4, 5, 6, 7]
        .iter()
        .flat_map(|x| x.to_le_bytes())
        .collect();
    let d = nrrd(
        &[
            "type: uint16",
            "dimension: 3",
            "sizes: 2 2 2",
            "endian: little",
            "encoding: gz",
        ],
        &gzip(&u),
    );
    std::fs::write(dir.join("d.nrrd"), d).unwrap();
    assert_eq!(read_nrrd(&dir.join("d.nrrd")).unwrap().values[0], 65535.0);
    // A detached header and its gzip data file beside it.
    let f: Vec<u8> = (0..8)
        .flat_map(|x| (x as f32 * 0.5).to_le_bytes())
        .collect();
    std::fs::write(dir.join("e.raw.gz"), gzip(&f)).unwrap();
    let e = nrrd(
        &[
            "type: float",
            "dimension: 3",
            "sizes: 2 2 2",
            "endian: little",
            "encoding: gzip",
            "data file: e.raw.gz",
        ],
        &[],
    );
    std::fs::write(dir.join("e.nhdr"), e).unwrap();
    let e = read_nrrd(&dir.join("e.nhdr")).unwrap();
    assert_eq!(e.values, (0..8).map(|x| x as f64 * 0.5).collect::<Vec<_>>());
    let _ = std::fs::remove_dir_all(&dir);
}

/// The trilinear interpolant of `v` (x fastest) at the voxel coordinates
/// `s` (sample `i` at `s = i`), written independently of the library.
fn trilinear(size: [usize; 3], v: &[f64], s: [f64; 3]) -> f64 {
    let c = [0, 1, 2].map(|a| (s[a].floor() as usize).min(size[a] - 2));
    let t = [0, 1, 2].map(|a| s[a] - c[a] as f64);
    let mut sum = 0.0;
    for corner in 0..8 {
        let b = [corner & 1, corner >> 1 & 1, corner >> 2 & 1];
        let w: f64 = (0..3)
            .map(|a| if b[a] == 1 { t[a] } else { 1.0 - t[a] })
            .product();
        let i = [0, 1, 2].map(|a| c[a] + b[a]);
        sum += w * v[i[0] + size[0] * (i[1] + size[1] * i[2])];
    }
    sum
}

fn build(file: &str, body: &str) -> Result<Geometry, Error> {
    let spec: GeometrySpec = toml::from_str(body).unwrap();
    spec.build(file)
}

fn scale_of(g: &Geometry) -> f64 {
    match &g.leaves()[0].shape {
        Shape::Image(v) => v.scale(),
        other => panic!("not an image leaf: {other:?}"),
    }
}

#[test]
fn the_level_set_is_the_trilinear_interpolant() {
    let dir = temp_dir("trilinear");
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let size = [7, 5, 6];
    let values: Vec<f64> = (0..210).map(|_| rng.gen_range(0.0..100.0)).collect();
    std::fs::write(dir.join("r.nrrd"), double_image(size, &values, &[])).unwrap();
    let case = dir.join("case.toml").display().to_string();
    let (spacing, origin, t) = ([0.5, 0.25, 0.75], [1.0, -2.0, 3.0], 47.5);
    for inside in ["above", "below"] {
        let body = format!(
            "type = \"image\"\nfile = \"r.nrrd\"\nthreshold = {t}\ninside = \"{inside}\"\nspacing = {spacing:?}\norigin = {origin:?}"
        );
        let g = build(&case, &body).unwrap();
        let k = scale_of(&g);
        assert!(k > 0.0);
        let sign = if inside == "above" { -1.0 } else { 1.0 };
        let mut worst = 0.0f64;
        for _ in 0..2000 {
            let s = [0, 1, 2].map(|a| rng.gen_range(0.0..(size[a] - 1) as f64));
            let x = [0, 1, 2].map(|a| origin[a] + s[a] * spacing[a]);
            let want = sign * k * (trilinear(size, &values, s) - t);
            worst = worst.max((g.phi(x) - want).abs());
            // The gradient: the interpolant's, by central differences (it is
            // linear along each axis inside a cell).
            let grad = g.gradient(x);
            for a in 0..3 {
                let e = 1e-7;
                let (mut sp, mut sm) = (s, s);
                sp[a] = (s[a] + e).min(s[a].floor() + 1.0);
                sm[a] = (s[a] - e).max(s[a].floor());
                let fd = sign * k * (trilinear(size, &values, sp) - trilinear(size, &values, sm))
                    / ((sp[a] - sm[a]) * spacing[a]);
                assert!(
                    (grad[a] - fd).abs() <= 1e-5 * (1.0 + fd.abs()),
                    "{inside}: ∂{a} {} against {fd}",
                    grad[a]
                );
            }
        }
        assert!(
            worst <= 1e-12 * k * 100.0,
            "{inside}: largest difference {worst:e}"
        );
        // Beyond the padding ring ψ is outside.
        for x in [
            [0.0, -2.0, 3.0],
            [1.0, -2.0 - 0.3, 3.0],
            [1.0 + 3.6, 0.0, 7.0],
        ] {
            assert!(g.phi(x) > 0.0, "{x:?}");
        }
        // Bounds over random boxes enclose the samples, and reach them.
        let mut exact = 0;
        for _ in 0..200 {
            let c = [0, 1, 2].map(|a| origin[a] + rng.gen_range(-1.0..size[a] as f64) * spacing[a]);
            let w = [0, 1, 2].map(|a| rng.gen_range(0.01..2.5) * spacing[a]);
            let b = Aabb::new(c, [0, 1, 2].map(|a| c[a] + w[a]));
            let bounds: Interval = g.bounds(&b);
            let leaf = g.leaves()[0].bounds(&b);
            for _ in 0..200 {
                let x = [0, 1, 2].map(|a| rng.gen_range(b.lo[a]..=b.hi[a]));
                let v = g.phi(x);
                assert!(
                    v >= bounds.lo - 1e-12 && v <= bounds.hi + 1e-12,
                    "{v} not in {bounds:?}"
                );
                for (a, (d, e)) in g.gradient(x).iter().zip(leaf.d).enumerate() {
                    assert!(
                        *d >= e.lo - 1e-9 && *d <= e.hi + 1e-9,
                        "∂{a} {d} not in {e:?}"
                    );
                }
            }
            // Exact inside the image: a trilinear piece's extremes are at the
            // corners of the box's part in its cell, so the range is the
            // min/max over the box's ends and the sample planes between.
            let sb = [0, 1, 2].map(|a| {
                (
                    (b.lo[a] - origin[a]) / spacing[a],
                    (b.hi[a] - origin[a]) / spacing[a],
                )
            });
            if (0..3).all(|a| sb[a].0 >= 0.0 && sb[a].1 <= (size[a] - 1) as f64) {
                let planes = sb.map(|(lo, hi)| {
                    let mut p = vec![lo, hi];
                    p.extend((lo.ceil() as usize..=hi.floor() as usize).map(|i| i as f64));
                    p
                });
                let (mut elo, mut ehi) = (f64::INFINITY, f64::NEG_INFINITY);
                for &z in &planes[2] {
                    for &y in &planes[1] {
                        for &x in &planes[0] {
                            let v = sign * k * (trilinear(size, &values, [x, y, z]) - t);
                            (elo, ehi) = (elo.min(v), ehi.max(v));
                        }
                    }
                }
                let tol = 1e-12 * k * 100.0;
                assert!(
                    (bounds.lo - elo).abs() <= tol && (bounds.hi - ehi).abs() <= tol,
                    "{bounds:?} against [{elo}, {ehi}]"
                );
                exact += 1;
            }
        }
        assert!(exact >= 20, "only {exact} boxes inside the image");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Builds the case `text` written as `case.toml` in `dir`: the error.
fn refused(dir: &Path, text: &str) -> Error {
    let file = dir.join("case.toml").display().to_string();
    match Case::from_str(&file, text).and_then(|c| Setup::new(&c, Some(2)).map(|_| ())) {
        Ok(()) => panic!("accepted: {text}"),
        Err(e) => e,
    }
}

#[test]
fn bad_images_are_refused_by_case_file_and_key() {
    let dir = temp_dir("bad");
    let good_values: Vec<f64> = (0..27).map(f64::from).collect();
    let put = |name: &str, bytes: Vec<u8>| std::fs::write(dir.join(name), bytes).unwrap();
    put("good.nrrd", double_image([3, 3, 3], &good_values, &[]));
    put(
        "int64.nrrd",
        nrrd(
            &[
                "type: int64",
                "dimension: 3",
                "sizes: 1 1 1",
                "endian: little",
                "encoding: raw",
            ],
            &[0; 8],
        ),
    );
    put(
        "bzip.nrrd",
        nrrd(
            &[
                "type: uint8",
                "dimension: 3",
                "sizes: 2 2 2",
                "encoding: bzip2",
            ],
            &[0; 8],
        ),
    );
    put(
        "short.nrrd",
        nrrd(
            &[
                "type: uint8",
                "dimension: 3",
                "sizes: 2 2 3",
                "encoding: raw",
            ],
            &[0; 8],
        ),
    );
    put(
        "flat.nrrd",
        nrrd(
            &["type: uint8", "dimension: 2", "sizes: 2 2", "encoding: raw"],
            &[0; 4],
        ),
    );
    put(
        "detached.nrrd",
        nrrd(
            &[
                "type: uint8",
                "dimension: 3",
                "sizes: 2 2 2",
                "encoding: raw",
                "data file: x.raw",
            ],
            &[],
        ),
    );
    put("noise.nrrd", b"P6 not an image".to_vec());
    put(
        "gz.nrrd",
        nrrd(
            &[
                "type: uint8",
                "dimension: 3",
                "sizes: 2 2 2",
                "encoding: gzip",
            ],
            b"\x1f\x8b not gzip",
        ),
    );
    put(
        "skew.nrrd",
        double_image(
            [3, 3, 3],
            &good_values,
            &["space directions: (1,0,0) (1,1,0) (0,0,1)"],
        ),
    );
    put("thin.nrrd", double_image([1, 3, 9], &good_values, &[]));
    put("scan.png", vec![0; 8]);
    let cases = [
        ("missing.nrrd", "13", "file", "cannot read"),
        (
            "int64.nrrd",
            "13",
            "file",
            "unsupported sample type 'int64'",
        ),
        ("bzip.nrrd", "13", "file", "unsupported encoding 'bzip2'"),
        (
            "short.nrrd",
            "13",
            "file",
            "the data holds 8 bytes, the sizes and type need 12",
        ),
        ("flat.nrrd", "13", "file", "only 3D images"),
        ("detached.nrrd", "13", "file", "cannot read the data file"),
        ("noise.nrrd", "13", "file", "not a NRRD file"),
        ("gz.nrrd", "13", "file", "does not decompress"),
        ("skew.nrrd", "13", "file", "orthogonal"),
        ("thin.nrrd", "13", "file", "at least 2 samples"),
        ("scan.png", "13", "file", "unsupported image format"),
        ("good.nrrd", "26", "threshold", "empty"),
        ("good.nrrd", "0", "threshold", "the whole image"),
        ("good.nrrd", "nan", "threshold", "finite"),
        ("good.nrrd", "13\nsmooth = -1", "smooth", "in [0, 16]"),
        (
            "good.nrrd",
            "13\nspacing = [1, 0, 1]",
            "spacing",
            "positive",
        ),
    ];
    for (file, threshold, key, reason) in cases {
        let text = format!("[geometry]\ntype = \"image\"\nfile = \"{file}\"\nthreshold = {threshold}\n[material]\nyoung = 1\npoisson = 0.3\n[dirichlet.surface]\nvalue = [\"0\", \"0\", \"0\"]\n");
        match refused(&dir, &text) {
            Error::CaseFile {
                file: f,
                key: k,
                reason: r,
            } => {
                assert!(f.ends_with("case.toml"), "{file}: {f}");
                assert_eq!(k, format!("geometry.{key}"), "{file}: {r}");
                assert!(r.contains(reason), "{file}: '{r}' does not say '{reason}'");
                println!("{file}, threshold {threshold}: {k}: {r}");
            }
            e => panic!("{file}: not a case-file error: {e:?}"),
        }
    }
    // The binary: exit code 2, the key on stderr.
    std::fs::write(dir.join("bad.toml"), "[geometry]\ntype = \"image\"\nfile = \"int64.nrrd\"\nthreshold = 1\n[material]\nyoung = 1\npoisson = 0.3\n").unwrap();
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_cgfem-gpu"))
        .args([
            "run",
            dir.join("bad.toml").to_str().unwrap(),
            "--out",
            dir.join("out").to_str().unwrap(),
        ])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("geometry.file") && stderr.contains("int64"),
        "{stderr}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
