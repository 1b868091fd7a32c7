//! `derive` and `simulate` for a model with operating modes (README "Modes"): every mode compiled or derived
//! and interpreted (`modal_engine`), the mode sequence by `invsim_runtime::modes`.

use std::path::Path;

use invsim_inversion::{ModalModel, ModeRole, ModelFile, Schedule};
use invsim_model_api::InverseModel;
use invsim_runtime::modes::{
    gears, GearSource, InputSpec, ModalOptions, ModalSpec, ModeSpec, Role, SequenceParams,
    Switching,
};
use invsim_runtime::{output, Cycle};

use crate::error::Failure;
use crate::files::print_stdout;

/// The file read as a model with modes for a run with `engine` (for compiled code without building each
/// mode's model: `modal_engine::read_compiled`), or `None` for an ordinary model (then read as before).
pub fn read_modal_run(
    path: &Path,
    engine: crate::engine::EngineChoice,
) -> Result<Option<ModalRead>, Failure> {
    if crate::engine::is_builtin_single(path) {
        return Ok(None);
    }
    if let Some((m, loaded)) = crate::modal_engine::read_compiled(path, engine)? {
        return Ok(Some(ModalRead::Compiled(m, loaded)));
    }
    Ok(read_modal(path)?.map(ModalRead::Full))
}

/// The file read as a model with modes, or `None` for an ordinary model (then read as before).
pub fn read_modal(path: &Path) -> Result<Option<ModalModel>, Failure> {
    if crate::engine::is_builtin_single(path) {
        return Ok(None);
    }
    match ModelFile::from_path(path) {
        Ok(ModelFile::Modal(m)) => Ok(Some(*m)),
        Ok(ModelFile::Single(_)) => Ok(None),
        Err(e) => Err(Failure::user(e.to_string())),
    }
}

/// The file read as a model with modes, or `None` for anything else (an ordinary model, or a file that does
/// not read: the command's own reader then gives its message, as before).
pub fn modal_if_readable(path: &Path) -> Option<ModalModel> {
    if crate::engine::is_builtin_single(path) {
        return None;
    }
    match ModelFile::from_path(path) {
        Ok(ModelFile::Modal(m)) => Some(*m),
        _ => None,
    }
}

/// `sweep` does not run models with modes yet: exit 2 saying so (an unreadable file is left to
/// the command's own reader and its message).
pub fn refuse_modal(path: &Path, command: &str) -> Result<(), Failure> {
    if crate::engine::is_builtin_single(path) {
        return Ok(());
    }
    if let Ok(ModelFile::Modal(_)) = ModelFile::from_path(path) {
        return Err(Failure::user(format!(
            "{}: a model with operating modes runs with `invsim derive`, `invsim simulate` and `invsim forward`; `invsim {command}` \
             does not run models with modes yet",
            path.display()
        )));
    }
    Ok(())
}

pub use crate::modal_engine::{DerivedMode, ModalRead};

/// Every mode's derivation (the returned model keeps everything but its modes).
pub fn derive_modes(mut m: ModalModel) -> Result<(ModalModel, Vec<DerivedMode>), Failure> {
    let out = crate::modal_engine::derive_list(std::mem::take(&mut m.modes))?;
    Ok((m, out))
}

fn role_of(r: ModeRole) -> Role {
    match r {
        ModeRole::Traction => Role::Traction,
        ModeRole::Brake => Role::Brake,
        ModeRole::Standstill => Role::Standstill,
    }
}

/// `invsim derive` of a model with modes.
pub fn derive(m: ModalModel, format: crate::derive_format::Format) -> Result<(), Failure> {
    let (m, ds) = derive_modes(m)?;
    let text = match format {
        crate::derive_format::Format::Json => {
            let modes: Vec<serde_json::Value> = ds
                .iter()
                .map(|mode| {
                    let d = &mode.d;
                    let fixed: serde_json::Map<String, serde_json::Value> = mode
                        .fixed
                        .iter()
                        .map(|(i, e)| {
                            (
                                m.inputs[*i].name.clone(),
                                serde_json::Value::String(e.clone()),
                            )
                        })
                        .collect();
                    let mut o = serde_json::json!({
                        "name": mode.name, "family": mode.family, "gear": mode.gear,
                        "role": mode.role.as_str(), "free_input": m.inputs[mode.free].name,
                        "fixed_inputs": fixed, "derivation": d.to_json(),
                    });
                    if !mode.coupled.is_empty() {
                        // The states the mode couples (`couple`), with their couplings as written.
                        let couples: serde_json::Map<String, serde_json::Value> = mode
                            .coupled
                            .iter()
                            .map(|(s, e)| (d.model.states[*s].name.clone(), e.clone().into()))
                            .collect();
                        o["couples"] = couples.into();
                    }
                    o
                })
                .collect();
            let inputs: Vec<&str> = m.inputs.iter().map(|i| i.name.as_str()).collect();
            let v = serde_json::json!({ "name": m.name, "inputs": inputs, "modes": modes });
            let mut s = serde_json::to_string_pretty(&v).map_err(|e| Failure::io(e.to_string()))?;
            s.push('\n');
            s
        }
        f => {
            let mut s = invsim_inversion::render::modal_title(&m.name, ds.len());
            for mode in &ds {
                let d = &mode.d;
                let fixed: Vec<String> = mode
                    .fixed
                    .iter()
                    .map(|(i, e)| format!("{} = {e}", m.inputs[*i].name))
                    .chain(mode.coupled.iter().map(|(s, e)| {
                        invsim_inversion::render::coupling_text(&d.model.states[*s].name, e)
                    }))
                    .collect();
                s.push_str(&invsim_inversion::render::mode_heading(
                    &mode.name,
                    mode.role.as_str(),
                    &m.inputs[mode.free].name,
                    &fixed,
                ));
                s.push_str(&if f == crate::derive_format::Format::Markdown {
                    d.to_markdown()
                } else {
                    d.to_text()
                });
            }
            s
        }
    };
    print_stdout(&text)
}

