//! FASTSim 3.1's engine thermal model (`fc.thrml: FuelConverterThermal`) as the internal state `T_fc`, the
//! lumped engine temperature (K), with the ambient temperature as the signal `T_amb` (°C, default 22 °C,
//! FASTSim's default cycle `temp_amb_air`): one model for the conventional and the hybrid import, which differ
//! only in the engine's output power the heat balance sees ([`Coupling`]).
//!
//! FASTSim (fuel_converter.rs, `FuelConverterThermal::solve`; reproduced from its histories on UDDS to within
//! 0.0005 K over the whole cycle), per step of length dt with the previous step's values:
//! - heat into the engine: Q = min(G (T_ad − T), f_max (P_fuel − P_fc)), the fuel power not delivered as
//!   output (P_fc: traction and auxiliary output), at most `max_frac_from_comb` of it, and at most the
//!   conductance `conductance_from_comb` G times the gap to the adiabatic flame temperature T_ad (gasoline,
//!   stoichiometric, from air and octane property tables; here its fit T_ad = a_0 + a_1 T, within 2.4 K over
//!   295–380 K);
//! - heat to the ambient: h A (T − T_amb), A = π L²/4 (L = `length_for_convection`), with the thermostat's
//!   opening s = clamp((T − T_sto)/ΔT, 0, 1) (`tstat_te_sto`, `tstat_te_delta`) and, below 1 m/s,
//!   h = (1 + s ε) h_stop (`radiator_effectiveness` ε, `htc_to_amb_stop`), else h = s · h_sphere, the forced
//!   convection of a sphere (Incropera eq. 7.44, Re ≥ 4·10⁴: Nu = 0.027 Re^0.805 Pr^(1/3)), which is
//!   h_sphere = κ(T_film) L^(−0.195) v^0.805 with κ the air-property factor 0.027 (ρ/μ)^0.805 Pr^(1/3) k at the
//!   film temperature (T + T_amb)/2, here its linear fit (within 0.01 % over film temperatures of 325–340 K);
//! - C dT/dt = Q − h A (T − T_amb) (C = `heat_capacitance`), from the file's initial temperature;
//! - the efficiency while cold: e · c(T), c(T) = max(1 − exp(−(T − T_off)/λ), c_min) (`fc_eff_model:
//!   Exponential` offset, lag, minimum), so P_fuel = max(P_fc/(e c), P_idle) (the idle floor is not scaled).
//!
//! Exact in `[outputs]` (c(T) in the fuel power); smooth in the state's rhs, which may hold no min, max, sign
//! or linear map: H(x) → (1 + tanh(x/w))/2, max(a, b) → (a + b + √((a − b)² + w²))/2 (min likewise), the
//! fuel power over the load as a smooth map of x/e(x). Their widths are far below the scales that matter (a
//! few watts, hundredths of a m/s, a tenth of a kelvin); their effect is measured in `docs/vehicles.md`.

use crate::curve::{Curve, Strategy};
use crate::error::ImportError;
use crate::model::{LinearMap, Model, State};
use crate::yaml::Doc;

/// The adiabatic flame temperature T_ad = A0 + A1·T (K), FASTSim's `te_adiabatic` (air and octane internal
/// energies, 33.7 kWh/gal gasoline at 0.75 kg/l, stoichiometric 14.7), fitted over 295–380 K.
const T_AD_0: f64 = 2898.89026;
const T_AD_1: f64 = 0.86256715;
/// κ(T_film) = κ_r/(1 + γ (T_film − T_r)) (W/(m² K) · m^0.195 / (m/s)^0.805): 0.027 (ρ/μ)^0.805 Pr^(1/3) k of
/// FASTSim's air properties, fitted to its convection coefficients over film temperatures of 325–340 K (the
/// fit there is κ = 0.932812 (7.44484 − 0.00848548 T_film), 0.932812 = 0.7^0.195 for its L = 0.7 m). The
/// rational form stays positive and keeps the heat rejection h A (T − T_amb) increasing in T at every
/// temperature, so the zero dynamics keep one type along any reference.
const KAPPA_R: f64 = 0.932_811_985_920_701_7 * (7.44483605 - 0.00848548 * 330.0);
const GAMMA: f64 = 0.00848548 / (7.44483605 - 0.00848548 * 330.0);
/// The lag of the acceleration that sets the engine's load in the thermal state (s): half FASTSim's 1 s step.
const TAU_A: f64 = 0.5;
/// Sample points per table segment of the smooth fuel map x/e(x).
const SUBDIVISIONS: usize = 8;

