//! A hybrid (`pt_type: HEV`): FASTSim's parallel hybrid as an invsim model with modes (docs/hybrids.md) —
//! the engine (fuel converter) and the electric machine both drive the transmission's input shaft, the
//! battery (res) feeds the machine and the auxiliary load; the energy-management strategy decides the split.
//!
//! FASTSim (hev.rs, fuel_converter.rs, electric_machine.rs, reversible_energy_storage.rs, transmission.rs) is
//! power-based: P_tx = P_w/η_t when driving, P_w η_t when braking, shared as P_tx = P_e + P_m (engine and
//! machine shaft powers); engine efficiency e_fc(P_e/P_e,max), fuel power P_e/e_fc while the engine runs;
//! machine P_el,m = P_m/e_em(P_m/P_m,max) driving and P_m e_em(0) regenerating; battery terminal power
//! P_el = P_el,m + P_aux (the auxiliaries on the battery, FASTSim's `AuxOnResPriority`), chemical power
//! P_el/η_res discharging and P_el η_res charging, SOC' = −P_chem/E_res.
//! An engine thermal model in the file (`fc.thrml: FuelConverterThermal`, the Sonata's) is imported as for a
//! conventional vehicle (`thermal.rs`): the efficiency while cold e·c(T), the state `T_fc`.

use crate::curve::{scalar, table, Curve, Strategy};
use crate::error::ImportError;
use crate::model::{Input, LinearMap, Model, State};
use crate::yaml::Doc;

const BASE: &str = "pt_type.HEV";

/// The speed below which the powers' conversion to a force is regularised, m/s: F = P/sqrt(v² + v_ε²).
const V_EPS: f64 = 0.1;
/// The power scale of the smooth positive part (P + sqrt(P² + p_ε²))/2, W: within p_ε/2 of max(P, 0).
const P_EPS: f64 = 1.0;

/// Emit the powertrain, its six modes and the `[hybrid]` table.
pub fn emit(doc: &Doc, model: &mut Model, warnings: &mut Vec<String>) -> Result<(), ImportError> {
    parameters(doc, model)?;
    let (fc, thermal) = engine(doc, model, warnings)?;
    let em = machine(doc, model)?;
    battery(doc, model, warnings)?;
    forces(model);
    rolling_at_standstill(model);
    inputs(doc, model, fc, em)?;
    outputs(model);
    let rules = crate::hev_rules::emit(doc, model, thermal, warnings)?;
    model.tail = tail(&rules, thermal);
    not_reproduced(doc, warnings);
    Ok(())
}

fn p(f: &str) -> String {
    format!("{BASE}.{f}")
}

/// The transmission, the regularisations and the modes' switches.
fn parameters(doc: &Doc, model: &mut Model) -> Result<(), ImportError> {
    let (eta_t, eta_t_path) = scalar(doc, &p("transmission.eff_interp"))?;
    model.field("eta_t", eta_t, "-", "transmission efficiency", &eta_t_path)?;
    model.constant("v_eps", V_EPS, "m/s", "speed scale of the power-to-force conversion F = P/sqrt(v^2 + v_eps^2) (exact within 0.5 % above 1 m/s; at a standstill the standstill mode holds the car)");
    model.constant(
        "p_eps",
        P_EPS,
        "W",
        "power scale of the smooth positive part pos(P) = (P + sqrt(P^2 + p_eps^2))/2 (within p_eps/2 of max(P, 0)): the battery's equations enter the charge's rate, which must be smooth",
    );
    model.constant(
        "c_on",
        1.0,
        "-",
        "1 with the engine running, 0 with it off (the modes set it)",
    );
    Ok(())
}

