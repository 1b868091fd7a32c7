//! `invsim cycles`: the built-in drive cycles with their duration, distance and top speed, as a text table or
//! JSON, or one built-in's samples as a cycle CSV (`--export NAME`: `time_s,speed_mps`, the numbers in
//! Rust's shortest round-trip form, so the file reads back to the same cycle). Distance is the exact integral
//! of the piecewise-linear speed trace (trapezoidal rule), as the summaries of `simulate` and `forward`
//! compute it.

use crate::error::Failure;
use crate::files::print_stdout;
use clap::ValueEnum;
use invsim_runtime::Cycle;
use std::fmt::Write as _;

#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum ListFormat {
    Text,
    Json,
}

#[derive(clap::Args, Debug)]
pub struct CyclesArgs {
    /// Output format.
    #[arg(long, value_enum, default_value_t = ListFormat::Text)]
    format: ListFormat,
    /// Write the built-in cycle NAME's samples as a cycle CSV (`time_s,speed_mps`) on stdout instead of the list.
    #[arg(long, value_name = "NAME")]
    export: Option<String>,
}

/// One built-in cycle's figures.
struct Row {
    name: &'static str,
    description: &'static str,
    start_s: f64,
    duration_s: f64,
    distance_m: f64,
    top_speed_mps: f64,
}

fn rows() -> Result<Vec<Row>, Failure> {
    Cycle::builtins()
        .iter()
        .map(|b| {
            let c = Cycle::builtin(b.name)
                .ok_or_else(|| Failure::io(format!("built-in cycle `{}` is missing", b.name)))?;
            Ok(Row {
                name: b.name,
                description: b.description,
                start_s: c.time.first().copied().unwrap_or(0.0),
                duration_s: c.duration(),
                distance_m: c.distance(),
                top_speed_mps: c.max_speed(),
            })
        })
        .collect()
}

fn text(rows: &[Row]) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{:<18} {:>9} {:>10} {:>11}  description",
        "name", "duration", "distance", "top speed"
    );
    for r in rows {
        let _ = writeln!(
            s,
            "{:<18} {:>7} s {:>7.3} km {:>6.1} km/h  {}",
            r.name,
            r.duration_s,
            r.distance_m / 1000.0,
            r.top_speed_mps * 3.6,
            r.description,
        );
    }
    s
}

fn json(rows: &[Row]) -> Result<String, Failure> {
    let list: Vec<serde_json::Value> = rows
        .iter()
        .map(|r| {
            serde_json::json!({
                "name": r.name,
                "description": r.description,
                "start_s": r.start_s,
                "duration_s": r.duration_s,
                "distance_m": r.distance_m,
                "top_speed_mps": r.top_speed_mps,
                "top_speed_kmh": r.top_speed_mps * 3.6,
            })
        })
        .collect();
    let mut s = serde_json::to_string_pretty(&list).map_err(|e| Failure::io(e.to_string()))?;
    s.push('\n');
    Ok(s)
}

/// The built-in cycle `name` as a cycle CSV.
fn export(name: &str) -> Result<String, Failure> {
    let c = Cycle::builtin(name).ok_or_else(|| {
        Failure::user(format!(
            "--export `{name}`: not a built-in cycle; expected one of {}",
            Cycle::builtin_names().join(", ")
        ))
    })?;
    let mut s = String::from("time_s,speed_mps\n");
    for (t, v) in c.time.iter().zip(&c.speed) {
        let float = invsim_runtime::output::float_text;
        let _ = writeln!(s, "{},{}", float(*t), float(*v));
    }
    Ok(s)
}

/// Print the list of built-in cycles, or one cycle's samples.
pub fn run(args: &CyclesArgs) -> Result<(), Failure> {
    if let Some(name) = &args.export {
        return print_stdout(&export(name)?);
    }
    let rows = rows()?;
    let out = match args.format {
        ListFormat::Text => text(&rows),
        ListFormat::Json => json(&rows)?,
    };
    print_stdout(&out)
}
