//! The plots of every shipped model (`models/*.toml`, through the interpreter; those with operating modes
//! inverse and forward, with their inputs and the gear panel): the SVG parsed and its
//! elements checked (one panel per variable, axis labels with the model's units, a legend entry per curve,
//! distinct bound colours, legible text, no text outside the canvas), the PNG decoded and checked for size and
//! content.

use std::path::{Path, PathBuf};

use invsim_inversion::{derive_file, Interpreter};
use invsim_model_api::InverseModel;
use invsim_runtime::forward::forward_modes;
use invsim_runtime::modes::{simulate_modes, ModalOptions};
use invsim_runtime::plot::{
    self, default_vars, forward_figure, modal_default_vars, modal_forward_figure,
    modal_simulation_figure, modal_valid_vars, simulation_figure, text_width, valid_vars, Layout,
    PlotError, PlotFormat, WIDTH,
};
use invsim_runtime::{forward, simulate, Cycle, ForwardOptions, SimulationOptions};
use resvg::tiny_skia::Pixmap;

fn models() -> Vec<PathBuf> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../models");
    let mut v: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        // Models with operating modes are plotted by every_shipped_model_with_modes_plots_its_inputs_and_its_gear.
        .filter(|p| {
            !std::fs::read_to_string(p).is_ok_and(|t| t.lines().any(|l| l.starts_with("[modes.")))
        })
        .collect();
    v.sort();
    assert!(v.len() >= 3, "shipped models in {}", dir.display());
    v
}

fn load(path: &Path) -> Interpreter {
    Interpreter::new(&derive_file(path).unwrap()).unwrap()
}

fn sim_opts() -> SimulationOptions {
    SimulationOptions::builder()
        .engine("interpreted")
        .keep_series(true)
        .build()
        .unwrap()
}

/// One text element: class, content, font size and its box (left, top, right, bottom).
struct Text {
    class: String,
    content: String,
    size: f64,
    bbox: [f64; 4],
}

fn attr(n: roxmltree::Node, name: &str) -> f64 {
    n.attribute(name).unwrap().parse().unwrap()
}

/// Every `<text>` with its box from the embedded font's advances, ascent 0.76 em and descent 0.24 em (the
/// y labels rotated by −90° about their anchor).
fn texts(doc: &roxmltree::Document) -> Vec<Text> {
    doc.descendants()
        .filter(|n| n.has_tag_name("text"))
        .map(|n| {
            let content = n.text().unwrap_or("").to_string();
            let (x, y, size) = (attr(n, "x"), attr(n, "y"), attr(n, "font-size"));
            let w = text_width(&content, size);
            let start = match n.attribute("text-anchor") {
                Some("middle") => -w / 2.0,
                Some("end") => -w,
                _ => 0.0,
            };
            let bbox = if n.attribute("transform").is_some() {
                [x - 0.76 * size, y - start - w, x + 0.24 * size, y - start]
            } else {
                [x + start, y - 0.76 * size, x + start + w, y + 0.24 * size]
            };
            Text {
                class: n.attribute("class").unwrap_or("").to_string(),
                content,
                size,
                bbox,
            }
        })
        .collect()
}

