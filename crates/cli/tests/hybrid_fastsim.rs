//! FASTSim's hybrids imported (`models/vehicles/toyota_prius_2016` and `hyundai_sonata_hybrid_2021`, generated
//! from the vendored YAML by `cargo xtask vehicles`): each runs UDDS with every strategy, ECMS and DP
//! charge-sustaining and not above FASTSim's fuel, the rules J1711-corrected and no better than ECMS; at every
//! sample the fuel power is the engine's power over FASTSim's efficiency table (read from the YAML and
//! interpolated here) and, for the Sonata, its thermal model's factor c(T). The Sonata's engine starts warm (the
//! import's start, 90 °C), as FASTSim runs it in the cross-check (`tests/fastsim/crosscheck.py`). The rules,
//! balanced as FASTSim balances its runs on the legal trace (`--lookahead auto`, as the cross-check runs every
//! vehicle), are within 5 % of FASTSim's fuel on UDDS and HWFET.

use crate::common::{column as col, root, simulate_summary, simulate_with};

const VEHICLES: [&str; 2] = ["toyota_prius_2016", "hyundai_sonata_hybrid_2021"];

/// FASTSim 3.1's fuel energy on UDDS, J, corrected to zero battery energy change (`crosscheck.py`, the
/// Sonata from 90 °C; docs/vehicles.md §6).
fn fastsim_udds(stem: &str) -> f64 {
    if stem == VEHICLES[0] {
        14.26e6
    } else {
        17.30e6
    }
}

/// Runs `simulate --cycle udds --dt 1 --strategy STRATEGY`: the summary JSON and the CSV.
fn run(stem: &str, strategy: &str) -> (serde_json::Value, Vec<String>, Vec<Vec<String>>) {
    let model = format!("models/vehicles/{stem}.toml");
    let args = [
        model.as_str(),
        "--cycle",
        "udds",
        "--dt",
        "1",
        "--strategy",
        strategy,
    ];
    simulate_with(&args, &format!("fastsim_hev_{stem}_{strategy}"))
}

/// FASTSim's engine efficiency table (grid, values) from the vendored YAML.
fn fc_table(stem: &str) -> (Vec<f64>, Vec<f64>) {
    let text =
        std::fs::read_to_string(root().join(format!("models/vehicles/{stem}.yaml"))).unwrap();
    let y = invsim_import::parse_yaml(&text).unwrap();
    let t = &y["pt_type"]["HEV"]["fc"]["eff_interp_from_pwr_out"]["data"];
    let grid = t["grid"][0].as_sequence().unwrap();
    let values = t["values"].as_sequence().unwrap();
    (
        grid.iter().map(|x| x.as_f64().unwrap()).collect(),
        values.iter().map(|x| x.as_f64().unwrap()).collect(),
    )
}

/// Linear interpolation held at the end values.
fn interp((x, y): &(Vec<f64>, Vec<f64>), a: f64) -> f64 {
    if a <= x[0] {
        return y[0];
    }
    for k in 1..x.len() {
        if a <= x[k] {
            return y[k - 1] + (y[k] - y[k - 1]) * (a - x[k - 1]) / (x[k] - x[k - 1]);
        }
    }
    y[y.len() - 1]
}

#[test]
fn fastsim_hybrids_run_udds_with_every_strategy() {
    // The two vehicles side by side (six runs of a few seconds each).
    std::thread::scope(|scope| {
        for stem in VEHICLES {
            scope.spawn(move || check_vehicle(stem));
        }
    });
}

/// One vehicle's three runs: charge sustaining, the fuel power against FASTSim's table, ECMS no worse than the
/// rules.
fn check_vehicle(stem: &str) {
    let table = fc_table(stem);
    let mut corrected = Vec::new();
    for strategy in ["ecms", "dp", "rule-based"] {
        let (v, header, rows) = run(stem, strategy);
        let h = &v["hybrid"];
        let dsoc = h["delta_soc"].as_f64().unwrap();
        if strategy == "rule-based" {
            // Not charge-sustaining by construction, and corrected: one run from the middle of the SOC
            // window (the import's start, FASTSim's first balancing run's) ends within 0.1 of it (measured
            // −0.075 for the Sonata; FASTSim's own first runs drift up to 0.03 on UDDS and HWFET).
            assert!(dsoc.abs() < 0.1, "{stem} {strategy}: ΔSOC {dsoc}");
        } else {
            assert!(dsoc.abs() <= 1e-4, "{stem} {strategy}: ΔSOC {dsoc}");
            assert_eq!(h["charge_sustaining"].as_bool(), Some(true), "{stem}");
        }
        corrected.push(h["fuel_energy_corrected_j"].as_f64().unwrap());
        // The fuel power is P_e/(e(P_e/P_fc_max) c(T)) with FASTSim's table, at every sample the engine runs
        // (c = 1 without the thermal model).
        let (p_e, fuel) = (
            col(&header, &rows, "P_engine"),
            col(&header, &rows, "fuel_energy"),
        );
        let cold = if header.iter().any(|h| h == "c_cold") {
            col(&header, &rows, "c_cold")
        } else {
            vec![1.0; rows.len()]
        };
        let p_max = v["inputs"][0]["upper_bound"].as_f64().unwrap();
        assert_eq!(v["inputs"][0]["name"], "P_e");
        for ((p, f), c) in p_e.iter().zip(&fuel).zip(&cold) {
            if *p > 0.0 {
                let expected = p / (interp(&table, p / p_max) * c);
                assert!(
                    (f - expected).abs() <= 1e-9 * expected,
                    "{stem} {strategy}: {f} vs {expected}"
                );
            }
        }
    }
    // A few MJ of fuel over UDDS (FASTSim's own figures: Prius 14.3 MJ, Sonata warm 12 to 14 MJ).
    for c in &corrected {
        assert!((8e6..2e7).contains(c), "{stem}: {corrected:?}");
    }
    assert!(
        corrected[0] <= corrected[2],
        "{stem}: ECMS above the rules: {corrected:?}"
    );
    // ECMS and DP not above FASTSim's own controller.
    for c in &corrected[..2] {
        assert!(*c <= fastsim_udds(stem), "{stem}: {corrected:?}");
    }
}

