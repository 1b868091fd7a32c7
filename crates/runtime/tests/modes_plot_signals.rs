//! The plots of a model with operating modes and a signal: si_engine_5speed with a road grade (the model of
//! `modes_signals`) on ECE-15 with a varying grade column, inverse and forward. The signal's panel comes
//! after the reference by default and by name (`--plot-vars grade`); its curves, read back from the SVG
//! through the panel's own tick labels, are the cycle's grade column (raw, every sample) and, for the
//! inverse run only, the grade smoothed with the reference's kernel (against an independent smoother of
//! the same column); an unknown name is an error listing the valid ones, `grade` among them.

use invsim_runtime::forward::forward_modes;
use invsim_runtime::modes::{simulate_modes_with_signals, ModalOptions};
use invsim_runtime::plot::{
    check_modal_vars, modal_default_vars, modal_forward_figure, modal_simulation_figure,
    modal_valid_vars, PlotError,
};
use invsim_runtime::{Cycle, ForwardOptions, Smoother};

use crate::modes::support::{spec, speed_schedule};
use crate::modes_signals::graded;
use crate::plot::check_svg;

/// ECE-15 sampled every second (linear between its corners) with grade = 0.03·sin(2π t/40).
fn graded_ece() -> Cycle {
    let base = Cycle::builtin("ece").expect("built-in");
    let mut text = String::from("t,mps,grade\n");
    for k in 0..=base.duration().round() as usize {
        let t = base.time[0] + k as f64;
        let j = base
            .time
            .partition_point(|&c| c <= t)
            .clamp(1, base.time.len() - 1);
        let w = (t - base.time[j - 1]) / (base.time[j] - base.time[j - 1]);
        let v = base.speed[j - 1] + w * (base.speed[j] - base.speed[j - 1]);
        text.push_str(&format!("{t},{v},{}\n", grade(t)));
    }
    Cycle::from_csv_str("ece_graded", &text).expect("the cycle reads")
}

fn grade(t: f64) -> f64 {
    0.03 * (2.0 * std::f64::consts::PI * t / 40.0).sin()
}

/// A panel's title, legend labels and curves in data coordinates, each its colour and a list of
/// (t, value): pixels mapped back through the first and last grid line of each axis and their tick labels.
struct PanelData {
    title: String,
    legend: Vec<String>,
    curves: Vec<(String, Vec<(f64, f64)>)>,
}

impl PanelData {
    /// The points of the curve drawn in `colour`.
    fn curve(&self, colour: &str) -> &[(f64, f64)] {
        let c = self.curves.iter().find(|c| c.0 == colour);
        &c.unwrap_or_else(|| panic!("a curve in {colour}")).1
    }
}

/// The raw signal's colour (the raw cycle's) and the smoothed one's (the reference's).
const RAW: &str = "#000000";
const SMOOTHED: &str = "#D55E00";

fn num(n: roxmltree::Node, a: &str) -> f64 {
    n.attribute(a).unwrap().parse().unwrap()
}

fn panel_data(svg: &str, var: &str) -> PanelData {
    let doc = roxmltree::Document::parse(svg).unwrap();
    let panel = doc
        .descendants()
        .find(|n| n.attribute("class") == Some("panel") && n.attribute("data-var") == Some(var))
        .unwrap_or_else(|| panic!("a panel {var}"));
    let class = |c: &str| -> Vec<roxmltree::Node> {
        panel
            .descendants()
            .filter(|n| n.attribute("class") == Some(c))
            .collect()
    };
    let text = |n: &roxmltree::Node| n.text().unwrap_or("").to_string();
    let ticks =
        |c: &str| -> Vec<f64> { class(c).iter().map(|n| text(n).parse().unwrap()).collect() };
    let (tx, ty) = (ticks("tick x"), ticks("tick y"));
    let grid = class("grid")[0];
    let lines: Vec<roxmltree::Node> = grid.children().filter(|n| n.is_element()).collect();
    // The grid's vertical lines (x ticks) come first, then the horizontal ones (y ticks), in tick order.
    let (vx, hy) = lines.split_at(tx.len());
    assert_eq!(hy.len(), ty.len());
    let lin =
        |p0: f64, p1: f64, v0: f64, v1: f64| move |p: f64| v0 + (p - p0) * (v1 - v0) / (p1 - p0);
    let fx = lin(
        num(vx[0], "x1"),
        num(vx[tx.len() - 1], "x1"),
        tx[0],
        tx[tx.len() - 1],
    );
    let fy = lin(
        num(hy[0], "y1"),
        num(hy[ty.len() - 1], "y1"),
        ty[0],
        ty[ty.len() - 1],
    );
    let curves = class("series")
        .iter()
        .map(|n| {
            let points = n
                .attribute("points")
                .unwrap()
                .split_whitespace()
                .map(|p| {
                    let (x, y) = p.split_once(',').unwrap();
                    (fx(x.parse().unwrap()), fy(y.parse().unwrap()))
                })
                .collect();
            (n.attribute("stroke").unwrap().to_string(), points)
        })
        .collect();
    PanelData {
        title: text(&class("panel-title")[0]),
        legend: class("legend-label").iter().map(text).collect(),
        curves,
    }
}