/// The engine: peak power, idle fuel, efficiency over the load fraction (linear, in the outputs only), and its
/// thermal model where the file has one (`thermal.rs`, as for a conventional vehicle): the state `T_fc`, the
/// efficiency while cold e·c(T). Whether the thermal model was emitted is in the second value.
fn engine(
    doc: &Doc,
    model: &mut Model,
    warnings: &mut Vec<String>,
) -> Result<(f64, bool), ImportError> {
    let max = doc.num(&p("fc.pwr_out_max_watts"))?;
    model.field(
        "P_fc_max",
        max,
        "W",
        "engine peak power",
        &p("fc.pwr_out_max_watts"),
    )?;
    if crate::fuel::idle_and_energy(doc, model, BASE, warnings)? {
        model.output("fuel", "P_fuel/e_f", "kg/s", "fuel mass flow: the model's answer (the [headline], in l/100 km, mpg and CO2 g/km as petrol)", true);
        model.headline("fuel", Some("petrol"));
    }
    let curve = table(doc, &p("fc.eff_interp_from_pwr_out"))?;
    let eff = crate::efficiency::emit(model, "fc", &curve, "P_e/P_fc_max", "engine efficiency")?;
    let divisor = crate::fuel::divisor(&curve, &eff);
    // The hybrid mode's engine power is P_tx + P_c, P_tx = P_w/eta_t while driving (F_t above); the heat sees
    // it from the lagged wheel power, free of the free input as a state's rhs must be (P_c is decided).
    // The engine starts warm: ECMS, pricing each interval alone, cannot warm a cold one (docs/hybrids.md).
    let coupling = crate::thermal::Coupling {
        output_s: "c_on*(P_w_pos_s/eta_t + P_c)",
        run_s: "c_on",
        fuel_s: "1",
        warm: true,
    };
    let thermal = crate::thermal::emit(doc, model, (BASE, &curve), &coupling)?;
    if thermal {
        warnings.push(format!(
            "`{BASE}.fc.thrml.FuelConverterThermal.state.temperature_kelvin`: the engine starts warm, its \
             thermostat just fully open (T_fc = T_sto + dT_tstat), as the strategies are compared on a hot \
             start; FASTSim's cold start from the file's temperature with --initial T_fc=... (ECMS cannot \
             warm a cold engine: the rules or DP can)"
        ));
    }
    crate::thermal::others(doc, BASE, warnings);
    let divisor = crate::thermal::cold_divisor(divisor, thermal);
    model.def(
        "P_fuel",
        &format!("c_on*max(P_e/{divisor}, P_idle)"),
        "W",
        "fuel power while the engine runs, at least the idle fuel power; 0 with the engine off",
    );
    Ok((max, thermal))
}

/// The machine: peak power and its efficiency table as a smooth map (it enters the charge's rate).
fn machine(doc: &Doc, model: &mut Model) -> Result<f64, ImportError> {
    let max = doc.num(&p("em.pwr_out_max_watts"))?;
    model.field(
        "P_em_max",
        max,
        "W",
        "electric machine peak power (drive and regeneration)",
        &p("em.pwr_out_max_watts"),
    )?;
    let curve = table(doc, &p("em.eff_interp_achieved"))?;
    smooth_map(model, "em", &curve, "electric machine efficiency")?;
    doc.mark(&p("em.eff_interp_at_max_input"));
    Ok(max)
}

/// A linear FASTSim table as a map with `interp = "smooth"` (the kernel-smoothed interpolant, contract §6).
fn smooth_map(
    model: &mut Model,
    prefix: &str,
    curve: &Curve,
    what: &str,
) -> Result<(), ImportError> {
    if curve.strategy != Strategy::Linear {
        return Err(ImportError::field(
            &format!("{}.strategy", curve.path),
            "a hybrid's machine efficiency must be interpolated linearly (`Linear`): it enters the battery's charge rate, which must be smooth",
        ));
    }
    model.smooth_maps.push(LinearMap {
        name: format!("{prefix}_map"),
        args: vec!["load".to_string()],
        x: curve.x.clone(),
        y: Vec::new(),
        values: curve.y.clone(),
        unit: "-".to_string(),
        doc: format!(
            "{what} over the load fraction: FASTSim's linear interpolation smoothed by the kernel over half the \
             smallest grid spacing (it enters the charge's rate); FASTSim `{}` (x: `data.grid[0]`, values: `data.values`)",
            curve.path
        ),
    });
    Ok(())
}