/// Check the SVG's structure: the panels `vars`, their labels, legends and the canvas.
pub(crate) fn check_svg(svg: &str, vars: &[String], what: &str) {
    let doc = roxmltree::Document::parse(svg).unwrap_or_else(|e| panic!("{what}: {e}"));
    let root = doc.root_element();
    let (w, h) = (attr(root, "width"), attr(root, "height"));
    assert_eq!(w, WIDTH, "{what}");
    let panels: Vec<_> = doc
        .descendants()
        .filter(|n| n.attribute("class") == Some("panel"))
        .collect();
    let shown: Vec<&str> = panels
        .iter()
        .map(|p| p.attribute("data-var").unwrap())
        .collect();
    // The engine's operating points are a panel of their own axes under the time panels.
    let over_time: Vec<&String> = vars.iter().filter(|v| *v != "engine").collect();
    assert_eq!(shown, over_time, "{what}: one panel per variable, in order");
    let scatter = doc.descendants().any(|n| {
        n.attribute("class") == Some("scatter") && n.attribute("data-var") == Some("engine")
    });
    assert_eq!(
        scatter,
        vars.iter().any(|v| v == "engine"),
        "{what}: operating points"
    );
    for p in &panels {
        let var = p.attribute("data-var").unwrap();
        let y_label = p
            .descendants()
            .find(|n| n.attribute("class") == Some("axis-label y"))
            .unwrap_or_else(|| panic!("{what}: panel {var} has a y label"));
        let label = y_label.text().unwrap_or("");
        assert!(
            text_width(label, attr(y_label, "font-size")) <= 200.0,
            "{what}: `{label}` fits beside its plot"
        );
        assert!(
            label.contains(" [") && label.ends_with(']'),
            "{what}: unit in `{label}`"
        );
        let entries: Vec<_> = p
            .descendants()
            .filter(|n| n.attribute("class") == Some("legend-entry"))
            .collect();
        let curves: Vec<&str> = p
            .descendants()
            .filter(|n| n.attribute("class") == Some("series"))
            .filter_map(|n| n.attribute("stroke"))
            .collect();
        assert!(!entries.is_empty(), "{what}: legend of {var}");
        let colours: Vec<&str> = entries
            .iter()
            .filter_map(|e| e.first_element_child()?.attribute("stroke"))
            .collect();
        let mut distinct = colours.clone();
        distinct.sort();
        distinct.dedup();
        assert_eq!(
            distinct.len(),
            colours.len(),
            "{what}: distinct colours in {var}"
        );
        // Every entry is drawn but a guide outside the scale (an input's bound the input does not reach).
        let drawn_or_off_scale = entries.iter().all(|e| {
            let colour = e.first_element_child().and_then(|l| l.attribute("stroke"));
            let off = e
                .last_element_child()
                .and_then(|t| t.text())
                .is_some_and(|t| t.ends_with("(off scale)"));
            off || colour.is_some_and(|c| curves.contains(&c))
        });
        assert!(drawn_or_off_scale, "{what}: every entry drawn in {var}");
        if var == "reference" {
            assert_eq!(entries.len(), 2, "{what}: cycle and reference/achieved");
        }
        let ticks = p
            .descendants()
            .filter(|n| n.attribute("class") == Some("tick y"))
            .count();
        assert!(ticks >= 3, "{what}: {ticks} y ticks in {var}");
    }
    assert!(svg.contains(">t [s]</text>"), "{what}: time axis label");
    for t in texts(&doc) {
        assert!(t.size >= 14.0, "{what}: `{}` at {} px", t.content, t.size);
        let [l, top, r, b] = t.bbox;
        assert!(
            l >= 0.0 && top >= 0.0 && r <= w && b <= h,
            "{what}: {} `{}` at {:?} outside the {w}×{h} canvas",
            t.class,
            t.content,
            t.bbox
        );
    }
}

#[test]
fn every_shipped_model_plots_with_units_legends_and_text_inside() {
    let nedc = Cycle::builtin("nedc").unwrap();
    let mut forwards = 0;
    for path in models() {
        let model = load(&path);
        let info = model.info();
        let what = path.file_name().unwrap().to_string_lossy().to_string();
        let res = simulate(&model, &nedc, &sim_opts()).unwrap();
        for vars in [default_vars(info), valid_vars(info)] {
            let fig = simulation_figure(&res, &nedc, info, &vars).unwrap();
            check_svg(&fig.to_svg(), &vars, &format!("{what} simulate {vars:?}"));
        }
        let fwd_opts = ForwardOptions::builder().keep_series(true).build().unwrap();
        // diesel_gasflow has no forward start at a standstill (its output is a pressure, not the cycle's speed).
        if let Ok(fwd) = forward(&model, &nedc, &fwd_opts) {
            forwards += 1;
            let vars = default_vars(info);
            let fig = forward_figure(&fwd, info, model.reference(), &vars).unwrap();
            let svg = fig.to_svg();
            check_svg(&svg, &vars, &format!("{what} forward"));
            assert!(
                svg.contains("achieved"),
                "{what}: forward shows the output achieved"
            );
        }
    }
    assert!(forwards >= 2, "forward plots of si_engine and driveline");
}

/// The shipped models with operating modes (`[modes.…]` tables) that run with the mode sequence (a hybrid,
/// with `[hybrid]`, runs only with a strategy: its plot is the command line's, `crates/cli/tests/hybrid.rs`).
fn modal_models() -> Vec<PathBuf> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../models");
    let mut v: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .filter(|p| {
            std::fs::read_to_string(p).is_ok_and(|t| {
                t.lines().any(|l| l.starts_with("[modes.")) && !t.lines().any(|l| l == "[hybrid]")
            })
        })
        .collect();
    v.sort();
    v
}