/// The rules balanced as FASTSim balances its runs (`balance_soc`, as `crosscheck.py` does): the first from
/// the model's start (the middle of the SOC window), each next from the charge where the previous ended, until
/// the battery's energy change is below 0.5 % of the fuel's (at most 5 runs), on the legal trace
/// (`--lookahead auto`); within 5 % of FASTSim's fuel (corrected to zero battery energy change;
/// docs/vehicles.md §6). FASTSim 14.26 and 17.72 MJ (the Prius on UDDS and HWFET; measured +0.7 % and
/// −0.4 %), 17.30 and 20.03 MJ (the Sonata; measured −4.1 % and −1.9 %).
#[test]
fn balanced_rules_are_within_five_percent_of_fastsim() {
    std::thread::scope(|scope| {
        for (stem, cycle, reference) in [
            (VEHICLES[0], "udds", fastsim_udds(VEHICLES[0])),
            (VEHICLES[0], "hwfet", 17.72e6),
            (VEHICLES[1], "udds", fastsim_udds(VEHICLES[1])),
            (VEHICLES[1], "hwfet", 20.03e6),
        ] {
            scope.spawn(move || check_balanced_rules(stem, cycle, reference));
        }
    });
}

/// One vehicle's balanced rules on `cycle` against FASTSim's corrected fuel `reference`, J.
fn check_balanced_rules(stem: &str, cycle: &str, reference: f64) {
    let model = format!("models/vehicles/{stem}.toml");
    let mut soc0: Option<String> = None;
    let mut fuel = f64::NAN;
    let mut balance = f64::NAN;
    for _ in 0..5 {
        let mut args = vec![
            model.as_str(),
            "--cycle",
            cycle,
            "--dt",
            "1",
            "--strategy",
            "rule-based",
            "--lookahead",
            "auto",
        ];
        let initial = soc0.as_deref().map(|s| format!("soc={s}"));
        if let Some(i) = &initial {
            args.extend(["--initial", i.as_str()]);
        }
        let (v, _) = simulate_summary(&args, &format!("fastsim_hev_{stem}_{cycle}_rules"));
        let h = &v["hybrid"];
        fuel = h["fuel_energy_corrected_j"].as_f64().unwrap();
        balance =
            h["battery_energy_j"].as_f64().unwrap().abs() / h["fuel_energy_j"].as_f64().unwrap();
        if balance < 0.005 {
            break;
        }
        soc0 = Some(format!("{:?}", h["soc_end"].as_f64().unwrap()));
    }
    assert!(
        balance < 0.005,
        "{stem} {cycle}: battery energy {balance} of the fuel's"
    );
    let diff = fuel / reference - 1.0;
    assert!(
        diff.abs() <= 0.05,
        "{stem} {cycle}: {fuel} J: {:+.2} %",
        100.0 * diff
    );
}

/// `--strategy rule-based` follows the imported model's own rules (FASTSim's controller, `[hybrid]`
/// `rule_request = "fc_request"`, `rule_target = "fc_target_error"`): never electric drive where
/// `fc_request` asks for the engine, and with the engine on its power at FASTSim's choice (the target within
/// 1 W) at 99 % of the samples or more — measured: every sample of both on UDDS (the machine's power from
/// the engine's, P_c, takes what the engine's choice leaves over the demand).
#[test]
fn the_rules_are_the_models_own() {
    for stem in VEHICLES {
        let (_, header, rows) = run(stem, "rule-based");
        let mode = col(&header, &rows, "mode");
        let request = col(&header, &rows, "fc_request");
        let error = col(&header, &rows, "fc_target_error");
        let p_e = col(&header, &rows, "P_engine");
        let p_m = col(&header, &rows, "P_m");
        let electric = (0..rows.len()).filter(|&i| p_e[i] == 0.0 && p_m[i] > 0.0);
        for i in electric {
            assert!(
                request[i] <= 0.0,
                "{stem}: electric at row {i} (mode {}) while the engine is requested",
                mode[i]
            );
        }
        let on: Vec<usize> = (0..rows.len()).filter(|&i| p_e[i] > 0.0).collect();
        let at_target = on.iter().filter(|&&i| error[i].abs() <= 1.0).count();
        assert!(
            !on.is_empty() && at_target * 100 >= on.len() * 99,
            "{stem}: {at_target} of {} engine samples at the target",
            on.len()
        );
    }
}
