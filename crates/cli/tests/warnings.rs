//! Warnings as a user meets them: a cycle file's plausibility warnings (km/h in an m/s column, a time column in
//! milliseconds) on stderr before the run and in the summary, `--strict` turning any warning into exit 2 with
//! nothing written, and the messages that name the input, the mode and the time.

use crate::common::{invsim, json_file, stderr, tmp};
use invsim_runtime::Cycle;

/// The built-in cycle `name` as a CSV file `file` under `header` (time, speed), its times multiplied by
/// `time_factor` and its speeds (m/s) by `speed_factor`; the path.
fn cycle_file(
    name: &str,
    file: &str,
    header: &str,
    (time_factor, speed_factor): (f64, f64),
) -> String {
    let c = Cycle::builtin(name).unwrap();
    let mut text = format!("{header}\n");
    for (t, v) in c.time.iter().zip(&c.speed) {
        text.push_str(&format!("{},{}\n", t * time_factor, v * speed_factor));
    }
    let path = tmp(file);
    std::fs::write(&path, text).unwrap();
    path.display().to_string()
}

/// UDDS in km/h under `speed_mps` (the imported Leaf's case): the run goes on, the warning comes first on
/// stderr with the line of the top speed, the likely unit and the fix, and the summary records it.
#[test]
fn kmh_in_an_mps_column_warns_before_the_run_and_in_the_summary() {
    let cycle = cycle_file("udds", "udds_kmh.csv", "time_s,speed_mps", (1.0, 3.6));
    let summary = tmp("udds_kmh.json");
    let o = invsim(&[
        "simulate",
        "models/vehicles/nissan_leaf_2016.toml",
        "--cycle",
        &cycle,
        "--dt",
        "1",
        "--summary-json",
        summary.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let expected = format!(
        "{cycle}: line 242, column `speed_mps`: top speed 91.2 m/s (328.5 km/h) is beyond any drive cycle \
         (invsim's plausibility limit is 70 m/s = 252 km/h); as km/h it would be 25.3 m/s and as mph 40.8 m/s: \
         the column probably holds km/h (or mph); name it `speed_kmh` (or `speed_mph`), or convert its values \
         to m/s"
    );
    assert_eq!(
        stderr(&o).lines().next(),
        Some(format!("invsim: warning: {expected}").as_str())
    );
    let s = json_file(&summary);
    assert_eq!(s["warnings"][0], expected.as_str());
    // The run itself is the 43 km trip of the complaint: what the warning is for.
    let km = s["distance_m"].as_f64().unwrap() / 1000.0;
    assert!((km - 43.2).abs() < 0.1, "{km} km");
}

/// UDDS with its time column in ms: `--strict` stops before the run with the warning (exit 2, no summary);
/// without it the warning is printed (the run is not made here: it would last 15.8 days of cycle).
#[test]
fn a_time_column_in_ms_is_an_error_with_strict() {
    let cycle = cycle_file("udds", "udds_ms.csv", "time_s,speed_mps", (1000.0, 1.0));
    let summary = tmp("udds_ms.json");
    let o = invsim(&[
        "simulate",
        "models/si_engine.toml",
        "--cycle",
        &cycle,
        "--strict",
        "--summary-json",
        summary.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert_eq!(
        stderr(&o),
        format!(
            "invsim: error: {cycle}: column `time_s`: the median time step is 1000 and the times span 1.369e6 \
             (15.8 days if seconds); the column probably holds milliseconds: divide its times by 1000 (invsim \
             reads time columns in seconds) (a warning, an error with --strict)\n"
        )
    );
    assert!(!summary.exists());
}

/// `--strict` before or after the command makes a run's own warning an error: si_engine on the NEDC warns that
/// its input leaves its bounds; with `--strict` that is exit 2 and no output is written.
#[test]
fn strict_makes_a_run_warning_an_error() {
    let out = tmp("strict_nedc.csv");
    let plain = invsim(&[
        "simulate",
        "models/si_engine.toml",
        "--cycle",
        "nedc",
        "--dt",
        "1",
    ]);
    assert!(plain.status.success());
    let text = String::from_utf8_lossy(&plain.stdout).into_owned();
    // The farthest sample beyond the bounds is the CSV's smallest m_at, −0.01208 kg/s at t = 1151 s.
    assert!(
        text.contains(
            "warning: input m_at leaves its bounds [0, 0.08] in 18 interval(s), 121 s in total (reached -0.01208 \
             … 0.04712; the farthest beyond them at t = 1151 s); not clipped"
        ),
        "{text}"
    );
    for args in [
        vec!["--strict", "simulate", "models/si_engine.toml"],
        vec!["simulate", "models/si_engine.toml", "--strict"],
    ] {
        let mut args = args.clone();
        args.extend([
            "--cycle",
            "nedc",
            "--dt",
            "1",
            "--out",
            out.to_str().unwrap(),
        ]);
        let o = invsim(&args);
        assert_eq!(o.status.code(), Some(2), "{args:?}");
        let e = stderr(&o);
        assert!(e.starts_with("invsim: error: "), "{e}");
        assert!(
            e.contains("input m_at leaves its bounds [0, 0.08] in "),
            "{e}"
        );
        assert!(e.contains("with --strict"), "{e}");
        assert!(!out.exists());
        assert!(o.stdout.is_empty());
    }
}

/// The modes' bound warning names the input, its value, the mode, the time and the speed: si_engine_5speed
/// on UDDS brakes a hair below 0 while creeping to a stop at 1247.4 s.
#[test]
fn the_modes_bound_warning_names_input_mode_and_time() {
    let o = invsim(&[
        "simulate",
        "models/si_engine_5speed.toml",
        "--cycle",
        "udds",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout).into_owned();
    let w = text
        .lines()
        .find(|l| l.contains("no mode absorbs it"))
        .unwrap_or_else(|| panic!("{text}"));
    assert_eq!(
        w,
        "warning: 1 interval(s), 0.1 s in total, where a mode's free input leaves its bounds and no mode absorbs \
         it; the farthest at t = 1247.4 s: `F_b` = -10.43 N in mode `idle` (bounds [0, 15000]), at a speed of \
         0.00714 m/s"
    );
}

/// `derive` of the BEV: the integrator's unknown class says what to do instead of `nominal`; `--strict` makes
/// its L_g η warning an error.
#[test]
fn derive_explains_an_integrator_and_strict_refuses_its_warning() {
    let o = invsim(&["derive", "models/bev.toml"]);
    assert!(o.status.success());
    let text = String::from_utf8_lossy(&o.stdout).into_owned();
    let class = text.lines().find(|l| l.contains("class: unknown")).unwrap();
    assert!(
        class.contains(
            "eta1 = soc appears in no equation of the zero dynamics: an integrator (like a charge state or a \
             fuel mass), with no equilibrium at y = 0 and a zero eigenvalue everywhere, so no `nominal` decides \
             the class; `simulate` integrates it forward"
        ),
        "{class}"
    );
    assert!(
        class.contains("give `initial = …` on the state or `--initial NAME=VALUE`, not `nominal`")
    );
    assert!(!class.contains("set the output's `nominal`"), "{class}");
    let o = invsim(&["derive", "models/bev.toml", "--strict"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).starts_with(
        "invsim: error: internal coordinate eta1 = soc has L_g η ≠ 0: the input acts on `soc` directly"
    ));
}

/// A missing parameter `Q_b` beside `I_b` gets no "did you mean" (one letter of three is another quantity);
/// `m_veh` for `m_vej` does.
#[test]
fn did_you_mean_only_for_close_names() {
    let model = |unknown: &str| {
        format!(
            "[parameters]\nI_b = 1.0\nm_veh = 1000.0\n[states]\nv = {{ rhs = \"(u - {unknown}*v)/m_veh\" }}\n\
             [input]\nname = \"u\"\n[output]\nname = \"y\"\nh = \"v\"\n"
        )
    };
    for (unknown, hint) in [("Q_b", None), ("m_vej", Some("did you mean `m_veh`?"))] {
        let path = tmp(&format!("suggest_{unknown}.toml"));
        std::fs::write(&path, model(unknown)).unwrap();
        let o = invsim(&["derive", path.to_str().unwrap()]);
        assert_eq!(o.status.code(), Some(2));
        let e = stderr(&o);
        assert!(e.contains(&format!("unknown name `{unknown}`")), "{e}");
        match hint {
            Some(h) => assert!(e.contains(h), "{e}"),
            None => assert!(!e.contains("did you mean"), "{e}"),
        }
    }
}

/// The forward run's warnings give the count, the total and the longest interval: si_engine on the NEDC with
/// enforced bounds cannot brake, so the last deceleration (1139.3 s to the end) is the longest.
#[test]
fn forward_warnings_name_the_longest_interval() {
    let o = invsim(&[
        "forward",
        "models/si_engine.toml",
        "--cycle",
        "nedc",
        "--bounds",
        "enforce",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(
        text.contains(
            "warning: the driver's demand for m_at leaves its bounds in 47 interval(s), 369.6 s in total, the \
             longest from t = 1139.3 s to 1180 s; clipped"
        ),
        "{text}"
    );
    assert!(
        text.contains(
            "warning: the vehicle misses the cycle's trace (± 0.5556 m/s around the cycle within ± 1 s, UNECE \
             band) in 14 interval(s), 187.1 s in total, the longest from t = 1145.8 s to 1180 s"
        ),
        "{text}"
    );
}

/// A model with modes driven forward through a launch it cannot make (0 to 35 m/s in 10 s): the warning names the
/// farthest demand's input, value, mode and time.
#[test]
fn the_modal_forward_warning_names_input_mode_and_time() {
    let cycle = tmp("hard_launch.csv");
    std::fs::write(
        &cycle,
        "time_s,speed_mps\n0,0\n5,0\n15,35\n40,35\n60,0\n70,0\n",
    )
    .unwrap();
    let o = invsim(&[
        "forward",
        "models/si_engine_5speed.toml",
        "--cycle",
        cycle.to_str().unwrap(),
        "--bounds",
        "enforce",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(
        text.contains(
            "warning: the driver's demand leaves the bounds of the mode's free input, and no mode absorbs it, in \
             1 interval(s), 9.4 s in total, the longest from t = 9.7 s to 19.1 s; clipped; the farthest at t = \
             14.9 s: `m_at` = 0.3007 kg/s demanded in mode `drive_5` (bound 0.08)"
        ),
        "{text}"
    );
}
