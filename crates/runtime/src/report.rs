//! What the inverse and the forward simulation's summaries share: the two blocks of fields both report
//! ([`CycleInfo`], [`Totals`], flattened into each summary so that the JSON keys and their order stay those of
//! one flat object), intervals of flagged samples, the integrals of accumulated outputs with their per-100-km
//! figures (only for outputs marked `per_distance`) and units, the units of the series' columns, number
//! formatting and the summary text lines.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use invsim_model_api::ModelInfo;
use serde::Serialize;

use crate::cycle::Cycle;

/// The run's model and cycle: the first fields of both summaries.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CycleInfo {
    pub model: String,
    /// The model file's `description` (left out when it has none; the text summary prints its first
    /// sentence).
    #[serde(skip_serializing_if = "String::is_empty")]
    pub description: String,
    pub cycle: String,
    /// Cycle duration (last minus first time stamp), s.
    pub duration_s: f64,
    /// Distance of the (raw, piecewise-linear) cycle, m.
    pub distance_m: f64,
}

impl CycleInfo {
    /// The first fields of a run of `info`'s model on `cycle`.
    pub(crate) fn new(info: &ModelInfo, cycle: &Cycle, duration_s: f64) -> CycleInfo {
        CycleInfo {
            model: info.name.clone(),
            description: info.description.clone(),
            cycle: cycle.name.clone(),
            duration_s,
            distance_m: cycle.distance(),
        }
    }

    /// Summary text: the `model:` line and, where the model has a description, its first sentence.
    pub(crate) fn write_model(&self, s: &mut String) {
        let _ = writeln!(s, "model: {}", self.model);
        if !self.description.trim().is_empty() {
            let _ = writeln!(s, "description: {}", first_sentence(&self.description));
        }
    }
}

/// The first sentence of `description` (up to the first ". "), or all of it without a final period.
pub(crate) fn first_sentence(description: &str) -> &str {
    let d = description.trim();
    match d.find(". ") {
        Some(i) => &d[..i],
        None => d.trim_end_matches('.'),
    }
}

/// One column of the CSV: its name and unit (`None` where the model gives none).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Column {
    pub name: String,
    pub unit: Option<String>,
}

/// The columns `names` of a series of `info`'s model with their units: `t` in s, `yc` and `yd_0` in the
/// output's unit, `yd_k` in the output's unit per s^k, the input, the states, the output and the extra outputs
/// in the model file's units, `etaN` without a unit (η is a combination of states).
pub fn columns_with_units(info: &ModelInfo, names: &[String]) -> Vec<Column> {
    names
        .iter()
        .map(|name| Column {
            name: name.clone(),
            unit: column_unit(info, name),
        })
        .collect()
}

/// The unit of the column `name` (see [`columns_with_units`]).
fn column_unit(info: &ModelInfo, name: &str) -> Option<String> {
    if let Some(j) = info.states.iter().position(|s| s == name) {
        return info.state_units.get(j).cloned().flatten();
    }
    if name == info.input {
        return info.input_unit.clone();
    }
    if name == info.output {
        return info.output_unit.clone();
    }
    if let Some(o) = info.outputs.iter().find(|o| o.name == name) {
        return o.unit.clone();
    }
    if name == "t" {
        return Some("s".to_string());
    }
    if name == "yc" {
        return info.output_unit.clone();
    }
    let k: u32 = name.strip_prefix("yd_")?.parse().ok()?;
    info.output_unit.as_deref().map(|u| per_second(u, k))
}

/// `unit` divided by s^k: `m/s`, 1 → `m/s^2`; `Pa`, 2 → `Pa/s^2`.
fn per_second(unit: &str, k: u32) -> String {
    if k == 0 {
        return unit.to_string();
    }
    let (base, already) = match unit.rsplit_once("/s") {
        Some((b, "")) => (b, 1),
        Some((b, p)) => match p.strip_prefix('^').and_then(|p| p.parse::<u32>().ok()) {
            Some(n) => (b, n),
            None => (unit, 0),
        },
        None => (unit, 0),
    };
    match already + k {
        1 => format!("{base}/s"),
        n => format!("{base}/s^{n}"),
    }
}

