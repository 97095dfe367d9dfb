//! `run_case` as a library call: what it says, what it writes, and how a
//! failed solve comes back.

use std::sync::Mutex;

use super::*;
use crate::comm::Serial;
use crate::driver::output::OutputFiles;
use crate::progress::Event;

/// The shipped sphere (the paper's Problem 1), run at level 2.
fn sphere(overrides: &[String]) -> Case {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("cases/sphere.toml");
    Case::from_file_with(&path, overrides).unwrap()
}

/// The lines a run says and tells.
#[derive(Default)]
struct Lines(Mutex<Vec<Event>>);

impl Progress for Lines {
    fn event(&self, event: &Event) {
        if matches!(event, Event::Say { .. } | Event::Notice { .. }) {
            self.0.lock().unwrap().push(event.clone());
        }
    }
}

fn options(dir: &Path) -> RunOptions {
    RunOptions {
        level: Some(2),
        out: Some(dir.to_path_buf()),
        paraview: ParaView {
            files: OutputFiles::Surface,
            ..ParaView::default()
        },
        plots: false,
        condition: false,
        device: DeviceRequest {
            backend: Some(BackendChoice::Cpu),
            ..DeviceRequest::default()
        },
    }
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("cgfem-run-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

fn written(dir: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(dir.join("report.json")).unwrap();
    serde_json::from_str(&text).unwrap()
}

#[test]
fn a_linear_run_says_what_it_solves_and_writes_the_report_it_returns() {
    let dir = scratch("linear");
    let case = sphere(&[]);
    let lines = Lines::default();
    let outcome = run_case(case, &options(&dir), &Serial, &lines).unwrap();
    assert!(outcome.result.is_ok());
    let json = written(&dir);
    let mut expected = serde_json::to_value(&outcome.report).unwrap();
    expected["outputs"] = serde_json::to_value(&outcome.files).unwrap();
    // Through text both ways, so that both numbers are parsed alike.
    let expected: serde_json::Value = serde_json::from_str(&expected.to_string()).unwrap();
    assert_eq!(json, expected);
    assert_eq!(outcome.files, ["surface.vtp", "solution.pvd"]);
    for f in &outcome.files {
        assert!(dir.join(f).is_file(), "{f}");
    }
    let lines = lines.0.into_inner().unwrap();
    let said = |e: &Event| match e {
        Event::Say { text } => Some(text.clone()),
        _ => None,
    };
    let said: Vec<String> = lines.iter().filter_map(said).collect();
    let dofs = outcome.report.dofs;
    let start = format!("case sphere ({}): level 2, Q1, ", outcome.report.file);
    assert!(said[0].starts_with(&start), "{said:?}");
    assert!(said[0].contains(&format!(" {dofs} dofs")), "{said:?}");
    assert_eq!(said[1], "  backend cpu (f64)");
    assert_eq!(said.len(), 2, "{said:?}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_failed_solve_comes_back_with_its_report_written() {
    let dir = scratch("failed");
    let overrides = ["solver.max_fixed_point=2".to_string()];
    let case = sphere(&overrides);
    let outcome = run_case(case, &options(&dir), &Serial, &crate::progress::Silent).unwrap();
    let e = outcome.result.as_ref().unwrap_err();
    assert_eq!(e.exit_code(), 3, "{e}");
    assert_eq!(outcome.report.status, "failed");
    assert_eq!(written(&dir)["status"], "failed");
    assert!(outcome.files.is_empty());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn an_out_folder_that_is_a_file_is_refused_before_the_run() {
    let dir = scratch("file");
    std::fs::write(&dir, "keep").unwrap();
    let case = sphere(&[]);
    let err = run_case(case, &options(&dir), &Serial, &crate::progress::Silent).err();
    assert!(matches!(err, Some(Error::Io { .. })), "{err:?}");
    assert_eq!(std::fs::read_to_string(&dir).unwrap(), "keep");
    std::fs::remove_file(&dir).unwrap();
}
