//! Bookkeeping shared by the inverse and the forward simulation's summaries: intervals of flagged samples, the
//! integrals of accumulated outputs with their per-100-km figures and units, and the summary text lines.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use invsim_model_api::ModelInfo;

use crate::simulate::{fmt_sig, integral_unit};

/// Appends to a list of maximal intervals of consecutive flagged samples.
#[derive(Default)]
pub(crate) struct Intervals {
    done: Vec<[f64; 2]>,
    open: Option<[f64; 2]>,
}

impl Intervals {
    pub(crate) fn push(&mut self, t: f64, flagged: bool) {
        match (&mut self.open, flagged) {
            (Some(v), true) => v[1] = t,
            (None, true) => self.open = Some([t, t]),
            (Some(v), false) => {
                self.done.push(*v);
                self.open = None;
            }
            (None, false) => {}
        }
    }
    pub(crate) fn finish(mut self) -> Vec<[f64; 2]> {
        if let Some(v) = self.open.take() {
            self.done.push(v);
        }
        self.done
    }
}

/// The integrals of the accumulated outputs, keyed by output name.
pub(crate) struct IntegralTables {
    /// Output → ∫ o dt over the run.
    pub integrals: BTreeMap<String, f64>,
    /// Output → integral · 1e5 / distance (per 100 km); empty when the cycle covers no distance.
    pub per_100km: BTreeMap<String, f64>,
    /// Output → unit of its integral (`kg` for `kg/s`), where known.
    pub units: BTreeMap<String, String>,
}

/// Tabulate `integrals[k]` of the outputs `accumulate[k]` of `info`, over a cycle of `distance` metres.
pub(crate) fn integral_tables(
    info: &ModelInfo,
    accumulate: &[usize],
    integrals: &[f64],
    distance: f64,
) -> IntegralTables {
    let has_distance = distance > 0.0 && distance.is_finite();
    let mut t = IntegralTables {
        integrals: BTreeMap::new(),
        per_100km: BTreeMap::new(),
        units: BTreeMap::new(),
    };
    for (acc, &i) in integrals.iter().zip(accumulate) {
        let o = &info.outputs[i];
        t.integrals.insert(o.name.clone(), *acc);
        if has_distance {
            t.per_100km.insert(o.name.clone(), acc * 1e5 / distance);
        }
        if let Some(unit) = o.unit.as_deref().and_then(integral_unit) {
            t.units.insert(o.name.clone(), unit);
        }
    }
    t
}

/// Summary text: one line per accumulated output, `fuel: 0.5617 kg (integral), 6.846 l/100 km`.
pub(crate) fn write_integrals(
    s: &mut String,
    integrals: &BTreeMap<String, f64>,
    units: &BTreeMap<String, String>,
    per_100km: &BTreeMap<String, f64>,
) {
    for (name, value) in integrals {
        let unit = units.get(name);
        let _ = write!(s, "{name}: {}", fmt_sig(*value, 4));
        if let Some(u) = unit {
            let _ = write!(s, " {u}");
        }
        s.push_str(" (integral)");
        if let Some(p) = per_100km.get(name) {
            let _ = match unit {
                Some(u) => write!(s, ", {} {u}/100 km", fmt_sig(*p, 4)),
                None => write!(s, ", {} per 100 km", fmt_sig(*p, 4)),
            };
        }
        s.push('\n');
    }
}

/// Summary text: the input's range over the run and its declared bounds.
pub(crate) fn write_input_range(
    s: &mut String,
    input: &str,
    range: [f64; 2],
    bounds: [Option<f64>; 2],
) {
    let _ = write!(
        s,
        "{input}: min {}, max {}",
        fmt_sig(range[0], 4),
        fmt_sig(range[1], 4)
    );
    if bounds.iter().any(Option::is_some) {
        let b = |v: Option<f64>, inf: &str| v.map_or(inf.to_string(), |v| fmt_sig(v, 6));
        let _ = write!(
            s,
            " (bounds [{}, {}])",
            b(bounds[0], "-inf"),
            b(bounds[1], "inf")
        );
    }
    s.push('\n');
}

/// Summary text: a list of time intervals with their count and total length, or `none`.
pub(crate) fn write_intervals(s: &mut String, label: &str, intervals: &[[f64; 2]]) {
    if intervals.is_empty() {
        let _ = writeln!(s, "{label}: none");
        return;
    }
    let total: f64 = intervals.iter().map(|[a, b]| b - a).sum();
    let list: Vec<String> = intervals
        .iter()
        .map(|[a, b]| format!("[{}, {}]", fmt_sig(*a, 6), fmt_sig(*b, 6)))
        .collect();
    let _ = writeln!(
        s,
        "{label}: {} intervals, {} s: {}",
        list.len(),
        fmt_sig(total, 4),
        list.join(" ")
    );
}