/// ` UNIT` for the text summary (nothing for no unit or a dimensionless `-`).
pub(crate) fn unit_suffix(unit: Option<&str>) -> String {
    match unit.map(str::trim) {
        Some(u) if !u.is_empty() && u != "-" => format!(" {u}"),
        _ => String::new(),
    }
}

/// The integrals and the input's range and bounds: a block of fields both summaries report alike.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Totals {
    /// Accumulated output → its integral over the run (trapezoidal rule on the output grid).
    pub integrals: BTreeMap<String, f64>,
    /// Accumulated output marked `per_distance` → integral · 1e5 / distance_m (per 100 km); empty if the cycle
    /// covers no distance.
    pub integrals_per_100km: BTreeMap<String, f64>,
    /// Accumulated output → unit of its integral (e.g. `kg` for an output in `kg/s`), where the unit is known.
    pub integral_units: BTreeMap<String, String>,
    /// The input's name and unit.
    pub input: String,
    pub input_unit: Option<String>,
    /// The unit of the tracked output (and so of the tracking errors).
    pub output_unit: Option<String>,
    /// Smallest and largest input reached over the run.
    pub input_min: f64,
    pub input_max: f64,
    /// The model's input bounds (reported, never clipped).
    pub input_lower_bound: Option<f64>,
    pub input_upper_bound: Option<f64>,
    /// Maximal time intervals [t_start, t_end] of consecutive samples with the input outside its bounds.
    pub input_bound_violations: Vec<[f64; 2]>,
}

impl Totals {
    /// The totals of a run of `info`'s model over a cycle of `distance` metres: `integrals[k]` of the outputs
    /// `accumulate[k]`, the input's `range` and its bound `violations`.
    pub(crate) fn new(
        info: &ModelInfo,
        accumulate: &[usize],
        integrals: &[f64],
        distance: f64,
        range: [f64; 2],
        violations: Vec<[f64; 2]>,
    ) -> Totals {
        let tables = integral_tables(info, accumulate, integrals, distance);
        Totals {
            integrals: tables.integrals,
            integrals_per_100km: tables.per_100km,
            integral_units: tables.units,
            input: info.input.clone(),
            input_unit: info.input_unit.clone(),
            output_unit: info.output_unit.clone(),
            input_min: range[0],
            input_max: range[1],
            input_lower_bound: info.input_min,
            input_upper_bound: info.input_max,
            input_bound_violations: violations,
        }
    }

    /// Summary text: the integrals (the `headline` output's marked as the model's answer), the input's range
    /// and its bound violations.
    pub(crate) fn write_text(&self, s: &mut String, headline: Option<&str>) {
        write_integrals(
            s,
            (&self.integrals, headline),
            &self.integral_units,
            &self.integrals_per_100km,
        );
        write_input_range(
            s,
            (&self.input, self.input_unit.as_deref()),
            [self.input_min, self.input_max],
            [self.input_lower_bound, self.input_upper_bound],
        );
        write_intervals(s, "input bound violations", &self.input_bound_violations);
    }
}

/// One input of a model with modes over the run: the range of the values it took (as the free input of the
/// mode in force or as a fixed input) and its declared bounds.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct InputRange {
    pub name: String,
    pub unit: Option<String>,
    pub min: f64,
    pub max: f64,
    pub lower_bound: Option<f64>,
    pub upper_bound: Option<f64>,
}

impl Totals {
    /// The totals of a run with modes: the integral tables as the run computed them, the headline input
    /// `input` (the traction input: see `docs/reference.md`, "Summary") with its range and bounds, and the
    /// intervals where the free input of the mode in force leaves its bounds.
    pub(crate) fn of_modes(
        (integrals, integrals_per_100km, integral_units): (
            BTreeMap<String, f64>,
            BTreeMap<String, f64>,
            BTreeMap<String, String>,
        ),
        output_unit: Option<String>,
        input: &InputRange,
        violations: Vec<[f64; 2]>,
    ) -> Totals {
        Totals {
            integrals,
            integrals_per_100km,
            integral_units,
            input: input.name.clone(),
            input_unit: input.unit.clone(),
            output_unit,
            input_min: input.min,
            input_max: input.max,
            input_lower_bound: input.lower_bound,
            input_upper_bound: input.upper_bound,
            input_bound_violations: violations,
        }
    }
}

