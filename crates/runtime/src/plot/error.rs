//! Why a plot could not be drawn or written: a bad panel name, size, resolution or window (the user's, named
//! with its option), or a failure to render or write the file.

use thiserror::Error;

/// Why a plot could not be drawn or written.
#[derive(Debug, Error)]
pub enum PlotError {
    #[error("nothing to plot: the result has no samples")]
    Empty,
    #[error("cannot plot to {path}: the file name must end in .svg or .png")]
    Format { path: String },
    #[error("--plot-vars: unknown panel `{name}`; this model's panels are: {valid}")]
    UnknownVar { name: String, valid: String },
    #[error("--plot-vars: no panel given; this model's panels are: {valid}")]
    NoVars { valid: String },
    #[error(
        "--plot-vars: {given} panels, more than the {max} a plot draws (each panel is 200 pixels high); plot \
         fewer variables, or several plots"
    )]
    TooManyPanels { given: usize, max: usize },
    #[error("--size `{given}`: {why}")]
    Size { given: String, why: String },
    #[error("--dpi {given}: the resolution must be {min} … {max} dpi")]
    Dpi { given: f64, min: f64, max: f64 },
    #[error(
        "--size and --dpi: a {width}×{height}-pixel image exceeds the limit of {max} pixels; choose a smaller \
         size or resolution"
    )]
    TooManyPixels { width: f64, height: f64, max: f64 },
    #[error(
        "--size: a height of {height} pixels leaves too little for {panels} panel(s) (40 pixels of plot each); \
         give at least {needed} pixels, or fewer --plot-vars"
    )]
    TooLow {
        height: f64,
        needed: f64,
        panels: usize,
    },
    #[error("--window `{given}`: {why}")]
    Window { given: String, why: String },
    #[error("cannot draw the engine map ([engine] map): {0}")]
    EngineMap(String),
    #[error("cannot render the plot as PNG: {0}")]
    Render(String),
    #[error("cannot write the plot {path}: {message}")]
    Write { path: String, message: String },
}
