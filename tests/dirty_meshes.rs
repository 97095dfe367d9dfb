//! Dirty STL parts: a unit cube with a second, inside-out box through its
//! x = 1 face (12 edges cross the cube's triangles). The winding number
//! check passes it (the defect is small), but the cells the inverted box
//! crosses get rules of negative volume: the set-up refuses the part (exit
//! code 2) naming the node and the cells, instead of a solver breakdown in
//! the multigrid (exit code 3) or a wrong answer.

use std::fmt::Write;
use std::process::Command;

/// The 12 triangles of the box `lo`–`hi` as ASCII STL facets, outward (or
/// inward with `inverted`).
fn box_facets(lo: [f64; 3], hi: [f64; 3], inverted: bool, out: &mut String) {
    let v = |i: usize| {
        [
            if i & 1 == 0 { lo[0] } else { hi[0] },
            if i & 2 == 0 { lo[1] } else { hi[1] },
            if i & 4 == 0 { lo[2] } else { hi[2] },
        ]
    };
    let quads = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    for q in quads {
        for mut t in [[q[0], q[1], q[2]], [q[0], q[2], q[3]]] {
            if inverted {
                t.reverse();
            }
            out.push_str("facet normal 0 0 0\nouter loop\n");
            for i in t {
                let p = v(i);
                writeln!(out, "vertex {} {} {}", p[0], p[1], p[2]).unwrap();
            }
            out.push_str("endloop\nendfacet\n");
        }
    }
}

/// Runs the cube with the inverted box at `level`, its face x = 0 clamped,
/// under its own weight; returns (exit code, stderr, whether a report was
/// left).
fn run(level: u32) -> (i32, String, bool) {
    let dir = std::env::temp_dir().join(format!("cgfem-dirty-{}-{level}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let mut stl = String::from("solid dirty\n");
    box_facets([0.0; 3], [1.0; 3], false, &mut stl);
    box_facets([0.8, 0.3, 0.3], [1.2, 0.7, 0.7], true, &mut stl);
    stl.push_str("endsolid dirty\n");
    std::fs::write(dir.join("dirty.stl"), stl).unwrap();
    let case = r#"
[geometry]
type = "stl"
path = "dirty.stl"
[grid]
offset = [0.31, 0.27, 0.43]
[material]
young = 1000
poisson = 0.3
[body_load]
value = ["0", "0", "-1"]
[dirichlet.surface]
value = ["0", "0", "0"]
region = { min = [-1, -1, -1], max = [0.01, 2, 2] }
"#;
    std::fs::write(dir.join("dirty.toml"), case).unwrap();
    let out = dir.join("out");
    let o = Command::new(env!("CARGO_BIN_EXE_cgfem-gpu"))
        .arg("run")
        .arg(dir.join("dirty.toml"))
        .arg("--level")
        .arg(level.to_string())
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    (
        o.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&o.stderr).into_owned(),
        out.join("report.json").exists(),
    )
}

#[test]
fn an_inverted_shell_through_a_face_is_refused_naming_where() {
    // Level 3 happens to give no cell a rule of negative volume; 4 and 5 do
    // (on the solve's grid, or on a coarser multigrid level).
    for level in [4, 5] {
        let (code, err, report) = run(level);
        assert_eq!(code, 2, "level {level}: {err}");
        for word in [
            "dirty.toml: geometry",
            "negative",
            "cut cells at the node",
            "edges through other triangles",
        ] {
            assert!(err.contains(word), "level {level}: '{word}' missing: {err}");
        }
        assert!(!report, "level {level}: a report was left");
    }
}
