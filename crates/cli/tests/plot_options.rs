//! The figure options of every command that plots (`--size`, `--dpi`, `--window`) rendered and measured, and
//! what every figure shows: each panel scaled to its data (a bound outside it is a guide marked "off scale"),
//! one cumulative-fuel panel, the raw and the smoothed speed drawn apart, the headline result under the title,
//! the engine's operating points for a model with an `[engine]`.

use crate::common;
use common::{invsim, json_file, stderr, tmp};

/// Run `command` of `model` on `cycle` with `extra` options, plotting to `name`; the plot's bytes.
fn plot(command: &str, model: &str, cycle: &str, name: &str, extra: &[&str]) -> Vec<u8> {
    let path = tmp(name);
    let mut args = vec![
        command,
        model,
        "--cycle",
        cycle,
        "--plot",
        path.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let o = invsim(&args);
    assert!(o.status.success(), "{args:?}: {}", stderr(&o));
    std::fs::read(&path).unwrap()
}

/// Width and height of a PNG (its IHDR chunk).
fn png_size(png: &[u8]) -> (u32, u32) {
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    let be = |i: usize| u32::from_be_bytes([png[i], png[i + 1], png[i + 2], png[i + 3]]);
    (be(16), be(20))
}

fn attr(tag: &str, name: &str) -> f64 {
    let pat = format!(" {name}=\"");
    let rest = &tag[tag.find(&pat).unwrap_or_else(|| panic!("{name} in {tag}")) + pat.len()..];
    rest.split('"').next().unwrap().parse().unwrap()
}

/// The text of panel `var` of an SVG.
fn panel<'a>(svg: &'a str, var: &str) -> &'a str {
    let start = svg
        .find(&format!("class=\"panel\" data-var=\"{var}\""))
        .unwrap_or_else(|| panic!("panel {var}"));
    let end = svg[start..]
        .find("<g class=\"panel\"")
        .map_or(svg.len(), |e| start + e);
    let end = svg[start + 1..end]
        .find("<g class=\"scatter\"")
        .map_or(end, |e| start + 1 + e);
    &svg[start..end]
}

/// The y tick values of a panel.
fn y_ticks(panel: &str) -> Vec<f64> {
    panel
        .split("class=\"tick y\"")
        .skip(1)
        .map(|t| {
            t.split('>')
                .nth(1)
                .unwrap()
                .split('<')
                .next()
                .unwrap()
                .parse()
                .unwrap()
        })
        .collect()
}

#[test]
fn size_and_dpi_set_the_image_size() {
    let png = plot(
        "simulate",
        "models/si_engine.toml",
        "ece",
        "size.png",
        &["--size", "800x900"],
    );
    assert_eq!(png_size(&png), (800, 900));
    let png = plot(
        "forward",
        "models/si_engine.toml",
        "ece",
        "size_in.png",
        &["--size", "8x10in", "--dpi", "150"],
    );
    assert_eq!(png_size(&png), (1200, 1500), "8 × 10 in at 150 dpi");
    // The file says its resolution (pHYs right after the header: pixels per metre, unit 1).
    assert_eq!(&png[37..41], b"pHYs");
    let per_metre = u32::from_be_bytes([png[41], png[42], png[43], png[44]]);
    assert_eq!(per_metre, (150.0f64 / 0.0254).round() as u32);
    assert_eq!(png[49], 1);
    let png = plot(
        "simulate",
        "models/si_engine.toml",
        "ece",
        "dpi.png",
        &["--dpi", "192"],
    );
    let natural = plot(
        "simulate",
        "models/si_engine.toml",
        "ece",
        "natural.png",
        &[],
    );
    let (w, h) = png_size(&natural);
    assert_eq!(
        png_size(&png),
        (2 * w, 2 * h),
        "--dpi 192 doubles the default figure"
    );
    let svg = String::from_utf8(plot(
        "simulate",
        "models/si_engine.toml",
        "ece",
        "size.svg",
        &["--size", "1200x1000", "--dpi", "48"],
    ))
    .unwrap();
    let root = svg.lines().next().unwrap();
    assert_eq!((attr(root, "width"), attr(root, "height")), (600.0, 500.0));
    assert!(root.contains("viewBox=\"0 0 1200 1000\""), "{root}");
}

