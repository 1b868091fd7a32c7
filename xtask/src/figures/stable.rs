//! Figures of the zero dynamics and their stable inversion (Fröberg & Nielsen, IEEE TVT 57(3), 2008; Devasia,
//! Chen & Paden 1996), for `docs/stable_inversion.md`:
//!
//! * `driveline_resonance.svg` — `models/driveline.toml` on the first ECE-15 of the NEDC: the internal states of
//!   the (minimum-phase, lightly damped) zero dynamics; the shaft torsion follows the load, and after every
//!   change of acceleration the body rings on the tyre/suspension compliance at 2 Hz (body speed minus wheel
//!   speed), more with a short look-ahead (a = 1 s) than with the paper's a = 5 s;
//! * `diesel_stable_inversion.svg` — `models/diesel_gasflow.toml` (non-minimum phase): the boost demand from the
//!   first ECE-15 and the stable inverse (exhaust pressure η and VGT position), then forward (causal)
//!   integration of the same zero dynamics from the stable solution, 1 Pa off, leaving it within a fraction of
//!   a second, and the pre-actuation: the VGT moving before the boost demand does, around a fast demand step.
//!
//! The models run on the interpreter (so the figures follow the model files) on the output grid dt = 0.01 s;
//! long series are thinned to the minimum and maximum of each of [`BUCKETS`] time buckets.

use crate::{derive_relative, ensure_file_contents, Check, Failure};
use invsim_inversion::Interpreter;
use invsim_model_api::InverseModel;
use invsim_runtime::{simulate, Cycle, SimulationOptions, SimulationResult, Smoother};
use plotters::prelude::*;
use std::path::{Path, PathBuf};

/// The models, relative to the workspace root.
pub const DRIVELINE: &str = "models/driveline.toml";
pub const DIESEL: &str = "models/diesel_gasflow.toml";
/// Output step of the runs, s.
pub const DT: f64 = 0.01;
/// Series are thinned to the min and max of this many buckets.
pub const BUCKETS: usize = 1500;

const BLUE: RGBColor = RGBColor(0, 0, 200);
const RED: RGBColor = RGBColor(200, 0, 0);
const ORANGE: RGBColor = RGBColor(230, 140, 0);
const GREEN: RGBColor = RGBColor(0, 140, 60);

fn interpreted(root: &Path, rel: &str) -> Result<Interpreter, Failure> {
    let d = derive_relative(root, Path::new(rel))?;
    Interpreter::new(&d).map_err(|e| Failure::user(format!("{rel}: {e}")))
}

fn run(
    model: &dyn InverseModel,
    cycle: &Cycle,
    lookahead: f64,
    include_extension: bool,
) -> Result<SimulationResult, Failure> {
    let opts = SimulationOptions {
        lookahead,
        dt: DT,
        engine: "interpreted".into(),
        include_extension,
        ..Default::default()
    };
    simulate(model, cycle, &opts).map_err(|e| {
        Failure::io(format!(
            "inverse simulation of {} on {}: {e}",
            model.info().name,
            cycle.name
        ))
    })
}

fn column<'a>(res: &'a SimulationResult, name: &str) -> Result<&'a [f64], Failure> {
    res.column(name)
        .ok_or_else(|| Failure::io(format!("no column `{name}` in {:?}", res.columns)))
}

/// Render this group's figures into `out`; returns the files written.
pub fn render(root: &Path, out: &Path) -> Result<Vec<PathBuf>, Failure> {
    Ok(vec![driveline(root, out)?, diesel(root, out)?])
}

// --- drawing ---------------------------------------------------------------------------------------------

struct Series {
    label: String,
    color: RGBColor,
    width: u32,
    points: Vec<(f64, f64)>,
}

fn line(label: impl Into<String>, color: RGBColor, width: u32, points: Vec<(f64, f64)>) -> Series {
    Series {
        label: label.into(),
        color,
        width,
        points,
    }
}

struct Panel {
    title: String,
    y_desc: String,
    x_range: (f64, f64),
    /// Fixed y range, or `None` to fit the data.
    y_range: Option<(f64, f64)>,
    series: Vec<Series>,
}

