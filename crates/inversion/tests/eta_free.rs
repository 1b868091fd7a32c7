//! Which results of the inverse are free of the internal states η (`Derivation::eta_free`, the
//! interpreter's `ModelInfo::eta_free`): a battery of constant voltage against one whose voltage follows the
//! charge, and a state whose closed form reads η.

use invsim_inversion::{Derivation, Model};
use invsim_model_api::EtaFree;
use std::path::Path;

/// A car and its battery: v' = (u − c v)/m, soc' = −I/Q with I = v u/U, U = `voltage`, the chemical power
/// U0 I; y = v.
fn car(voltage: &str) -> EtaFree {
    let text = format!(
        "[parameters]\nc = {{ value = 10.0 }}\nm = {{ value = 1000.0 }}\nQ = {{ value = 1.0e4 }}\n\
         U0 = {{ value = 300.0 }}\nk = {{ value = 50.0 }}\n\
         [definitions]\nU = {{ expr = \"{voltage}\" }}\nI_b = {{ expr = \"v*u/U\" }}\n\
         [states]\nv = {{ rhs = \"(u - c*v)/m\" }}\nsoc = {{ rhs = \"-I_b/Q\", initial = 0.6 }}\n\
         [input]\nname = \"u\"\n[output]\nname = \"y\"\nh = \"v\"\n\
         [outputs]\nP_batt = {{ expr = \"U0*I_b\" }}\nP_w = {{ expr = \"v*u\" }}\nsoc_pct = {{ expr = \"100*soc\" }}\n"
    );
    let model = Model::from_str(Path::new("car.toml"), &text).unwrap_or_else(|e| panic!("{e}"));
    Derivation::new(model)
        .unwrap_or_else(|e| panic!("{e}"))
        .eta_free()
}

#[test]
fn a_battery_of_constant_voltage_prices_free_of_the_charge() {
    let free = car("U0");
    assert!(free.input);
    assert_eq!(free.outputs, [true, true, false]);
}

#[test]
fn a_voltage_that_follows_the_charge_makes_the_battery_power_depend_on_it() {
    let free = car("U0 + k*soc");
    assert!(free.input);
    assert_eq!(free.outputs, [false, true, false]);
}

#[test]
fn a_state_whose_closed_form_reads_eta_and_an_input_that_does() {
    // y = x1 + x2, η = x2 (g_η = 0): x1 = ξ − η, and u = (y' + x1 + x2·x2)/1 reads η through x2².
    let text = "[states]\nx1 = { rhs = \"-x1 + u\" }\nx2 = { rhs = \"-x2\" }\n[input]\nname = \"u\"\n\
                [output]\nname = \"y\"\nh = \"x1 + x2*x2\"\n\
                [outputs]\nu_out = { expr = \"u\" }\nx1_out = { expr = \"x1\" }\nx2_out = { expr = \"2*x2\" }\n";
    let model = Model::from_str(Path::new("xy.toml"), text).unwrap_or_else(|e| panic!("{e}"));
    let d = Derivation::new(model).unwrap_or_else(|e| panic!("{e}"));
    let free = d.eta_free();
    assert!(!free.input, "α = −x1 − 2x2² reads η: {free:?}");
    assert_eq!(free.outputs, [false, false, false]);
    // The interpreter reports the same.
    assert_eq!(invsim_inversion::model_info(&d).eta_free, free);
}
