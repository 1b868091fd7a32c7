//! `invsim compare … --plot FILE.svg|FILE.png`: the runs' series overlaid, one colour per run (A, B, …), in
//! panels over time — the reference (y_d of an inverse run, the raw cycle of a forward run; speeds in km/h),
//! the input, the running integral of the fuel used (in litres where the runs have a fuel volume), or the
//! columns `--plot-vars` names — with the headline figure of each run and its difference to A under the
//! title. Each run's CSV series is `--series`, else the `--out` file its summary records
//! ([`crate::run_series`]); the plot may not overwrite any of these inputs.

use std::io::Write as _;
use std::path::{Path, PathBuf};

use invsim_runtime::plot::{thin, Figure, Panel, Series, PALETTE};

use crate::compare_table::label;
use crate::error::Failure;
use crate::plotting::FigureArgs;
use crate::run_series::{self, RunSeries};
use crate::run_summary::{four_digits, RunSummary};

// No doc comment: clap would make it the command's about.
#[derive(clap::Args, Debug)]
pub struct ComparePlotArgs {
    /// Overlay the runs' series in one figure, SVG or PNG (chosen by the extension).
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// The runs' CSV series (`--out` of each run), comma-separated in the order of the summaries. Default: the
    /// --out file each summary records (from the current directory, else beside the summary).
    #[arg(long, value_delimiter = ',', requires = "plot", value_name = "A.csv,…")]
    pub series: Vec<PathBuf>,
    /// The panels, comma-separated: reference, input, any column all runs have, cum:NAME (running integral of
    /// an integral all runs report). Default: reference, input and the fuel's cum:.
    #[arg(long, value_delimiter = ',', requires = "plot", value_name = "NAME,…")]
    pub plot_vars: Vec<String>,
    #[command(flatten)]
    pub figure: FigureArgs,
}

/// What a panel of the comparison draws.
enum Var {
    Reference,
    Input,
    Column(String),
    Cumulative(String),
}

/// Write the overlaid figure of `runs` when `--plot` was given.
pub fn write(args: &ComparePlotArgs, runs: &[RunSummary]) -> Result<(), Failure> {
    let Some(path) = &args.plot else {
        return Ok(());
    };
    if !args.series.is_empty() && args.series.len() != runs.len() {
        return Err(Failure::user(format!(
            "compare --series: {} file(s) for {} runs; give one CSV per summary, in the same order",
            args.series.len(),
            runs.len()
        )));
    }
    invsim_runtime::plot::PlotFormat::from_path(path).map_err(crate::plotting::user)?;
    let vars = resolve(runs, &args.plot_vars)?;
    let names: Vec<String> = vars.iter().map(|_| "panel".to_string()).collect();
    args.figure.check(&names, None)?;
    let files: Vec<PathBuf> = runs
        .iter()
        .enumerate()
        .map(|(k, r)| run_series::locate(r, args.series.get(k).map(PathBuf::as_path)))
        .collect::<Result<_, _>>()?;
    let mut inputs = crate::inputs::Inputs::new();
    for (r, f) in runs.iter().zip(&files) {
        inputs = inputs.file("summary", &r.path).file("series", f);
    }
    let mut outputs = crate::outputs::Outputs::plan(&inputs, &[("--plot", Some(path))])?;
    let series: Vec<RunSeries> = runs
        .iter()
        .zip(&files)
        .map(|(r, f)| run_series::read(r, f, &columns(r, &vars)))
        .collect::<Result<_, _>>()?;
    let figure = figure(runs, &series, &vars);
    let bytes = args.figure.render(path, figure, headline(runs))?;
    outputs.write("--plot", |mut f| f.write_all(&bytes))?;
    outputs.commit()
}

/// The panels `names` ask for (none: the default), each checked against every run.
fn resolve(runs: &[RunSummary], names: &[String]) -> Result<Vec<Var>, Failure> {
    let names: Vec<String> = if names.is_empty() {
        let mut d = vec!["reference".to_string(), "input".to_string()];
        d.extend(fuel(runs).map(|f| format!("cum:{f}")));
        d
    } else {
        names
            .iter()
            .map(|n| n.trim().to_string())
            .filter(|n| !n.is_empty())
            .collect()
    };
    if names.is_empty() || names.len() > invsim_runtime::plot::MAX_PANELS {
        return Err(Failure::user(format!(
            "compare --plot-vars: give 1 … {} panels",
            invsim_runtime::plot::MAX_PANELS
        )));
    }
    names.iter().map(|n| resolve_one(runs, n)).collect()
}