/// The count, total time and longest of time intervals `[start, end]` for a warning: "N interval(s), T s in
/// total, the longest from t = A s to B s" (empty for none).
pub(crate) fn describe_intervals(intervals: &[[f64; 2]]) -> String {
    let Some([a, b]) =
        intervals
            .iter()
            .copied()
            .reduce(|x, y| if y[1] - y[0] > x[1] - x[0] { y } else { x })
    else {
        return String::new();
    };
    let total: f64 = intervals.iter().map(|[a, b]| b - a).sum();
    format!(
        "{} interval(s), {} s in total, the longest from t = {} s to {} s",
        intervals.len(),
        fmt_sig(total, 4),
        fmt_sig(a, 6),
        fmt_sig(b, 6)
    )
}

/// `v` with `digits` significant digits, in positional notation for moderate magnitudes.
pub(crate) fn fmt_sig(v: f64, digits: usize) -> String {
    if !v.is_finite() {
        return format!("{v}");
    }
    if v == 0.0 {
        return "0".to_string();
    }
    let mag = v.abs().log10().floor() as i32;
    if !(-4..15).contains(&mag) {
        return format!("{:.*e}", digits.saturating_sub(1), v);
    }
    // A whole number (|v| < 10¹⁵ here) prints as its digits whatever the decimals (they are zeros, trimmed):
    // the integer's formatting, without the exact float formatting's cost.
    if v == v.trunc() {
        return (v as i64).to_string();
    }
    let decimals = (digits as i32 - 1 - mag).max(0) as usize;
    let s = format!("{v:.decimals$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// "0.5, -2 ± 1i" style list of complex numbers given as [re, im].
pub(crate) fn format_eigenvalues(eigs: &[[f64; 2]]) -> String {
    if eigs.is_empty() {
        return "not computable (∂q/∂η is not finite)".to_string();
    }
    let mut s = String::new();
    let mut i = 0;
    while i < eigs.len() {
        if !s.is_empty() {
            s.push_str(", ");
        }
        let [re, im] = eigs[i];
        // Conjugate pairs are listed together.
        let paired =
            im != 0.0 && i + 1 < eigs.len() && eigs[i + 1][0] == re && eigs[i + 1][1] == -im;
        if paired {
            let _ = write!(s, "{} ± {}i", fmt_sig(re, 6), fmt_sig(im.abs(), 6));
            i += 2;
        } else if im == 0.0 {
            let _ = write!(s, "{}", fmt_sig(re, 6));
            i += 1;
        } else {
            let sign = if im < 0.0 { '-' } else { '+' };
            let _ = write!(s, "{} {} {}i", fmt_sig(re, 6), sign, fmt_sig(im.abs(), 6));
            i += 1;
        }
    }
    s
}

/// The unit of ∫ o dt for an output in `unit`: `kg/s` → `kg`, `W` → `J`; `None` if not obvious.
pub(crate) fn integral_unit(unit: &str) -> Option<String> {
    let unit = unit.trim();
    if let Some(base) = unit.strip_suffix("/s") {
        return (!base.is_empty()).then(|| base.to_string());
    }
    match unit {
        "W" => Some("J".to_string()),
        "kW" => Some("kJ".to_string()),
        _ => None,
    }
}

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
    /// Output → integral · 1e5 / distance (per 100 km), for `per_distance` outputs; empty when the cycle
    /// covers no distance.
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
        if has_distance && o.per_distance {
            t.per_100km.insert(o.name.clone(), acc * 1e5 / distance);
        }
        if let Some(unit) = o.unit.as_deref().and_then(integral_unit) {
            t.units.insert(o.name.clone(), unit);
        }
    }
    t
}