fn draw_error(path: &Path, e: impl std::fmt::Display) -> Failure {
    Failure::io(format!("cannot draw {}: {e}", path.display()))
}

/// Draw `panels` stacked vertically, 1000 px wide and 330 px per panel.
fn draw(path: &Path, panels: &[Panel]) -> Result<PathBuf, Failure> {
    let mut svg = String::new();
    draw_into(&mut svg, (1000, 330 * panels.len() as u32), path, panels)?;
    ensure_file_contents(path, &svg, Check::Write)?;
    Ok(path.to_path_buf())
}

/// Draw `panels` into the SVG text `svg` of the given size (`path` names the figure in errors).
fn draw_into(
    svg: &mut String,
    size: (u32, u32),
    path: &Path,
    panels: &[Panel],
) -> Result<(), Failure> {
    let root = SVGBackend::with_string(svg, size).into_drawing_area();
    root.fill(&WHITE).map_err(|e| draw_error(path, e))?;
    for (panel, area) in panels.iter().zip(&root.split_evenly((panels.len(), 1))) {
        let (lo, hi) = panel.y_range.unwrap_or_else(|| {
            let (lo, hi) = panel
                .series
                .iter()
                .flat_map(|s| s.points.iter().map(|p| p.1))
                .filter(|v| v.is_finite())
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                    (lo.min(v), hi.max(v))
                });
            let (lo, hi) = if lo < hi {
                (lo, hi)
            } else {
                (lo - 1.0, lo + 1.0)
            };
            let pad = 0.06 * (hi - lo);
            (lo - pad, hi + pad)
        });
        let mut chart = ChartBuilder::on(area)
            .caption(&panel.title, ("sans-serif", 17))
            .margin(12)
            .x_label_area_size(36)
            .y_label_area_size(70)
            .build_cartesian_2d(panel.x_range.0..panel.x_range.1, lo..hi)
            .map_err(|e| draw_error(path, e))?;
        chart
            .configure_mesh()
            .x_desc("t [s]")
            .y_desc(panel.y_desc.as_str())
            .draw()
            .map_err(|e| draw_error(path, e))?;
        for s in &panel.series {
            let color = s.color;
            // Points outside the y range are cut (a diverging run leaves the chart).
            let pts: Vec<(f64, f64)> = s
                .points
                .iter()
                .copied()
                .filter(|p| p.1.is_finite() && p.1 >= lo && p.1 <= hi)
                .collect();
            chart
                .draw_series(LineSeries::new(pts, color.stroke_width(s.width)))
                .map_err(|e| draw_error(path, e))?
                .label(s.label.as_str())
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 22, y)], color.stroke_width(2))
                });
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .position(SeriesLabelPosition::UpperLeft)
            .draw()
            .map_err(|e| draw_error(path, e))?;
    }
    root.present().map_err(|e| draw_error(path, e))
}

/// Points (t_k, scale·v_k) for t_k in [t0, t1], thinned to the min and max of each of [`BUCKETS`] buckets.
fn thin(t: &[f64], v: &[f64], scale: f64, (t0, t1): (f64, f64)) -> Vec<(f64, f64)> {
    let idx: Vec<usize> = (0..t.len().min(v.len()))
        .filter(|&k| t[k] >= t0 && t[k] <= t1)
        .collect();
    if idx.len() <= 2 * BUCKETS {
        return idx.iter().map(|&k| (t[k], scale * v[k])).collect();
    }
    let mut out = Vec::with_capacity(2 * BUCKETS);
    for b in 0..BUCKETS {
        let bucket = &idx[b * idx.len() / BUCKETS..(b + 1) * idx.len() / BUCKETS];
        let lo = *bucket
            .iter()
            .min_by(|&&i, &&j| v[i].total_cmp(&v[j]))
            .unwrap_or(&bucket[0]);
        let hi = *bucket
            .iter()
            .max_by(|&&i, &&j| v[i].total_cmp(&v[j]))
            .unwrap_or(&bucket[0]);
        for k in if lo <= hi { [lo, hi] } else { [hi, lo] } {
            out.push((t[k], scale * v[k]));
        }
    }
    out
}

// --- the figures -------------------------------------------------------------------------------------------