/// How the heat balance sees the engine run, as smooth expressions free of the inputs (a state's rhs; the
/// load from the lagged wheel power `P_w_pos_s`, the smooth positive part of (F_res + m_eff a_lag) v).
pub struct Coupling<'a> {
    /// The engine's output power: conventional, P_w_pos_s/η_t + P_aux/η_alt (traction and the alternator);
    /// hybrid, c_on P_w_pos_s/(η_t (1 − ρ)) (the hybrid mode's engine power at its share ρ, 0 with it off).
    pub output_s: &'a str,
    /// The smooth running factor: stop-start's (`c_run_s`), the hybrid's modes (`c_on`), or `1`.
    pub run_s: &'a str,
    /// The smooth fuel cut-off factor (`c_fuel_s`), or `1`.
    pub fuel_s: &'a str,
    /// Start warm, the thermostat just fully open (T_sto + ΔT), instead of at the file's initial temperature.
    pub warm: bool,
}

/// Emit the thermal model if the file has one at `{base}.fc.thrml`: parameters, the smooth heat balance, the
/// state `T_fc`, the signal `T_amb` and the definition `c_cold` (the cold efficiency factor); returns whether it
/// did. `curve` is the engine's efficiency table.
pub fn emit(
    doc: &Doc,
    model: &mut Model,
    (base, curve): (&str, &Curve),
    coupling: &Coupling<'_>,
) -> Result<bool, ImportError> {
    let path = format!("{base}.fc.thrml.FuelConverterThermal");
    if doc.get(&path).is_none() {
        return Ok(false);
    }
    let file_t0 = parameters(doc, model, &path)?;
    let initial = format!("{path}.state.temperature_kelvin");
    let (t0, origin) = if coupling.warm {
        let open = doc.num(&format!("{path}.tstat_te_sto_kelvin"))?
            + doc.num(&format!("{path}.tstat_te_delta_kelvin"))?;
        let origin = format!(
            "initially warm, T_sto + dT_tstat (the thermostat just fully open), not the file's `{initial}` \
             ({} K: --initial T_fc=... for it)",
            crate::model::number(file_t0)
        );
        (open, origin)
    } else {
        (file_t0, format!("initial value `{initial}`"))
    };
    model.constant("T_ad0", T_AD_0, "K", "adiabatic flame temperature T_ad = T_ad0 + T_ad1*T_fc: FASTSim's gasoline `te_adiabatic`, fitted over 295-380 K");
    model.constant(
        "T_ad1",
        T_AD_1,
        "-",
        "adiabatic flame temperature: slope over the engine temperature",
    );
    model.constant("kappa_r", KAPPA_R, "W/(m^2 K) m^0.195 (m/s)^-0.805", "air factor of the sphere's forced convection, 0.027 (rho/mu)^0.805 Pr^(1/3) k = kappa_r/(1 + gamma_k*(T_film - 330 K)): FASTSim's air properties, fitted over 325-340 K");
    model.constant("gamma_k", GAMMA, "1/K", "air factor of the sphere's forced convection: its relative decrease per kelvin of film temperature");
    model.signals.push(crate::model::Signal {
        name: "T_amb".to_string(),
        default: 22.0,
        unit: "degC".to_string(),
        doc: "ambient air temperature for the engine's thermal model; FASTSim's cycle field `temp_amb_air` \
              (default 22 °C; --signal T_amb=...)"
            .to_string(),
    });
    fuel_map(model, curve);
    // Exact, for [outputs]: the cold efficiency factor.
    model.def(
        "c_cold",
        "max(1 - exp(-(T_fc - T_c_off)/T_c_lag), c_cold_min)",
        "-",
        "cold efficiency factor of the engine: its efficiency is e*c_cold",
    );
    heat_balance(model, coupling);
    model.states.push(State {
        name: "T_fc".to_string(),
        rhs: "(Q_fc - h_fc*pi*L_fc^2/4*(T_fc - T_amb_K))/C_fc".to_string(),
        initial: t0,
        unit: "K".to_string(),
        doc: format!(
            "engine temperature: C_fc dT_fc/dt = Q_fc - h_fc A (T_fc - T_amb), A = pi L_fc^2/4; FASTSim \
             `fc.thrml`, {origin}"
        ),
    });
    model.output(
        "T_engine",
        "T_fc - 273.15",
        "degC",
        "engine temperature",
        false,
    );
    model.output(
        "c_cold",
        "c_cold",
        "-",
        "cold efficiency factor of the engine",
        false,
    );
    Ok(true)
}

