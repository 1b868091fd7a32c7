//! `invsim sweep`: many variants of a model (a full-factorial grid of parameter values or a table of them) on
//! one or more cycles, one CSV (or Parquet) row of summary figures per variant × cycle (contract §3, exit status 3 when some
//! variants failed).

use std::io::IsTerminal;
use std::path::{Path, PathBuf};

use indicatif::{ProgressBar, ProgressStyle};
use invsim_loader::{Loaded, SingleModel};
use invsim_runtime::{inverse, Cycle, Plant, SimulationOptions, Sweep, SweepBuilder, SweepResult};

use crate::engine::{load, parse_set, set_failure, EngineChoice};
use crate::error::{Failure, Warnings};
use crate::number_arg::parse_number;
use crate::outputs::Outputs;

/// Exit status of a sweep in which some variants failed (their rows say why).
pub const SOME_FAILED: u8 = 3;

#[derive(clap::Args, Debug)]
pub struct SweepArgs {
    /// The model file (TOML).
    pub model: PathBuf,
    /// A built-in cycle or the path of a cycle CSV file.
    #[arg(long)]
    cycle: Option<String>,
    /// More cycles, comma-separated (every variant runs on each).
    #[arg(long, value_delimiter = ',')]
    cycles: Vec<String>,
    /// A grid axis NAME=START:STOP:N (N values from START to STOP, both included); repeated: full factorial.
    #[arg(
        long = "grid",
        value_name = "NAME=START:STOP:N",
        conflicts_with = "table"
    )]
    grid: Vec<String>,
    /// A CSV file of variants: a header of parameter names, one row of values per variant.
    #[arg(long, value_name = "PARAMS.csv")]
    table: Option<PathBuf>,
    /// Worker threads (default: one per core; at most one per run and 4 per core are started).
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Write the rows to this file: Parquet if its name ends in `.parquet`, else CSV (default: CSV on stdout).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Replay every variant's input through the original model and report its tracking error.
    #[arg(long)]
    verify: bool,
    /// Differentiate every variant's figures exactly with respect to parameters (NAME,NAME,… or `all`; a gear's
    /// ratio of a model with modes as `NAME[g]`) and a map's grid values (MAP[i], MAP[i,j], MAP): a column
    /// `d(FIGURE)/d(PARAMETER)` for each.
    #[arg(long, value_name = "NAME,…|all", value_delimiter = ',')]
    gradient: Option<Vec<String>>,
    /// Kernel half-width a in seconds: the driver's look-ahead; `auto` chooses it per cycle (as `simulate`).
    #[arg(long, value_name = "A|auto", allow_negative_numbers = true,
          default_value_t = crate::lookahead_arg::LookaheadArg::DEFAULT)]
    lookahead: crate::lookahead_arg::LookaheadArg,
    /// Output step in seconds.
    #[arg(long, default_value_t = inverse::DEFAULT_DT)]
    dt: f64,
    /// Override a parameter of every variant: NAME=VALUE (repeatable).
    #[arg(long = "set", value_name = "NAME=VALUE")]
    set: Vec<String>,
    /// Which implementation of the model to run.
    #[arg(long, value_enum, default_value_t = EngineChoice::Auto)]
    engine: EngineChoice,
    /// Hybrids: the strategy of every run and its options, as `simulate`'s; the rows gain the hybrid columns.
    #[command(flatten)]
    strategy: crate::strategy_args::StrategyArgs,
}

/// Parse `NAME=START:STOP:N`.
fn parse_grid(s: &str) -> Result<(String, f64, f64, usize), Failure> {
    let bad = |why: &str| {
        Failure::user(format!(
            "--grid `{s}`: {why}; expected NAME=START:STOP:N, e.g. --grid m=1000:1800:9"
        ))
    };
    let (name, spec) = s.split_once('=').ok_or_else(|| bad("no `=`"))?;
    let parts: Vec<&str> = spec.split(':').map(str::trim).collect();
    let [start, stop, n] = parts[..] else {
        return Err(bad(&format!("{} `:`-separated fields, not 3", parts.len())));
    };
    let num = |v: &str| parse_number(v).map_err(|e| bad(&e.describe(v)));
    let n: usize = match n.parse() {
        Ok(n) if n >= 1 => n,
        _ => return Err(bad(&format!("N = `{n}` is not a whole number ≥ 1"))),
    };
    if n > invsim_runtime::sweep::MAX_RUNS {
        let max = invsim_runtime::sweep::MAX_RUNS;
        return Err(bad(&format!(
            "N = {n} values exceed the limit of {max} runs a sweep makes"
        )));
    }
    let name = name.trim();
    if name.is_empty() {
        return Err(bad("the parameter name is empty"));
    }
    Ok((name.to_string(), num(start)?, num(stop)?, n))
}