/// Summary text: one line per accumulated output, `fuel: 0.5617 kg (integral), 6.846 l/100 km`; the line of
/// the `headline` output ends with `(the model's answer: the headline)`.
pub(crate) fn write_integrals(
    s: &mut String,
    (integrals, headline): (&BTreeMap<String, f64>, Option<&str>),
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
        if headline == Some(name.as_str()) {
            s.push_str(" (the model's answer: the headline)");
        }
        s.push('\n');
    }
}

/// Summary text: the input's range over the run and its declared bounds, in the input's unit.
pub(crate) fn write_input_range(
    s: &mut String,
    (input, unit): (&str, Option<&str>),
    range: [f64; 2],
    bounds: [Option<f64>; 2],
) {
    let unit = unit_suffix(unit);
    let _ = write!(
        s,
        "{input}: min {}{unit}, max {}{unit}",
        fmt_sig(range[0], 4),
        fmt_sig(range[1], 4)
    );
    if bounds.iter().any(Option::is_some) {
        let b = |v: Option<f64>, inf: &str| v.map_or(inf.to_string(), |v| fmt_sig(v, 6));
        let _ = write!(
            s,
            " (bounds [{}, {}]{unit})",
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

#[cfg(test)]
mod tests {
    /// Count, total and the longest interval (the first of equally long ones).
    #[test]
    fn intervals_described() {
        assert_eq!(super::describe_intervals(&[]), "");
        assert_eq!(
            super::describe_intervals(&[[1.0, 2.0], [10.0, 12.5], [20.0, 22.5]]),
            "3 interval(s), 6 s in total, the longest from t = 10 s to 12.5 s"
        );
    }

    use super::*;

    /// Whole numbers print as the formatted float does after its zeros are trimmed.
    #[test]
    fn whole_numbers_print_as_formatted() {
        let slow = |v: f64, digits: usize| {
            let mag = v.abs().log10().floor() as i32;
            let decimals = (digits as i32 - 1 - mag).max(0) as usize;
            let s = format!("{v:.decimals$}");
            match s.contains('.') {
                true => s.trim_end_matches('0').trim_end_matches('.').to_string(),
                false => s,
            }
        };
        for v in [
            1.0,
            -1.0,
            7.0,
            10.0,
            120.0,
            -300.0,
            1180.0,
            99999.0,
            123456789.0,
            4.0e14,
            -9.0e14,
        ] {
            for digits in 1..8 {
                assert_eq!(fmt_sig(v, digits), slow(v, digits), "{v} to {digits}");
            }
        }
    }

    #[test]
    fn significant_digits() {
        assert_eq!(fmt_sig(0.345_612, 4), "0.3456");
        assert_eq!(fmt_sig(5.666_3, 3), "5.67");
        assert_eq!(fmt_sig(11_013.3, 6), "11013.3");
        assert_eq!(fmt_sig(1180.0, 6), "1180");
        assert_eq!(fmt_sig(-2.0e-9, 3), "-2.00e-9");
        assert_eq!(fmt_sig(0.0, 3), "0");
    }

    #[test]
    fn eigenvalue_list() {
        assert_eq!(
            format_eigenvalues(&[[0.5, 0.0], [-2.0, 1.0], [-2.0, -1.0]]),
            "0.5, -2 ± 1i"
        );
    }

    #[test]
    fn derivative_units() {
        assert_eq!(per_second("m/s", 1), "m/s^2");
        assert_eq!(per_second("m/s", 2), "m/s^3");
        assert_eq!(per_second("Pa", 1), "Pa/s");
        assert_eq!(per_second("Pa", 2), "Pa/s^2");
        assert_eq!(per_second("m/s^2", 1), "m/s^3");
    }

    #[test]
    fn first_sentences() {
        assert_eq!(first_sentence("A car. With a gear."), "A car");
        assert_eq!(first_sentence("A car."), "A car");
        assert_eq!(first_sentence(" e.g.x "), "e.g.x");
    }

    #[test]
    fn integral_units() {
        assert_eq!(integral_unit("kg/s").as_deref(), Some("kg"));
        assert_eq!(integral_unit("W").as_deref(), Some("J"));
        assert_eq!(integral_unit("Pa"), None);
    }
}
