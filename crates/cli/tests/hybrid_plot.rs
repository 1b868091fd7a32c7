//! `simulate --strategy … --plot` and `--out` of `models/hev_p2.toml`: the figure's state-of-charge panel
//! (its title the CSV's first and last charge, SOC(0) as a guide) and engine on/off band (a step curve with a
//! corner pair at every change of the CSV's `engine_on`), chosen by default and by `--plot-vars`; the CSV's
//! `engine_on` is 1 exactly in the `[hybrid] engine_on` modes and adds up to the summary's `engine_on_s`.

use crate::common::{column, invsim, json_file, num, read_csv, stderr, tmp};

const MODEL: &str = "models/hev_p2.toml";

/// The `data-var` of every panel of an SVG, in order.
fn panels(svg: &str) -> Vec<String> {
    svg.split("<g class=\"panel\" data-var=\"")
        .skip(1)
        .filter_map(|s| s.split('"').next())
        .map(String::from)
        .collect()
}

/// The SVG of panel `var`: from its opening tag to the next panel's.
fn panel<'a>(svg: &'a str, var: &str) -> &'a str {
    let open = format!("<g class=\"panel\" data-var=\"{var}\">");
    let start = svg.find(&open).unwrap_or_else(|| panic!("no panel {var}"));
    let rest = &svg[start + open.len()..];
    &rest[..rest.find("<g class=\"panel\"").unwrap_or(rest.len())]
}

/// The points of every series polyline of a panel.
fn polylines(panel: &str) -> Vec<Vec<(f64, f64)>> {
    panel
        .split("<polyline class=\"series\"")
        .skip(1)
        .map(|p| {
            let pts = p
                .split("points=\"")
                .nth(1)
                .unwrap()
                .split('"')
                .next()
                .unwrap();
            pts.split(' ')
                .map(|xy| {
                    let (x, y) = xy.split_once(',').unwrap();
                    (num(x), num(y))
                })
                .collect()
        })
        .collect()
}

/// A CSV: its header and rows.
type Table = (Vec<String>, Vec<Vec<String>>);

/// Run `simulate MODEL --cycle ece --dt 1 --strategy ecms --equivalence 3.4` with `--plot`, `--out` and the
/// summary; returns the SVG, the CSV and the summary.
fn run(extra: &[&str], tag: &str) -> (String, Table, serde_json::Value) {
    let (svg, csv, json) = (
        tmp(&format!("{tag}.svg")),
        tmp(&format!("{tag}.csv")),
        tmp(&format!("{tag}.json")),
    );
    let mut args = vec![
        "simulate",
        MODEL,
        "--cycle",
        "ece",
        "--dt",
        "1",
        "--strategy",
        "ecms",
        "--equivalence",
        "3.4",
        "--plot",
        svg.to_str().unwrap(),
        "--out",
        csv.to_str().unwrap(),
        "--summary-json",
        json.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let o = invsim(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&svg).unwrap();
    (text, read_csv(&csv), json_file(&json))
}

#[test]
fn the_figure_has_the_charge_and_the_engine_band_under_the_gears() {
    let (svg, (header, rows), summary) = run(&[], "hybrid-plot");
    assert_eq!(
        panels(&svg),
        [
            "reference",
            "T_e",
            "T_m",
            "F_b",
            "gear",
            "soc",
            "engine_on",
            "cum:fuel_volume"
        ]
    );
    let soc = column(&header, &rows, "soc");
    let (first, last) = (soc[0], soc[soc.len() - 1]);
    assert!(
        (last - first).abs() > 1e-3,
        "s = 3.4 moves the charge on the ECE"
    );
    let title = format!("state of charge soc: {first:.4} → {last:.4}");
    assert!(panel(&svg, "soc").contains(&title), "{title}");
    assert!(panel(&svg, "soc").contains(&format!("SOC(0) = {first}")));
    // The band: a step curve with two corners at every change of engine_on, and its ends.
    let on = column(&header, &rows, "engine_on");
    let changes = on.windows(2).filter(|w| w[0] != w[1]).count();
    assert!(changes >= 2, "the engine starts and stops on the ECE");
    let band = polylines(panel(&svg, "engine_on"));
    assert_eq!(band.len(), 1);
    assert_eq!(band[0].len(), 2 * changes + 2);
    let ys: Vec<f64> = band[0].iter().map(|p| p.1).collect();
    let distinct = ys.iter().fold(Vec::<f64>::new(), |mut v, &y| {
        if !v.contains(&y) {
            v.push(y);
        }
        v
    });
    assert_eq!(distinct.len(), 2, "two levels, on and off: {distinct:?}");
    // engine_on is 1 exactly in the hybrid (engine-on) modes; its intervals add up to engine_on_s.
    let names: Vec<String> = summary["modes"]["per_mode"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m["name"].as_str().unwrap().to_string())
        .collect();
    let mode = column(&header, &rows, "mode");
    for (m, e) in mode.iter().zip(&on) {
        let family_on = names[*m as usize].starts_with("hybrid_");
        assert_eq!(
            *e,
            if family_on { 1.0 } else { 0.0 },
            "{}",
            names[*m as usize]
        );
    }
    let t = column(&header, &rows, "t");
    let on_s: f64 = (0..t.len() - 1).map(|k| on[k] * (t[k + 1] - t[k])).sum();
    assert_eq!(on_s, summary["hybrid"]["engine_on_s"].as_f64().unwrap());
}

#[test]
fn plot_vars_name_the_charge_and_the_engine_band() {
    let (svg, _, _) = run(&["--plot-vars", "engine_on,soc"], "hybrid-plot-vars");
    assert_eq!(panels(&svg), ["engine_on", "soc"]);
    let png = tmp("hybrid-plot.png");
    let o = invsim(&[
        "simulate",
        MODEL,
        "--cycle",
        "ece",
        "--dt",
        "1",
        "--strategy",
        "dp",
        "--plot",
        png.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(&std::fs::read(&png).unwrap()[..8], b"\x89PNG\r\n\x1a\n");
    // Not a panel of a model without [hybrid].
    let o = invsim(&[
        "simulate",
        "models/si_engine_5speed.toml",
        "--cycle",
        "ece",
        "--plot",
        tmp("no-band.svg").to_str().unwrap(),
        "--plot-vars",
        "engine_on",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("unknown panel `engine_on`"),
        "{}",
        stderr(&o)
    );
}
