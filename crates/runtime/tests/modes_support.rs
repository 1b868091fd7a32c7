//! The modes of a model file derived and interpreted, and the `ModalSpec` that runs them (shared by the
//! `modes` tests and the `modes` benchmark).
#![allow(dead_code)]

use std::path::Path;

use invsim_inversion::{Derivation, Interpreter, ModalModel, ModeRole, ModelFile, Schedule};
use invsim_model_api::InverseModel;
use invsim_runtime::modes::{GearSource, InputSpec, ModalSpec, ModeSpec, Role, SequenceParams};

pub const W: &[f64] = &[];

/// The modes of a model file, derived and interpreted, with the meta data the spec needs.
/// A mode's name, family, gear, role, free input, fixed inputs and coupled states.
pub type Meta = (
    String,
    String,
    Option<usize>,
    ModeRole,
    usize,
    Vec<usize>,
    Vec<usize>,
);

pub struct Loaded {
    pub model: ModalModel,
    pub meta: Vec<Meta>,
    pub interps: Vec<Interpreter>,
}

pub fn load(file: &Path, text: &str) -> Loaded {
    load_edited(file, text, |_| ())
}

/// [`load`] with each mode's derivation changed by `edit` before it is interpreted.
pub fn load_edited(file: &Path, text: &str, edit: impl Fn(&mut Derivation)) -> Loaded {
    let ModelFile::Modal(m) = ModelFile::from_str(file, text).expect("the model reads") else {
        panic!("a model with modes")
    };
    let mut m = *m;
    let mut meta = Vec::new();
    let mut interps = Vec::new();
    for mode in std::mem::take(&mut m.modes) {
        let fixed = mode.fixed.iter().map(|(i, _)| *i).collect();
        meta.push((
            mode.name.clone(),
            mode.family.clone(),
            mode.gear,
            mode.role,
            mode.free,
            fixed,
            mode.coupled.iter().map(|(s, _)| *s).collect(),
        ));
        let mut d = Derivation::new(mode.model).expect("the mode derives");
        edit(&mut d);
        interps.push(Interpreter::new(&d).expect("the interpreter builds"));
    }
    Loaded {
        model: m,
        meta,
        interps,
    }
}

pub fn spec<'a>(l: &'a Loaded, gear_source: GearSource) -> ModalSpec<'a> {
    let n_fixed = l.model.inputs.len() - 1;
    let n_outputs = l.interps[0].info().outputs.len() - n_fixed - l.meta[0].6.len();
    let modes = l
        .meta
        .iter()
        .zip(&l.interps)
        .map(|((name, family, gear, role, free, fixed, coupled), i)| {
            let outs = &i.info().outputs;
            let coupled = coupled
                .iter()
                .map(|&s| {
                    let name = invsim_inversion::coupling_name(&i.info().states[s]);
                    let o = outs.iter().rposition(|o| o.name == name);
                    (s, o.expect("the coupling's output"))
                })
                .collect();
            ModeSpec {
                name: name.clone(),
                family: family.clone(),
                role: match role {
                    ModeRole::Traction => Role::Traction,
                    ModeRole::Brake => Role::Brake,
                    ModeRole::Standstill => Role::Standstill,
                },
                gear: *gear,
                free_input: *free,
                fixed_outputs: fixed
                    .iter()
                    .map(|j| {
                        let name = &l.model.inputs[*j].name;
                        (
                            *j,
                            outs.iter()
                                .rposition(|o| &o.name == name)
                                .expect("fixed input output"),
                        )
                    })
                    .collect(),
                coupled,
                model: i as &dyn InverseModel,
            }
        })
        .collect();
    let s = &l.model.sequence;
    ModalSpec {
        name: l.model.name.clone(),
        inputs: l
            .model
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
        gears: l.model.gearbox.as_ref().map_or(1, |g| g.gears),
        gear_source,
        sequence: SequenceParams {
            standstill_below: s.standstill_below,
            standstill_above: s.standstill_above,
            brake_band: s.brake_band,
            min_dwell: s.min_dwell,
        },
        n_outputs,
        hybrid: None,
    }
}

pub fn five_speed() -> Loaded {
    load_repo("models/si_engine_5speed.toml")
}

/// A model file of the repository (path relative to its root), read and loaded.
pub fn load_repo(rel: &str) -> Loaded {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .join(rel);
    let text = std::fs::read_to_string(&path).expect("the model file");
    load(&path, &text)
}

/// ∂f/∂x_j by Richardson-extrapolated central differences (error O(h^4)).
pub fn partial(f: &dyn Fn(&[f64]) -> f64, x: &[f64], j: usize) -> f64 {
    let h = 1e-3 * x[j].abs().max(1e-2);
    let d = |h: f64| {
        let (mut a, mut b) = (x.to_vec(), x.to_vec());
        a[j] += h;
        b[j] -= h;
        (f(&a) - f(&b)) / (2.0 * h)
    };
    (4.0 * d(h / 2.0) - d(h)) / 3.0
}

pub fn speed_schedule(l: &Loaded) -> GearSource {
    match &l.model.gearbox.as_ref().expect("a gearbox").schedule {
        Schedule::Speed { up, down } => GearSource::Speed {
            up: up.clone(),
            down: down.clone(),
        },
        other => panic!("a speed schedule, got {other:?}"),
    }
}