/// Largest parameter table read, in bytes: the cycle files' cap (64 MiB), far above the
/// [`invsim_runtime::sweep::MAX_RUNS`] rows of a few numbers a sweep makes at most; `/dev/zero` stops there.
pub const MAX_TABLE_BYTES: u64 = invsim_runtime::cycle::MAX_CYCLE_BYTES;

/// The text of the table file `path`, read through [`MAX_TABLE_BYTES`] (a larger file is refused without
/// reading the rest).
fn read_table_text(path: &Path) -> Result<String, Failure> {
    use std::io::Read as _;
    let cannot = |e: std::io::Error| Failure::user(format!("cannot read {}: {e}", path.display()));
    let file = std::fs::File::open(path).map_err(cannot)?;
    let mut bytes = Vec::new();
    file.take(MAX_TABLE_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(cannot)?;
    if bytes.len() as u64 > MAX_TABLE_BYTES {
        return Err(Failure::user(format!(
            "{}: the parameter table is larger than {MAX_TABLE_BYTES} bytes (64 MiB), the limit of a table",
            path.display()
        )));
    }
    String::from_utf8(bytes).map_err(|e| {
        Failure::user(format!(
            "{}: not UTF-8 text (invalid byte at offset {})",
            path.display(),
            e.utf8_error().valid_up_to()
        ))
    })
}

/// Read a table of variants: a header of parameter names, then one row of finite numbers per variant
/// (blank lines skipped; at least one, at most [`invsim_runtime::sweep::MAX_RUNS`]), each read by the number
/// rule of `--set` ([`parse_number`]). Errors name FILE:LINE:COLUMN.
pub fn read_table(path: &Path) -> Result<(Vec<String>, Vec<Vec<f64>>), Failure> {
    let text = read_table_text(path)?;
    let at = |line: usize, col: usize, what: String| {
        Failure::user(format!("{}:{line}:{col}: {what}", path.display()))
    };
    let mut lines = text
        .trim_start_matches('\u{feff}')
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim_end_matches('\r')))
        .filter(|(_, l)| !l.trim().is_empty());
    let (_, header) = lines.next().ok_or_else(|| {
        at(
            1,
            1,
            "empty table: expected a header of parameter names".into(),
        )
    })?;
    let names: Vec<String> = header.split(',').map(|s| s.trim().to_string()).collect();
    if let Some(i) = names.iter().position(|n| n.is_empty()) {
        let col = fields(header).nth(i).map_or(1, |(c, _)| c);
        return Err(at(1, col, "empty parameter name in the header".into()));
    }
    let mut rows = Vec::new();
    let mut last_line = 1;
    for (line, l) in lines {
        last_line = line;
        if rows.len() == invsim_runtime::sweep::MAX_RUNS {
            let max = invsim_runtime::sweep::MAX_RUNS;
            return Err(at(
                line,
                1,
                format!("more than {max} rows of variants, the limit of runs a sweep makes"),
            ));
        }
        let mut row = Vec::with_capacity(names.len());
        for (i, (col, field)) in fields(l).enumerate() {
            let Some(name) = names.get(i) else {
                return Err(at(
                    line,
                    col,
                    format!(
                        "more values than the {} parameters of the header",
                        names.len()
                    ),
                ));
            };
            match parse_number(field) {
                Ok(v) => row.push(v),
                Err(e) => {
                    let what = format!("{} (parameter `{name}`)", e.describe(field.trim()));
                    return Err(at(line, col, what));
                }
            }
        }
        if row.len() < names.len() {
            let what = format!(
                "{} values, the header names {} parameters",
                row.len(),
                names.len()
            );
            return Err(at(line, l.chars().count() + 1, what));
        }
        rows.push(row);
    }
    if rows.is_empty() {
        return Err(at(
            last_line + 1,
            1,
            "the table has no variants: expected a row of values after the header".into(),
        ));
    }
    Ok((names, rows))
}

