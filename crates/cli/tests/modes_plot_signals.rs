//! `--plot` of a model with operating modes and a signal (si_engine_5speed with a road grade, as the runtime's
//! modes_signals tests build it) on a cycle with a grade column: `simulate` and `forward` draw the grade's
//! panel after the reference (raw and smoothed for the inverse run, raw for the forward run, each title
//! saying which), its y axis spanning the grade's range and its raw curve through every sample of the
//! column; `--plot-vars grade` draws that panel alone, and an unknown name is exit 2 listing the valid ones.

use crate::common::{invsim, root, stderr, tmp};

/// The model file and a cycle file with grade = 0.03·sin(2π t/40) on a 1 s grid (120 s), in the temporary
/// directory.
fn files() -> (String, String) {
    let text = std::fs::read_to_string(root().join("models/si_engine_5speed.toml")).expect("model");
    let old = r#"F_res  = { expr = "0.5*rho_a*C_d*A_f*v^2 + m*g_0*c_r*tanh(v/v_eps)","#;
    let new = r#"F_res  = { expr = "0.5*rho_a*C_d*A_f*v^2 + m*g_0*c_r*tanh(v/v_eps)/sqrt(1 + grade^2) + m*g_0*grade/sqrt(1 + grade^2)","#;
    assert!(text.contains(old), "si_engine_5speed's F_res changed");
    let text = text.replace(old, new).replace(
        "[states]",
        "[signals]\ngrade = { default = 0.0, unit = \"-\", doc = \"road grade\" }\n\n[states]",
    );
    let model = tmp("modes_grade.toml");
    std::fs::write(&model, text).expect("write the model");
    // Accelerate to 15 m/s, cruise, brake to a stop.
    let mut csv = String::from("t,mps,grade\n");
    for k in 0..=SAMPLES - 1 {
        let t = k as f64;
        let v = (t * 0.75).min(15.0).min((119.0 - t).max(0.0) * 1.0);
        let g = 0.03 * (2.0 * std::f64::consts::PI * t / 40.0).sin();
        csv.push_str(&format!("{t},{v},{g}\n"));
    }
    let cycle = tmp("modes_grade_cycle.csv");
    std::fs::write(&cycle, csv).expect("write the cycle");
    (model.display().to_string(), cycle.display().to_string())
}

const SAMPLES: usize = 121;

/// The SVG text of the panel `var` (up to the next panel).
fn panel<'a>(svg: &'a str, var: &str) -> &'a str {
    let start = svg
        .find(&format!("<g class=\"panel\" data-var=\"{var}\">"))
        .unwrap_or_else(|| panic!("a panel {var}"));
    let rest = &svg[start + 1..];
    let end = rest.find("<g class=\"panel\"").unwrap_or(rest.len());
    &rest[..end]
}

/// The number of points of each polyline of a panel.
fn polylines(panel: &str) -> Vec<usize> {
    panel
        .split("<polyline class=\"series\"")
        .skip(1)
        .map(|p| {
            let points = p.split("points=\"").nth(1).expect("points");
            points[..points.find('"').expect("end")]
                .split_whitespace()
                .count()
        })
        .collect()
}

/// The values of a panel's y tick labels.
fn y_ticks(panel: &str) -> Vec<f64> {
    panel
        .split("class=\"tick y\"")
        .skip(1)
        .map(|p| {
            let text = &p[p.find('>').expect("tag") + 1..];
            text[..text.find('<').expect("end")]
                .parse()
                .expect("a number")
        })
        .collect()
}

#[test]
fn simulate_and_forward_plot_the_signal_of_a_model_with_modes() {
    let (model, cycle) = files();
    for (command, title, curves) in [
        (
            "simulate",
            "signal grade: raw and smoothed with the reference's kernel",
            2,
        ),
        (
            "forward",
            "signal grade: raw (linear between samples), as the forward run used it",
            1,
        ),
    ] {
        let svg = tmp(&format!("modes-grade-{command}.svg"));
        let svg_s = svg.to_str().expect("utf-8");
        let o = invsim(&[command, &model, "--cycle", &cycle, "--plot", svg_s]);
        assert!(o.status.success(), "{command}: {}", stderr(&o));
        let text = std::fs::read_to_string(&svg).expect("SVG");
        let order: Vec<&str> = text
            .match_indices("<g class=\"panel\" data-var=\"")
            .map(|(i, m)| {
                let rest = &text[i + m.len()..];
                &rest[..rest.find('"').expect("end")]
            })
            .collect();
        assert_eq!(&order[..3], ["reference", "grade", "m_at"], "{command}");
        let p = panel(&text, "grade");
        assert!(p.contains(title), "{command}: title in {p:.400}");
        assert!(p.contains("grade (raw, cycle column grade)"), "{command}");
        let lines = polylines(p);
        assert_eq!(lines.len(), curves, "{command}: curves {lines:?}");
        // The raw curve (drawn last, on top): every sample of the column.
        assert_eq!(lines[curves - 1], SAMPLES, "{command}: raw points");
        if curves == 2 {
            assert!(p.contains("grade (smoothed)"));
            assert_eq!(
                lines[0],
                10 * (SAMPLES - 1) + 1,
                "one smoothed point per sample"
            );
        }
        // The axis is on the grade's scale (±0.03): ticks on both sides of 0, none beyond ±0.05.
        let ticks = y_ticks(p);
        let (lo, hi) = ticks
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                (a.min(v), b.max(v))
            });
        assert!(
            (-0.05..=-0.01).contains(&lo) && (0.01..=0.05).contains(&hi),
            "{command}: {ticks:?}"
        );
        // By name: that panel alone.
        let o = invsim(&[
            command,
            &model,
            "--cycle",
            &cycle,
            "--plot",
            svg_s,
            "--plot-vars",
            "grade",
        ]);
        assert!(o.status.success(), "{command}: {}", stderr(&o));
        let text = std::fs::read_to_string(&svg).expect("SVG");
        assert_eq!(text.matches("<g class=\"panel\"").count(), 1, "{command}");
        assert_eq!(polylines(panel(&text, "grade")).len(), curves);
        // A wrong name: exit 2, listing the valid names, the signal among them.
        std::fs::remove_file(&svg).expect("remove");
        let o = invsim(&[
            command,
            &model,
            "--cycle",
            &cycle,
            "--plot",
            svg_s,
            "--plot-vars",
            "grad",
        ]);
        assert_eq!(o.status.code(), Some(2), "{command}");
        let e = stderr(&o);
        assert!(
            e.contains("unknown panel `grad`") && e.contains("m_at, F_b, grade, gear"),
            "{command}: {e}"
        );
        assert!(!svg.exists(), "{command}: no plot written");
    }
}
