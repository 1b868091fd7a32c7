//! The smoothed cycle a run with modes reads, made once for a cycle and its options: the smoother with the
//! run's signals, its values at the samples ([`SampleTable`]) and on the zero dynamics' sub-grid
//! ([`FineTable`]), each block evaluated when a run first needs it and kept. A sweep's runs on one cycle
//! share one ([`ReferenceCell`]): the smoothed cycle depends on the cycle, the look-ahead, the signals and
//! the grid, not on a parameter, so every variant reads the blocks the first one evaluated (the same bits).

use std::sync::{Arc, OnceLock};

use invsim_model_api::{InverseModel, ModelInfo, SignalInfo};

use super::bases::SampleTable;
use super::{ModalError, ModalOptions, ModalSpec};
use crate::cycle::Cycle;
use crate::elevation::Along;
use crate::grid::Grid;
use crate::signals::{resolve_declared, ResolvedSignal, SignalInput};
use crate::smoother::{FineTable, Smoother, ZeroDynamicsReference};

/// Where a sweep keeps the reference of its runs on one cycle (made by the first run that needs it).
pub(crate) type ReferenceCell = OnceLock<Arc<ModalReference>>;

/// The smoothed cycle of the runs of one spec's modes on one cycle, grid and look-ahead.
pub(crate) struct ModalReference {
    pub(super) smoother: Smoother,
    pub(super) resolved: Vec<ResolvedSignal>,
    pub(super) samples: SampleTable,
    /// The zero dynamics' sub-grid (`None`: no mode has internal dynamics, or the reference is evaluated
    /// pointwise).
    pub(super) fine: Option<Arc<FineTable>>,
    /// What it was made for: the grid's t_0, dt and n, the look-ahead, the way the zero dynamics read it, the
    /// orders at the samples and on the sub-grid.
    made_for: Key,
}

type Key = (
    u64,
    u64,
    usize,
    u64,
    ZeroDynamicsReference,
    usize,
    Option<usize>,
);

impl ModalReference {
    /// The reference of `spec`'s run on `cycle` over `grid` with `opts` and the `signals` given, for what
    /// `made_for` says ([`key`]).
    fn new(
        spec: &ModalSpec<'_>,
        (cycle, grid): (&Cycle, &Grid),
        opts: &ModalOptions,
        signals: &[SignalInput],
        (made_for, shared): (Key, bool),
    ) -> Result<ModalReference, ModalError> {
        let (smoother, resolved) = smoother_with_signals(spec, cycle, opts, signals)?;
        let fine = match (made_for.4, made_for.6) {
            (ZeroDynamicsReference::SubGrid, Some(q)) => Some(Arc::new(FineTable::new(
                &smoother,
                (grid.time(0), grid.dt, grid.n),
                (opts.lookahead, q),
                shared,
            ))),
            _ => None,
        };
        Ok(ModalReference {
            samples: SampleTable::new(grid, made_for.5),
            smoother,
            resolved,
            fine,
            made_for,
        })
    }

    /// The reference kept in `cell` where it was made for this run, else a new one (kept in `cell` if that
    /// is empty). `rereads`: the run reads its sub-grid again (a replay, a gradient's pass), which keeps the
    /// sub-grid's blocks as a cell does.
    pub(super) fn kept_or_new(
        (cell, rereads): (Option<&ReferenceCell>, bool),
        spec: &ModalSpec<'_>,
        (cycle, grid): (&Cycle, &Grid),
        opts: &ModalOptions,
        (signals, zd): (&[SignalInput], ZeroDynamicsReference),
    ) -> Result<Arc<ModalReference>, ModalError> {
        let made_for = key(spec, grid, opts, zd);
        if let Some(kept) = cell.and_then(OnceLock::get) {
            if kept.made_for == made_for {
                return Ok(kept.clone());
            }
        }
        let new = Arc::new(ModalReference::new(
            spec,
            (cycle, grid),
            opts,
            signals,
            (made_for, rereads || cell.is_some()),
        )?);
        if let Some(cell) = cell {
            let _ = cell.set(new.clone());
        }
        Ok(new)
    }
}

/// q: the highest relative degree of a mode with internal dynamics (none: nothing to integrate).
fn key(spec: &ModalSpec<'_>, grid: &Grid, opts: &ModalOptions, zd: ZeroDynamicsReference) -> Key {
    let q = spec
        .modes
        .iter()
        .map(|m| m.model.info())
        .filter(|i| i.n_eta > 0)
        .map(|i| i.relative_degree)
        .max();
    (
        grid.time(0).to_bits(),
        grid.dt.to_bits(),
        grid.n,
        opts.lookahead.to_bits(),
        zd,
        spec.r_max().max(1) + 1,
        q,
    )
}

/// The exogenous signals a mode's model declares: its signals less the inputs a strategy decides, which the
/// model carries as signals named like the input.
pub(super) fn exogenous<'i>(spec: &ModalSpec<'_>, info: &'i ModelInfo) -> Vec<&'i SignalInfo> {
    let is_input = |s: &SignalInfo| spec.inputs.iter().any(|i| i.name == s.name);
    info.signals.iter().filter(|s| !is_input(s)).collect()
}

/// The signals of the run, from the first mode's declaration (every mode of a model file declares the same
/// `[signals]`; a spec whose modes disagree is refused).
pub(super) fn resolve_modal(
    spec: &ModalSpec<'_>,
    cycle: &Cycle,
    given: &[SignalInput],
    along: Along,
) -> Result<Vec<ResolvedSignal>, ModalError> {
    let Some(first) = spec.modes.first() else {
        return Ok(Vec::new());
    };
    let names = |m: &dyn InverseModel| -> Vec<String> {
        let exo = exogenous(spec, m.info());
        exo.iter().map(|s| s.name.clone()).collect()
    };
    let declared = names(first.model);
    if let Some(m) = spec.modes.iter().find(|m| names(m.model) != declared) {
        return Err(ModalError::Setup(format!(
            "mode `{}` declares other signals than mode `{}`",
            m.name, first.name
        )));
    }
    let declared: Vec<SignalInfo> = exogenous(spec, first.model.info())
        .into_iter()
        .cloned()
        .collect();
    resolve_declared(&declared, cycle, given, along).map_err(|e| ModalError::Run(e.into()))
}

/// The run's smoother: the smoothed cycle carrying the signals of `given` and the other sources
/// ([`resolve_modal`], a route profile read along the smoothed reference's distance as in a single-mode
/// inverse run), with the signals resolved.
pub(super) fn smoother_with_signals(
    spec: &ModalSpec<'_>,
    cycle: &Cycle,
    opts: &ModalOptions,
    given: &[SignalInput],
) -> Result<(Smoother, Vec<ResolvedSignal>), ModalError> {
    let along = Along::Smoothed {
        lookahead: opts.lookahead,
    };
    let resolved = resolve_modal(spec, cycle, given, along)?;
    let smoother = Smoother::new(cycle, opts.lookahead)
        .map_err(|e| ModalError::Setup(e.to_string()))?
        .with_signals(crate::signals::smoothers(&resolved, opts.lookahead));
    Ok((smoother, resolved))
}
