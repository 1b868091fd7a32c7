//! Loading a model file and choosing the engine that runs it: the one way the command line and the Python
//! package get from a path to something the runtime runs.
//!
//! [`load`] reads the file once and gives a [`Loaded`] model: without modes a [`SingleModel`] (compiled code
//! where the file is byte for byte a built-in model's, else the derivation's interpreter tape), with modes a
//! [`LoadedModal`] whose [`ModalPlant`](invsim_runtime::modes::ModalPlant) owns every mode's model (compiled
//! or derived and interpreted the same way). A file that matches compiled code is not derived at run time.
//!
//! Modules: `choice` (the engine asked for), `error`, `single` and `modal` (the two kinds of model),
//! `map_files` (the map CSV files a model file names, inputs of a run).

mod choice;
mod error;
mod map_files;
mod modal;
mod params;
mod single;

use std::path::Path;

use invsim_inversion::ModelFile;

pub use choice::EngineChoice;
pub use error::LoadError;
pub use invsim_inversion::Extent;
pub use map_files::map_files;
pub use modal::{derive_modes, modal_derive_json, DerivedMode, LoadedModal};
pub use single::SingleModel;

/// A model file loaded for runs.
pub enum Loaded {
    /// A model without modes.
    Single(SingleModel),
    /// A model with operating modes.
    Modal(Box<LoadedModal>),
}

impl Loaded {
    /// `"compiled"` or `"interpreted"`.
    pub fn engine_name(&self) -> &'static str {
        match self {
            Loaded::Single(m) => m.engine_name(),
            Loaded::Modal(m) => m.engine_name(),
        }
    }

    /// Set parameter `name` (every mode's, for a model with modes).
    pub fn set_param(&mut self, name: &str, value: f64) -> Result<(), LoadError> {
        let err = |reason: String| LoadError::Parameter {
            name: name.to_string(),
            reason,
        };
        match self {
            Loaded::Single(m) => m
                .as_model_mut()
                .set_param(name, value)
                .map_err(|e| err(e.to_string())),
            Loaded::Modal(m) => m
                .plant
                .set_param(name, value)
                .map_err(|e| err(e.to_string())),
        }
    }

    /// Replace a lookup map's grid and values (`--map NAME=FILE.csv`).
    pub fn set_map(
        &mut self,
        name: &str,
        data: (&[f64], Option<&[f64]>, &[f64]),
    ) -> Result<(), invsim_model_api::ModelError> {
        match self {
            Loaded::Single(m) => m.as_model_mut().set_map(name, data),
            Loaded::Modal(m) => m.plant.set_map(name, data),
        }
    }

    /// The model's lookup maps (of every mode, each once, for a model with modes).
    pub fn maps(&self) -> Vec<&invsim_model_api::map::Map> {
        match self {
            Loaded::Single(m) => m.as_model().maps().iter().collect(),
            Loaded::Modal(m) => m.plant.maps(),
        }
    }

    /// The model as the runtime runs it.
    pub fn into_plant(self) -> invsim_runtime::Plant {
        match self {
            Loaded::Single(SingleModel::Interpreted(m)) => invsim_runtime::Plant::Single(m),
            Loaded::Single(SingleModel::Compiled(m)) => invsim_runtime::Plant::Single(m),
            Loaded::Modal(m) => invsim_runtime::Plant::Modal(m.plant),
        }
    }

    /// The description of the model (of its first mode, for a model with modes: parameters, states and
    /// `[outputs]` are every mode's).
    pub fn info(&self) -> &invsim_model_api::ModelInfo {
        match self {
            Loaded::Single(m) => m.as_model().info(),
            Loaded::Modal(m) => m.plant.first().info(),
        }
    }
}

/// Load the model file at `path` with the engine `choice` asks for, for runs without a gradient
/// ([`load_to`] with [`Extent::Run`]).
pub fn load(path: &Path, choice: EngineChoice) -> Result<Loaded, LoadError> {
    load_to(path, choice, Extent::Run)
}

/// Load the model file at `path` with the engine `choice` asks for. A file whose bytes are a built-in model's
/// runs its compiled code (with `auto` or `compiled`) without being derived: it is byte for byte the file the
/// code was generated from, so its derivation succeeds and the compiled model carries everything the run
/// needs. Any other file is derived first (as far as `extent` asks: [`Extent::Full`] where a run will be
/// differentiated, for the closed-form Jacobians of the gradient), so a bad file gives the same error
/// whichever engine was asked for. The file is read once, through the reader's cap, so a pipe
/// (`<(cat m.toml)`) serves both.
pub fn load_to(path: &Path, choice: EngineChoice, extent: Extent) -> Result<Loaded, LoadError> {
    let bytes = invsim_inversion::read_model_file(path)?;
    load_source(path, &bytes, (choice, extent))
}

/// [`load_to`] of a model file given as its bytes (`path` names it in messages).
pub fn load_source(
    path: &Path,
    bytes: &[u8],
    (choice, extent): (EngineChoice, Extent),
) -> Result<Loaded, LoadError> {
    if choice != EngineChoice::Interpreted {
        if let Some(m) = compiled(path, bytes)? {
            return Ok(m);
        }
    }
    let file = ModelFile::from_bytes(path, bytes)?;
    from_file(file, path, (choice, extent))
}

/// The compiled code made from a file with exactly these bytes, with or without modes, if any.
fn compiled(path: &Path, bytes: &[u8]) -> Result<Option<Loaded>, LoadError> {
    if let Some(m) = single::builtin_of(bytes) {
        return Ok(Some(Loaded::Single(SingleModel::Compiled(m))));
    }
    Ok(modal::read_compiled(path, bytes)?.map(|m| Loaded::Modal(Box::new(m))))
}

