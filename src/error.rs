//! The library's one error type. Every variant names what was being done and
//! with which input, so that the binary can print it as is and map it to an exit
//! code (2 bad input, 3 solver failure, 1 internal).

use thiserror::Error;

/// Errors raised by the library.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum Error {
    /// A geometric parameter is out of range (negative radius, zero axis, ...).
    #[error("invalid geometry: {what}: {reason}")]
    InvalidGeometry { what: String, reason: String },
    /// A CSG operation or the whole geometry encloses no volume.
    #[error("empty geometry: {what}")]
    EmptyGeometry { what: String },
    /// The geometry does not meet the grid box.
    #[error("geometry lies outside the grid box {lo:?}..{hi:?}")]
    GeometryOutsideGrid { lo: [f64; 3], hi: [f64; 3] },
    /// A grid parameter is out of range.
    #[error("invalid grid: {what}: {reason}")]
    InvalidGrid { what: String, reason: String },
    /// The grid would need more memory than allowed.
    #[error(
        "level {level} needs about {needed_bytes} bytes, over the memory budget of \
         {budget_bytes} bytes; the largest level that fits is {max_level}"
    )]
    MemoryBudget {
        level: u32,
        needed_bytes: u64,
        budget_bytes: u64,
        max_level: u32,
    },
    /// A case file that cannot be read or has a bad key.
    #[error("{file}: {key}: {reason}")]
    CaseFile {
        file: String,
        key: String,
        reason: String,
    },
    /// Reading or writing a file failed.
    #[error("{path}: {reason}")]
    Io { path: String, reason: String },
    /// An image file that cannot be read as one (bad header, unsupported
    /// type or encoding, data that does not match the sizes).
    #[error("{path}: {reason}")]
    Image { path: String, reason: String },
    /// A boundary tag that no boundary part carries.
    #[error("unknown boundary tag '{tag}' (known: {known})")]
    UnknownTag { tag: String, known: String },
    /// A Krylov solver option is out of range (tolerance not in (0, ∞), ...).
    #[error("invalid solver options: {what}: {reason}")]
    InvalidSolverOptions { what: String, reason: String },
    /// A Krylov solve used up its iteration budget without converging.
    #[error(
        "{method} did not converge in {iterations} iterations \
         (true relative residual {residual:.3e})"
    )]
    MaxIterations {
        method: String,
        iterations: usize,
        residual: f64,
    },
    /// A Krylov solve broke down (a zero divisor, a non-finite value, an
    /// operator or preconditioner that is not positive definite for CG).
    #[error("{method} broke down at iteration {iterations}: {what}")]
    Breakdown {
        method: String,
        iterations: usize,
        what: String,
    },
    /// An analytic expression that does not parse; `position` is a byte offset.
    #[error("cannot parse expression '{expr}' at {position}: {reason}")]
    Expression {
        expr: String,
        position: usize,
        reason: String,
    },
    /// A node's recovery patch has no acceptable fit, or a recovered field was
    /// evaluated where no patch was recovered: in practice a grid too coarse
    /// for the body, so a solver failure (exit code 3), not an internal error.
    #[error(
        "patch recovery at node {node}: {reason} (is the grid too coarse for the body? \
         try a higher grid.level)"
    )]
    Recovery { node: usize, reason: String },
    /// An SVG plot could not be drawn (a bug, not bad input).
    #[error("drawing the plot '{title}': {reason}")]
    Plot { title: String, reason: String },
    /// No GPU adapter matches what was asked for (`--backend gpu`, an adapter
    /// name, f64).
    #[error("no GPU adapter: wanted {wanted}; adapters found: {found}")]
    NoAdapter { wanted: String, found: String },
    /// A solver setting the chosen backend does not run (the multigrid
    /// preconditioner on the GPU backend).
    #[error("the {backend} backend does not run {what}; {hint}")]
    UnsupportedOnBackend {
        backend: String,
        what: String,
        hint: String,
    },
    /// The problem does not fit the device (a vector beyond one storage binding).
    #[error("the GPU cannot hold this problem: {what}")]
    DeviceTooSmall { what: String },
    /// The GPU device failed (opening it, a buffer map, a lost device).
    #[error("GPU: {what}")]
    Gpu { what: String },
    /// A benchmark could not run (a thread pool, a factorisation).
    #[error("bench: {what}: {reason}")]
    Bench { what: String, reason: String },
    /// The run was stopped (Ctrl-C) at a fixed-point iteration boundary.
    #[error("interrupted after {iterations} fixed-point iterations")]
    Interrupted { iterations: usize },
    /// A distributed run failed on another rank (that rank names why).
    #[error("distributed run: {what}")]
    Distributed { what: String },
    /// A load step of the nonlinear (Newton) solver failed after every
    /// allowed cut of its increment; the last converged step is kept.
    #[error(
        "load step {step} (load factor {load_factor:.6}) failed after {cuts} cuts: \
         {reason}; last converged: step {last_converged_step} at load factor \
         {last_converged_load:.6}"
    )]
    LoadStepFailed {
        step: usize,
        load_factor: f64,
        cuts: usize,
        reason: String,
        last_converged_step: usize,
        last_converged_load: f64,
    },
}

impl Error {
    /// Exit code of the binary for this error (130 = 128 + SIGINT
    /// for an interrupted run, as shells report it).
    pub fn exit_code(&self) -> i32 {
        match self {
            Error::Interrupted { .. } => 130,
            Error::MaxIterations { .. }
            | Error::Breakdown { .. }
            | Error::Recovery { .. }
            | Error::Distributed { .. }
            | Error::LoadStepFailed { .. } => 3,
            Error::Plot { .. } | Error::Gpu { .. } | Error::Bench { .. } => 1,
            _ => 2,
        }
    }
}

/// Result alias of the library.
pub type Result<T> = std::result::Result<T, Error>;