/// The efficiency divisor of the fuel power with the thermal model: e·c_cold (FASTSim's efficiency while
/// cold, P_fuel = P/(e c(T))); without it `divisor` as it is.
pub fn cold_divisor(divisor: String, thermal: bool) -> String {
    if thermal {
        format!("({divisor}*c_cold)")
    } else {
        divisor
    }
}

/// A thermal model at `{base}.fc.thrml` other than `FuelConverterThermal` is named in a warning (the engine is
/// then warm from the start); `None` is marked as read.
pub fn others(doc: &Doc, base: &str, warnings: &mut Vec<String>) {
    let thrml = format!("{base}.fc.thrml");
    match doc.get(&thrml) {
        Some(v) if v.as_str() == Some("None") => doc.mark(&thrml),
        Some(_) if doc.get(&format!("{thrml}.FuelConverterThermal")).is_some() => {}
        Some(v) if v.is_mapping() => {
            warnings.push(format!(
                "`{thrml}` is a thermal model: it is not reproduced (only `FuelConverterThermal` is; the \
                 engine is warm from the start, so a cold start's extra fuel is not counted)"
            ));
            doc.mark(&thrml);
        }
        _ => {}
    }
}

/// The thermal model's parameters read from `path` (`fc.thrml.FuelConverterThermal`), each checked against its
/// range; returns the initial engine temperature (K).
fn parameters(doc: &Doc, model: &mut Model, path: &str) -> Result<f64, ImportError> {
    let p = |f: &str| format!("{path}.{f}");
    let mut field = |name: &str, f: &str, unit: &str, what: &str| -> Result<(), ImportError> {
        model.field(name, doc.num(&p(f))?, unit, what, &p(f))
    };
    field(
        "C_fc",
        "heat_capacitance_joules_per_kelvin",
        "J/K",
        "engine heat capacitance",
    )?;
    field(
        "L_fc",
        "length_for_convection_meters",
        "m",
        "engine length for convection (a sphere's diameter)",
    )?;
    field(
        "h_fc_stop",
        "htc_to_amb_stop_watts_per_square_meter_kelvin",
        "W/(m^2 K)",
        "engine heat transfer coefficient to the ambient while the car stands (below 1 m/s)",
    )?;
    field(
        "G_fc",
        "conductance_from_comb_watts_per_kelvin",
        "W/K",
        "conductance from the adiabatic flame temperature to the engine",
    )?;
    field(
        "f_comb",
        "max_frac_from_comb",
        "-",
        "largest fraction of the fuel power not delivered (the losses) that heats the engine",
    )?;
    field(
        "T_sto",
        "tstat_te_sto_kelvin",
        "K",
        "thermostat: temperature at which it starts to open",
    )?;
    field(
        "dT_tstat",
        "tstat_te_delta_kelvin",
        "K",
        "thermostat: temperature rise over which it opens fully",
    )?;
    field(
        "eps_rad",
        "radiator_effectiveness",
        "-",
        "radiator effectiveness: the open thermostat's heat rejection over the passive one (standing)",
    )?;
    // FASTSim's init rebuilds `tstat_interp` from T_sto and ΔT (0 → 1 over [T_sto, T_sto + ΔT]).
    doc.mark(&p("tstat_interp"));
    let eff = p("fc_eff_model.Exponential");
    if doc.get(&eff).is_none() {
        return Err(ImportError::field(
            &p("fc_eff_model"),
            "expected `Exponential` (offset, lag, minimum): the other efficiency models are not imported",
        ));
    }
    let mut efield = |name: &str, f: &str, unit: &str, what: &str| -> Result<(), ImportError> {
        let q = format!("{eff}.{f}");
        model.field(name, doc.num(&q)?, unit, what, &q)
    };
    efield(
        "T_c_off",
        "offset",
        "K",
        "cold efficiency: temperature at which the factor vanishes",
    )?;
    efield(
        "T_c_lag",
        "lag",
        "K",
        "cold efficiency: temperature scale of the factor's rise",
    )?;
    efield(
        "c_cold_min",
        "minimum",
        "-",
        "cold efficiency: the factor's lower bound",
    )?;
    let init = p("state.temperature_kelvin");
    let t0 = doc.num(&init)?;
    crate::limits::check(&init, t0)?;
    Ok(t0)
}

