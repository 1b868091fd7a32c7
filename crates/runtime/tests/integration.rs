//! The integration tests of this crate in one test binary (one link instead of one per file):
//! - `causal_zero_dynamics`: A causal run's zero dynamics with the sub-grid reference against the smoother pointwise:
//!   driveline and bev on the NEDC, UDDS (and WLTC): states and integrals within 1e-9.
//! - `cycle`: Tests for drive cycles: the built-in NEDC / ECE-15 / EUDC checksums, the regulation tables (UDDS, HWFET,
//! - `cycle_limits`: The cycle reader's limits (issue 15, defects 8, 10, 11): files read through a size cap, finite but absurd
//! - `forward`: Tests of the forward simulation (issue #6): the integrators' order of convergence on test problems that carry
//! - `forward_budget`: The forward run's budgets (issue 15, defect 5): a closed loop made stiff or fast by absurd driver gains stops
//! - `forward_integrals`: The forward run's integrals do not depend on the output grid (issue 15, defect 12): the accumulated outputs
//! - `fuzz_regressions`: Replays the fuzz regressions of the drive-cycle reader (`fuzz/regressions/cycle_reader/*`) through the very
//! - `modes_plot_signals`: The plots of a model with operating modes and a road grade signal, inverse and
//!   forward: the signal's panel with its raw and smoothed curves read back from the SVG.
//! - `modes_coupling`: States a mode couples to the others (`couple`): a coupled gain switch against the gain
//!   switch's run and its coupling, and si_engine_5speed_clutch (the engine speed a state of its own at idle)
//!   on the NEDC, inverse and forward, against si_engine_5speed.
//! - `modes_forward`: The forward run with modes against the inverse run with modes: si_engine_5speed on the NEDC,
//!   fuel within 2 %, the same gears outside a short window around each shift, the tracking error reported.
//! - `modes`: Runs with operating modes: si_engine_5speed on the NEDC and the UDDS, and a two-mode linear model against
//!   its exact solution (re-entry and quasi-static).
//! - `modes_zero_dynamics`: The zero dynamics' reference from the sub-grid against the smoother evaluated pointwise:
//!   si_engine_5speed and ford_fusion_2012_dynamic_6speed on the NEDC, UDDS and WLTC at dt 0.1 and 0.01 s.
//! - `nonsense_options`: Options that make no sense for the cycle (issue 15, defect 10): a look-ahead longer than a quarter of the
//! - `plot`: The plots of every shipped model (`models/*.toml`, through the interpreter): the SVG parsed and its
//! - `si_engine_maps`: si_engine_maps on the NEDC: inverse consistency, replay, a constant map equals si_engine, compiled vs
//!   interpreted, `set_map`, the block inverse equals the pointwise one and the earlier run bit for bit.
//! - `simulate`: Tests of the inverse-simulation driver against hand-written models with known answers.
//! - `smoother`: Tests for the kernel (eq. 33–35 of Fröberg & Nielsen 2004) and the smoother: every value is checked
//! - `stable`: Stable (non-causal) inversion of unstable zero dynamics (`invsim_runtime::stable`): linear non-minimum-phase
//! - `sweep`: Parameter sweeps: every row equals the single run of its variant (bit for bit), for the compiled and the

mod causal_zero_dynamics;
mod common;
mod cycle;
mod cycle_limits;
mod forward;
mod forward_budget;
mod forward_integrals;
mod fusion_6speed;
mod fuzz_regressions;
mod modes;
mod modes_coupling;
mod modes_forward;
mod modes_plot_signals;
mod modes_signals;
mod modes_summary_blocks;
mod modes_zero_dynamics;
mod nonsense_options;
mod plot;
mod si_engine_maps;
mod simulate;
mod smoother;
mod stable;
mod sweep;