/// The battery: capacity, peak power, efficiency (constant or the C-rate × temperature table), initial SOC.
fn battery(doc: &Doc, model: &mut Model, warnings: &mut Vec<String>) -> Result<(), ImportError> {
    let peak = "battery peak power (not enforced: see the warnings)";
    crate::battery::peak_power_and_capacity(doc, model, &p("res"), peak)?;
    for (name, f, what) in [
        (
            "soc_min",
            "res.min_soc",
            "lowest state of charge FASTSim allows",
        ),
        (
            "soc_max",
            "res.max_soc",
            "highest state of charge FASTSim allows",
        ),
    ] {
        model.field(name, doc.num(&p(f))?, "-", what, &p(f))?;
    }
    let table = crate::battery::efficiency(doc, model, &p("res.eff_interp"), warnings)?;
    model.def("P_mach", "P_m - P_r - P_c - rho*P_e", "W", "machine shaft power: driving alone (P_m), regenerating (P_r), taking P_c of the engine's power in the hybrid mode (charging for P_c > 0, assisting for P_c < 0), or all of it in the charging modes (rho = 1)");
    model.def(
        "P_m_pos",
        "(P_mach + sqrt(P_mach^2 + p_eps^2))/2",
        "W",
        "machine shaft power while driving: the smooth positive part of P_mach",
    );
    model.def("P_el_m", "P_m_pos/em_map(P_m_pos/P_em_max) + (P_mach - P_m_pos)*em_map(0)", "W", "machine electrical power: driving P/e_em(P/P_em_max), regenerating at the table's zero-load efficiency (FASTSim's electric_machine.rs)");
    model.def(
        "P_el",
        "P_el_m + P_aux",
        "W",
        "battery terminal power: the machine and the auxiliary load (FASTSim's AuxOnResPriority)",
    );
    model.def(
        "P_el_pos",
        "(P_el + sqrt(P_el^2 + p_eps^2))/2",
        "W",
        "battery terminal power while discharging: the smooth positive part of P_el",
    );
    if table == crate::battery::Efficiency::Table {
        // The table enters the charge's rate: smooth (FASTSim interpolates it bilinearly).
        if let Some(mut m) = model.maps.pop() {
            m.doc = format!("{}; smoothed by the kernel over half the smallest grid spacing per axis (it enters the charge's rate)", m.doc);
            model.smooth_maps.push(m);
        }
        model.def("eta_res", "res_map(P_el/(E_res/3600), T_res)", "-", "battery efficiency, each way, at the C-rate of the terminal power and the cell temperature");
    }
    model.def("P_chem", "P_el_pos/eta_res + (P_el - P_el_pos)*eta_res", "W", "battery chemical power: P_el/eta_res discharging, P_el*eta_res charging (FASTSim's reversible_energy_storage.rs)");
    let (soc0, from) = initial_soc(doc)?;
    model.states.push(State {
        name: "soc".to_string(),
        rhs: "-P_chem/E_res".to_string(),
        initial: soc0,
        unit: "-".to_string(),
        doc: format!("battery state of charge, a fraction of the capacity: d(SOC)/dt = -P_chem/E_res; initially {from}"),
    });
    Ok(())
}

/// The charge a run starts with, and where it comes from: with `sim_params.balance_soc` FASTSim's walk starts
/// its first run in the middle of [min_soc, max_soc] (and the next ones where the previous ended, until the
/// battery's energy change is below `res_per_fuel_lim` of the fuel's), not at the file's `res.state.soc`.
fn initial_soc(doc: &Doc) -> Result<(f64, String), ImportError> {
    let balance = doc
        .get(&p("sim_params.balance_soc"))
        .and_then(serde_yaml::Value::as_bool);
    let soc0 = doc.num(&p("res.state.soc"))?;
    crate::limits::check(&p("res.state.soc"), soc0)?;
    if balance != Some(true) {
        return Ok((soc0, format!("FASTSim `{}`", p("res.state.soc"))));
    }
    let mid = 0.5 * (doc.num(&p("res.min_soc"))? + doc.num(&p("res.max_soc"))?);
    let from = format!(
        "the middle of [soc_min, soc_max], where FASTSim's walk starts with `{}` (not `res.state.soc`)",
        p("sim_params.balance_soc")
    );
    Ok((mid, from))
}