#[test]
fn bad_sizes_resolutions_and_windows_exit_2_before_the_run() {
    let out = tmp("never.png");
    for (extra, message) in [
        (
            &["--size", "1200"][..],
            "--size `1200`: expected WIDTHxHEIGHT",
        ),
        (&["--size", "100x800"], "the width must be 400…8000"),
        (
            &["--size", "8000x8000"],
            "exceeds the limit of 32768000 pixels",
        ),
        (
            &["--dpi", "5000"],
            "--dpi 5000: the resolution must be 24 … 1200 dpi",
        ),
        (
            &["--window", "400:200"],
            "--window `400:200`: T0 must be less than T1",
        ),
        (&["--window", "100:200"], "the run spans 0 … 195 s"),
        (&["--size", "1000x250"], "leaves too little for 4 panel(s)"),
    ] {
        let mut args = vec![
            "simulate",
            "models/si_engine.toml",
            "--cycle",
            "ece",
            "--plot",
        ];
        args.push(out.to_str().unwrap());
        args.extend_from_slice(extra);
        let o = invsim(&args);
        assert_eq!(o.status.code(), Some(2), "{extra:?}");
        assert!(stderr(&o).contains(message), "{extra:?}: {}", stderr(&o));
        assert!(!out.exists(), "{extra:?}: no plot written");
    }
    let o = invsim(&[
        "simulate",
        "models/si_engine.toml",
        "--cycle",
        "ece",
        "--dpi",
        "100",
    ]);
    assert_eq!(o.status.code(), Some(2), "--dpi needs --plot");
}

#[test]
fn a_window_shows_its_seconds_scaled_to_its_data() {
    let whole = String::from_utf8(plot(
        "simulate",
        "models/si_engine.toml",
        "nedc",
        "whole.svg",
        &[],
    ))
    .unwrap();
    let svg = String::from_utf8(plot(
        "simulate",
        "models/si_engine.toml",
        "nedc",
        "window.svg",
        &["--window", "200:400"],
    ))
    .unwrap();
    let reference = panel(&svg, "reference");
    let x_ticks: Vec<f64> = reference
        .split("class=\"tick x\"")
        .skip(1)
        .map(|t| {
            t.split('>')
                .nth(1)
                .unwrap()
                .split('<')
                .next()
                .unwrap()
                .parse()
                .unwrap()
        })
        .collect();
    assert_eq!(x_ticks.first(), Some(&200.0));
    assert_eq!(x_ticks.last(), Some(&400.0));
    // Every point of the curves but the one beyond each edge lies inside the plot area.
    let frame = reference.split("<rect class=\"frame\"").nth(1).unwrap();
    let (left, width) = (attr(frame, "x"), attr(frame, "width"));
    for line in reference.split("points=\"").skip(1) {
        let xs: Vec<f64> = line
            .split('"')
            .next()
            .unwrap()
            .split(' ')
            .map(|p| p.split(',').next().unwrap().parse().unwrap())
            .collect();
        let inside = &xs[1..xs.len() - 1];
        assert!(inside
            .iter()
            .all(|&x| x >= left - 0.01 && x <= left + width + 0.01));
        assert!(xs[0] <= left + 0.01 && xs[xs.len() - 1] >= left + width - 0.01);
    }
    // The ECE part (at most 50 km/h) is scaled to itself, not to the EUDC's 120 km/h.
    let top = |s: &str| {
        y_ticks(panel(s, "reference"))
            .into_iter()
            .fold(f64::MIN, f64::max)
    };
    assert!(
        top(&whole) >= 100.0 && top(&svg) <= 60.0,
        "{} {}",
        top(&whole),
        top(&svg)
    );
    assert!(svg.contains("t [s] (window 200 … 400 s)"));
}