/// The smooth heat balance for the rhs of T_fc: the lagged acceleration `a_lag`, the engine's losses, the heat
/// into the engine `Q_fc`, the thermostat and the heat transfer coefficient `h_fc`.
fn heat_balance(model: &mut Model, coupling: &Coupling<'_>) {
    let Coupling {
        output_s,
        run_s,
        fuel_s,
        ..
    } = coupling;
    // Smooth, for the rhs of T_fc.
    let smax = |a: &str, b: &str, w: &str| {
        format!("0.5*(({a}) + ({b}) + sqrt((({a}) - ({b}))^2 + {w}^2))")
    };
    let smin = |a: &str, b: &str, w: &str| {
        format!("0.5*(({a}) + ({b}) - sqrt((({a}) - ({b}))^2 + {w}^2))")
    };
    model.def(
        "T_amb_K",
        "T_amb + 273.15",
        "K",
        "ambient air temperature in kelvin",
    );
    model.def(
        "c_cold_s",
        &smax("1 - exp(-(T_fc - T_c_off)/T_c_lag)", "c_cold_min", "0.001"),
        "-",
        "cold efficiency factor, smooth (for the thermal state)",
    );
    // The heat's dependence on the load enters through a_lag, the vehicle's acceleration lagged by tau_a:
    // FASTSim heats the engine with the previous step's losses (a lag of one step), and a state rhs free of
    // the input keeps the heat exact in the zero dynamics. With F_t in it, the derivation's numeric test of
    // ∂²rhs/∂u² ≡ 0 (probing states and input at O(1) values, where this rhs's curvature in F_t is below
    // its rounding bound) took the rhs as affine and split it into f + g u: the heat, linear in the load,
    // left the engine 39 K colder than FASTSim's on UDDS.
    model.constant(
        "tau_a",
        TAU_A,
        "s",
        "time constant of the lagged acceleration that sets the engine's load in the thermal state (FASTSim heats with the previous step's losses)",
    );
    model.states.push(State {
        name: "a_lag".to_string(),
        rhs: "((F_t - F_res)/m_eff - a_lag)/tau_a".to_string(),
        initial: 0.0,
        unit: "m/s^2".to_string(),
        doc: "the vehicle's acceleration lagged by tau_a: da_lag/dt = (a - a_lag)/tau_a, for the engine's load in the thermal state".to_string(),
    });
    model.def(
        "P_w_s",
        "(F_res + m_eff*a_lag)*v",
        "W",
        "tractive power at the wheels from the lagged acceleration (for the thermal state)",
    );
    model.def(
        "P_w_pos_s",
        &smax("P_w_s", "0", "10"),
        "W",
        "tractive power at the wheels while driving, smooth, from the lagged acceleration (for the thermal state)",
    );
    model.def(
        "P_fc_s",
        output_s,
        "W",
        "engine output power, smooth (for the thermal state)",
    );
    model.def(
        "P_fuel_s",
        &format!(
            "{run_s}*({fuel_s}*{} - P_fc_s)",
            smax("P_fc_max*fc_fuel_map(P_fc_s/P_fc_max)/c_cold_s", "P_idle", "10")
        ),
        "W",
        "fuel power not delivered as engine output (the engine's losses), smooth (for the thermal state)",
    );
    model.def(
        "Q_fc",
        &smin("G_fc*(T_ad0 + T_ad1*T_fc - T_fc)", "f_comb*P_fuel_s", "10"),
        "W",
        "heat into the engine: a fraction of its losses, at most the conduction from the flame",
    );
    model.def(
        "s_tstat",
        &smax(&smin("(T_fc - T_sto)/dT_tstat", "1", "0.02"), "0", "0.02"),
        "-",
        "thermostat opening, 0 (closed) to 1 (open), linear over [T_sto, T_sto + dT_tstat], smooth",
    );
    model.def(
        "m_fc",
        "0.5*(1 + tanh((v - 1)/0.02))",
        "-",
        "1 while the car moves (at least 1 m/s, FASTSim's switch to forced convection), else 0, smooth",
    );
    model.def(
        "h_fc",
        "(1 - m_fc)*(1 + s_tstat*eps_rad)*h_fc_stop + m_fc*s_tstat*kappa_r/(1 + gamma_k*((T_fc + T_amb_K)/2 - 330))*pow(L_fc, -0.195)*pow(v^2 + 1e-4, 0.4025)",
        "W/(m^2 K)",
        "engine heat transfer coefficient to the ambient: standing, passive plus the radiator as the thermostat opens; moving, the thermostat's share of a sphere's forced convection",
    );
}

