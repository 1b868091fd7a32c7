//! Budgets on the size of expressions, so that user-controlled structure (long chains of definitions,
//! definitions that reuse their predecessor several times) ends in a typed error instead of a stack
//! overflow or an exponential blow-up.
//!
//! Two measures are kept per node by the [`crate::Pool`] at construction, in O(children):
//!
//! * the *depth*: 1 for a leaf, 1 + the largest depth of the children otherwise (the nesting a recursive
//!   walk would follow);
//! * the *written size*: the number of nodes of the expression written out as a tree (shared subterms
//!   counted every time they occur), 1 for a leaf and 1 + Σ children otherwise, saturating. The printed
//!   text has at least this many characters, so it bounds printing time and length from below; a DAG of
//!   n nodes can have a written size of 3ⁿ (`d_i = sin(d_{i-1}) + cos(d_{i-1})*d_{i-1}`).

use thiserror::Error;

/// Deepest expression a model may define: each definition after inlining, each state's right-hand side and
/// the output.
pub const MAX_DEPTH: u32 = 1_000;

/// Largest depth printed as text or LaTeX (derived expressions are deeper than the definitions they
/// come from: every Lie derivative adds a few levels).
pub const MAX_PRINT_DEPTH: u32 = 2_000;

/// Largest written size printed as text or LaTeX (at least this many characters).
pub const MAX_PRINT_SIZE: u64 = 200_000;

/// Most distinct nodes in one model's expression pool (all expressions and their derivatives together).
pub const MAX_POOL_NODES: usize = 5_000_000;

/// Below this depth the memoised walks recurse as they always did; above it they first visit the DAG in
/// post-order (children before parents, an explicit stack), so that their recursion never goes deeper
/// than a few levels.
pub const ITERATIVE_DEPTH: u32 = 200;

/// Which size an expression exceeded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Measure {
    /// Nesting depth.
    Depth,
    /// Number of nodes written out as a tree (a lower bound on the printed length).
    Written,
}

/// An expression exceeds a budget of [`crate::limits`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
#[error("{}", describe(*.measure, *.size, *.limit))]
pub struct TooLarge {
    pub measure: Measure,
    pub size: u64,
    pub limit: u64,
}

fn describe(m: Measure, size: u64, limit: u64) -> String {
    match m {
        Measure::Depth => format!("it nests {size} levels deep (limit {limit})"),
        Measure::Written => format!(
            "written out it has {} nodes, at least as many characters (limit {limit} for printing)",
            if size == u64::MAX {
                "more than 2^64".to_string()
            } else {
                size.to_string()
            }
        ),
    }
}