/// The options of `simulate` a modal run uses.
pub struct ModalRun<'a> {
    pub model: &'a Path,
    pub cycle: &'a str,
    pub max_cycle_bytes: u64,
    pub lookahead: f64,
    pub dt: f64,
    pub set: &'a [String],
    pub out: Option<&'a Path>,
    pub summary_json: Option<&'a Path>,
    pub plot: &'a crate::plotting::PlotArgs,
    pub verify: bool,
    pub switching: Switching,
    pub transition_time: Option<f64>,
    pub engine: crate::engine::EngineChoice,
    /// `--signal NAME=FILE.csv|VALUE` as given.
    pub signals: &'a [String],
    /// `--map NAME=FILE.csv` as given.
    pub maps: &'a [String],
    /// The command's options for the summary's provenance (`provenance::options_of`).
    pub options: serde_json::Map<String, serde_json::Value>,
}

fn gear_source(m: &ModalModel, cycle: &Cycle, spec: &str) -> Result<(usize, GearSource), Failure> {
    let Some(g) = &m.gearbox else {
        return Ok((1, GearSource::Fixed));
    };
    let src = match &g.schedule {
        Schedule::Speed { up, down } => GearSource::Speed { up: up.clone(), down: down.clone() },
        Schedule::Regulation => GearSource::Table(gears::regulation_table(&cycle.name).ok_or_else(|| {
            Failure::user(format!(
                "{}: the regulation's gear prescription exists for the built-in ece, eudc and nedc, not for `{}`",
                m.file.display(),
                cycle.name
            ))
        })?),
        Schedule::Column(c) => {
            if crate::cycle_spec::is_builtin(spec) {
                return Err(Failure::user(format!(
                    "{}: the gearbox takes the gear from the cycle file's column `{c}`, but `{spec}` is a built-in cycle",
                    m.file.display()
                )));
            }
            GearSource::Table(
                gears::column_table(Path::new(spec), c).map_err(|e| Failure::user(format!("{spec}: {e}")))?,
            )
        }
    };
    Ok((g.gears, src))
}

/// A model with modes ready to run: its modes compiled or derived and interpreted (with the `--set`
/// overrides), and the gearbox's schedule for the cycle.
pub struct Prepared {
    pub model: ModalModel,
    pub modes: Vec<invsim_inversion::ModeHeader>,
    pub interps: Vec<Box<dyn InverseModel>>,
    /// `compiled` or `interpreted`.
    pub engine: &'static str,
    pub gears: (usize, GearSource),
}

/// Load every mode of `read` with `engine` for a run on `cycle` (`cycle_spec` as given), with `set` and
/// `maps` (`--map`) applied.
pub fn prepare(
    read: ModalRead,
    cycle: &Cycle,
    cycle_spec: &str,
    (set, maps): (&[String], &[String]),
    engine: crate::engine::EngineChoice,
) -> Result<Prepared, Failure> {
    let gears = gear_source(read.model(), cycle, cycle_spec)?;
    let (m, loaded) = match read {
        ModalRead::Full(mut m) => {
            let loaded = crate::modal_engine::load_modes(&mut m, engine)?;
            (m, loaded)
        }
        ModalRead::Compiled(m, loaded) => (m, loaded),
    };
    let mut interps = loaded.models;
    for s in set {
        let (name, value) = crate::engine::parse_set(s)?;
        if m.gearbox
            .as_ref()
            .is_some_and(|g| g.parameters.iter().any(|(p, _)| *p == name))
        {
            return Err(Failure::user(format!(
                "--set {name}: `{name}` is set per gear by the model's [gearbox]; change its values there"
            )));
        }
        for i in interps.iter_mut() {
            i.set_param(&name, value)
                .map_err(|e| Failure::user(format!("--set {name}: {e}")))?;
        }
    }
    crate::map_args::apply(maps, |name, data| {
        set_map_in_modes(&mut interps, name, data)
    })?;
    Ok(Prepared {
        model: m,
        modes: loaded.meta,
        interps,
        engine: loaded.engine,
        gears,
    })
}

