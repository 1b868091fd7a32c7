//! `invsim forward` of a model with operating modes (and the dispatch of `invsim forward` by the kind of model) (README "Modes"): every mode compiled or derived and
//! interpreted (`modal_engine`), the forward run with the mode sequence by `invsim_runtime::forward::forward_modes`.

use invsim_inversion::ModalModel;
use invsim_runtime::forward::{forward_modes, ForwardError};
use invsim_runtime::{output, Cycle};

use crate::error::Failure;
use crate::files::print_stdout;
use crate::forward::ForwardArgs;
use crate::provenance;

/// `invsim forward`: a model with modes here, any other by `forward::run`.
pub fn run(args: &ForwardArgs) -> Result<(), Failure> {
    match crate::modal_cmd::modal_if_readable(&args.model) {
        Some(m) => run_modal(m, args),
        None => crate::forward::run(args),
    }
}

/// `invsim forward MODEL` where MODEL has modes.
fn run_modal(m: ModalModel, args: &ForwardArgs) -> Result<(), Failure> {
    let mut outputs = crate::outputs::Outputs::plan(
        &crate::engine::run_inputs(&args.model, &args.cycle),
        &[
            ("--out", args.out.as_deref()),
            ("--summary-json", args.summary_json.as_deref()),
            ("--plot", args.plot.plot.as_deref()),
        ],
    )?;
    let cycle = Cycle::load_with_limit(&args.cycle, args.max_cycle_bytes)
        .map_err(|e| Failure::user(e.to_string()))?;
    let prepared = crate::modal_cmd::prepare(
        crate::modal_cmd::ModalRead::Full(m),
        &cycle,
        &args.cycle,
        (&args.set, &args.data.map),
        args.engine,
    )?;
    let spec = crate::modal_cmd::spec(&prepared);
    crate::plotting::check_modal(&args.plot, &spec)?;
    let stopped = |e: ForwardError| {
        Failure::user(format!(
            "forward simulation of `{}` on `{}` stopped: {e}",
            args.model.display(),
            cycle.name
        ))
    };
    let (progress, bar) = crate::progress::start("forward");
    let mut opts = crate::forward::options(args, prepared.engine, progress).map_err(stopped)?;
    opts.initial = crate::initial_args::parse_initial(&args.data.initial)?;
    opts.signals = crate::signal_args::parse_signals(&args.data.signal)?;
    let result = forward_modes(&spec, &cycle, &opts);
    bar.finish();
    let mut result = result.map_err(stopped)?;
    result.summary.provenance = Some(provenance::record(provenance::RunRecord {
        command: "forward",
        model: &args.model,
        info: prepared.interps[0].info(),
        cycle_spec: &args.cycle,
        cycle: &cycle,
        sets: &args.set,
        options: provenance::options_of(args),
    })?);
    outputs.write("--out", |f| {
        output::write_table_csv(&result.columns, &result.data, f)
    })?;
    outputs.write("--summary-json", |f| output::write_json(&result.summary, f))?;
    crate::plotting::write(&args.plot, &mut outputs, |vars| {
        invsim_runtime::plot::modal_forward_figure(&result, &spec, vars)
    })?;
    outputs.commit()?;
    print_stdout(&result.summary.to_text())
}
