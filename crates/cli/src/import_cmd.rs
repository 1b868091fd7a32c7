//! `invsim import fastsim VEHICLE.yaml [--out MODEL.toml]`: a FASTSim 3 vehicle file as an invsim model file
//! (the importer is the `invsim-import` crate); warnings on stderr, the model on stdout or into `--out`.

use crate::error::Failure;
use clap::Subcommand;
use std::path::PathBuf;

/// The formats `invsim import` reads, each a command of its own (built with `invsim`'s command tree, not
/// deferred with `import`'s arguments, so that clap's `help import fastsim` and the completions have them).
#[derive(Subcommand, Debug)]
pub enum ImportFormat {
    /// A FASTSim 3 vehicle file (YAML; conventional, battery-electric or hybrid-electric).
    Fastsim {
        /// The vehicle file, e.g. from `fastsim.Vehicle.from_resource(name).to_yaml()`.
        vehicle: PathBuf,
        /// Write the model here instead of stdout.
        #[arg(long)]
        out: Option<PathBuf>,
    },
}

pub fn run(format: &ImportFormat, warnings: crate::error::Warnings) -> Result<(), Failure> {
    let ImportFormat::Fastsim { vehicle, out } = format;
    // `--out` checked before anything is read: not the vehicle file (whatever the spelling), written through
    // a temporary file renamed into place (`crate::outputs`).
    let mut outputs = crate::outputs::Outputs::plan(
        &crate::inputs::Inputs::new().file("vehicle file", vehicle),
        &[("--out", out.as_deref())],
    )?;
    let shown = vehicle.display().to_string();
    let text = invsim_import::read_vehicle_file(vehicle)
        .map_err(|e| Failure::user(e.message_for(&shown)))?;
    let source = vehicle
        .file_name()
        .map_or(shown.clone(), |n| n.to_string_lossy().into_owned());
    let imported = invsim_import::import_fastsim(&text, &source)
        .map_err(|e| Failure::user(e.message_for(&shown)))?;
    let shown_warnings: Vec<String> = imported
        .warnings
        .iter()
        .map(|w| format!("{shown}: {w}"))
        .collect();
    warnings.emit(&shown_warnings)?;
    match out {
        Some(_) => {
            use std::io::Write;
            outputs.write("--out", |mut f| f.write_all(imported.model.as_bytes()))?;
            outputs.commit()
        }
        None => crate::files::print_stdout(&imported.model),
    }
}
