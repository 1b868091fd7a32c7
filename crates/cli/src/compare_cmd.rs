//! `invsim compare A.json B.json [C.json …]`: the figures of several runs' summaries side by side, with each
//! run's difference to the first (absolute and relative), as text or JSON; runs on different cycles are
//! compared with a warning. `--plot` overlays the runs' CSV series ([`crate::compare_plot`]).

use std::path::PathBuf;

use crate::compare_table::{self, label};
use crate::cycles_cmd::ListFormat;
use crate::error::{Failure, Warnings};
use crate::run_summary::RunSummary;

/// Most runs compared at once (labelled A … Z).
pub const MAX_RUNS: usize = 26;

// No doc comment: clap would make it the command's about, over the one `main.rs` gives it.
#[derive(clap::Args, Debug)]
pub struct CompareArgs {
    /// Two or more summary JSON files (`simulate` or `forward` with --summary-json); the first is the
    /// baseline the others are compared to.
    #[arg(required = true, num_args = 2.., value_name = "RUN.json")]
    pub runs: Vec<PathBuf>,
    /// Output format of the table.
    #[arg(long, value_enum, default_value_t = ListFormat::Text)]
    pub format: ListFormat,
    #[command(flatten)]
    pub plot: crate::compare_plot::ComparePlotArgs,
}

pub fn run(args: &CompareArgs, warnings: Warnings) -> Result<(), Failure> {
    if args.runs.len() > MAX_RUNS {
        return Err(Failure::user(format!(
            "compare: {} runs given, more than the {MAX_RUNS} compared at once",
            args.runs.len()
        )));
    }
    let runs: Vec<RunSummary> = args
        .runs
        .iter()
        .map(|p| RunSummary::read(p))
        .collect::<Result<_, _>>()?;
    warnings.emit(&other_cycles(&runs))?;
    crate::compare_plot::write(&args.plot, &runs)?;
    let figures: Vec<_> = runs.iter().map(RunSummary::figures).collect();
    let rows = compare_table::rows(&figures);
    let text = match args.format {
        ListFormat::Text => compare_table::text(&runs, &rows),
        ListFormat::Json => {
            let v = compare_table::json(&runs, &rows);
            let s = serde_json::to_string_pretty(&v)
                .map_err(|e| Failure::io(format!("cannot write the comparison as JSON: {e}")))?;
            s + "\n"
        }
    };
    crate::files::print_stdout(&text)
}

/// The warning when the runs did not all drive the first run's cycle: their totals then differ by the cycle too.
fn other_cycles(runs: &[RunSummary]) -> Vec<String> {
    let first = runs[0].text("cycle");
    let others: Vec<String> = runs
        .iter()
        .enumerate()
        .filter(|(_, r)| r.text("cycle") != first)
        .map(|(k, r)| format!("{} drove `{}`", label(k), r.text("cycle")))
        .collect();
    if others.is_empty() {
        return Vec::new();
    }
    vec![format!(
        "the runs drove different cycles (A drove `{first}`, {}): their totals differ by the cycle too; \
         compare the per-100-km figures",
        others.join(", ")
    )]
}
