//! `invsim import fastsim VEHICLE.yaml [--out MODEL.toml]`: a FASTSim 3 vehicle file as an invsim model file
//! (the importer is the `invsim-import` crate); warnings on stderr, the model on stdout or into `--out`.

use crate::error::Failure;
use clap::Subcommand;
use std::path::PathBuf;

/// The formats `invsim import` reads, each a command of its own (built with `invsim`'s command tree, not
/// deferred with `import`'s arguments, so that clap's `help import fastsim` and the completions have them).
#[derive(Subcommand, Debug)]
pub enum ImportFormat {
    /// A FASTSim 3 vehicle file (YAML; conventional or battery-electric).
    Fastsim {
        /// The vehicle file, e.g. from `fastsim.Vehicle.from_resource(name).to_yaml()`.
        vehicle: PathBuf,
        /// Write the model here instead of stdout.
        #[arg(long)]
        out: Option<PathBuf>,
    },
}

pub fn run(format: &ImportFormat) -> Result<(), Failure> {
    let ImportFormat::Fastsim { vehicle, out } = format;
    let shown = vehicle.display().to_string();
    let text = invsim_import::read_vehicle_file(vehicle)
        .map_err(|e| Failure::user(e.message_for(&shown)))?;
    let source = vehicle
        .file_name()
        .map_or(shown.clone(), |n| n.to_string_lossy().into_owned());
    let imported = invsim_import::import_fastsim(&text, &source)
        .map_err(|e| Failure::user(e.message_for(&shown)))?;
    for w in &imported.warnings {
        eprintln!("invsim: warning: {shown}: {w}");
    }
    match out {
        Some(path) => std::fs::write(path, &imported.model)
            .map_err(|e| Failure::user(format!("{}: cannot write: {e}", path.display()))),
        None => {
            use std::io::Write;
            std::io::stdout()
                .write_all(imported.model.as_bytes())
                .map_err(|e| Failure::user(format!("stdout: {e}")))
        }
    }
}
