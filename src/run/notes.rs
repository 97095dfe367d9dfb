//! The lines that tell a user what the set-up found in a body
//! ([`BodyReport`]): cut cells given the repaired rule, walls glued or split
//! at vertices between parts of the body. Each is `None` where there is
//! nothing to tell.

use crate::report::BodyReport;

/// A position as the notes print it.
fn point(v: [f64; 3]) -> String {
    format!("({:.4}, {:.4}, {:.4})", v[0], v[1], v[2])
}

/// How many cut cells of `b` took the repaired rule, and where.
pub fn repaired(b: &BodyReport) -> Option<String> {
    let [lo, hi] = b.cells.repaired_box?;
    Some(format!(
        "note: body '{}': {} cut cells in {}..{} took the first-order repaired rule: the \
         mesh does not bound a solid there (open, overlapping or crossing facets)",
        b.name,
        b.cells.repaired,
        point(lo),
        point(hi)
    ))
}

/// Where a run glued walls: vertices whose cells hold parts of the body that
/// do not meet, sharing one unknown.
pub fn glued(b: &BodyReport) -> Option<String> {
    glued_with(
        b,
        "one unknown moves both walls, so the part is stiffer there than it is; a finer level \
         resolves it",
    )
}

/// Where the geometry has walls that a run may glue (the `geometry` command).
pub fn glued_geometry(b: &BodyReport) -> Option<String> {
    glued_with(
        b,
        "a linear Q1 run on the CPU gives them one set of unknowns per part (where no Dirichlet \
         boundary crosses their cells); other runs glue them, so the part is stiffer there than it is",
    )
}

/// The glued vertices of `b`, where there are some, and what they do.
fn glued_with(b: &BodyReport, consequence: &str) -> Option<String> {
    let [lo, hi] = b.cells.glued_box?;
    Some(format!(
        "warning: body '{}': {} grid vertices in {}..{} join parts of the body that do not \
         meet inside their cells (a slot, gap or hole narrower than about two cells, h = {:.4}): \
         {consequence}",
        b.name,
        b.cells.glued_nodes,
        point(lo),
        point(hi),
        b.h
    ))
}

/// Where the walls of a body were taken apart (one set of unknowns per part
/// of the body at the vertices between them).
pub fn split(b: &BodyReport) -> Option<String> {
    let [lo, hi] = b.cells.split_box?;
    Some(format!(
        "  note: body '{}': {} grid vertices in {}..{} get one set of unknowns per part of the \
         body around them (walls of a slot or gap thinner than a cell, h = {:.4})",
        b.name,
        b.cells.split_nodes,
        point(lo),
        point(hi),
        b.h
    ))
}
