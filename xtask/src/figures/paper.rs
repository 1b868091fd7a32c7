//! The figures of Fröberg & Nielsen (IFAC AAC 2004) reproduced with invsim, for `docs/paper.md`:
//!
//! * `fig4_kernel.svg` — the kernel g(t) = exp(−a²/(a² − t²)) of eq. 33–35 for a = 1 s, and its normalised
//!   form g/C;
//! * `fig5_ece_smoothing.svg` — the ECE-15 cycle and its smoothed version for a look-ahead of a = 5 s;
//! * `fig7_nedc_inverse_vs_forward.svg` — the NEDC: air mass flow past the throttle and vehicle speed, from the
//!   inverse simulation and from a forward simulation with the PI driver (bounds ignored, as in the inverse);
//! * `fig7_first_ece_detail.svg` — the same for the first ECE-15 (0–195 s), where the curves can be told apart;
//! * `lookahead_effect.svg` — the effect of the look-ahead a ∈ {1, 2, 5, 10} s on the input (first ECE-15) and
//!   on the fuel over the NEDC.
//!
//! The model is `models/si_engine.toml`, run by the interpreter (so the figures follow the model file), on
//! the output grid dt = 0.01 s; long series are thinned to the minimum and maximum of each of
//! [`BUCKETS`] time buckets for drawing.

use crate::{derive_relative, ensure_file_contents, Check, Failure};
use invsim_inversion::Interpreter;
use invsim_model_api::InverseModel;
use invsim_runtime::forward::{self, ForwardOptions, ForwardResult};
use invsim_runtime::{simulate, Cycle, Kernel, SimulationOptions, SimulationResult, Smoother};
use plotters::prelude::*;
use std::path::{Path, PathBuf};

/// The model of the paper, relative to the workspace root.
pub const MODEL: &str = "models/si_engine.toml";
/// Output step of the runs behind the figures, s.
pub const DT: f64 = 0.01;
/// Look-ahead times of the look-ahead figure, s.
pub const LOOKAHEADS: [f64; 4] = [1.0, 2.0, 5.0, 10.0];
/// Series are thinned to the min and max of this many buckets.
pub const BUCKETS: usize = 1500;

const KMH: f64 = 3.6;
const GPS: f64 = 1e3;
const ORANGE: RGBColor = RGBColor(230, 140, 0);
const DARK_GREEN: RGBColor = RGBColor(0, 140, 60);

/// The SI-engine model of the paper, interpreted from the model file.
pub fn model(root: &Path) -> Result<Interpreter, Failure> {
    let d = derive_relative(root, Path::new(MODEL))?;
    Interpreter::new(&d).map_err(|e| Failure::user(format!("{MODEL}: {e}")))
}

fn builtin(name: &str) -> Result<Cycle, Failure> {
    Cycle::builtin(name).ok_or_else(|| Failure::io(format!("no built-in cycle `{name}`")))
}

/// The inverse simulation of `model` on `cycle` with look-ahead `a`.
pub fn inverse(
    model: &dyn InverseModel,
    cycle: &Cycle,
    a: f64,
) -> Result<SimulationResult, Failure> {
    let opts = SimulationOptions {
        lookahead: a,
        dt: DT,
        engine: "interpreted".into(),
        ..Default::default()
    };
    simulate(model, cycle, &opts)
        .map_err(|e| Failure::io(format!("inverse simulation on {}: {e}", cycle.name)))
}

/// The forward simulation of `model` on `cycle` with the default PI driver, bounds ignored.
pub fn forward_run(model: &dyn InverseModel, cycle: &Cycle) -> Result<ForwardResult, Failure> {
    let opts = ForwardOptions {
        dt: DT,
        engine: "interpreted".into(),
        ..Default::default()
    };
    forward::forward(model, cycle, &opts)
        .map_err(|e| Failure::io(format!("forward simulation on {}: {e}", cycle.name)))
}

