//! `cgfem-gpu reproduce table1` writes its rows, table and plot (level 3 here
//! to keep CI short; the paper's levels are 4 and 5).

use std::process::Command;

#[test]
fn table1_writes_rows_markdown_and_svg() {
    let out = std::env::temp_dir().join(format!("cgfem-reproduce-{}", std::process::id()));
    let o = Command::new(env!("CARGO_BIN_EXE_cgfem-gpu"))
        .args([
            "reproduce",
            "table1",
            "--level",
            "3",
            "--out",
            out.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("table1.json")).unwrap()).unwrap();
    let rows = json["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 5);
    for r in rows {
        for key in [
            "level",
            "element",
            "k2",
            "A",
            "kappa",
            "kappa_jacobi",
            "krylov_iterations",
            "paper_kappa",
        ] {
            assert!(r.get(key).is_some(), "row lacks {key}: {r}");
        }
        assert!(r["kappa"].as_f64().unwrap() >= 1.0);
    }
    // The S-term rows are no worse conditioned than the row without it.
    let plain = rows[0]["kappa"].as_f64().unwrap();
    assert_eq!(rows[0]["k2"], 0.0);
    for r in &rows[1..] {
        assert!(r["kappa"].as_f64().unwrap() <= plain * 1.0001, "{r}");
    }
    let md = std::fs::read_to_string(out.join("table1.md")).unwrap();
    assert!(md.contains("| level | k2 | A |"));
    let svg = std::fs::read_to_string(out.join("table1.svg")).unwrap();
    assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
    std::fs::remove_dir_all(&out).unwrap();
}