/// The panel names of an SVG, in order, and the y-axis label of each.
fn panel_labels(svg: &str) -> Vec<(String, String)> {
    let doc = roxmltree::Document::parse(svg).unwrap();
    doc.descendants()
        .filter(|n| n.attribute("class") == Some("panel"))
        .map(|p| {
            let label = p
                .descendants()
                .find(|n| n.attribute("class") == Some("axis-label y"))
                .and_then(|n| n.text())
                .unwrap_or("")
                .to_string();
            (p.attribute("data-var").unwrap().to_string(), label)
        })
        .collect()
}

/// Every shipped model with modes (si_engine_5speed, ford_fusion_2012_dynamic_6speed) plotted inverse and forward on the NEDC: the same
/// checks as every other model's plots, every input in a panel of its own with its unit, and under them the
/// step panel of the gear (a curve of horizontal and vertical segments only, 0 … the number of gears).
#[test]
fn every_shipped_model_with_modes_plots_its_inputs_and_its_gear() {
    let models = modal_models();
    assert!(!models.is_empty(), "si_engine_5speed is shipped");
    let nedc = Cycle::builtin("nedc").unwrap();
    for path in models {
        let what = path.file_name().unwrap().to_string_lossy().to_string();
        let text = std::fs::read_to_string(&path).unwrap();
        let l = crate::modes::support::load(&path, &text);
        let spec = crate::modes::support::spec(&l, crate::modes::support::speed_schedule(&l));
        let opts = ModalOptions::default();
        let inv = simulate_modes(&spec, &nedc, &opts).unwrap();
        let fwd_opts = ForwardOptions::builder().keep_series(true).build().unwrap();
        let fwd = forward_modes(&spec, &nedc, &fwd_opts).unwrap();
        for vars in [modal_default_vars(&spec), modal_valid_vars(&spec)] {
            let svg = modal_simulation_figure(&inv, &nedc, &spec, &vars)
                .unwrap()
                .to_svg();
            check_svg(&svg, &vars, &format!("{what} simulate {vars:?}"));
            let svg = modal_forward_figure(&fwd, &spec, &vars).unwrap().to_svg();
            check_svg(&svg, &vars, &format!("{what} forward {vars:?}"));
            assert!(
                svg.contains("achieved"),
                "{what}: forward shows the output achieved"
            );
        }
        let svg = modal_simulation_figure(&inv, &nedc, &spec, &[])
            .unwrap()
            .to_svg();
        let panels = panel_labels(&svg);
        let names: Vec<&str> = panels.iter().map(|(n, _)| n.as_str()).collect();
        // The signals (the 6-speed Fusion's grade) come right after the reference.
        let signals: Vec<&str> = spec.modes[0]
            .model
            .info()
            .signals
            .iter()
            .map(|s| s.name.as_str())
            .collect();
        let expected: Vec<&str> = ["reference"]
            .into_iter()
            .chain(signals.iter().copied())
            .chain(["m_at", "F_b", "gear", "cum:fuel_volume"])
            .collect();
        assert_eq!(
            names.len(),
            expected.len(),
            "{what}: one cumulative-fuel panel, in litres"
        );
        assert_eq!(
            &names[..expected.len()],
            expected,
            "{what}: the signals after the reference, the gear under the inputs"
        );
        for (var, label) in [
            ("m_at", "m_at [kg/s]"),
            ("F_b", "F_b [N]"),
            ("gear", "gear [-]"),
        ] {
            assert!(
                panels.contains(&(var.to_string(), label.to_string())),
                "{what}: {label}"
            );
        }
        assert!(
            svg.contains("lower bound 0 N") && svg.contains("upper bound 15000 N"),
            "{what}: the brake's bounds"
        );
        assert!(svg.contains("gear of the mode in force (0: idle)"));
        // The gear curve is a staircase: consecutive points share their x or their y.
        let doc = roxmltree::Document::parse(&svg).unwrap();
        let gear = doc
            .descendants()
            .find(|n| n.attribute("data-var") == Some("gear"))
            .unwrap();
        let line = gear
            .descendants()
            .find(|n| n.attribute("class") == Some("series"))
            .unwrap();
        let pts: Vec<(f64, f64)> = line
            .attribute("points")
            .unwrap()
            .split_whitespace()
            .map(|p| {
                let (x, y) = p.split_once(',').unwrap();
                (x.parse().unwrap(), y.parse().unwrap())
            })
            .collect();
        assert!(pts.len() > 60, "{what}: {} points", pts.len());
        assert!(pts.windows(2).all(|w| w[0].0 == w[1].0 || w[0].1 == w[1].1));
        let levels: std::collections::BTreeSet<i64> =
            pts.iter().map(|p| p.1.round() as i64).collect();
        assert_eq!(
            levels.len(),
            spec.gears + 1,
            "{what}: gears 0 … {} drawn at distinct heights",
            spec.gears
        );
    }
}