/// The smooth map `fc_fuel_map`: the fuel power over the peak power, x/e(x), against the load x, sampled at
/// SUBDIVISIONS points per segment of the efficiency table (at a zero efficiency, the limit from the right).
fn fuel_map(model: &mut Model, curve: &Curve) {
    let e = |x: f64| -> f64 {
        let n = curve.x.len();
        let k = curve
            .x
            .iter()
            .rposition(|&xk| xk <= x)
            .unwrap_or(0)
            .min(n - 1);
        if k + 1 >= n || curve.strategy == Strategy::StepLower {
            return curve.y[k];
        }
        let t = (x - curve.x[k]) / (curve.x[k + 1] - curve.x[k]);
        curve.y[k] + t * (curve.y[k + 1] - curve.y[k])
    };
    let mut xs = Vec::new();
    for w in curve.x.windows(2) {
        for j in 0..SUBDIVISIONS {
            xs.push(w[0] + (w[1] - w[0]) * j as f64 / SUBDIVISIONS as f64);
        }
    }
    xs.push(*curve.x.last().unwrap_or(&1.0));
    let mut values: Vec<f64> = xs
        .iter()
        .map(|&x| if e(x) > 0.0 { x / e(x) } else { f64::NAN })
        .collect();
    for k in (0..values.len()).rev() {
        if !values[k].is_finite() {
            values[k] = values.get(k + 1).copied().unwrap_or(0.0);
        }
    }
    model.smooth_maps.push(LinearMap {
        name: "fc_fuel_map".to_string(),
        args: vec!["load".to_string()],
        x: xs,
        y: Vec::new(),
        values,
        unit: "-".to_string(),
        doc: format!(
            "fuel power over peak power, x/e(x), against the load fraction x: derived from FASTSim `{}` at {SUBDIVISIONS} \
             points per segment, smooth (for the thermal state only; the fuel output uses the table itself)",
            curve.path
        ),
    });
}
