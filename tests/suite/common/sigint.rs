//! Ctrl-C in the CLI tests: run the binary, wait for a line on its stderr,
//! then send it SIGINT, as a user pressing Ctrl-C would.

use std::io::{BufRead, BufReader, Read};
use std::process::{Command, Stdio};

/// Spawns `cmd` with stderr piped, sends SIGINT once stderr contains
/// `marker`, and returns the exit code and everything it wrote to stderr.
pub fn interrupt_after(mut cmd: Command, marker: &str) -> (Option<i32>, String) {
    let mut child = cmd
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stderr = BufReader::new(child.stderr.take().unwrap());
    let mut seen = String::new();
    while !seen.contains(marker) {
        assert!(stderr.read_line(&mut seen).unwrap() > 0, "{seen}");
    }
    let pid = child.id().to_string();
    assert!(Command::new("kill")
        .args(["-INT", &pid])
        .status()
        .unwrap()
        .success());
    stderr.read_to_string(&mut seen).unwrap();
    (child.wait().unwrap().code(), seen)
}
