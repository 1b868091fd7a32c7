//! Sweep benchmark (placeholder).
fn main() {}