/// The driveline's zero dynamics on the first ECE-15: shaft torsion and the body's ringing.
fn driveline(root: &Path, out: &Path) -> Result<PathBuf, Failure> {
    let d = derive_relative(root, Path::new(DRIVELINE))?;
    let model = Interpreter::new(&d).map_err(|e| Failure::user(format!("{DRIVELINE}: {e}")))?;
    // The lightly damped pair at the nominal speed (invsim derive's classification).
    let nominal = d.classify();
    let pair = nominal
        .eigenvalues
        .iter()
        .find(|e| e[1] > 0.0)
        .copied()
        .unwrap_or([0.0; 2]);
    let zeta = -pair[0] / pair[0].hypot(pair[1]);
    let nedc = Cycle::builtin("nedc").ok_or_else(|| Failure::io("no built-in NEDC"))?;
    let (slow, fast) = (
        run(&model, &nedc, 5.0, false)?,
        run(&model, &nedc, 1.0, false)?,
    );
    let range = (0.0, 195.0);
    let zoom = (15.5, 21.0);
    let (v, y) = (column(&fast, "eta3")?, column(&fast, "yd_0")?);
    let slip: Vec<f64> = v.iter().zip(y).map(|(v, y)| v - y).collect();
    let speed = Panel {
        title: "driveline, first ECE-15 of the NEDC: reference (wheel speed) and body speed η3, a = 1 s".into(),
        y_desc: "speed [km/h]".into(),
        x_range: range,
        y_range: None,
        series: vec![
            line("reference v_w = y_d", BLUE, 2, thin(fast.time(), y, 3.6, range)),
            line("body speed η3", RED, 1, thin(fast.time(), v, 3.6, range)),
        ],
    };
    let torsion = Panel {
        title: "drive-shaft torsion η1 = θ_s: follows the load, smoothly with a = 5 s, sharply with a = 1 s".into(),
        y_desc: "θ_s [mrad]".into(),
        x_range: range,
        y_range: None,
        series: vec![
            line("a = 5 s", BLUE, 2, thin(slow.time(), column(&slow, "eta1")?, 1e3, range)),
            line("a = 1 s", RED, 1, thin(fast.time(), column(&fast, "eta1")?, 1e3, range)),
        ],
    };
    let ringing = Panel {
        title: format!(
            "zoom, a = 1 s: after the first acceleration the body rings on the tyre/suspension compliance, \
             {:.2} Hz, damping ratio {zeta:.3}",
            pair[1] / (2.0 * std::f64::consts::PI)
        ),
        y_desc: "η3 − y_d [mm/s]".into(),
        x_range: zoom,
        y_range: None,
        series: vec![line("body speed − wheel speed", RED, 2, thin(fast.time(), &slip, 1e3, zoom))],
    };
    let shaft = Panel {
        title: "zoom, a = 1 s: the shaft torsion carries the same resonance".into(),
        y_desc: "θ_s [mrad]".into(),
        x_range: (16.5, 21.0),
        y_range: None,
        series: vec![line(
            "θ_s",
            BLUE,
            2,
            thin(fast.time(), column(&fast, "eta1")?, 1e3, (16.5, 21.0)),
        )],
    };
    draw(
        &out.join("driveline_resonance.svg"),
        &[speed, torsion, ringing, shaft],
    )
}