fn resolve_one(runs: &[RunSummary], name: &str) -> Result<Var, Failure> {
    let common = |what: &dyn Fn(&RunSummary) -> Vec<String>| -> Vec<String> {
        let mut c = what(&runs[0]);
        c.retain(|x| runs.iter().all(|r| what(r).contains(x)));
        c
    };
    let columns = |r: &RunSummary| r.column_names().into_iter().map(str::to_string).collect();
    let integrals = |r: &RunSummary| integral_names(r);
    match name {
        "reference" => return Ok(Var::Reference),
        "input" => return Ok(Var::Input),
        _ => {}
    }
    if let Some(i) = name.strip_prefix("cum:") {
        if common(&integrals).iter().any(|x| x == i) {
            return Ok(Var::Cumulative(i.to_string()));
        }
    } else if common(&columns).iter().any(|x| x == name) {
        return Ok(Var::Column(name.to_string()));
    }
    let mut valid = vec!["reference".to_string(), "input".to_string()];
    valid.extend(common(&columns).into_iter().filter(|c| c != "t"));
    valid.extend(common(&integrals).iter().map(|i| format!("cum:{i}")));
    Err(Failure::user(format!(
        "compare --plot-vars: `{name}` is not a panel of every run; the runs share: {}",
        valid.join(", ")
    )))
}

fn integral_names(r: &RunSummary) -> Vec<String> {
    r.json
        .get("integrals")
        .and_then(|v| v.as_object())
        .map(|m| m.keys().cloned().collect())
        .unwrap_or_default()
}

fn integral_unit(r: &RunSummary, name: &str) -> Option<String> {
    let u = r.json.get("integral_units")?.get(name)?.as_str()?;
    Some(u.to_string())
}

/// The integral every run reports that the figure integrates: the first in litres, else the first.
fn fuel(runs: &[RunSummary]) -> Option<String> {
    let common: Vec<String> = integral_names(&runs[0])
        .into_iter()
        .filter(|i| runs.iter().all(|r| integral_names(r).contains(i)))
        .collect();
    let litres = common
        .iter()
        .find(|i| integral_unit(&runs[0], i).as_deref() == Some("l"));
    litres.or(common.first()).cloned()
}

/// The column a run's reference panel draws: y_d of an inverse run, else the raw cycle.
fn reference_column(r: &RunSummary) -> &'static str {
    if r.column_names().contains(&"yd_0") {
        "yd_0"
    } else {
        "yc"
    }
}

/// The column `var` reads from run `r` (the rate for a running integral).
fn column_of(r: &RunSummary, var: &Var) -> String {
    match var {
        Var::Reference => reference_column(r).to_string(),
        Var::Input => r.text("input").to_string(),
        Var::Column(c) | Var::Cumulative(c) => c.clone(),
    }
}

fn columns(r: &RunSummary, vars: &[Var]) -> Vec<String> {
    let mut c = vec!["t".to_string()];
    c.extend(vars.iter().map(|v| column_of(r, v)));
    c
}

/// The unit of column `name` as the summary lists it.
fn column_unit(r: &RunSummary, name: &str) -> Option<String> {
    let columns = r.json.get("columns")?.as_array()?;
    let c = columns
        .iter()
        .find(|c| c.get("name").and_then(|n| n.as_str()) == Some(name))?;
    Some(c.get("unit")?.as_str()?.to_string())
}

