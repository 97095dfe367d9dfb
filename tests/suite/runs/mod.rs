//! Whole runs through the command line: cases, bad input, solver failures, progress and Ctrl-C, reports, the README, the paper's tables, fuzzed cases.

mod bad_inputs;
mod case_model;
mod cases;
mod cli;
mod cli_progress;
mod diagnostics;
mod examples;
mod failures;
mod fuzz_case;
mod output_modes;
mod readme_reference;
mod reproduce;
mod robustness_runs;
mod surface_output;
mod table2;
