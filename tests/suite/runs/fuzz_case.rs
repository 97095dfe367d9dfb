//! Property test of the case parser and the setup: seeded random and mutated
//! case files (the files of `cases/` with keys deleted, values replaced by
//! numbers of every kind — NaN, ±∞, negative, huge, subnormal — strings,
//! arrays and tables, random geometry trees and placements, truncated and
//! garbled text, random `--set` overrides) go through `Case::from_str_with`
//! and, when they parse, through `Setup` at a tiny level, and some through
//! the solve. Nothing may panic; every error of the parser and the setup must
//! be a `CaseFile` error naming the file and a key, every error of the solve
//! a solver failure (exit code 3). Cases on the Newton path (from `cases/`
//! and a built-in two-block contact case) go, a third of those that parse,
//! through `BodiesSetup` at level 0 or 1, under the same rules.
//!
//! 1 500 inputs by default (a third of those that parse are set up; about
//! ten seconds in release), 100 000 in the long tier (`CGFEM_LONG=1`); set
//! `CGFEM_FUZZ_CASES=1000000` for a longer run and `CGFEM_FUZZ_SEED` to change
//! the seed. A failure prints the input that caused it.

use std::panic::{catch_unwind, AssertUnwindSafe};

use cgfem_gpu::bodies::setup::BodiesSetup;
use cgfem_gpu::case::{Case, SolutionPath};
use cgfem_gpu::driver::fixed_point::FixedPointReport;
use cgfem_gpu::driver::setup::Setup;
use cgfem_gpu::driver::solve::solve;
use cgfem_gpu::Error;
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use toml::{Table, Value};

mod mutate;
mod values;

use mutate::{mutate_text, mutate_tree, overrides};

const FILE: &str = "fuzz.toml";

fn seeds() -> Vec<String> {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("cases");
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    let seeds: Vec<String> = files
        .iter()
        .map(|p| std::fs::read_to_string(p).unwrap())
        .collect();
    assert!(seeds.len() >= 2, "no case files to start from");
    let mut seeds = seeds;
    seeds.push(TWO_BLOCKS.to_string());
    seeds
}

/// A multi-body seed: two blocks, a contact pair, per-component and
/// region-restricted Dirichlet data.
const TWO_BLOCKS: &str = r#"
name = "blocks"
[load]
steps = 2
[newton]
max_iterations = 10
[[body]]
name = "lower"
geometry = { type = "cuboid", min = [-1, -1, -1], max = [1, 1, 0] }
grid = { level = 1, offset = [0.1, 0.2, 0.3] }
material = { young = 1000.0, poisson = 0.3 }
dirichlet.zmin = { value = ["0", "0", "0"] }
[[body]]
name = "upper"
geometry = { type = "cuboid", min = [-0.5, -0.5, 0.01], max = [0.5, 0.5, 1.01] }
grid = { level = 1 }
material = { model = "st_venant_kirchhoff", young = 500.0, poisson = 0.25 }
dirichlet.zmax = { value = ["free", "free", "-0.01"], region = { min = [-inf, -inf, 1.0] } }
[[contact]]
slave = "upper.zmin"
master = "lower.zmax"
"#;

/// A parsed case on the Newton path: a third of them set up at level 0 or 1.
fn try_newton(rng: &mut ChaCha8Rng, k: usize, case: &Case, text: &str, sets: &[String]) {
    if rng.gen_bool(1.0 / 3.0) {
        let level = rng.gen_range(0..=1);
        let silent = cgfem_gpu::progress::Silent;
        let r = catch_unwind(AssertUnwindSafe(|| {
            BodiesSetup::new(case, Some(level), &silent)
        }));
        match r {
            Err(_) => panic!("input {k}: the Newton setup panicked on\n{text}\n{sets:?}"),
            Ok(Err(e)) => check_error(&e, "Newton setup", text, sets),
            Ok(Ok(_)) => {}
        }
    }
}

/// One input: a mutated seed (structure, then text), and overrides.
fn input(rng: &mut ChaCha8Rng, seeds: &[String]) -> (String, Vec<String>) {
    let seed = seeds.choose(rng).unwrap();
    let mut root = Value::Table(seed.parse::<Table>().unwrap());
    for _ in 0..rng.gen_range(0..4) {
        mutate_tree(rng, &mut root);
    }
    let mut text = if rng.gen_bool(0.1) {
        seed.clone()
    } else {
        toml::to_string(&root).unwrap_or_else(|_| seed.clone())
    };
    if rng.gen_bool(0.2) {
        mutate_text(rng, &mut text);
    }
    let sets = if rng.gen_bool(0.2) {
        overrides(rng)
    } else {
        Vec::new()
    };
    (text, sets)
}

