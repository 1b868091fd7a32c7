//! `cargo xtask figures [--check]`: the SVG figures under `docs/figures/`, rendered from fresh runs.
//!
//! Figures come in groups, one module each; [`render_all`] calls every group in turn:
//!
//! * [`paper`] — the reproduction of Fröberg & Nielsen (IFAC AAC 2004): Fig. 4 (the kernel), Fig. 5 (ECE with a
//!   5 s look-ahead), Fig. 7 (NEDC, inverse vs forward simulation with a PI driver) and the effect of the
//!   look-ahead on the input and on fuel (see `docs/paper.md`).
//! * [`stable`] — the zero dynamics and their stable inversion: the driveline's resonance in the internal states,
//!   the diesel air path's stable inverse, causal blow-up and pre-actuation (see `docs/stable_inversion.md`).
//!
//! A group is a function `render(root, out) -> Result<Vec<PathBuf>, Failure>` that writes its SVGs into `out`
//! and returns their paths. `--check` renders every figure into a scratch directory under `target/` and fails
//! unless every group succeeds and every SVG is a non-empty, complete SVG document that also exists under
//! `docs/figures/`. The figures are not compared byte for byte: they come from floating-point runs whose last
//! digits may differ between platforms, and a figure is a picture, not a golden file.

pub mod paper;
pub mod stable;

use crate::{ensure_file_contents, Check, Failure};
use std::path::{Path, PathBuf};

/// Where the figures live, relative to the workspace root.
pub const FIGURES_DIR: &str = "docs/figures";

/// The command that regenerates the figures.
pub const COMMAND: &str = "cargo xtask figures";

/// Where `--check` renders (into a subdirectory per run), relative to the workspace root.
pub const CHECK_DIR: &str = "target/xtask-figures-check";

/// Render every figure group into `out`; returns the files written, in group order.
pub fn render_all(root: &Path, out: &Path) -> Result<Vec<PathBuf>, Failure> {
    std::fs::create_dir_all(out)
        .map_err(|e| Failure::io(format!("cannot create {}: {e}", out.display())))?;
    let mut written = Vec::new();
    // One line per group, in the order the figures are listed.
    written.extend(paper::render(root, out)?);
    written.extend(stable::render(root, out)?);
    Ok(written)
}

/// Regenerate the figures in `docs/figures/` (or with `check`, render them into a scratch directory and check
/// them); returns the files written.
pub fn run(root: &Path, check: bool) -> Result<Vec<PathBuf>, Failure> {
    if !check {
        return render_all(root, &root.join(FIGURES_DIR));
    }
    // A directory of its own for every check, so that concurrent checks (parallel tests) do not collide.
    static RUNS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let run = RUNS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let scratch = root
        .join(CHECK_DIR)
        .join(format!("{}-{run}", std::process::id()));
    if scratch.exists() {
        std::fs::remove_dir_all(&scratch)
            .map_err(|e| Failure::io(format!("cannot clear {}: {e}", scratch.display())))?;
    }
    let written = render_all(root, &scratch)?;
    let mut problems = Vec::new();
    if written.is_empty() {
        problems.push("no figure was rendered".to_string());
    }
    for path in &written {
        let name = path
            .file_name()
            .map(|f| f.to_string_lossy().into_owned())
            .unwrap_or_default();
        let text = match std::fs::read_to_string(path) {
            Ok(text) => text,
            Err(e) => {
                problems.push(format!("{name}: cannot read the rendered file ({e})"));
                continue;
            }
        };
        if !is_complete_svg(&text) {
            problems.push(format!("{name}: not a complete SVG document"));
        }
        let committed = root.join(FIGURES_DIR).join(&name);
        if let Err(f) = ensure_file_contents(&committed, &text, Check::Exists { command: COMMAND })
        {
            problems.push(f.message);
        }
    }
    if problems.is_empty() {
        Ok(written)
    } else {
        Err(Failure::check(problems.join("\n")))
    }
}

/// A non-empty SVG document: an `<svg` element that is closed, with something drawn in between.
pub fn is_complete_svg(text: &str) -> bool {
    let (Some(open), Some(close)) = (text.find("<svg"), text.rfind("</svg>")) else {
        return false;
    };
    if open >= close {
        return false;
    }
    let body = &text[open..close];
    body.contains("<polyline") || body.contains("<path")
}
