//! `--output volume|surface|all|none` and `--compress` of `cgfem-gpu run`:
//! each mode writes exactly its files and lists them in the report's
//! `outputs`, on the linear path and on the Newton path; the compressed
//! files hold the same values, bit for bit, as the uncompressed ones (both
//! read back with `cgfem_gpu::vtu::read`).

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::Command;

use cgfem_gpu::vtu::{read, DataArray, DataValues};

/// A fresh, empty scratch folder for one run.
fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("cgfem-output-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Runs `cases/{case}` at `level` on the CPU into a fresh folder with
/// `args`; returns the folder and its report.
fn run(name: &str, case: &str, level: &str, args: &[&str]) -> (PathBuf, serde_json::Value) {
    let out = scratch(name).join("out");
    let case = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("cases")
        .join(case);
    let o = Command::new(env!("CARGO_BIN_EXE_cgfem-gpu"))
        .arg("run")
        .arg(&case)
        .args(["--level", level, "--backend", "cpu", "--out"])
        .arg(&out)
        .args(args)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let report = serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap();
    (out, report)
}

/// The names of the files in `dir`.
fn files_in(dir: &Path) -> BTreeSet<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect()
}

/// The report's `outputs`.
fn outputs(report: &serde_json::Value) -> Vec<String> {
    report["outputs"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f.as_str().unwrap().to_string())
        .collect()
}

/// Every array's name, components and values as bits.
fn bits(arrays: &[DataArray]) -> Vec<(String, usize, Vec<u64>)> {
    arrays
        .iter()
        .map(|a| {
            let values = match &a.values {
                DataValues::F64(v) => v.iter().map(|x| x.to_bits()).collect(),
                DataValues::I64(v) => v.iter().map(|&x| x as u64).collect(),
                DataValues::I32(v) => v.iter().map(|&x| x as u64).collect(),
                DataValues::U8(v) => v.iter().map(|&x| u64::from(x)).collect(),
            };
            (a.name.clone(), a.components, values)
        })
        .collect()
}

#[test]
fn each_output_mode_writes_exactly_its_files() {
    let modes: [(&str, &[&str]); 4] = [
        ("all", &["solution.vtu", "surface.vtp", "solution.pvd"]),
        ("volume", &["solution.vtu", "solution.pvd"]),
        ("surface", &["surface.vtp", "solution.pvd"]),
        ("none", &[]),
    ];
    for (mode, expected) in modes {
        let (out, report) = run(mode, "sphere.toml", "2", &["--output", mode]);
        assert_eq!(outputs(&report), expected, "{mode}");
        let mut on_disk: BTreeSet<String> = expected.iter().map(|f| f.to_string()).collect();
        on_disk.insert("report.json".into());
        assert_eq!(files_in(&out), on_disk, "{mode}");
        if mode != "none" {
            let pvd = std::fs::read_to_string(out.join("solution.pvd")).unwrap();
            for (part, file) in expected[..expected.len() - 1].iter().enumerate() {
                let entry = format!("part=\"{part}\" file=\"{file}\"");
                assert!(pvd.contains(&entry), "{mode}: {pvd}");
            }
        }
    }
    // The plots need the surface, written or not; the report lists them.
    let (out, report) = run(
        "plots",
        "sphere.toml",
        "2",
        &["--output", "none", "--plots"],
    );
    assert_eq!(outputs(&report), ["deformed.svg", "residuals.svg"]);
    let expected = ["deformed.svg", "report.json", "residuals.svg"];
    assert_eq!(files_in(&out), expected.map(String::from).into());
}

#[test]
fn compressed_files_hold_the_same_values_bit_for_bit() {
    let (plain, plain_report) = run("plain", "sphere.toml", "3", &[]);
    let (packed, packed_report) = run("packed", "sphere.toml", "3", &["--compress"]);
    assert_eq!(outputs(&plain_report), outputs(&packed_report));
    let timings = &packed_report["timings"];
    let (write, output) = (timings["output_write"].as_f64(), timings["output"].as_f64());
    assert!(write.unwrap() <= output.unwrap(), "{timings}");
    for file in ["solution.vtu", "surface.vtp"] {
        let (a, b) = (
            read(&plain.join(file)).unwrap(),
            read(&packed.join(file)).unwrap(),
        );
        assert!(a.iter().any(|a| a.name == "displacement"), "{file}");
        assert_eq!(bits(&a), bits(&b), "{file}");
        let head = |dir: &Path| {
            let bytes = std::fs::read(dir.join(file)).unwrap();
            let xml = String::from_utf8_lossy(&bytes[..bytes.len().min(400)]).into_owned();
            (bytes.len(), xml)
        };
        let ((plain_len, plain_xml), (packed_len, packed_xml)) = (head(&plain), head(&packed));
        assert!(packed_len < plain_len, "{file}: {packed_len} ≥ {plain_len}");
        assert!(packed_xml.contains("compressor=\"vtkZLibDataCompressor\""));
        assert!(!plain_xml.contains("compressor="));
    }
}

#[test]
fn newton_runs_write_the_series_of_their_mode() {
    let (out, report) = run(
        "newton-volume",
        "annuli_contact.toml",
        "3",
        &["--output", "volume"],
    );
    let listed = outputs(&report);
    let steps = report["converged_steps"].as_u64().unwrap() as usize;
    assert_eq!(listed.len(), 2 * steps + 1, "{listed:?}");
    assert!(listed[..2 * steps].iter().all(|f| f.ends_with(".vtu")));
    assert_eq!(listed.last().unwrap(), "solution.pvd");
    let mut on_disk: BTreeSet<String> = listed.iter().cloned().collect();
    on_disk.insert("report.json".into());
    assert_eq!(files_in(&out), on_disk);
    let body = read(&out.join(&listed[0])).unwrap();
    assert!(body.iter().any(|a| a.name == "displacement"));

    let (out, report) = run(
        "newton-none",
        "annuli_contact.toml",
        "3",
        &["--output", "none"],
    );
    assert!(outputs(&report).is_empty());
    assert_eq!(files_in(&out), BTreeSet::from(["report.json".to_string()]));
}