/// The diesel air path: the stable inverse, the causal blow-up, and the pre-actuation.
fn diesel(root: &Path, out: &Path) -> Result<PathBuf, Failure> {
    let model = interpreted(root, DIESEL)?;
    let ece = Cycle::builtin("ece").ok_or_else(|| Failure::io("no built-in ECE"))?;
    let res = run(&model, &ece, 5.0, false)?;
    let range = (0.0, 195.0);
    let (t, eta, u) = (res.time(), column(&res, "eta1")?, res.input());
    let lambda = res
        .summary
        .zero_dynamics_eigenvalues
        .first()
        .map_or(f64::NAN, |e| e[0]);
    let boost = Panel {
        title: format!(
            "diesel_gasflow on the ECE-15 (boost demand 1.3 bar + 40 mbar per m/s): non-minimum phase, zero at +{lambda:.0}/s"
        ),
        y_desc: "pressure [bar]".into(),
        x_range: range,
        y_range: None,
        series: vec![
            line("boost demand p_im = y_d", BLUE, 2, thin(t, res.yd(0).unwrap_or(&[]), 1e-5, range)),
            line("exhaust pressure p_em = η (stable inverse)", RED, 1, thin(t, eta, 1e-5, range)),
        ],
    };
    let input = Panel {
        title: "VGT position from the stable inverse".into(),
        y_desc: "u_vgt [-]".into(),
        x_range: range,
        y_range: None,
        series: vec![line("u_vgt", GREEN, 2, thin(t, u, 1.0, range))],
    };

    // Causal: RK4 of the zero dynamics from the stable solution at t_c, 1 Pa off.
    let t_c = 16.0;
    let smoother = Smoother::new(&ece, 5.0)
        .map_err(|e| Failure::io(e.to_string()))?
        .with_reference(model.reference());
    let q = |t: f64, e: f64| {
        let mut y = [0.0; 3];
        smoother.eval(t, &mut y);
        let mut d = [0.0];
        model.zero_dynamics(&y[..2], &[e], &[], y[2], &mut d);
        d[0]
    };
    let k_c = t.iter().position(|&x| x >= t_c).unwrap_or(0);
    let (h, mut tt, mut e) = (1e-3, t[k_c], eta[k_c] + 1.0);
    let mut causal = vec![(tt, e * 1e-5)];
    while tt < t_c + 2.0 && e.is_finite() && e.abs() < 1e7 {
        let k1 = q(tt, e);
        let k2 = q(tt + h / 2.0, e + h / 2.0 * k1);
        let k3 = q(tt + h / 2.0, e + h / 2.0 * k2);
        let k4 = q(tt + h, e + h * k3);
        e += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
        tt += h;
        causal.push((tt, e * 1e-5));
    }
    let zoom = (t_c - 0.2, t_c + 2.0);
    let stable_zoom = thin(t, eta, 1e-5, zoom);
    let (lo, hi) = stable_zoom
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
            (a.min(p.1), b.max(p.1))
        });
    let blowup = Panel {
        title: format!("causal integration of the same zero dynamics from t = {t_c} s, 1 Pa off: it leaves at e^({lambda:.0}·t)"),
        y_desc: "p_em [bar]".into(),
        x_range: zoom,
        y_range: Some((lo - 0.3, hi + 0.3)),
        series: vec![
            line("stable inverse (bounded)", RED, 2, stable_zoom),
            line("causal, forward from the stable solution + 1 Pa", ORANGE, 2, causal),
        ],
    };

    // Pre-actuation: a fast demand step from 1.7 to 2.5 bar, short look-ahead, extended grid kept.
    let step = Cycle {
        tolerance: invsim_runtime::cycle::Tolerance::EPA,
        name: "boost step".into(),
        time: vec![0.0, 5.0, 5.5, 10.0],
        speed: vec![10.0, 10.0, 30.0, 30.0],
        grade: None,
        columns: Vec::new(),
    };
    let pre = run(&model, &step, 0.25, true)?;
    let window = (4.0, 6.0);
    let (tp, up, yp) = (pre.time(), pre.input(), pre.yd(0).unwrap_or(&[]));
    // Normalise both to [0, 1] over the window so that the lead of the input shows.
    let norm = |v: &[f64]| -> Vec<f64> {
        let (a, b) = (
            v.first().copied().unwrap_or(0.0),
            v.last().copied().unwrap_or(1.0),
        );
        v.iter().map(|x| (x - a) / (b - a)).collect()
    };
    let preact = Panel {
        title: "pre-actuation: demand step 1.7 → 2.5 bar (a = 0.25 s); the VGT moves before the demand does".into(),
        y_desc: "normalised [-]".into(),
        x_range: window,
        y_range: None,
        series: vec![
            line("boost demand y_d", BLUE, 2, thin(tp, &norm(yp), 1.0, window)),
            line("VGT position u_vgt (stable inverse)", GREEN, 2, thin(tp, &norm(up), 1.0, window)),
        ],
    };
    draw(
        &out.join("diesel_stable_inversion.svg"),
        &[boost, input, blowup, preact],
    )
}