fn check_error(e: &Error, what: &str, text: &str, sets: &[String]) {
    match e {
        Error::CaseFile { file, key, reason } => {
            assert_eq!(file, FILE, "{what}: {e}\n--- input ---\n{text}\n{sets:?}");
            assert!(
                !key.is_empty() && !reason.is_empty(),
                "{what}: {e}\n--- input ---\n{text}\n{sets:?}"
            );
        }
        other => panic!("{what}: untyped error {other:?}\n--- input ---\n{text}\n{sets:?}"),
    }
}

/// Solves a set-up case with at most 2000 Krylov iterations per solve: no
/// panic, and a failure may only be a solver failure (exit code 3) or the
/// refusal of a body that its Dirichlet conditions do not hold. True when
/// it solved. (Solves run from level 1: at level 0 the stress recovery often
/// finds too few cells, a solver failure too, but it teaches the fuzzer
/// nothing new.)
fn try_solve(case: &Case, setup: &Setup, text: &str, sets: &[String]) -> bool {
    let mut spec = case.spec.solver.clone();
    spec.max_iterations = spec.max_iterations.min(2000);
    let mut report = FixedPointReport::default();
    let r = catch_unwind(AssertUnwindSafe(|| solve(setup, &spec, &mut report)));
    match r {
        Err(_) => panic!("the solve panicked on\n{text}\n{sets:?}"),
        Ok(Ok(_)) => true,
        Ok(Err(Error::CaseFile { key, reason, .. })) if key == "dirichlet" => {
            assert!(reason.contains("is not held"), "{reason}");
            false
        }
        Ok(Err(e)) => {
            assert_eq!(
                e.exit_code(),
                3,
                "solve: {e}\n--- input ---\n{text}\n{sets:?}"
            );
            false
        }
    }
}

#[test]
fn random_and_mutated_cases_never_panic() {
    let n: usize = std::env::var("CGFEM_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(match std::env::var_os("CGFEM_LONG") {
            Some(_) => 100_000,
            None => 1_500,
        });
    let seed: u64 = std::env::var("CGFEM_FUZZ_SEED")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(20_260_509);
    let seeds = seeds();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (mut parsed, mut set_up, mut solved, mut setup_seconds) = (0, 0, 0, 0.0);
    let mut newton_parsed = 0;
    let start = std::time::Instant::now();
    for k in 0..n {
        let (text, sets) = input(&mut rng, &seeds);
        let r = catch_unwind(AssertUnwindSafe(|| Case::from_str_with(FILE, &text, &sets)));
        let case = match r {
            Err(_) => panic!("input {k}: the parser panicked on\n{text}\n{sets:?}"),
            Ok(Err(e)) => {
                check_error(&e, "parse", &text, &sets);
                continue;
            }
            Ok(Ok(case)) => case,
        };
        parsed += 1;
        if let SolutionPath::Newton(_) = case.path {
            newton_parsed += 1;
            try_newton(&mut rng, k, &case, &text, &sets);
            continue;
        }
        // A setup costs a thousand parses (cut-cell rules and matrices even
        // at level 0): set up one parsed case in three.
        if !rng.gen_bool(1.0 / 3.0) {
            continue;
        }
        // Level 2 for a quarter of the cases: cut cells of every kind appear
        // already at levels 0 and 1, at a fraction of the cost.
        let level = if rng.gen_bool(0.25) {
            2
        } else {
            rng.gen_range(0..=1)
        };
        let t = std::time::Instant::now();
        let r = catch_unwind(AssertUnwindSafe(|| Setup::new(&case, Some(level))));
        setup_seconds += t.elapsed().as_secs_f64();
        match r {
            Err(_) => panic!("input {k}: the setup panicked at level {level} on\n{text}\n{sets:?}"),
            Ok(Err(e)) => check_error(&e, "setup", &text, &sets),
            Ok(Ok(s)) => {
                set_up += 1;
                assert!(
                    s.fixed_rhs.iter().all(|v| v.is_finite()),
                    "input {k}: non-finite load\n{text}\n{sets:?}"
                );
                if level > 0 && rng.gen_bool(0.3) {
                    solved += try_solve(&case, &s, &text, &sets) as usize;
                }
            }
        }
    }
    println!(
        "{n} inputs: {parsed} parsed, {set_up} set up, {solved} solved; \
         {newton_parsed} of them on the Newton path; {:.1} s in all, {setup_seconds:.1} s in setups",
        start.elapsed().as_secs_f64()
    );
    // The generator must reach the checks behind the parser and the setup.
    assert!(parsed * 10 >= n, "only {parsed} of {n} inputs parsed");
    assert!(
        newton_parsed * 50 >= n,
        "only {newton_parsed} Newton-path inputs of {n} parsed"
    );
    assert!(set_up * 40 >= n, "only {set_up} of {n} inputs were set up");
}