/// The largest difference of a curve's values from `f` at its own times.
fn worst(curve: &[(f64, f64)], f: &dyn Fn(f64) -> f64) -> f64 {
    curve
        .iter()
        .map(|&(t, v)| (v - f(t)).abs())
        .fold(0.0, f64::max)
}

#[test]
fn a_model_with_modes_plots_its_signal_raw_and_smoothed() {
    let l = graded();
    let spec = spec(&l, speed_schedule(&l));
    let cycle = graded_ece();
    let inv = simulate_modes_with_signals(&spec, &cycle, &ModalOptions::default(), &[])
        .expect("the run succeeds");
    let fopts = ForwardOptions::builder().keep_series(true).build().unwrap();
    let fwd = forward_modes(&spec, &cycle, &fopts).expect("forward runs");
    let defaults = modal_default_vars(&spec);
    assert_eq!(&defaults[..3], ["reference", "grade", "m_at"]);
    assert!(modal_valid_vars(&spec).contains(&"grade".to_string()));
    // The grade column smoothed like a cycle (shifted by 1: a cycle's speed is not negative), with the
    // run's look-ahead: independent of the plot's own smoother.
    let shifted: String = std::iter::once("t,mps\n".to_string())
        .chain(
            cycle
                .time
                .iter()
                .map(|&t| format!("{t},{}\n", grade(t) + 1.0)),
        )
        .collect();
    let gs = Smoother::new(
        &Cycle::from_csv_str("g", &shifted).unwrap(),
        inv.summary.lookahead_s,
    )
    .unwrap();
    let smoothed = |t: f64| {
        let mut v = [0.0];
        gs.eval(t, &mut v);
        v[0] - 1.0
    };
    let samples = cycle.time.len();
    for vars in [
        defaults.clone(),
        modal_valid_vars(&spec),
        vec!["grade".to_string()],
    ] {
        let svg = modal_simulation_figure(&inv, &cycle, &spec, &vars)
            .unwrap()
            .to_svg();
        check_svg(&svg, &vars, &format!("simulate {vars:?}"));
        let p = panel_data(&svg, "grade");
        assert_eq!(
            p.title,
            "signal grade: raw and smoothed with the reference's kernel"
        );
        assert_eq!(
            p.legend,
            ["grade (raw, cycle column grade)", "grade (smoothed)"]
        );
        assert_eq!(p.curves.len(), 2);
        // The raw curve: every sample of the column (the first and last at the run's ends).
        assert_eq!(p.curve(RAW).len(), samples);
        let raw = worst(p.curve(RAW), &grade);
        assert!(raw < 2e-4, "raw grade off by {raw}");
        // The smoothed curve: one point per sample of the run.
        assert_eq!(p.curve(SMOOTHED).len(), inv.column("t").unwrap().len());
        let sm = worst(p.curve(SMOOTHED), &smoothed);
        assert!(sm < 2e-4, "smoothed grade off by {sm}");
        // Smoothing over ±5 s damps the 40 s wave, but not away.
        let peak = p
            .curve(SMOOTHED)
            .iter()
            .map(|q| q.1.abs())
            .fold(0.0, f64::max);
        assert!(peak > 0.02 && peak < 0.03, "smoothed peak {peak}");
    }
    for vars in [defaults, vec!["grade".to_string()]] {
        let svg = modal_forward_figure(&fwd, &spec, &vars).unwrap().to_svg();
        check_svg(&svg, &vars, &format!("forward {vars:?}"));
        let p = panel_data(&svg, "grade");
        assert_eq!(
            p.title,
            "signal grade: raw (linear between samples), as the forward run used it"
        );
        assert_eq!(p.legend, ["grade (raw, cycle column grade)"]);
        assert_eq!(p.curves.len(), 1);
        assert_eq!(p.curve(RAW).len(), samples);
        let raw = worst(p.curve(RAW), &grade);
        assert!(raw < 2e-4, "forward: raw grade off by {raw}");
    }
    let e = check_modal_vars(&spec, &["grad".to_string()]).unwrap_err();
    assert!(matches!(e, PlotError::UnknownVar { .. }));
    assert!(
        e.to_string().contains("`grad`") && e.to_string().contains("grade"),
        "{e}"
    );
}