/// Render this group's figures into `out`; returns the files written.
pub fn render(root: &Path, out: &Path) -> Result<Vec<PathBuf>, Failure> {
    let model = model(root)?;
    let nedc = builtin("nedc")?;
    let ece = builtin("ece")?;
    let mut written = Vec::new();

    written.push(fig4_kernel(out)?);
    written.push(fig5_ece(out, &ece)?);

    let inv = inverse(&model, &nedc, 5.0)?;
    let fwd = forward_run(&model, &nedc)?;
    written.push(fig7(
        out,
        "fig7_nedc_inverse_vs_forward.svg",
        "NEDC",
        &nedc,
        &inv,
        &fwd,
        None,
    )?);
    written.push(fig7(
        out,
        "fig7_first_ece_detail.svg",
        "first ECE-15 of the NEDC",
        &nedc,
        &inv,
        &fwd,
        Some(195.0),
    )?);

    let mut runs = Vec::new();
    for a in LOOKAHEADS {
        runs.push((a, inverse(&model, &nedc, a)?));
    }
    written.push(lookahead(out, &runs, &fwd)?);
    Ok(written)
}

// --- drawing ---------------------------------------------------------------------------------------------

/// One line of a chart.
struct Series {
    label: String,
    color: RGBColor,
    width: u32,
    points: Vec<(f64, f64)>,
    markers: bool,
}

impl Series {
    fn line(
        label: impl Into<String>,
        color: RGBColor,
        width: u32,
        points: Vec<(f64, f64)>,
    ) -> Series {
        Series {
            label: label.into(),
            color,
            width,
            points,
            markers: false,
        }
    }
}

/// One panel: title, axis labels, series, the x range (the y range is fitted).
struct Panel {
    title: String,
    x_desc: String,
    y_desc: String,
    x_range: (f64, f64),
    series: Vec<Series>,
    legend: SeriesLabelPosition,
}

fn draw_error(path: &Path, e: impl std::fmt::Display) -> Failure {
    Failure::io(format!("cannot draw {}: {e}", path.display()))
}

/// Draw `panels` stacked vertically into an SVG of width 1000 and 380 px per panel.
fn draw(path: &Path, panels: &[Panel]) -> Result<PathBuf, Failure> {
    let height = 380 * panels.len() as u32;
    let mut svg = String::new();
    draw_into(&mut svg, (1000, height), path, panels)?;
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
    let areas = root.split_evenly((panels.len(), 1));
    for (panel, area) in panels.iter().zip(&areas) {
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
        let mut chart = ChartBuilder::on(area)
            .caption(&panel.title, ("sans-serif", 18))
            .margin(12)
            .x_label_area_size(38)
            .y_label_area_size(64)
            .build_cartesian_2d(panel.x_range.0..panel.x_range.1, (lo - pad)..(hi + pad))
            .map_err(|e| draw_error(path, e))?;
        chart
            .configure_mesh()
            .x_desc(panel.x_desc.as_str())
            .y_desc(panel.y_desc.as_str())
            .draw()
            .map_err(|e| draw_error(path, e))?;
        for s in &panel.series {
            let style = s.color.stroke_width(s.width);
            let color = s.color;
            chart
                .draw_series(LineSeries::new(s.points.iter().copied(), style))
                .map_err(|e| draw_error(path, e))?
                .label(s.label.as_str())
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 22, y)], color.stroke_width(2))
                });
            if s.markers {
                chart
                    .draw_series(s.points.iter().map(|&p| Circle::new(p, 4, color.filled())))
                    .map_err(|e| draw_error(path, e))?;
            }
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .position(panel.legend.clone())
            .draw()
            .map_err(|e| draw_error(path, e))?;
    }
    root.present().map_err(|e| draw_error(path, e))
}

/// Points (t_k, scale·v_k) with t_k in [t0, t1], thinned to the min and max of each of [`BUCKETS`] buckets.
fn thin(t: &[f64], v: &[f64], scale: f64, (t0, t1): (f64, f64)) -> Vec<(f64, f64)> {
    let idx: Vec<usize> = (0..t.len().min(v.len()))
        .filter(|&k| t[k] >= t0 && t[k] <= t1)
        .collect();
    if idx.len() <= 2 * BUCKETS {
        return idx.iter().map(|&k| (t[k], scale * v[k])).collect();
    }
    let mut out = Vec::with_capacity(2 * BUCKETS + 1);
    for b in 0..BUCKETS {
        let bucket = &idx[b * idx.len() / BUCKETS..(b + 1) * idx.len() / BUCKETS];
        let (mut lo, mut hi) = (bucket[0], bucket[0]);
        for &k in bucket {
            if v[k] < v[lo] {
                lo = k;
            }
            if v[k] > v[hi] {
                hi = k;
            }
        }
        let (first, second) = if lo <= hi { (lo, hi) } else { (hi, lo) };
        out.push((t[first], scale * v[first]));
        if second != first {
            out.push((t[second], scale * v[second]));
        }
    }
    out
}