/// The tractive force from the shaft powers (before the chassis's P_w = F_t v, which uses it).
fn forces(model: &mut Model) {
    let f_t = crate::model::Item {
        name: "F_t".to_string(),
        expr: "(eta_t*((1 - rho)*P_e - P_c + P_m) - P_r/eta_t)/sqrt(v^2 + v_eps^2) - F_b".to_string(),
        unit: "N".to_string(),
        doc: "tractive force at the wheels: the transmission input power while driving (the engine's less what the machine takes of it, P_c in the hybrid mode or all with rho = 1, and the machine's alone) times eta_t, less the regenerated power over eta_t and the friction brakes (FASTSim: P_w = eta_t P_tx driving, P_tx/eta_t braking); each mode's power flows one way".to_string(),
        accumulate: None,
    };
    model.defs.insert(0, f_t);
}

/// The rolling resistance faded out below v_eps, m g c_r cos(atan(grade)) tanh(v/v_eps) (within 0.5 % above
/// 0.3 m/s; FASTSim books it with the step's mean speed, so at a standstill it costs nothing): otherwise the
/// standstill mode, whose brakes can only hold, would have to push the car against it.
fn rolling_at_standstill(model: &mut Model) {
    if let Some(d) = model.defs.iter_mut().find(|d| d.name == "F_res") {
        d.expr = "0.5*rho_a*C_d*A_f*v^2 + m*g_0*(c_r*cos(atan(grade))*tanh(v/v_eps) + grade)"
            .to_string();
        d.doc = format!("{}; the rolling resistance faded out below v_eps by tanh(v/v_eps), so that a standing car needs no force", d.doc);
    }
}

/// The inputs: the engine's power, the machine's power taken from the engine's in the hybrid mode (either
/// sign: charging or assisting) and its switch to all of it in the charging modes, the machine driving alone
/// or regenerating, the friction brakes up to 1 g. The engine's power is free in the hybrid mode, so its
/// transmission input P_e − P_c is the wheels' demand, positive: the power flows one way (a mode whose power
/// could flow either way through the transmission with one efficiency would gain 1/eta_t^2 of the braking
/// power). The strategy decides P_c, held over a step as FASTSim's controller holds its powers; the engine
/// follows the demand within the step (deciding a share of the engine's power instead, P_e = P_tx/(1 − share)
/// multiplied the demand's change within a step by up to 1/(1 − share), 100 at a share of 0.99).
fn inputs(doc: &Doc, model: &mut Model, fc: f64, em: f64) -> Result<(), ImportError> {
    let mass = doc.num("mass_kilograms")?;
    let input = |name: &str, min: f64, max: f64, unit: &str, doc: &str| Input {
        name: name.to_string(),
        min,
        max,
        unit: unit.to_string(),
        doc: doc.to_string(),
    };
    model.inputs = vec![
        input("P_e", 0.0, fc, "W", "engine shaft power, up to its peak (FASTSim `fc.pwr_out_max_watts`)"),
        input("P_c", -em, em, "W", "in the hybrid mode, the machine's shaft power taken from the engine's: charging for P_c > 0, assisting (adding -P_c) for P_c < 0, up to the machine's peak (FASTSim `em.pwr_out_max_watts`)"),
        input("rho", 0.0, 1.0, "-", "1 in the charging modes at a standstill and while braking (the machine takes all the engine's power), 0 elsewhere"),
        input("P_m", 0.0, em, "W", "electric machine shaft power driving alone, up to its peak (FASTSim `em.pwr_out_max_watts`)"),
        input("P_r", 0.0, em, "W", "electric machine shaft power regenerating (braking), up to its peak (FASTSim `em.pwr_out_max_watts`)"),
        input("F_b", 0.0, mass * crate::chassis::GRAVITY, "N", "friction brake force, up to the vehicle's weight (1 g)"),
    ];
    Ok(())
}

fn outputs(model: &mut Model) {
    model.output(
        "fuel_energy",
        "P_fuel",
        "W",
        "fuel power; its integral is FASTSim's `fc.energy_fuel_joules`",
        true,
    );
    model.output("battery_power", "P_chem", "W", "battery chemical power, positive discharging; its integral is FASTSim's `res.energy_out_chemical_joules`", true);
    model.output("P_wheel", "P_w", "W", "tractive power at the wheels", false);
    model.output("P_engine", "P_e", "W", "engine shaft power", false);
    model.output(
        "P_motor",
        "P_mach",
        "W",
        "electric machine shaft power, negative regenerating or charging",
        false,
    );
    model.output(
        "fc_load",
        "P_e/P_fc_max",
        "-",
        "engine load fraction",
        false,
    );
    model.output("eff_engine", "eff_fc", "-", "engine efficiency", false);
}

