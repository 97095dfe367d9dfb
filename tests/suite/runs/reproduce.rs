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

fn reproduce(args: &[&str], out: &std::path::Path) -> serde_json::Value {
    let o = Command::new(env!("CARGO_BIN_EXE_cgfem-gpu"))
        .arg("reproduce")
        .args(args)
        .args(["--out", out.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let name = args[0];
    for ext in ["md", "svg"] {
        let text = std::fs::read_to_string(out.join(format!("{name}.{ext}"))).unwrap();
        assert!(!text.is_empty());
    }
    serde_json::from_slice(&std::fs::read(out.join(format!("{name}.json"))).unwrap()).unwrap()
}

/// fig3 at levels 2–3: one row per level and configuration, with the rate
/// between the two levels close to the optimal 1 for Q1 with and without S.
#[test]
fn fig3_writes_rates_for_every_configuration() {
    let out = std::env::temp_dir().join(format!("cgfem-fig3-{}", std::process::id()));
    let json = reproduce(
        &["fig3", "--level", "2", "--level", "3", "--element", "q1"],
        &out,
    );
    let rows = json["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 10);
    for r in rows {
        for key in [
            "level",
            "element",
            "k2",
            "A",
            "h",
            "dofs",
            "energy_error",
            "energy_rate",
        ] {
            assert!(r.get(key).is_some(), "row lacks {key}: {r}");
        }
        if r["level"] == 3 {
            let rate = r["energy_rate"].as_f64().unwrap();
            assert!((0.85..1.2).contains(&rate), "{r}");
        } else {
            assert!(r["energy_rate"].is_null());
        }
    }
    std::fs::remove_dir_all(&out).unwrap();
}

/// cut-sweep at level 3 with 2 offsets: a row per stabilisation with κ and
/// iteration statistics (multigrid's converged), and every offset's run
/// listed.
#[test]
fn cut_sweep_writes_a_row_per_level_and_stabilisation() {
    let out = std::env::temp_dir().join(format!("cgfem-sweep-{}", std::process::id()));
    let json = reproduce(&["cut-sweep", "--level", "3", "--offsets", "2"], &out);
    let rows = json["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 2);
    assert_eq!(json["runs"].as_array().unwrap().len(), 4);
    // The paper's S-term (k2 = 0.01, A = 1%), whatever the case file says.
    for (r, stabilised, k2) in [(&rows[0], false, 0.0), (&rows[1], true, 0.01)] {
        assert_eq!(r["stabilised"], stabilised);
        assert_eq!(r["k2"], k2);
        assert_eq!(r["A"], 0.01);
        assert_eq!(r["offsets"], 2);
        assert!(r["kappa_max"].as_f64().unwrap() >= r["kappa_median"].as_f64().unwrap());
        assert!(r["first_solve_jacobi_max"].as_u64().unwrap() > 0);
        assert!(r["first_solve_multigrid_max"].as_u64().unwrap() > 0);
        assert_eq!(r["failures_multigrid"], 0);
    }
    std::fs::remove_dir_all(&out).unwrap();
}