/// `--map NAME=…` for a model with modes: every mode whose equations use the map takes the new data
/// (modes are derived apart, so a mode that never calls the map has none); a name no mode knows is refused
/// with the first mode's list of maps.
fn set_map_in_modes(
    interps: &mut [Box<dyn InverseModel>],
    name: &str,
    data: crate::map_args::MapData<'_>,
) -> Result<(), invsim_model_api::ModelError> {
    let mut unknown = None;
    let mut applied = false;
    for i in interps.iter_mut() {
        match i.set_map(name, data) {
            Ok(()) => applied = true,
            Err(e @ invsim_model_api::ModelError::UnknownMap { .. }) => {
                unknown.get_or_insert(e);
            }
            Err(e) => return Err(e),
        }
    }
    match unknown {
        Some(e) if !applied => Err(e),
        _ => Ok(()),
    }
}

/// The runtime's spec of a prepared model.
pub fn spec(p: &Prepared) -> ModalSpec<'_> {
    let m = &p.model;
    let n_fixed = m.inputs.len() - 1;
    let n_outputs = p.interps[0].info().outputs.len() - n_fixed - p.modes[0].coupled.len();
    let modes: Vec<ModeSpec<'_>> = p
        .modes
        .iter()
        .zip(&p.interps)
        .map(|(mode, i)| {
            let outs = &i.info().outputs;
            let fixed_outputs = mode
                .fixed
                .iter()
                .filter_map(|(j, _)| {
                    let name = &m.inputs[*j].name;
                    outs.iter().rposition(|o| &o.name == name).map(|o| (*j, o))
                })
                .collect();
            let coupled = mode
                .coupled
                .iter()
                .filter_map(|(s, _)| {
                    let name = invsim_inversion::coupling_name(&i.info().states[*s]);
                    outs.iter().rposition(|o| o.name == name).map(|o| (*s, o))
                })
                .collect();
            ModeSpec {
                name: mode.name.clone(),
                family: mode.family.clone(),
                role: role_of(mode.role),
                gear: mode.gear,
                free_input: mode.free,
                fixed_outputs,
                coupled,
                model: i.as_ref(),
            }
        })
        .collect();
    ModalSpec {
        name: m.name.clone(),
        inputs: m
            .inputs
            .iter()
            .map(|i| InputSpec {
                name: i.name.clone(),
                unit: i.unit.clone(),
                min: i.min,
                max: i.max,
            })
            .collect(),
        modes,
        gears: p.gears.0,
        gear_source: p.gears.1.clone(),
        sequence: SequenceParams {
            standstill_below: m.sequence.standstill_below,
            standstill_above: m.sequence.standstill_above,
            brake_band: m.sequence.brake_band,
            min_dwell: m.sequence.min_dwell,
        },
        n_outputs,
    }
}

/// `invsim simulate` of a model with modes.
pub fn simulate(m: ModalRead, run: &ModalRun<'_>) -> Result<(), Failure> {
    let outputs = crate::outputs::Outputs::plan(
        &crate::engine::run_inputs(run.model, run.cycle),
        &[
            ("--out", run.out),
            ("--summary-json", run.summary_json),
            ("--plot", run.plot.plot.as_deref()),
        ],
    )?;
    let cycle = Cycle::load_with_limit(run.cycle, run.max_cycle_bytes)
        .map_err(|e| Failure::user(e.to_string()))?;
    let prepared = prepare(m, &cycle, run.cycle, (run.set, run.maps), run.engine)?;
    let spec = spec(&prepared);
    crate::plotting::check_modal(run.plot, &spec)?;
    let opts = ModalOptions {
        lookahead: run.lookahead,
        dt: run.dt,
        switching: run.switching,
        transition_time: run.transition_time,
        verify: run.verify,
    };
    let signals = crate::signal_args::parse_signals(run.signals)?;
    let mut result =
        invsim_runtime::modes::simulate_modes_with_signals(&spec, &cycle, &opts, &signals)
            .map_err(|e| {
                Failure::user(format!(
                    "simulation of `{}` on `{}` stopped: {e}",
                    run.model.display(),
                    cycle.name
                ))
            })?;
    result.summary.engine = prepared.engine.to_string();
    result.summary.provenance = Some(crate::provenance::record(crate::provenance::RunRecord {
        command: "simulate",
        model: run.model,
        info: prepared.interps[0].info(),
        cycle_spec: run.cycle,
        cycle: &cycle,
        sets: run.set,
        options: run.options.clone(),
    })?);
    let mut outputs = outputs;
    outputs.write("--out", |f| {
        output::write_table_csv(&result.columns, &result.data, f)
    })?;
    outputs.write("--summary-json", |f| output::write_json(&result.summary, f))?;
    crate::plotting::write(run.plot, &mut outputs, |vars| {
        invsim_runtime::plot::modal_simulation_figure(&result, &cycle, &spec, vars)
    })?;
    outputs.commit()?;
    print_stdout(&result.summary.to_text())
}