/// The raw cycle between t0 and t1, at its own breakpoints, in km/h.
fn raw_cycle(cycle: &Cycle, (t0, t1): (f64, f64)) -> Vec<(f64, f64)> {
    let mut pts = vec![(t0, cycle.speed_at(t0) * KMH)];
    pts.extend(
        cycle
            .time
            .iter()
            .zip(&cycle.speed)
            .filter(|(&t, _)| t > t0 && t < t1)
            .map(|(&t, &v)| (t, v * KMH)),
    );
    pts.push((t1, cycle.speed_at(t1) * KMH));
    pts
}

fn column<'a>(columns: &[String], data: &'a [Vec<f64>], name: &str) -> Result<&'a [f64], Failure> {
    columns
        .iter()
        .position(|c| c == name)
        .map(|i| data[i].as_slice())
        .ok_or_else(|| Failure::io(format!("no column `{name}` in {columns:?}")))
}

// --- the figures -------------------------------------------------------------------------------------------

/// Fig. 4: g(t) = exp(−a²/(a² − t²)) for a = 1 (peak 1/e), and g/C, C = 0.443 994 a.
fn fig4_kernel(out: &Path) -> Result<PathBuf, Failure> {
    let kernel = Kernel::new(1.0);
    let c = kernel.normalisation();
    let t: Vec<f64> = (0..=600).map(|i| -1.5 + 3.0 * i as f64 / 600.0).collect();
    let g: Vec<(f64, f64)> = t.iter().map(|&t| (t, c * kernel.value(t))).collect();
    let k: Vec<(f64, f64)> = t.iter().map(|&t| (t, kernel.value(t))).collect();
    let panel = Panel {
        title: "Fig. 4: the kernel g(t) = exp(-a²/(a² - t²)), |t| < a, for a = 1 s".into(),
        x_desc: "t [s]".into(),
        y_desc: "g(t)".into(),
        x_range: (-1.5, 1.5),
        series: vec![
            Series::line("g(t)", RGBColor(0, 0, 0), 2, g),
            Series::line(format!("g(t)/C, C = {c:.6}"), RGBColor(200, 0, 0), 1, k),
        ],
        legend: SeriesLabelPosition::UpperRight,
    };
    draw(&out.join("fig4_kernel.svg"), &[panel])
}

/// Fig. 5: the ECE-15 and its smoothed version y_d for a = 5 s.
fn fig5_ece(out: &Path, ece: &Cycle) -> Result<PathBuf, Failure> {
    let smoother = Smoother::new(ece, 5.0).map_err(|e| Failure::io(e.to_string()))?;
    let range = (0.0, ece.duration());
    let yd: Vec<(f64, f64)> = (0..=1950)
        .map(|i| {
            let t = i as f64 * 0.1;
            let mut y = [0.0];
            smoother.eval(t, &mut y);
            (t, y[0] * KMH)
        })
        .collect();
    let panel = Panel {
        title: "Fig. 5: ECE-15 cycle and smoothed speed, look-ahead a = 5 s".into(),
        x_desc: "t [s]".into(),
        y_desc: "speed [km/h]".into(),
        x_range: range,
        series: vec![
            Series::line("cycle", RGBColor(0, 0, 0), 1, raw_cycle(ece, range)),
            Series::line("smoothed (a = 5 s)", RGBColor(200, 0, 0), 2, yd),
        ],
        legend: SeriesLabelPosition::UpperLeft,
    };
    draw(&out.join("fig5_ece_smoothing.svg"), &[panel])
}