/// The overlaid figure.
fn figure(runs: &[RunSummary], series: &[RunSeries], vars: &[Var]) -> Figure {
    let (mut t0, mut t1) = (f64::INFINITY, f64::NEG_INFINITY);
    for s in series {
        let t = s.column("t");
        t0 = t0.min(t.first().copied().unwrap_or(f64::INFINITY));
        t1 = t1.max(t.last().copied().unwrap_or(f64::NEG_INFINITY));
    }
    if t0.partial_cmp(&t1) != Some(std::cmp::Ordering::Less) {
        (t0, t1) = (0.0, 1.0);
    }
    let files: Vec<String> = runs
        .iter()
        .enumerate()
        .map(|(k, r)| format!("{} {}", label(k), file_name(&r.path)))
        .collect();
    Figure {
        title: format!("compare {}", files.join(", ")),
        headline: None,
        x_label: "t [s]".to_string(),
        x_range: (t0, t1),
        panels: vars.iter().map(|v| panel(runs, series, v)).collect(),
        scatter: None,
    }
}

fn file_name(p: &Path) -> String {
    p.file_name().map_or_else(
        || p.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    )
}

/// One panel: the runs' curves of `var`, one colour each.
fn panel(runs: &[RunSummary], series: &[RunSeries], var: &Var) -> Panel {
    let a = &runs[0];
    let name = column_of(a, var);
    let speed = matches!(var, Var::Reference) && a.text("output_unit") == "m/s";
    let (y_label, factor) = match var {
        Var::Reference if speed => ("speed [km/h]".to_string(), 3.6),
        Var::Cumulative(i) => (
            with_unit(&format!("cumulative {i}"), integral_unit(a, i)),
            1.0,
        ),
        _ => (with_unit(&name, column_unit(a, &name)), 1.0),
    };
    let curves = runs
        .iter()
        .zip(series)
        .enumerate()
        .map(|(k, (r, s))| {
            let t = s.column("t");
            let v = s.column(&column_of(r, var));
            let values: Vec<f64> = match var {
                Var::Cumulative(_) => cumulative(t, v),
                _ => v.iter().map(|x| x * factor).collect(),
            };
            Series {
                label: format!("{} {}", label(k), file_name(&r.path)),
                color: PALETTE[k % PALETTE.len()],
                width: 1.5,
                dashed: k % 2 == 1,
                points: thin(t, &values),
            }
        })
        .collect();
    Panel {
        var: match var {
            Var::Reference => "reference".to_string(),
            Var::Input => "input".to_string(),
            Var::Column(c) => c.clone(),
            Var::Cumulative(i) => format!("cum:{i}"),
        },
        title: format!("{y_label}, run by run"),
        y_label,
        y_zero: matches!(var, Var::Reference | Var::Cumulative(_)),
        series: curves,
        guides: Vec::new(),
    }
}

fn with_unit(name: &str, unit: Option<String>) -> String {
    match unit.filter(|u| !u.trim().is_empty()) {
        Some(u) => format!("{name} [{u}]"),
        None => name.to_string(),
    }
}

/// ∫ v dt by the trapezoidal rule at every sample (as the summaries' integrals).
fn cumulative(t: &[f64], v: &[f64]) -> Vec<f64> {
    let mut acc = 0.0;
    let mut out = Vec::with_capacity(t.len());
    for k in 0..t.len().min(v.len()) {
        if k > 0 {
            acc += 0.5 * (v[k] + v[k - 1]) * (t[k] - t[k - 1]);
        }
        out.push(acc);
    }
    out
}

/// The figure's headline: the fuel's per-100-km figure (or integral) of each run, with its difference to A.
fn headline(runs: &[RunSummary]) -> Option<String> {
    let f = fuel(runs)?;
    let per = |r: &RunSummary, key: &str| r.json.get(key)?.get(&f)?.as_f64();
    let key = if runs.iter().all(|r| per(r, "integrals_per_100km").is_some()) {
        "integrals_per_100km"
    } else {
        "integrals"
    };
    let unit = integral_unit(&runs[0], &f).unwrap_or_default();
    let unit = if key == "integrals" {
        unit
    } else {
        format!("{unit}/100 km")
    };
    let a = per(&runs[0], key)?;
    let items: Vec<String> = runs
        .iter()
        .enumerate()
        .filter_map(|(k, r)| {
            let v = per(r, key)?;
            let diff = match k {
                0 => String::new(),
                _ if a != 0.0 => format!(" ({:+.2} %)", 100.0 * (v - a) / a.abs()),
                _ => String::new(),
            };
            Some(format!("{} {} {unit}{diff}", label(k), four_digits(v)))
        })
        .collect();
    Some(format!("{f}: {}", items.join(", ")))
}