/// The model file `file` (read from `path`) derived as far as `extent` asks, run by the engine `choice` asks
/// for.
fn from_file(
    file: ModelFile,
    path: &Path,
    (choice, extent): (EngineChoice, Extent),
) -> Result<Loaded, LoadError> {
    match file {
        ModelFile::Single(model) => {
            single::from_model(*model, path, (choice, extent)).map(Loaded::Single)
        }
        ModelFile::Modal(m) => {
            modal::from_model(*m, choice, extent).map(|m| Loaded::Modal(Box::new(m)))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use invsim_runtime::{Cycle, RunResult, SimulationOptions};

    /// An interpreted model loaded for runs ([`Extent::Run`]) has no closed-form Jacobians (a gradient takes
    /// the implicit function theorem's route); loaded for gradients ([`Extent::Full`]) every mode with internal
    /// dynamics has them; the two run the same run bit for bit.
    #[test]
    fn a_model_loaded_for_runs_runs_as_one_loaded_for_gradients() {
        let path = Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../models/si_engine_5speed.toml"
        ));
        let cycle = Cycle::builtin("udds").expect("built in");
        let opts = SimulationOptions::builder().dt(1.0).build().expect("valid");
        let mut data = Vec::new();
        for (extent, closed) in [(Extent::Run, false), (Extent::Full, true)] {
            let Loaded::Modal(m) = load_to(path, EngineChoice::Interpreted, extent).expect("loads")
            else {
                panic!("a model with modes")
            };
            for model in m.plant.models() {
                let info = model.info();
                let (r, ne) = (info.relative_degree, info.n_eta);
                let width = ne * (ne + r + 1 + info.parameters.len());
                let mut out = vec![0.0; width];
                let w = vec![0.0; info.n_w()];
                let (xi, eta) = (vec![5.0; r], vec![4.0e4; ne]);
                let has = model.zero_dynamics_jacobian(&xi, &eta, &w, 0.1, &mut out);
                assert_eq!(has, closed && ne > 0, "{extent:?}: mode {}", info.name);
            }
            let run = Loaded::Modal(m).into_plant().simulate(&cycle, None, &opts);
            let Ok(RunResult::Modal(result, _)) = run else {
                panic!("a run with modes")
            };
            data.push(result.data);
        }
        let same = |a: &[f64], b: &[f64]| a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits());
        assert!(data[0].iter().zip(&data[1]).all(|(a, b)| same(a, b)));
        assert!(!data[0].is_empty());
    }

    /// The coefficients A, b of zero dynamics affine in their one state (`zero_dynamics_affine`, one
    /// evaluation) reproduce η' = A η + b of `zero_dynamics` at several states within 1e-12 of |η'|'s terms,
    /// and the compiled modes give the interpreted ones' numbers within 1e-13, for both cars with gears; a
    /// mode whose dynamics are not affine has none.
    #[test]
    fn affine_zero_dynamics_coefficients_reproduce_the_zero_dynamics() {
        for file in ["si_engine_5speed", "ford_fusion_2012_dynamic_6speed"] {
            let path = Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("../../models")
                .join(format!("{file}.toml"));
            let plants = [EngineChoice::Interpreted, EngineChoice::Compiled].map(|c| {
                let Loaded::Modal(m) = load_to(&path, c, Extent::Run).expect("loads") else {
                    panic!("a model with modes")
                };
                m.plant
            });
            let mut affine = 0;
            for (mi, mc) in plants[0].models().zip(plants[1].models()) {
                let info = mi.info();
                let (r, ne) = (info.relative_degree, info.n_eta);
                let w = vec![0.01; info.n_w()];
                let (mut ai, mut ac) = ([0.0f64; 2], [0.0f64; 2]);
                let has = mi.zero_dynamics_affine(&vec![8.0; r], &w, 0.3, &mut ai);
                assert_eq!(
                    has,
                    info.zero_dynamics_affine && ne == 1,
                    "{file} {}",
                    info.name
                );
                assert_eq!(
                    has,
                    mc.zero_dynamics_affine(&vec![8.0; r], &w, 0.3, &mut ac)
                );
                if !has {
                    continue;
                }
                affine += 1;
                for (xi, yr) in [(3.0f64, 0.2f64), (12.0, -0.8), (25.0, 0.0)] {
                    let xi = vec![xi; r];
                    mi.zero_dynamics_affine(&xi, &w, yr, &mut ai);
                    mc.zero_dynamics_affine(&xi, &w, yr, &mut ac);
                    for (a, c) in ai.iter().zip(&ac) {
                        assert!(
                            (a - c).abs() <= 1e-13 * a.abs().max(1.0),
                            "{file}: {ai:?} {ac:?}"
                        );
                    }
                    for eta in [2.0e4f64, 5.5e4, 9.0e4] {
                        let mut q = [0.0f64];
                        mi.zero_dynamics(&xi, &[eta], &w, yr, &mut q);
                        let scale = (ai[0] * eta).abs() + ai[1].abs();
                        let off = (ai[0] * eta + ai[1] - q[0]).abs();
                        assert!(
                            off <= 1e-12 * scale,
                            "{file} {}: {off:e} of {scale:e}",
                            info.name
                        );
                    }
                }
            }
            assert!(affine > 0, "{file}: a mode with affine zero dynamics");
        }
    }
}
