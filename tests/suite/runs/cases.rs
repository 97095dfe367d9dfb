//! Every case in `cases/` runs as is (at level 2, to keep CI short) and
//! writes its report (status ok) and solution: `solution.vtu`, `surface.vtp`
//! and the `solution.pvd` listing them for a single-body case, the
//! `solution.pvd` series (every body at the level) for a multi-body one.

use std::process::Command;

#[test]
fn every_case_runs() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("cases");
    let mut count = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().and_then(|e| e.to_str()) != Some("toml") {
            continue;
        }
        let out = std::env::temp_dir().join(format!(
            "cgfem-cases-{}-{}",
            std::process::id(),
            path.file_stem().unwrap().to_string_lossy()
        ));
        let o = Command::new(env!("CARGO_BIN_EXE_cgfem-gpu"))
            .args([
                "run",
                path.to_str().unwrap(),
                "--level",
                "2",
                "--out",
                out.to_str().unwrap(),
            ])
            .output()
            .unwrap();
        assert!(
            o.status.success(),
            "{}: {}",
            path.display(),
            String::from_utf8_lossy(&o.stderr)
        );
        let report: serde_json::Value =
            serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap();
        assert_eq!(report["status"], "ok", "{}", path.display());
        let bodies = report["bodies"].as_array().unwrap();
        assert!(bodies.iter().all(|b| b["level"] == 2), "{}", path.display());
        assert!(out.join("solution.pvd").exists(), "{}", path.display());
        if report["path"] == "linear" {
            for file in ["solution.vtu", "surface.vtp"] {
                assert!(out.join(file).exists(), "{}: {file}", path.display());
            }
        }
        std::fs::remove_dir_all(&out).unwrap();
        count += 1;
    }
    // The paper's sphere, the plate with a hole and the worked examples.
    assert!(count >= 5, "only {count} cases found");
}
