//! The integration tests of this crate in one test binary (one link instead of one per file):
//! - `compare`: `invsim compare`: runs' figures side by side with their differences, refusals, `--plot` overlays.
//! - `cli`: The `invsim` command line as a user meets it: exit codes, the contract's JSON and CSV layouts, and
//! - `conveniences`: The first-hour conveniences of the `invsim` command: `invsim cycles` (text and JSON), shell completions,
//! - `derive_bad_model`: `invsim derive` on a model that cannot be loaded or inverted exits with status 2 and prints
//! - `forward`: `invsim forward` and `invsim simulate --verify` as a user meets them: exit codes, the CSV and JSON layouts,
//! - `gradient`: `invsim simulate --gradient`: the summary's block and table, fuel against central differences,
//!   compiled against interpreted, a stable (non-causal) run's block, the runs not differentiated refused with exit 2,
//!   a map's grid values (`--map`, bad names, sweep columns).
//! - `gradient_modes`: gradients of runs with modes against central differences of every parameter (each
//!   gear's ratio on its own) of si_engine_5speed and the 6-speed Fusion on NEDC and UDDS and of the Fusion's map
//!   values, compiled against interpreted.
//! - `headline`: The summary leads with the model's headline in the units people report (l/100 km, mpg, CO2
//!   g/km; kWh/100 km, mpgge); the Fusions say which fuel figure is the model's answer.
//! - `hostile`: Hostile-input suite: every case in `tests/hostile/*.json` runs the built `invsim` binary on hostile model
//! - `hybrid`: `simulate --strategy ecms`: the closed-form split of a quadratic hybrid, hev_p2 charge-sustaining
//!   on UDDS, HWFET and WLTC 3b with every mode's equation checked by hand and its fuel within 3 % of DP's, the
//!   J1711 correction.
//! - `hybrid_charge`: the battery's charge within [0, 1]: a start outside and a run draining the battery below
//!   empty exit 2 naming the state, the option and the time.
//! - `hybrid_dp`: `simulate --strategy dp`: convergence to the closed-form discrete optimum of a quadratic
//!   hybrid as the grids are refined (ECMS reaching it), hev_p2 on UDDS charge-sustaining and within its grid
//!   error of ECMS, refusals.
//! - `hybrid_fastsim`: FASTSim's 2016 Prius and 2021 Sonata Hybrid imported and run on UDDS with ECMS, DP and
//!   their own rules: charge-sustaining, fuel against FASTSim's engine table, the engine at FASTSim's power.
//! - `hybrid_mvem`: the P2 hybrid with a mean-value engine: the decided throttle enters only the manifold's
//!   zero dynamics, ECMS (pricing the interval) opens it, DP refuses the manifold state.
//! - `hybrid_plot`: `simulate --strategy --plot` of hev_p2: the SOC panel and the engine on/off band against
//!   the CSV, `--plot-vars` naming them; the CSV's `engine_on` against the modes and `engine_on_s`.
//! - `hybrid_prices`: ECMS's prices kept across the equivalence factor's search (`crates/runtime/src/modes/price_cache.rs`)
//! - `hybrid_series`: the series hybrid under ECMS, DP and rules on UDDS, HWFET and WLTC 3b: ordered,
//!   charge-sustaining, plausible fuel, the genset on its best-efficiency line.
//! - `hybrid_signals`: a strategy's run with `[signals]` (grade, auxiliary load): constant signals equal the
//!   twin model's parameters (ECMS, DP, rules), time-varying ones solve the equations at t_k, the midpoint and
//!   t_k+1 by hand, uphill costs more fuel than flat, an unknown `--signal` exits 2, an imported hybrid's
//!   grade from the cycle's column.
//! - `hybrid_sweep`: `sweep --strategy`: hev_p2's rows equal `simulate --strategy` bit for bit (ECMS, DP, the
//!   rules; 1 and 2 threads), a capacity sweep against the charge's 1/Q scaling, refusals.
//! - `hybrid_verify`: `simulate --strategy … --verify`: the replay through the original equations converges to
//!   the run at second order in dt (hev_p2 and the series hybrid under DP on the ECE).
//! - `map_option`: `--map NAME=FILE.csv` for ordinary models and models with modes; unknown names and wrong arity exit 2.
//! - `modes`: `invsim derive` and `invsim simulate` on a model with operating modes (si_engine_5speed).
//! - `modes_sweep`: `invsim sweep` of models with operating modes: rows equal `simulate` bit for bit, the modes'
//!   columns, a gearbox parameter refused.
//! - `modes_plot_signals`: `--plot` of a model with operating modes and a road grade signal: the signal's panel in
//!   `simulate` and `forward`, by default and by name.
//! - `outputs`: Output files of `simulate` and `forward` on success: written in place, through links into the linked file,
//! - `plot`: `--plot` and `--plot-vars` of `simulate` and `forward`: SVG and PNG by the extension, the chosen panels,
//! - `plot_options`: `--size`, `--dpi`, `--window` and what every figure shows: scales from the data, one
//!   cumulative-fuel panel, raw and smoothed apart, the headline result, the engine's operating points.
//! - `run_keep`: a run through `Plant::simulate_keeping` (the Python package's runs) reads the smoothed cycle the
//!   previous run kept and gives the figures of a run on its own, bit for bit, as cycles, options and
//!   parameters change.
//! - `schema`: Every shipped model's `simulate` and `forward` summaries and `sweep` rows validate against
//!   `docs/summary.schema.json`, checked by a small validator of the part of JSON Schema the schema uses.
//! - `stable`: `invsim` with unstable zero dynamics: the classification in `derive`, stable (non-causal) inversion selected
//! - `start_up`: What keeps an `invsim` process cheap to start without changing what it prints: each command's
//!   arguments built only when it runs, the about, `help` tree and completions as they were, a fixed-address
//!   executable on Linux.
//! - `summary`: The summaries answer the engineer's questions: units on every figure, how far the smoothed reference
//! - `sweep`: `invsim sweep`: its rows equal `invsim simulate --set …` of the same variants bit for bit (compiled and
//! - `vehicle_library`: the library's FASTSim imports against hand values: the Pacifica's idle floor at a standstill,
//!   the Bolt's battery table at the C-rate and temperature.
//! - `warnings`: Warnings as a user meets them: a cycle file's plausibility warnings (km/h in an m/s column, a time column in
//!   milliseconds), `--strict` turning any warning into exit 2, messages that name the input, the mode and the time.
//! - `written_numbers`: every float of a run's CSV written as a float (`0.0`, not `0`), control characters of a
//!   model's description escaped in the text summary.

mod cli;
mod common;
mod compare;
mod conveniences;
mod derive_bad_model;
mod forward;
mod gradient;
mod gradient_hybrid;
mod gradient_modes;
mod headline;
mod hostile;
mod hybrid;
mod hybrid_charge;
mod hybrid_dp;
mod hybrid_fastsim;
mod hybrid_mvem;
mod hybrid_plot;
mod hybrid_prices;
mod hybrid_series;
mod hybrid_signals;
mod hybrid_sweep;
mod hybrid_verify;
mod map_option;
mod modes;
mod modes_compiled;
mod modes_plot_signals;
mod modes_sweep;
mod outputs;
mod plot;
mod plot_options;
mod run_keep;
mod schema;
mod stable;
mod start_up;
mod summary;
mod sweep;
mod vehicle_library;
mod warnings;
mod written_numbers;
