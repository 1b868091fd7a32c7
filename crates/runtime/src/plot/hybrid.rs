//! The panels of a hybrid's run with a strategy (docs/hybrids.md): the state of charge with its start value,
//! the charge-sustaining target, as a guide; and the engine's on/off band, the strategy's choice of mode
//! reduced to whether the engine runs (the run's `engine_on` column: 1 where the chosen mode's family is one
//! of `[hybrid] engine_on`).

use invsim_model_api::ModelInfo;

use super::figure::{Panel, Series};
use super::panels::{self, signal_panel, Signal, INPUT, UPPER};

/// The `--plot-vars` name and the column of the engine's on/off band.
pub const ENGINE_ON: &str = crate::modes::hybrid::ENGINE_ON;

/// The SOC panel: state `i` (the `[hybrid]` table's `soc`) over the run, `k` its colour's index, with a
/// dashed guide at its first value, SOC(0), which a charge-sustaining run returns to.
pub(super) fn soc_panel(info: &ModelInfo, i: usize, t: &[f64], soc: &[f64], k: usize) -> Panel {
    let mut p = signal_panel(info, Signal::State(i), t, soc, k);
    let name = &info.states[i];
    let (Some(&first), Some(&last)) = (soc.first(), soc.last()) else {
        return p;
    };
    p.title = format!(
        "state of charge {name}: {first:.4} → {last:.4}, ΔSOC = {:+.2e} (dashed: SOC(0), the target)",
        last - first
    );
    let (t0, t1) = (t[0], t[t.len() - 1]);
    p.guides.push(Series {
        label: format!("SOC(0) = {first}"),
        color: UPPER,
        width: 1.5,
        dashed: true,
        points: vec![(t0, first), (t1, first)],
    });
    p
}

/// The engine's on/off band: a step curve of `on` (1 on, 0 off) over `t`; `families` the engine-on modes'
/// families for the title.
pub(super) fn engine_on_panel(families: &[String], t: &[f64], on: &[f64]) -> Panel {
    Panel {
        var: ENGINE_ON.to_string(),
        title: format!(
            "engine on (1) or off (0), the strategy's choice of mode: on in the {} modes",
            families.join(", ")
        ),
        y_label: panels::with_unit("engine on", None),
        y_zero: true,
        series: vec![Series {
            label: "engine on".to_string(),
            color: INPUT,
            width: 2.0,
            dashed: false,
            points: super::steps::steps(t, on),
        }],
        guides: Vec::new(),
    }
}
