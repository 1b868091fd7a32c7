//! `--plot` and `--plot-vars` of `simulate` and `forward`: SVG and PNG by the extension, the chosen panels,
//! and user errors (exit 2) for an unknown panel (listing the valid names), an unknown extension and
//! `--plot-vars` without `--plot`.

use crate::common;
use common::{invsim, stderr, tmp};

fn panels(svg: &str) -> Vec<String> {
    svg.split("<g class=\"panel\" data-var=\"")
        .skip(1)
        .filter_map(|s| s.split('"').next())
        .map(String::from)
        .collect()
}

#[test]
fn simulate_writes_svg_and_png_by_extension() {
    let svg = tmp("sim_plot.svg");
    let png = tmp("sim_plot.png");
    for path in [&svg, &png] {
        let o = invsim(&[
            "simulate",
            "models/si_engine.toml",
            "--cycle",
            "nedc",
            "--plot",
            path.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let text = std::fs::read_to_string(&svg).unwrap();
    assert_eq!(panels(&text), ["reference", "input", "cum:fuel_volume"]);
    assert!(text.contains("m_at [kg/s]") && text.contains("speed [km/h]"));
    let bytes = std::fs::read(&png).unwrap();
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
    // IHDR: width 1000.
    assert_eq!(
        u32::from_be_bytes([bytes[16], bytes[17], bytes[18], bytes[19]]),
        1000
    );
}

#[test]
fn plot_vars_choose_the_panels_of_simulate_and_forward() {
    let svg = tmp("vars.svg");
    let o = invsim(&[
        "simulate",
        "models/si_engine.toml",
        "--cycle",
        "ece",
        "--plot",
        svg.to_str().unwrap(),
        "--plot-vars",
        "p_i,m_at,n_e,cum:fuel",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&svg).unwrap();
    assert_eq!(panels(&text), ["p_i", "input", "n_e", "cum:fuel"]);
    assert!(text.contains("p_i [Pa]"));
    let fwd = tmp("fwd.svg");
    let o = invsim(&[
        "forward",
        "models/driveline.toml",
        "--cycle",
        "ece",
        "--plot",
        fwd.to_str().unwrap(),
        "--plot-vars",
        "reference,input",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&fwd).unwrap();
    assert_eq!(panels(&text), ["reference", "input"]);
    assert!(text.contains("cycle y_c (raw)") && text.contains("achieved v_w"));
}

#[test]
fn bad_plot_options_exit_2() {
    let svg = tmp("bad.svg");
    let o = invsim(&[
        "simulate",
        "models/si_engine.toml",
        "--cycle",
        "nedc",
        "--plot",
        svg.to_str().unwrap(),
        "--plot-vars",
        "reference,torque",
    ]);
    assert_eq!(o.status.code(), Some(2));
    let e = stderr(&o);
    assert!(
        e.contains("`torque`") && e.contains("reference, input, v, p_i"),
        "{e}"
    );
    assert!(!svg.exists(), "no plot written for a bad option");
    let o = invsim(&[
        "forward",
        "models/si_engine.toml",
        "--cycle",
        "nedc",
        "--plot",
        tmp("bad.pdf").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains(".svg or .png"), "{}", stderr(&o));
    let o = invsim(&[
        "simulate",
        "models/si_engine.toml",
        "--cycle",
        "nedc",
        "--plot-vars",
        "input",
    ]);
    assert_eq!(o.status.code(), Some(2), "--plot-vars needs --plot");
}

/// The `<g class="engine-map">` group of an SVG, if any.
fn engine_map(svg: &str) -> Option<&str> {
    let start = svg.find("<g class=\"engine-map\">")?;
    let len = svg[start..].find("</g>")?;
    Some(&svg[start..start + len])
}

#[test]
fn the_operating_points_are_drawn_over_the_engine_map_by_either_engine() {
    let mut maps = Vec::new();
    for engine in ["compiled", "interpreted"] {
        let svg = tmp(&format!("engine_map_{engine}.svg"));
        let o = invsim(&[
            "simulate",
            "models/si_engine_maps.toml",
            "--cycle",
            "ece",
            "--engine",
            engine,
            "--plot",
            svg.to_str().unwrap(),
            "--plot-vars",
            "v,engine",
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        let text = std::fs::read_to_string(&svg).unwrap();
        assert!(text.contains("over the engine map bsfc(n_e*pi/30, T_e) (g/kWh)"));
        assert!(
            text.contains("≤ 250") && text.contains("≥ 450"),
            "the file's map_range"
        );
        let cells = engine_map(&text)
            .expect("the engine map's cells")
            .to_string();
        assert!(cells.matches("<rect").count() > 40, "{cells}");
        maps.push(cells);
    }
    assert_eq!(
        maps[0], maps[1],
        "compiled and interpreted draw the same map"
    );
    // si_engine has operating points but no map.
    let svg = tmp("engine_map_none.svg");
    let o = invsim(&[
        "simulate",
        "models/si_engine.toml",
        "--cycle",
        "ece",
        "--plot",
        svg.to_str().unwrap(),
        "--plot-vars",
        "engine",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(engine_map(&text).is_none() && text.contains("coloured by the fuel flow"));
}