/// A parameter both overridden by `--set` and swept (by `--grid` or `--table`, named by `how`) is refused: the
/// sweep's values would silently win over the `--set` value.
fn check_not_set(sets: &[(String, f64)], swept: &[String], how: &str) -> Result<(), Failure> {
    match sets.iter().find(|(name, _)| swept.contains(name)) {
        Some((name, _)) => Err(Failure::user(format!(
            "parameter `{name}` is both set (--set) and swept ({how}): give one of the two"
        ))),
        None => Ok(()),
    }
}

/// The comma-separated fields of a line with the 1-based column (in characters) where each starts.
fn fields(line: &str) -> impl Iterator<Item = (usize, &str)> {
    let mut col = 1;
    line.split(',').map(move |f| {
        let start = col;
        col += f.chars().count() + 1;
        (start, f)
    })
}

/// The sweep's builder for the loaded model, each worker's copy with the `--set` overrides: copies of the
/// interpreter, fresh compiled models (for a model with modes, of every mode).
fn builder(model: Loaded, sets: Vec<(String, f64)>) -> Result<SweepBuilder, Failure> {
    let mut model = model;
    for (name, value) in &sets {
        model.set_param(name, *value).map_err(set_failure)?;
    }
    match model {
        Loaded::Single(SingleModel::Interpreted(m)) => Ok(Sweep::of(*m)),
        Loaded::Single(m) => Ok(Sweep::try_new(move || m.fresh().map_err(|e| e.to_string()))),
        Loaded::Modal(m) => Ok(Sweep::of_plants(move || {
            m.fresh().map(Plant::Modal).map_err(|e| e.to_string())
        })),
    }
}

/// The cycles of `--cycle` and `--cycles`, in that order, each with its name or path as given.
fn cycles(args: &SweepArgs, warnings: Warnings) -> Result<Vec<(Cycle, &str)>, Failure> {
    let names: Vec<&String> = args.cycle.iter().chain(&args.cycles).collect();
    if names.is_empty() {
        return Err(Failure::user(
            "sweep needs a cycle: --cycle C and/or --cycles c1,c2,…",
        ));
    }
    names
        .iter()
        .map(|c| {
            let max = invsim_runtime::cycle::MAX_CYCLE_BYTES;
            let (cycle, _) = crate::engine::load_cycle(c.trim(), max, warnings)?;
            Ok((cycle, c.as_str()))
        })
        .collect()
}

/// A progress bar on stderr when it is a terminal, else none.
fn progress_bar(rows: usize) -> Option<ProgressBar> {
    if !std::io::stderr().is_terminal() {
        return None;
    }
    let bar = ProgressBar::new(rows as u64);
    let style =
        ProgressStyle::with_template("{bar:40} {pos}/{len} runs, {elapsed} elapsed, eta {eta}");
    if let Ok(style) = style {
        bar.set_style(style);
    }
    Some(bar)
}

/// The sweep's `--out` checked against its inputs (model and its map CSV files, cycle files, parameter
/// table: [`crate::inputs`]) before the run.
fn plan_outputs(args: &SweepArgs) -> Result<Outputs, Failure> {
    let mut inputs = crate::inputs::Inputs::new().model(&args.model);
    for c in args.cycle.iter().chain(&args.cycles) {
        inputs = inputs.cycle(c);
    }
    if let Some(table) = &args.table {
        inputs = inputs.file("parameter table", table);
    }
    Outputs::plan(&inputs, &[("--out", args.out.as_deref())])
}

/// Write the rows to `--out` (through a temporary file renamed into place) or stdout: Parquet when the file
/// name ends in `.parquet` (any case), CSV otherwise.
fn write_rows(
    result: &SweepResult,
    mut outputs: Outputs,
    out: Option<&Path>,
) -> Result<(), Failure> {
    let to_io = |e: csv::Error| std::io::Error::other(e.to_string());
    match out {
        Some(path) if is_parquet(path) => {
            outputs.write("--out", |f| {
                result.write_parquet(std::io::BufWriter::new(f))
            })?;
            outputs.commit()
        }
        Some(_) => {
            outputs.write("--out", |f| {
                result.write_csv(std::io::BufWriter::new(f)).map_err(to_io)
            })?;
            outputs.commit()
        }
        None => result
            .write_csv(std::io::stdout().lock())
            .map_err(|e| Failure::user(format!("cannot write to stdout: {e}"))),
    }
}

