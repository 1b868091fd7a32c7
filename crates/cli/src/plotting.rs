//! `--plot FILE.svg|FILE.png`, `--plot-vars` and the figure's `--size`, `--dpi` and `--window` of `simulate`
//! and `forward` (the figure options are `compare --plot`'s too): the options checked before the run (a bad
//! extension, panel name, size, resolution or window is a user error, exit 2, saying what is accepted) and
//! the figure written after it, with the run's headline result under its title.

use std::io::Write as _;
use std::path::{Path, PathBuf};

use invsim_model_api::ModelInfo;
use invsim_runtime::plot::{self, Figure, Layout, PlotError, PlotFormat};

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
    /// integral of an accumulated output), engine (the engine's operating points, models with an [engine]).
    /// Default: reference, the signals, the input(s), one cum: (the fuel used: in litres where the model has
    /// a fuel volume) and engine.
    #[arg(long, value_delimiter = ',', requires = "plot", value_name = "NAME,…")]
    pub plot_vars: Vec<String>,
    #[command(flatten)]
    #[serde(flatten)]
    pub figure: FigureArgs,
}

// The size, resolution and time window of a figure (`simulate`, `forward`, `compare`).
#[derive(clap::Args, Debug, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub struct FigureArgs {
    /// The figure's size, WIDTHxHEIGHT in pixels at 96 dpi (1200x800) or in inches (8x5in); width 400 … 8000,
    /// height 200 … 32768 pixels. Default: 1000 pixels wide, 200 pixels of plot per panel.
    #[arg(long, value_name = "WxH[in]", requires = "plot")]
    pub size: Option<String>,
    /// Resolution: the image has the size × DPI / 96 pixels, text and lines scaled alike (default 96;
    /// 24 … 1200; at most 32 768 000 pixels in all).
    #[arg(long, value_name = "DPI", requires = "plot")]
    pub dpi: Option<f64>,
    /// Draw only the seconds T0 … T1 of the run (T0 < T1, inside the run); each panel's scale comes from that
    /// part, the headline stays the whole run's.
    #[arg(
        long,
        value_name = "T0:T1",
        requires = "plot",
        allow_hyphen_values = true
    )]
    pub window: Option<String>,
}

impl FigureArgs {
    /// The layout of `--size` and `--dpi`.
    pub fn layout(&self) -> Result<Layout, Failure> {
        let size = self
            .size
            .as_deref()
            .map(plot::parse_size)
            .transpose()
            .map_err(user)?;
        Layout::new(size, self.dpi).map_err(user)
    }

    /// `--window`, if given.
    pub fn window(&self) -> Result<Option<(f64, f64)>, Failure> {
        self.window
            .as_deref()
            .map(plot::parse_window)
            .transpose()
            .map_err(user)
    }

    /// Check the options for a figure of the panels `names`; `span`: the run's time span where known before
    /// it (the cycle's).
    pub fn check(&self, names: &[String], span: Option<(f64, f64)>) -> Result<(), Failure> {
        let layout = self.layout()?;
        if let Some(height) = layout.height {
            let needed = plot::min_height(names);
            if height < needed {
                return Err(user(PlotError::TooLow {
                    height,
                    needed,
                    panels: names.len(),
                }));
            }
        }
        if let (Some(w), Some(span)) = (self.window()?, span) {
            plot::check_window(w, span).map_err(user)?;
        }
        Ok(())
    }

    /// `figure` with `headline` (the run's result) cut to the window, rendered for `path` (SVG or PNG by its
    /// extension).
    pub fn render(
        &self,
        path: &Path,
        mut figure: Figure,
        headline: Option<String>,
    ) -> Result<Vec<u8>, Failure> {
        let window = self.window()?;
        figure.headline = match (headline, window) {
            (Some(h), Some(_)) => Some(format!("{h} (whole run)")),
            (h, _) => h,
        };
        if let Some((t0, t1)) = window {
            figure = figure.windowed((t0, t1)).map_err(user)?;
            figure.x_label = format!("{} (window {t0} … {t1} s)", figure.x_label);
        }
        let format = PlotFormat::from_path(path).map_err(user)?;
        figure
            .render_with(format, &self.layout()?)
            .map_err(|e| match e {
                PlotError::Render(_) | PlotError::Write { .. } => {
                    Failure::io(format!("{}: {e}", path.display()))
                }
                e => user(e),
            })
    }
}

/// The time span of `cycle`.
pub fn span(cycle: &invsim_runtime::Cycle) -> Option<(f64, f64)> {
    Some((*cycle.time.first()?, *cycle.time.last()?))
}

/// Check the plot options against `info`'s model and the cycle's span before the run.
pub fn check(args: &PlotArgs, info: &ModelInfo, span: Option<(f64, f64)>) -> Result<(), Failure> {
    if let Some(path) = &args.plot {
        PlotFormat::from_path(path).map_err(user)?;
        plot::check_vars(info, &args.plot_vars).map_err(user)?;
        args.figure.check(
            &names_or(&args.plot_vars, || plot::default_vars(info)),
            span,
        )?;
    }
    Ok(())
}

/// Check the plot options of a model with operating modes before the run.
pub fn check_modal(
    args: &PlotArgs,
    spec: &invsim_runtime::modes::ModalSpec<'_>,
    span: Option<(f64, f64)>,
) -> Result<(), Failure> {
    if let Some(path) = &args.plot {
        PlotFormat::from_path(path).map_err(user)?;
        plot::check_modal_vars(spec, &args.plot_vars).map_err(user)?;
        let names = names_or(&args.plot_vars, || plot::modal_default_vars(spec));
        args.figure.check(&names, span)?;
    }
    Ok(())
}

/// The `--plot-vars` names, or the model's default panels.
fn names_or(vars: &[String], default: impl FnOnce() -> Vec<String>) -> Vec<String> {
    let given: Vec<String> = vars
        .iter()
        .filter(|v| !v.trim().is_empty())
        .cloned()
        .collect();
    if given.is_empty() {
        default()
    } else {
        given
    }
}

/// Write `figure` (built only when `--plot` was given) with the run's `headline` to the `--plot` file,
/// through `outputs` (a temporary file renamed into place when every output of the run is written).
pub fn write(
    args: &PlotArgs,
    outputs: &mut Outputs,
    figure: impl FnOnce(&[String]) -> Result<Figure, PlotError>,
    headline: impl FnOnce() -> Option<String>,
) -> Result<(), Failure> {
    let Some(path) = &args.plot else {
        return Ok(());
    };
    let figure = figure(&args.plot_vars).map_err(user)?;
    let bytes = args.figure.render(path, figure, headline())?;
    outputs.write("--plot", |mut f| f.write_all(&bytes))
}

/// A plot error as a user error (exit 2).
pub fn user(e: PlotError) -> Failure {
    Failure::user(e.to_string())
}
