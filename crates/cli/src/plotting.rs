//! `--plot FILE.svg|FILE.png` and `--plot-vars` of `simulate` and `forward`: the options checked before the
//! run (a bad extension or panel name is a user error, exit 2, listing the valid names) and the figure written
//! after it.

use std::io::Write as _;
use std::path::{Path, PathBuf};

use invsim_model_api::ModelInfo;
use invsim_runtime::plot::{self, Figure, PlotError, PlotFormat};

use crate::error::Failure;
use crate::outputs::Outputs;

// The plot options shared by `simulate` and `forward` (serialised into the summary's provenance). No doc
// comment: clap would make it the command's about, over the one `main.rs` gives it (its arguments are built
// when the command runs).
#[derive(clap::Args, Debug, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub struct PlotArgs {
    /// Draw the run as SVG or PNG (chosen by the extension, .svg or .png).
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// The plot's panels, comma-separated: reference, input, any state, any [outputs] name, cum:NAME (running
    /// integral of an accumulated output). Default: reference, input and cum: of every accumulated output.
    #[arg(long, value_delimiter = ',', requires = "plot", value_name = "NAME,…")]
    pub plot_vars: Vec<String>,
}

/// Check the plot options against `info`'s model before the run.
pub fn check(args: &PlotArgs, info: &ModelInfo) -> Result<(), Failure> {
    if let Some(path) = &args.plot {
        PlotFormat::from_path(path).map_err(user)?;
        plot::check_vars(info, &args.plot_vars).map_err(user)?;
    }
    Ok(())
}

/// Check the plot options of a model with operating modes before the run.
pub fn check_modal(
    args: &PlotArgs,
    spec: &invsim_runtime::modes::ModalSpec<'_>,
) -> Result<(), Failure> {
    if let Some(path) = &args.plot {
        PlotFormat::from_path(path).map_err(user)?;
        plot::check_modal_vars(spec, &args.plot_vars).map_err(user)?;
    }
    Ok(())
}

/// Write `figure` (built only when `--plot` was given) to the `--plot` file, through `outputs` (a temporary
/// file renamed into place when every output of the run is written).
pub fn write(
    args: &PlotArgs,
    outputs: &mut Outputs,
    figure: impl FnOnce(&[String]) -> Result<Figure, PlotError>,
) -> Result<(), Failure> {
    let Some(path) = &args.plot else {
        return Ok(());
    };
    let bytes = render(path, figure(&args.plot_vars).map_err(user)?)?;
    outputs.write("--plot", |mut f| f.write_all(&bytes))
}

fn render(path: &Path, figure: Figure) -> Result<Vec<u8>, Failure> {
    let format = PlotFormat::from_path(path).map_err(user)?;
    figure
        .render(format)
        .map_err(|e| Failure::io(format!("{}: {e}", path.display())))
}

fn user(e: PlotError) -> Failure {
    Failure::user(e.to_string())
}
