//! The panel of an exogenous signal of the model's `[signals]` (contract §5), for single-mode and modal
//! figures alike: its raw samples (linear between them, held outside their span) and, for an inverse run,
//! the smoothed signal the inverse used; a forward run's panel shows the raw signal alone, which is what it
//! integrated with.

use invsim_model_api::ModelInfo;

use super::figure::Panel;
use super::panels::{self, with_unit};
use crate::signals::ResolvedSignal;

/// The panel of exogenous signal `i`: its raw samples (linear between them, held outside their span) and,
/// for an inverse run, the smoothed signal the inverse used (`smoothed`, on the times `t`).
pub(super) fn signal_raw_and_smoothed(
    info: &ModelInfo,
    i: usize,
    raw: Option<&ResolvedSignal>,
    (t, smoothed): (&[f64], &[f64]),
    (t0, t1): (f64, f64),
) -> Panel {
    let s = &info.signals[i];
    let mut series = Vec::new();
    if let Some(raw) = raw {
        // The raw signal's corners inside the plotted range, plus its values at the range's ends.
        let at = |x: f64| {
            let k = raw.time.partition_point(|&c| c <= x);
            match (k.checked_sub(1), raw.time.get(k)) {
                (Some(j), Some(&tn)) => {
                    let w = (x - raw.time[j]) / (tn - raw.time[j]);
                    raw.values[j] + w * (raw.values[j + 1] - raw.values[j])
                }
                (Some(j), None) => raw.values[j],
                (None, _) => raw.values[0],
            }
        };
        let mut points = vec![(t0, at(t0))];
        points.extend(
            raw.time
                .iter()
                .zip(&raw.values)
                .filter(|(&x, _)| x > t0 && x < t1)
                .map(|(&x, &v)| (x, v)),
        );
        points.push((t1, at(t1)));
        let (ts, vs): (Vec<f64>, Vec<f64>) = points.into_iter().unzip();
        series.push(panels::raw_series(
            format!("{} (raw, {})", s.name, raw.source),
            panels::thin(&ts, &vs),
        ));
    }
    if !smoothed.is_empty() {
        series.push(panels::smoothed_series(
            format!("{} (smoothed)", s.name),
            t,
            smoothed,
        ));
    }
    // A forward run integrates with the raw signal: its panel says so.
    let title = if smoothed.is_empty() {
        format!(
            "signal {}: raw (linear between samples), as the forward run used it",
            s.name
        )
    } else {
        format!(
            "signal {}: raw and smoothed with the reference's kernel",
            s.name
        )
    };
    Panel {
        var: s.name.clone(),
        title,
        y_label: with_unit(&s.name, s.unit.as_deref()),
        y_zero: false,
        series,
        guides: Vec::new(),
    }
}