#[test]
fn panels_are_scaled_to_their_data_not_to_the_bounds() {
    // si_engine's air flow reaches 0.047 kg/s of its 0.08 kg/s bound: the scale stops short of the bound.
    let svg = String::from_utf8(plot(
        "simulate",
        "models/si_engine.toml",
        "nedc",
        "scale.svg",
        &[],
    ))
    .unwrap();
    let input = panel(&svg, "input");
    let top = y_ticks(input).into_iter().fold(f64::MIN, f64::max);
    assert!(top < 0.06, "{top}");
    assert!(input.contains("upper bound 0.08 kg/s (off scale)"));
    assert!(
        input.contains(">lower bound 0 kg/s<"),
        "the lower bound is inside the scale"
    );
    // The brake of a car with modes: its force reaches a few kN of its 15 kN bound.
    let svg = String::from_utf8(plot(
        "simulate",
        "models/si_engine_5speed.toml",
        "nedc",
        "brake.svg",
        &["--plot-vars", "F_b"],
    ))
    .unwrap();
    let brake = panel(&svg, "F_b");
    let top = y_ticks(brake).into_iter().fold(f64::MIN, f64::max);
    assert!(top > 100.0 && top < 15000.0 * 0.8, "{top}");
    assert!(brake.contains("upper bound 15000 N (off scale)"), "{brake}");
}

#[test]
fn one_fuel_panel_raw_and_smoothed_apart_and_the_headline_on_the_figure() {
    let json = tmp("headline.json");
    let svg = String::from_utf8(plot(
        "simulate",
        "models/si_engine.toml",
        "nedc",
        "headline.svg",
        &["--summary-json", json.to_str().unwrap()],
    ))
    .unwrap();
    let panels: Vec<&str> = svg
        .split("class=\"panel\" data-var=\"")
        .skip(1)
        .map(|s| s.split('"').next().unwrap())
        .collect();
    assert_eq!(panels, ["reference", "input", "cum:fuel_volume"]);
    // The raw cycle is a thin solid black line, y_d a wider dashed one in another colour.
    let reference = panel(&svg, "reference");
    let entry = |label: &str| {
        let end = reference.find(&format!(">{label}<")).unwrap();
        let start = reference[..end].rfind("<line").unwrap();
        reference[start..end].to_string()
    };
    let (raw, smooth) = (entry("cycle (raw)"), entry("y_d (smoothed)"));
    assert!(
        raw.contains("stroke=\"#000000\"") && !raw.contains("dasharray"),
        "{raw}"
    );
    assert!(
        smooth.contains("stroke=\"#D55E00\"") && smooth.contains("stroke-dasharray"),
        "{smooth}"
    );
    assert!(attr(&smooth, "stroke-width") > attr(&raw, "stroke-width"));
    // The headline: the run's l/100 km as the summary gives it, to four significant digits.
    let l = json_file(&json)["integrals_per_100km"]["fuel_volume"]
        .as_f64()
        .unwrap();
    assert!(
        (6.0..10.0).contains(&l) && (l * 1e3).round() % 10.0 != 0.0,
        "{l}"
    );
    let shown = format!("result: {l:.3} l/100 km fuel_volume");
    assert!(
        svg.contains("class=\"headline\"") && svg.contains(&shown),
        "{shown}"
    );
}

#[test]
fn the_engine_operating_points_lie_over_the_fuel_flow() {
    let svg = String::from_utf8(plot(
        "simulate",
        "models/si_engine.toml",
        "ece",
        "engine.svg",
        &[],
    ))
    .unwrap();
    let start = svg
        .find("<g class=\"scatter\" data-var=\"engine\">")
        .expect("operating points");
    let scatter = &svg[start..];
    assert!(scatter.contains("n_e [rpm]") && scatter.contains("T_e [N m]"));
    assert!(
        scatter.contains("fuel_volume [l/s]: 0"),
        "the colour bar starts at no fuel"
    );
    let points = scatter.matches("<circle class=\"point\"").count();
    assert!(points > 200, "{points} points drawn");
    // The colours span the scale: dark blue where no fuel flows, and lighter ones.
    assert!(scatter.contains("fill=\"#440154\""));
    assert!(scatter.matches("fill=\"#").count() > points);
    // A model without an [engine] has no such panel, and refuses it by name.
    let bev =
        String::from_utf8(plot("simulate", "models/bev.toml", "ece", "bev.svg", &[])).unwrap();
    assert!(!bev.contains("class=\"scatter\""));
    let o = invsim(&[
        "simulate",
        "models/bev.toml",
        "--cycle",
        "ece",
        "--plot",
        tmp("bev2.svg").to_str().unwrap(),
        "--plot-vars",
        "engine",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("unknown panel `engine`"),
        "{}",
        stderr(&o)
    );
}