#[test]
fn input_panel_has_both_bounds_in_the_legend_and_units_from_the_model() {
    let path = models()
        .into_iter()
        .find(|p| p.ends_with("si_engine.toml"))
        .unwrap();
    let model = load(&path);
    let cycle = Cycle::builtin("wltc3b").unwrap();
    let res = simulate(&model, &cycle, &sim_opts()).unwrap();
    let vars: Vec<String> = ["reference", "input", "p_i", "cum:fuel"]
        .map(String::from)
        .to_vec();
    let svg = simulation_figure(&res, &cycle, model.info(), &vars)
        .unwrap()
        .to_svg();
    for label in [
        "speed [km/h]",
        "m_at [kg/s]",
        "lower bound 0 kg/s",
        "upper bound 0.08 kg/s",
        "p_i [Pa]",
        "cumulative fuel [kg]",
        "wltc3b",
    ] {
        assert!(svg.contains(label), "`{label}` in the SVG");
    }
    // The time axis of the WLTC ends at 1800 s with a tick there whose label stays inside the canvas.
    assert!(svg.contains(">1800</text>"));
    check_svg(&svg, &vars, "si_engine on wltc3b");
}

#[test]
fn png_decodes_at_the_svg_size_and_is_not_blank() {
    let path = models()
        .into_iter()
        .find(|p| p.ends_with("si_engine.toml"))
        .unwrap();
    let model = load(&path);
    let cycle = Cycle::builtin("nedc").unwrap();
    let res = simulate(&model, &cycle, &sim_opts()).unwrap();
    let fig = simulation_figure(&res, &cycle, model.info(), &[]).unwrap();
    let svg = String::from_utf8(fig.render(PlotFormat::Svg).unwrap()).unwrap();
    let height: f64 = svg
        .split("height=\"")
        .nth(1)
        .and_then(|s| s.split('"').next())
        .and_then(|s| s.parse().ok())
        .unwrap();
    let png = fig.render(PlotFormat::Png).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    let img = Pixmap::decode_png(&png).unwrap();
    assert_eq!((img.width(), img.height()), (WIDTH as u32, height as u32));
    let px = img.pixels();
    let ink = px
        .iter()
        .filter(|p| p.red() < 200 || p.green() < 200 || p.blue() < 200)
        .count();
    let frac = ink as f64 / px.len() as f64;
    assert!(frac > 0.02 && frac < 0.5, "{frac} of the pixels drawn");
    // The input's blue (#0072B2) and the reference's vermilion (#D55E00) are both there, and dark text.
    let has = |r: u8, g: u8, b: u8| {
        px.iter().any(|p| {
            p.red().abs_diff(r) < 12 && p.green().abs_diff(g) < 12 && p.blue().abs_diff(b) < 12
        })
    };
    assert!(has(0x00, 0x72, 0xB2) && has(0xD5, 0x5E, 0x00) && has(0, 0, 0));
}

#[test]
fn bad_names_and_formats_are_errors_listing_the_choices() {
    let path = models()
        .into_iter()
        .find(|p| p.ends_with("si_engine.toml"))
        .unwrap();
    let model = load(&path);
    let info = model.info();
    let e = plot::check_vars(info, &["reference".into(), "speed".into()]).unwrap_err();
    assert!(matches!(e, PlotError::UnknownVar { .. }));
    let msg = e.to_string();
    for name in ["`speed`", "reference", "input", "p_i", "cum:fuel"] {
        assert!(msg.contains(name), "{msg}");
    }
    // Only accumulated outputs have a running integral; the input's own name is accepted.
    assert!(plot::check_vars(info, &["cum:n_e".into()]).is_err());
    assert!(plot::check_vars(info, &["m_at".into(), "v".into()]).is_ok());
    assert!(plot::check_vars(info, &[" ".into()]).is_err());
    assert!(PlotFormat::from_path("a.pdf".as_ref()).is_err());
    assert_eq!(
        PlotFormat::from_path("a.PNG".as_ref()).unwrap(),
        PlotFormat::Png
    );
}