/// Does `path` name a Parquet file (extension `.parquet`, any case)?
fn is_parquet(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("parquet"))
}

/// `invsim sweep`; with `--strict` a cycle file's plausibility warning is an error (the runs' own warnings are
/// not part of a sweep's rows).
pub fn run(args: &SweepArgs, warnings: Warnings) -> Result<(), Failure> {
    let sets: Vec<(String, f64)> = args
        .set
        .iter()
        .map(|s| parse_set(s))
        .collect::<Result<_, _>>()?;
    let grid: Vec<_> = args
        .grid
        .iter()
        .map(|g| parse_grid(g))
        .collect::<Result<_, _>>()?;
    if grid.is_empty() && args.table.is_none() {
        return Err(Failure::user(
            "sweep needs --grid NAME=START:STOP:N (repeatable) or --table PARAMS.csv",
        ));
    }
    let n_cycles = args.cycle.iter().count() + args.cycles.len();
    let sizes: Vec<usize> = grid.iter().map(|g| g.3).collect();
    invsim_runtime::sweep::count_runs(
        &sizes,
        n_cycles,
        &match sizes.len() {
            1 => "1 grid axis".to_string(),
            n => format!("{n} grid axes"),
        },
    )
    .map_err(|e| Failure::user(format!("sweep: {e}")))?;
    let table = args.table.as_deref().map(read_table).transpose()?;
    if let Some((names, rows)) = &table {
        let what = format!("a table of {} rows", rows.len());
        invsim_runtime::sweep::count_runs(&[rows.len()], n_cycles, &what)
            .map_err(|e| Failure::user(format!("sweep: {e}")))?;
        check_not_set(&sets, names, "--table")?;
    }
    let swept: Vec<String> = grid.iter().map(|g| g.0.clone()).collect();
    check_not_set(&sets, &swept, "--grid")?;
    let outputs = plan_outputs(args)?;
    let cycles = cycles(args, warnings)?;
    let model = load(&args.model, args.engine, args.gradient.is_some())?;
    let gearbox = match &model {
        Loaded::Modal(m) => Some(m.plant.gear_parameters()),
        _ => None,
    };
    crate::simulate::check_gradient(
        args.gradient.as_deref(),
        gearbox,
        (model.info(), &model.maps()),
    )?;
    let failed = |e: String| Failure::user(format!("sweep of `{}`: {e}", args.model.display()));
    let mut opts = args
        .lookahead
        .apply(SimulationOptions::builder())
        .dt(args.dt)
        .engine(model.engine_name())
        .gradient(args.gradient.clone())
        .build()
        .map_err(|e| failed(e.to_string()))?;
    opts.strategy = args.strategy.options()?;
    let mut b = builder(model, sets)?;
    for (c, spec) in &cycles {
        b = match crate::cycle_spec::is_builtin(spec) {
            true => b.cycle(c),
            false => b.cycle_file(c, spec.trim()),
        };
    }
    for (name, start, stop, n) in grid {
        b = b.grid(name, start, stop, n);
    }
    if let Some((names, rows)) = table {
        b = b.table(names, rows);
    }
    let sweep = b
        .options(opts)
        .verify(args.verify)
        .threads(args.threads)
        .build();
    let sweep = sweep.map_err(|e| failed(e.to_string()))?;
    if args.threads > 0 && sweep.threads() < args.threads {
        crate::error::stderr_line(&format!(
            "invsim: note: --threads {}: using {} worker thread(s) (at most one per run, {} per core)",
            args.threads,
            sweep.threads(),
            invsim_runtime::sweep::MAX_THREADS_PER_CORE
        ));
    }
    let bar = progress_bar(sweep.len());
    let result = match &bar {
        Some(bar) => sweep.run_with_progress(&|n| bar.set_position(n as u64)),
        None => sweep.run(),
    };
    if let Some(bar) = bar {
        bar.finish_and_clear();
    }
    write_rows(&result, outputs, args.out.as_deref())?;
    match result.failed() {
        0 => Ok(()),
        n => Err(Failure {
            message: format!(
                "{n} of {} runs failed (their rows have status `error` and the reason)",
                result.rows.len()
            ),
            code: SOME_FAILED,
        }),
    }
}