/// Fig. 7: air mass flow past the throttle and vehicle speed, inverse vs forward with the PI driver.
fn fig7(
    out: &Path,
    file: &str,
    what: &str,
    cycle: &Cycle,
    inv: &SimulationResult,
    fwd: &ForwardResult,
    until: Option<f64>,
) -> Result<PathBuf, Failure> {
    let range = (0.0, until.unwrap_or(cycle.duration()));
    let (ti, tf) = (inv.time(), fwd.time());
    let u_inv = column(&inv.columns, &inv.data, "m_at")?;
    let u_fwd = column(&fwd.columns, &fwd.data, "m_at")?;
    let v_fwd = column(&fwd.columns, &fwd.data, "v")?;
    let yd = inv
        .yd(0)
        .ok_or_else(|| Failure::io("no y_d column".to_string()))?;
    let flow = Panel {
        title: format!("Fig. 7 ({what}): air mass flow past the throttle"),
        x_desc: "t [s]".into(),
        y_desc: "m_at [g/s]".into(),
        x_range: range,
        series: vec![
            Series::line(
                "forward, PI driver on the raw cycle",
                ORANGE,
                1,
                thin(tf, u_fwd, GPS, range),
            ),
            Series::line(
                "inverse (a = 5 s)",
                RGBColor(0, 0, 200),
                2,
                thin(ti, u_inv, GPS, range),
            ),
        ],
        legend: SeriesLabelPosition::UpperLeft,
    };
    let speed = Panel {
        title: format!("Fig. 7 ({what}): vehicle speed"),
        x_desc: "t [s]".into(),
        y_desc: "v [km/h]".into(),
        x_range: range,
        series: vec![
            Series::line("cycle", RGBColor(0, 0, 0), 1, raw_cycle(cycle, range)),
            Series::line("forward, PI driver", ORANGE, 2, thin(tf, v_fwd, KMH, range)),
            Series::line(
                "inverse: v = y_d",
                RGBColor(0, 0, 200),
                1,
                thin(ti, yd, KMH, range),
            ),
        ],
        legend: SeriesLabelPosition::UpperLeft,
    };
    draw(&out.join(file), &[flow, speed])
}

/// The effect of the look-ahead a on the input (first ECE-15 of the NEDC) and on the fuel over the NEDC.
fn lookahead(
    out: &Path,
    runs: &[(f64, SimulationResult)],
    fwd: &ForwardResult,
) -> Result<PathBuf, Failure> {
    let colors = [RGBColor(200, 0, 0), ORANGE, RGBColor(0, 0, 200), DARK_GREEN];
    let range = (0.0, 195.0);
    let mut inputs = Vec::new();
    let mut fuel = Vec::new();
    for ((a, res), color) in runs.iter().zip(colors) {
        let u = column(&res.columns, &res.data, "m_at")?;
        inputs.push(Series::line(
            format!("a = {a} s"),
            color,
            if *a == 5.0 { 2 } else { 1 },
            thin(res.time(), u, GPS, range),
        ));
        let per_100km = res
            .summary
            .totals
            .integrals_per_100km
            .get("fuel_volume")
            .copied()
            .unwrap_or(f64::NAN);
        fuel.push((*a, per_100km));
    }
    let input = Panel {
        title: "Look-ahead a and the input: m_at on the first ECE-15 of the NEDC".into(),
        x_desc: "t [s]".into(),
        y_desc: "m_at [g/s]".into(),
        x_range: range,
        series: inputs,
        legend: SeriesLabelPosition::UpperLeft,
    };
    let forward_fuel = fwd
        .summary
        .totals
        .integrals_per_100km
        .get("fuel_volume")
        .copied()
        .unwrap_or(f64::NAN);
    let (a0, a1) = (0.0, 11.0);
    let fuel_panel = Panel {
        title: "Look-ahead a and the fuel consumption over the NEDC".into(),
        x_desc: "look-ahead a [s]".into(),
        y_desc: "fuel [l/100 km]".into(),
        x_range: (a0, a1),
        series: vec![
            Series {
                label: "inverse simulation".into(),
                color: RGBColor(0, 0, 200),
                width: 2,
                points: fuel,
                markers: true,
            },
            Series::line(
                format!("forward, PI driver on the raw cycle: {forward_fuel:.3}"),
                ORANGE,
                1,
                vec![(a0, forward_fuel), (a1, forward_fuel)],
            ),
        ],
        legend: SeriesLabelPosition::LowerRight,
    };
    draw(&out.join("lookahead_effect.svg"), &[input, fuel_panel])
}
