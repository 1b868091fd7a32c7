//! The integration tests of this crate in one test binary (one link instead of one per file):
//! - `pow_pos`: `math::pow_pos` and `math::pow_pos_slice` against `f64::powf` and against correctly rounded references.
//! - `zero_dynamics`: The zero-dynamics module on a one-state model with known equilibria: Newton's method, its starting

mod pow_pos;
mod zero_dynamics;
