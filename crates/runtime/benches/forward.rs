//! Benchmark: inverse vs forward simulation of si_engine on the NEDC (placeholder).
fn main() {}