/// A model with modes but no gearbox (si_engine_5speed without its `[gearbox]`: drive, coast, overrun and
/// idle, one mode each) gets the mode's index as its sequence panel, titled with the modes' names.
#[test]
fn a_model_with_modes_but_no_gearbox_plots_the_mode_index() {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../models/si_engine_5speed.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    let start = text.find("\n[gearbox]").unwrap() + 1;
    let end = start + text[start..].find("\n[sequence]").unwrap() + 1;
    let text = format!("{}{}", &text[..start], &text[end..]);
    let l = crate::modes::support::load(&path, &text);
    let spec = crate::modes::support::spec(&l, invsim_runtime::modes::GearSource::Fixed);
    assert!(spec.modes.iter().all(|m| m.gear.is_none()));
    let ece = Cycle::builtin("ece").unwrap();
    let inv = simulate_modes(&spec, &ece, &ModalOptions::default()).unwrap();
    let vars = modal_default_vars(&spec);
    assert!(vars.contains(&"mode".to_string()) && !vars.contains(&"gear".to_string()));
    let svg = modal_simulation_figure(&inv, &ece, &spec, &vars)
        .unwrap()
        .to_svg();
    check_svg(&svg, &vars, "si_engine_5speed without a gearbox");
    assert!(panel_labels(&svg).contains(&("mode".to_string(), "mode [index]".to_string())));
    assert!(svg.contains("mode in force: 0 drive, 1 coast, 2 overrun, 3 idle"));
}

/// `--size`, `--dpi` and `--window` rendered: the PNG has the size × dpi / 96 pixels, and the input's blue
/// line lies inside the plot area from its left edge to its right one (the window's ends).
#[test]
fn a_sized_windowed_png_draws_its_window_across_the_plot_area() {
    let path = models()
        .into_iter()
        .find(|p| p.ends_with("si_engine.toml"))
        .unwrap();
    let model = load(&path);
    let cycle = Cycle::builtin("nedc").unwrap();
    let res = simulate(&model, &cycle, &sim_opts()).unwrap();
    let fig = simulation_figure(&res, &cycle, model.info(), &["input".to_string()])
        .unwrap()
        .windowed((200.0, 400.0))
        .unwrap();
    let layout = Layout::new(Some((800.0, 400.0)), Some(192.0)).unwrap();
    let img = Pixmap::decode_png(&fig.render_with(PlotFormat::Png, &layout).unwrap()).unwrap();
    assert_eq!((img.width(), img.height()), (1600, 800));
    let svg = fig.to_svg_with(&layout).unwrap();
    let doc = roxmltree::Document::parse(&svg).unwrap();
    let frame = doc
        .descendants()
        .find(|n| n.attribute("class") == Some("frame"))
        .unwrap();
    let s = layout.scale();
    let (x0, y0) = (attr(frame, "x") * s, attr(frame, "y") * s);
    let (x1, y1) = (
        x0 + attr(frame, "width") * s,
        y0 + attr(frame, "height") * s,
    );
    let blue: Vec<(f64, f64)> = (0..img.height())
        .flat_map(|y| (0..img.width()).map(move |x| (x, y)))
        .filter(|&(x, y)| {
            let p = img.pixel(x, y).unwrap();
            p.red() < 40 && p.green().abs_diff(0x72) < 30 && p.blue().abs_diff(0xB2) < 30
        })
        .map(|(x, y)| (f64::from(x), f64::from(y)))
        .filter(|&(_, y)| y > y0 && y < y1)
        .collect();
    assert!(
        blue.len() > 500,
        "{} blue pixels in the plot area",
        blue.len()
    );
    let (lo, hi) = blue
        .iter()
        .fold((f64::MAX, f64::MIN), |(l, h), p| (l.min(p.0), h.max(p.0)));
    assert!(
        lo >= x0 - 1.0 && hi <= x1 + 1.0,
        "{lo} … {hi} inside {x0} … {x1}"
    );
    assert!(
        lo <= x0 + 6.0 && hi >= x1 - 6.0,
        "the line spans the window: {lo} … {hi}"
    );
    assert!(
        fig.windowed((100.0, 500.0)).is_err(),
        "outside the window drawn"
    );
}
