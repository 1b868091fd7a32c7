//! One run of any model, the spine every front end shares: [`Plant::simulate`] takes the options built and
//! validated once ([`SimulationOptions`]) and plugs in the solver the model needs — the inverse (causal or
//! stable, [`crate::inverse`]) for a model without modes, the mode sequence ([`crate::modes`]) for one with
//! modes — and [`Plant::forward`] the forward simulation with the driver ([`crate::forward`]) of either; both
//! give a [`RunResult`] that writes its table, summary, text and figure the same way whatever ran.

use std::io::{self, Write};
use std::path::Path;

use thiserror::Error;

use crate::cycle::Cycle;
use crate::forward::ModalForwardResult;
use crate::forward::{forward, forward_modes, ForwardError, ForwardOptions, ForwardResult};
use crate::inverse::{
    simulate, simulate_shared, SimulateError, SimulationOptions, SimulationResult,
};
use crate::modes::{GearSource, ModalError, ModalOptions, ModalPlant, ModalResult, Switching};
use crate::plant::Plant;
use crate::plot::{self, Figure, PlotError};
use crate::provenance::Provenance;
use crate::run_keep::{RunKeep, Shared, SharedError};

/// Why a run could not start or had to stop.
#[derive(Debug, Error)]
pub enum RunFailure {
    #[error(transparent)]
    Inverse(#[from] SimulateError),
    #[error(transparent)]
    Modes(#[from] ModalError),
    #[error(transparent)]
    Forward(#[from] ForwardError),
    /// The gearbox's schedule does not exist for the cycle.
    #[error("{0}")]
    Gears(String),
}

impl From<SharedError> for RunFailure {
    fn from(e: SharedError) -> RunFailure {
        match e {
            SharedError::Reference(e) => RunFailure::Inverse(e),
            SharedError::Gears(reason) => RunFailure::Gears(reason),
        }
    }
}

/// The result of one run.
pub enum RunResult {
    /// An inverse run of a model without modes.
    Single(Box<SimulationResult>),
    /// An inverse run with modes, with the gear schedule it ran with (its figure needs the modes again).
    Modal(Box<ModalResult>, GearSource),
    /// A forward run of a model without modes.
    Forward(Box<ForwardResult>),
    /// A forward run with modes, with its gear schedule.
    ModalForward(Box<ModalForwardResult>, GearSource),
}

/// The options of the mode sequence taken from a run's options.
pub fn modal_options(opts: &SimulationOptions) -> ModalOptions {
    ModalOptions {
        lookahead: opts.lookahead,
        dt: opts.dt,
        switching: opts.switching,
        transition_time: opts.transition_time,
        verify: opts.verify,
        keep_series: opts.keep_series,
        operating_points: opts.operating_points,
    }
}

/// One inverse run of the model with modes `p` on the gear schedule `gears` (resolved for `cycle`): the
/// strategy's run ([`crate::modes::simulate_hybrid`]) where the options name one, else the mode sequence,
/// with the gradient with respect to `wrt` ([`modal_gradient_params`]; with a strategy, that of the
/// charge-sustaining fuel).
/// `invsim simulate` and every row of a sweep run through here, so their figures are the same bits (a sweep
/// passes `kept`, where its runs on the cycle keep the smoothed cycle they read).
pub(crate) fn simulate_modal(
    p: &ModalPlant,
    (gears, kept): (GearSource, Option<&crate::modes::ReferenceCell>),
    cycle: &Cycle,
    opts: &SimulationOptions,
    wrt: Option<&crate::gradient::ModalWrt>,
) -> Result<ModalResult, ModalError> {
    let spec = p.spec(gears);
    let mut r = match &opts.strategy {
        Some(strategy) => {
            let modal = modal_options(opts);
            crate::modes::simulate_hybrid_differentiated(
                &spec,
                p.hybrid(),
                cycle,
                &modal,
                (strategy, &opts.initial),
                (&opts.signals, wrt),
            )?
        }
        None => {
            if let Some((name, _)) = opts.initial.first() {
                return Err(ModalError::Setup(format!(
                    "initial value of `{name}`: a model with modes starts every mode from the cycle's \
                     first sample; start values of internal states apply to models without modes"
                )));
            }
            let how = (opts.zero_dynamics_reference, wrt);
            crate::modes::simulate_modes_kept(
                &spec,
                cycle,
                &modal_options(opts),
                &opts.signals,
                how,
                kept,
            )?
        }
    };
    r.summary.engine = opts.engine.clone();
    Ok(r)
}

impl Plant {
    /// Run the model inversely along `cycle` (read from `file`, `None` for a built-in cycle). A model with
    /// modes refuses start values of internal states (`initial`): its modes start from the cycle's standstill.
    pub fn simulate(
        &self,
        cycle: &Cycle,
        file: Option<&Path>,
        opts: &SimulationOptions,
    ) -> Result<RunResult, RunFailure> {
        self.simulate_keeping(cycle, file, opts, None)
    }

    /// [`Plant::simulate`], reading what runs on the cycle share from `keep` (and keeping it there for the
    /// next run; the same figures, bit for bit, [`RunKeep`]).
    pub fn simulate_keeping(
        &self,
        cycle: &Cycle,
        file: Option<&Path>,
        opts: &SimulationOptions,
        keep: Option<&RunKeep>,
    ) -> Result<RunResult, RunFailure> {
        opts.validate()?;
        if opts.lookahead_auto {
            let (fixed, choice) = crate::lookahead::resolve(opts, cycle)?;
            let mut result = self.simulate_keeping(cycle, file, &fixed, keep)?;
            if let Some(choice) = choice {
                result.set_lookahead_choice(choice);
            }
            return Ok(result);
        }
        match self {
            Plant::Single(_) if opts.strategy.is_some() => {
                Err(RunFailure::Modes(ModalError::Setup(format!(
                    "{}: the model has no modes and no [hybrid] table; a strategy decides the modes of a hybrid",
                    opts.strategy.as_ref().map_or("--strategy", |s| s.method.flag())
                ))))
            }
            Plant::Single(m) => {
                let shared = keep.map(|k| k.shared(self, cycle, file, opts)).transpose()?;
                let r = match shared.as_deref() {
                    Some(Shared::Reference(reference)) => {
                        simulate_shared(m.as_ref(), cycle, reference, opts, Vec::new())?
                    }
                    _ => simulate(m.as_ref(), cycle, opts)?,
                };
                Ok(RunResult::Single(Box::new(r)))
            }
            Plant::Modal(p) => {
                let wrt = opts
                    .gradient
                    .as_deref()
                    .map(|names| modal_gradient_params(p, opts, names))
                    .transpose()?;
                let shared = keep.map(|k| k.shared(self, cycle, file, opts)).transpose()?;
                let (gears, kept) = match shared.as_deref() {
                    Some(Shared::Gears(gears, kept)) => (gears.clone(), Some(kept)),
                    _ => (p.gear_source(cycle, file).map_err(RunFailure::Gears)?, None),
                };
                let r = simulate_modal(p, (gears.clone(), kept), cycle, opts, wrt.as_ref())?;
                Ok(RunResult::Modal(Box::new(r), gears))
            }
        }
    }

    /// Run the model forward along `cycle` (read from `file`, `None` for a built-in cycle), closed by the
    /// driver of `opts`.
    pub fn forward(
        &self,
        cycle: &Cycle,
        file: Option<&Path>,
        opts: &ForwardOptions,
    ) -> Result<RunResult, RunFailure> {
        match self {
            Plant::Single(m) => Ok(RunResult::Forward(Box::new(forward(
                m.as_ref(),
                cycle,
                opts,
            )?))),
            Plant::Modal(p) => {
                let gears = p.gear_source(cycle, file).map_err(RunFailure::Gears)?;
                let r = forward_modes(&p.spec(gears.clone()), cycle, opts)?;
                Ok(RunResult::ModalForward(Box::new(r), gears))
            }
        }
    }

    /// The figure of `result` (a run of this model on `cycle`) with the panels `vars` (empty: the default), the
    /// engine's operating points over its map where the model file gives one (`[engine] map`).
    pub fn figure(
        &self,
        result: &RunResult,
        cycle: &Cycle,
        vars: &[String],
    ) -> Result<Figure, PlotError> {
        let mut figure = self.figure_of(result, cycle, vars)?;
        let model = match self {
            Plant::Single(m) => m.as_ref(),
            Plant::Modal(p) => p.first(),
        };
        if let (Some(scatter), Some(layer)) = (&mut figure.scatter, plot::MapLayer::of(model)?) {
            scatter.over_map(layer);
        }
        Ok(figure)
    }

    /// [`Plant::figure`] without the engine map.
    fn figure_of(
        &self,
        result: &RunResult,
        cycle: &Cycle,
        vars: &[String],
    ) -> Result<Figure, PlotError> {
        match (self, result) {
            (Plant::Single(m), RunResult::Single(r)) => {
                plot::simulation_figure(r, cycle, m.info(), vars)
            }
            (Plant::Modal(p), RunResult::Modal(r, gears)) => {
                plot::modal_simulation_figure(r, cycle, &p.spec(gears.clone()), vars)
            }
            (Plant::Single(m), RunResult::Forward(r)) => {
                plot::forward_figure(r, m.info(), m.reference(), vars)
            }
            (Plant::Modal(p), RunResult::ModalForward(r, gears)) => {
                plot::modal_forward_figure(r, &p.spec(gears.clone()), vars)
            }
            _ => Err(PlotError::Empty),
        }
    }
}

impl RunResult {
    /// The table's column names.
    pub fn columns(&self) -> &[String] {
        match self {
            RunResult::Single(r) => &r.columns,
            RunResult::Modal(r, _) => &r.columns,
            RunResult::Forward(r) => &r.columns,
            RunResult::ModalForward(r, _) => &r.columns,
        }
    }

    /// The table, column by column.
    pub fn data(&self) -> &[Vec<f64>] {
        match self {
            RunResult::Single(r) => &r.data,
            RunResult::Modal(r, _) => &r.data,
            RunResult::Forward(r) => &r.data,
            RunResult::ModalForward(r, _) => &r.data,
        }
    }

    /// Each column's unit, in the table's order.
    pub fn units(&self) -> Vec<Option<String>> {
        let by_name = |columns: &[crate::Column]| -> Vec<Option<String>> {
            let unit = |c: &String| {
                let k = columns.iter().find(|k| &k.name == c);
                k.and_then(|k| k.unit.clone())
            };
            self.columns().iter().map(unit).collect()
        };
        match self {
            RunResult::Single(r) => by_name(&r.summary.columns),
            RunResult::Modal(r, _) => r.units.clone(),
            RunResult::Forward(r) => by_name(&r.summary.columns),
            RunResult::ModalForward(r, _) => r.units.clone(),
        }
    }

    /// Record what produced the run (the command line's invocation).
    /// Record how `--lookahead auto` chose the look-ahead (inverse runs).
    pub fn set_lookahead_choice(&mut self, c: crate::lookahead::LookaheadChoice) {
        match self {
            RunResult::Single(r) => r.summary.lookahead_choice = Some(c),
            RunResult::Modal(r, _) => r.summary.lookahead_choice = Some(c),
            RunResult::Forward(_) | RunResult::ModalForward(..) => {}
        }
    }

    pub fn set_provenance(&mut self, p: Provenance) {
        match self {
            RunResult::Single(r) => r.summary.provenance = Some(p),
            RunResult::Modal(r, _) => r.summary.provenance = Some(p),
            RunResult::Forward(r) => r.summary.provenance = Some(p),
            RunResult::ModalForward(r, _) => r.summary.provenance = Some(p),
        }
    }

    /// The summary's warnings.
    pub fn warnings(&self) -> &[String] {
        match self {
            RunResult::Single(r) => &r.summary.warnings,
            RunResult::Modal(r, _) => &r.summary.warnings,
            RunResult::Forward(r) => &r.summary.warnings,
            RunResult::ModalForward(r, _) => &r.summary.warnings,
        }
    }

    /// The summary's warnings, to add to (a cycle file's plausibility warnings).
    pub fn warnings_mut(&mut self) -> &mut Vec<String> {
        match self {
            RunResult::Single(r) => &mut r.summary.warnings,
            RunResult::Modal(r, _) => &mut r.summary.warnings,
            RunResult::Forward(r) => &mut r.summary.warnings,
            RunResult::ModalForward(r, _) => &mut r.summary.warnings,
        }
    }

    /// The summary as text (what `invsim simulate` prints).
    /// User strings in it (the model's name and description, the cycle's and the files' names, warnings) have
    /// their control characters escaped ([`crate::textfmt::escape_controls`]): the text goes to a terminal.
    pub fn summary_text(&self) -> String {
        let text = match self {
            RunResult::Single(r) => r.summary.to_text(),
            RunResult::Modal(r, _) => r.summary.to_text(),
            RunResult::Forward(r) => r.summary.to_text(),
            RunResult::ModalForward(r, _) => r.summary.to_text(),
        };
        crate::textfmt::escape_controls(&text, true).into_owned()
    }

    /// Write the summary as JSON (`--summary-json`).
    pub fn write_summary_json<W: Write>(&self, w: W) -> io::Result<()> {
        match self {
            RunResult::Single(r) => crate::output::write_json(&r.summary, w),
            RunResult::Modal(r, _) => crate::output::write_json(&r.summary, w),
            RunResult::Forward(r) => crate::output::write_json(&r.summary, w),
            RunResult::ModalForward(r, _) => crate::output::write_json(&r.summary, w),
        }
    }

    /// Write the table as CSV (`--out`).
    pub fn write_csv<W: Write>(&self, w: W) -> io::Result<()> {
        crate::output::write_table_csv(self.columns(), self.data(), w)
    }
}

/// A run's gradient that is not computed yet, as the error `simulate --gradient` reports.
fn gradient_refused(what: &'static str) -> RunFailure {
    RunFailure::Inverse(SimulateError::Gradient(
        crate::gradient::GradientError::ModalUnsupported { what },
    ))
}

/// The derivatives `names` asks for of a run of the model with modes `p` (`crate::gradient::modal`), or why
/// the run is not differentiated: quasi-static switching, modes that couple states.
pub(crate) fn modal_gradient_params(
    p: &crate::modes::ModalPlant,
    opts: &SimulationOptions,
    names: &[String],
) -> Result<crate::gradient::ModalWrt, RunFailure> {
    if let Some(strategy) = &opts.strategy {
        match strategy.method {
            crate::modes::Method::Ecms if strategy.equivalence.is_none() => {}
            crate::modes::Method::Ecms => {
                return Err(gradient_refused(
                    "runs with a given equivalence factor (--equivalence): the gradient of a strategy's run \
                     is that of the charge-sustaining optimum, whose factor the search finds; runs with \
                     --equivalence",
                ))
            }
            _ => {
                return Err(gradient_refused(
                    "runs with --strategy dp or rule-based: the gradient of a strategy's run is that of \
                     ECMS's charge-sustaining optimum (--strategy ecms without --equivalence); runs with \
                     dp or rules",
                ))
            }
        }
    }
    if opts.switching == Switching::QuasiStatic {
        return Err(gradient_refused("runs with quasi-static switching"));
    }
    if p.metas().any(|m| !m.coupled.is_empty()) {
        return Err(gradient_refused(
            "models whose modes couple states (`couple`)",
        ));
    }
    let parameters = p.parameters();
    let refused = |e| RunFailure::Inverse(SimulateError::Gradient(e));
    let (grid, params) = crate::gradient::resolve_modal_with_maps(
        (&parameters, p.gear_parameters()),
        &p.maps(),
        names,
    )
    .map_err(refused)?;
    let modes = p.metas().map(|m| (m.gear, &m.own_parameters[..]));
    let wrt = crate::gradient::ModalWrt::new(params, &parameters, modes);
    Ok(wrt.with_grid(parameters.len(), &grid, p.mode_maps()))
}