/// The modes, the standstill thresholds and the `[hybrid]` table. FASTSim runs the engine also at a
/// standstill and while braking where its controller keeps it on (the least running time, a low charge), the
/// machine taking all its power to the battery (hev.rs: P_e* above P_tx, the machine absorbing the rest):
/// `stop_charge` and `brake_charge` (rho = 1: the machine takes all the engine's power), whose decided P_e
/// the rules set to the controller's choice as in the hybrid mode.
fn tail(rules: &crate::hev_rules::Rules, thermal: bool) -> String {
    let head = r#"
[sequence]
standstill_below = 0.05
standstill_above = 1.0

[modes.hybrid]               # engine on: the machine's power from the engine's decided by the strategy, the engine's power free
free = "P_e"
decided = ["P_c"]
inputs = { rho = 0.0, P_m = 0.0, P_r = 0.0, F_b = 0.0 }
[modes.electric]             # engine off: the machine alone
free = "P_m"
inputs = { P_e = 0.0, P_c = 0.0, rho = 0.0, P_r = 0.0, F_b = 0.0 }
parameters = { c_on = 0.0 }
[modes.brake]                # engine off: the machine regenerates as decided, the friction brakes take the rest
free = "F_b"
role = "brake"
decided = ["P_r"]
inputs = { P_e = 0.0, P_c = 0.0, rho = 0.0, P_m = 0.0 }
parameters = { c_on = 0.0 }
[modes.stop]                 # standstill, engine off: the auxiliaries on the battery
free = "F_b"
role = "standstill"
inputs = { P_e = 0.0, P_c = 0.0, rho = 0.0, P_m = 0.0, P_r = 0.0 }
parameters = { c_on = 0.0 }
[modes.stop_charge]          # standstill, engine on: its power (decided) charges the battery through the machine
free = "F_b"
role = "standstill"
decided = ["P_e"]
inputs = { P_c = 0.0, rho = 1.0, P_m = 0.0, P_r = 0.0 }{heat}
[modes.brake_charge]         # braking, engine on: the machine takes the engine's power (decided) and brakes alone
free = "P_r"
role = "brake"
decided = ["P_e"]
inputs = { P_c = 0.0, rho = 1.0, P_m = 0.0, F_b = 0.0 }{heat}

[hybrid]
fuel_power = "fuel_energy"
battery_power = "battery_power"
soc = "soc"
engine_on = ["hybrid", "stop_charge", "brake_charge"]
start_penalty = 0.0
grid = 11
{keys}"#;
    // With the thermal model the engine's heat sees its power, decided in these modes (not the wheels').
    let heat = match thermal {
        true => "\ndefinitions = { P_fc_s = \"P_e\" }",
        false => "",
    };
    head.replace("{heat}", heat)
        .replace("{keys}", &rules.hybrid_keys)
}

/// What FASTSim's hybrid does that the model does not: each field read only to name it here.
fn not_reproduced(doc: &Doc, warnings: &mut Vec<String>) {
    let mut said = Vec::new();
    for (f, what) in [
        ("res.min_soc", "the SOC limits are parameters (soc_min, soc_max) but not enforced: a charge-sustaining run stays near its start"),
        ("fc.pwr_out_max_init_watts", "the engine's power ramp (pwr_out_max_init_watts, pwr_ramp_lag_seconds) is not reproduced"),
        ("aux_cntrl", "the auxiliaries are always on the battery (AuxOnResPriority; the battery's power limit is not enforced)"),
        ("sim_params", "FASTSim's SOC balancing is the run's start (the middle of the SOC window, as FASTSim's first iteration) and the strategies' charge-sustaining runs and J1711 correction; its further iterations from the previous run's end are `--initial soc=...`"),
    ] {
        let path = p(f);
        if doc.get(&path).is_some_and(|v| v.as_str() != Some("None")) {
            said.push(format!("`{path}`: {what}"));
        }
        doc.mark(&path);
    }
    for f in [
        "fc.pwr_ramp_lag_seconds",
        "soc_bal_iter_history",
        "soc_bal_iters",
    ] {
        doc.mark(&p(f));
    }
    warnings.extend(said);
}
