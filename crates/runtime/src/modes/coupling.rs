//! Entering a mode that couples states to the others (`couple`, docs/reference.md §2.5; a clutch that closes ties
//! the engine speed to the gearbox input speed): each coupled state s is set to its coupling c(x), read from
//! the mode's output that holds it. In the mode s then follows ċ, so s = c(x) for as long as the mode lasts.
//! Where s was already at c(x) (the clutch closing at equal speeds) nothing jumps; elsewhere the jump is the
//! explicit reset the model's coupling asks for, and the run lists it.

use super::record::Ctx;
use super::ModeSpec;

/// The relative size of a jump below which an entry counts as continuous (not listed).
pub(super) const JUMP_TOL: f64 = 1e-9;

/// Set each state mode `m` couples to its coupling at (x, w(t)); the coupled states that moved by more than
/// [`JUMP_TOL`] relative, with their jumps c(x) − s. `x` is untouched for a mode without couplings.
pub(super) fn enter(
    ctx: &Ctx<'_, '_>,
    m: usize,
    t: f64,
    x: &mut [f64],
    u: f64,
) -> Vec<(usize, f64)> {
    let mode = &ctx.spec.modes[m];
    if mode.coupled.is_empty() {
        return Vec::new();
    }
    set_couplings(mode, x, &ctx.w(m, t), u)
}

/// [`enter`] with the signals `w` in the mode's layout (the forward run's raw signals).
pub(crate) fn set_couplings(
    mode: &ModeSpec<'_>,
    x: &mut [f64],
    w: &[f64],
    u: f64,
) -> Vec<(usize, f64)> {
    if mode.coupled.is_empty() {
        return Vec::new();
    }
    let mut out = vec![0.0; mode.model.info().outputs.len()];
    mode.model.outputs(x, w, u, &mut out);
    let mut jumps = Vec::new();
    for &(s, o) in &mode.coupled {
        let c = out[o];
        let jump = c - x[s];
        if jump.abs() > JUMP_TOL * (1.0 + c.abs()) {
            jumps.push((s, jump));
        }
        x[s] = c;
    }
    jumps
}
