//! FASTSim's engine controls of a conventional vehicle: stop-start (`pt_cntrl: StartStop`) and deceleration
//! fuel cut-off (`dfco_cntrl`), as factors of the fuel power in `[outputs]`.
//!
//! Observed in FASTSim 3.1's histories (the 2026 Pacifica on UDDS, 1 s steps) and reproduced here:
//! - **Fuel cut-off**: no fuel while the speed is at least `minimum_dfco_speed` (10 m/s), the acceleration at
//!   most `minimum_dfco_deceleration` (−0.3 m/s²) and the wheels ask for no traction (P_w ≤ 0); the idle
//!   floor does not apply then.
//! - **Stop-start**: the engine is off (no fuel, not even the idle floor) while the car stands, its speed below
//!   `stopped_speed_threshold` (0.05 m/s); it restarts with the first traction request.
//!
//! With H(x) = max(sign(x), 0) (1 for x > 0, else 0) and the vehicle's acceleration a = (F_t − F_res)/m_eff:
//! P_fuel = H(v − v_stop) · (1 − H(v − v_dfco) H(a_dfco − a) (1 − H(P_w))) · max(P_fc/e, P_idle).
//! Not reproduced (named in a warning): the delay after a stop before the engine may stop and its minimum
//! time on (on FASTSim's 1 s steps the engine is already off in the first whole step at a standstill), the
//! temperature conditions of the thermal model, and any restart fuel (FASTSim books none).

use crate::error::ImportError;
use crate::model::Model;
use crate::yaml::Doc;

/// The controls' factors of the fuel power.
pub struct Factors {
    /// The exact factors (with their trailing `*`) that multiply the fuel power, empty when none is enabled.
    pub exact: String,
    /// The smooth stop-start factor for the thermal state's rhs (`1` without stop-start).
    pub run_s: String,
    /// The smooth fuel cut-off factor for the thermal state's rhs (`1` without fuel cut-off).
    pub fuel_s: String,
}

/// Emit the parameters and definitions of the controls the file enables. With the thermal model
/// (`thermal`), stop-start keeps the engine running while it is colder than `temp_fc_forced_on`.
pub fn emit(
    doc: &Doc,
    model: &mut Model,
    base: &str,
    thermal: bool,
    warnings: &mut Vec<String>,
) -> Result<Factors, ImportError> {
    let mut factors = Vec::new();
    let mut run_s = "1".to_string();
    let mut fuel_s = "1".to_string();
    if let Some(f) = stop_start(doc, model, base, thermal, warnings)? {
        factors.push(f);
        run_s = "c_run_s".to_string();
    }
    if let Some(f) = fuel_cut_off(doc, model, base, thermal)? {
        factors.push(f);
        fuel_s = "c_fuel_s".to_string();
    }
    Ok(Factors {
        exact: factors.iter().map(|f| format!("{f}*")).collect(),
        run_s,
        fuel_s,
    })
}

/// `pt_cntrl`: `Normal` (the engine always runs) or `StartStop`; anything else is refused.
fn stop_start(
    doc: &Doc,
    model: &mut Model,
    base: &str,
    thermal: bool,
    warnings: &mut Vec<String>,
) -> Result<Option<String>, ImportError> {
    let path = format!("{base}.pt_cntrl");
    let Some(v) = doc.get(&path) else {
        return Ok(None);
    };
    if v.as_str() == Some("Normal") {
        return Ok(None);
    }
    let ss = format!("{path}.StartStop");
    if doc.get(&ss).is_none() {
        return Err(ImportError::field(
            &path,
            "expected `Normal` or `StartStop` (the engine controls FASTSim 3.1 defines)",
        ));
    }
    let threshold = format!("{ss}.stopped_speed_threshold_meters_per_second");
    model.field(
        "v_stop",
        doc.num(&threshold)?,
        "m/s",
        "stop-start: the engine is off while the car is slower than this",
        &threshold,
    )?;
    let delay = doc.opt_num(&format!(
        "{ss}.time_delay_after_stop_until_fc_can_turn_off_seconds"
    ))?;
    let on = doc.opt_num(&format!("{ss}.fc_min_time_on_seconds"))?;
    let forced_on = format!("{ss}.temp_fc_forced_on_kelvin");
    let allowed_off = format!("{ss}.temp_fc_allowed_off_kelvin");
    if thermal && doc.opt_num(&forced_on)?.is_some_and(|x| !x.is_nan()) {
        // FASTSim 3.1 (observed): the engine stays on while T_fc < temp_fc_forced_on; its
        // temp_fc_allowed_off has no effect on a conventional vehicle's stop-start.
        model.field(
            "T_fc_on",
            doc.num(&forced_on)?,
            "K",
            "stop-start: the engine runs, even standing, while its temperature is below this",
            &forced_on,
        )?;
        doc.mark(&allowed_off);
        model.def(
            "c_run",
            "1 - (1 - max(sign(v - v_stop), 0))*max(sign(T_fc - T_fc_on), 0)",
            "-",
            "stop-start: 0 while the car stands and the engine is warm (engine off, no fuel), else 1",
        );
        model.def(
            "c_run_s",
            "1 - (1 - 0.5*(1 + tanh((v - v_stop)/0.01)))*0.5*(1 + tanh((T_fc - T_fc_on)/0.1))",
            "-",
            "stop-start factor, smooth (for the thermal state)",
        );
    } else {
        model.def(
            "c_run",
            "max(sign(v - v_stop), 0)",
            "-",
            "stop-start: 1 while the engine runs, 0 while the car stands (engine off, no fuel)",
        );
        if thermal {
            model.def(
                "c_run_s",
                "0.5*(1 + tanh((v - v_stop)/0.01))",
                "-",
                "stop-start factor, smooth (for the thermal state)",
            );
        }
    }
    warnings.push(format!(
        "`{ss}`: the engine stops as soon as the car stands; its delay after a stop ({} s) and minimum time \
         on ({} s) are not reproduced",
        delay.map_or("-".to_string(), crate::model::number),
        on.map_or("-".to_string(), crate::model::number),
    ));
    doc.mark(&ss);
    Ok(Some("c_run".to_string()))
}

/// `dfco_cntrl`: with `dfco_enabled`, the fuel cut-off's speed and deceleration thresholds.
fn fuel_cut_off(
    doc: &Doc,
    model: &mut Model,
    base: &str,
    thermal: bool,
) -> Result<Option<String>, ImportError> {
    let path = format!("{base}.dfco_cntrl");
    let enabled = doc
        .get(&format!("{path}.dfco_enabled"))
        .and_then(serde_yaml::Value::as_bool)
        == Some(true);
    doc.mark(&path);
    if !enabled {
        return Ok(None);
    }
    let speed = format!("{path}.minimum_dfco_speed_meters_per_second");
    model.field(
        "v_dfco",
        doc.num(&speed)?,
        "m/s",
        "fuel cut-off: the lowest speed at which the fuel is cut",
        &speed,
    )?;
    let decel = format!("{path}.minimum_dfco_deceleration_meters_per_second_squared");
    model.field(
        "a_dfco",
        doc.num(&decel)?,
        "m/s^2",
        "fuel cut-off: the fuel is cut at this acceleration or below (a deceleration)",
        &decel,
    )?;
    model.def(
        "c_fuel",
        "1 - max(sign(v - v_dfco), 0)*max(sign(a_dfco - (F_t - F_res)/m_eff), 0)*(1 - max(sign(P_w), 0))",
        "-",
        "fuel cut-off: 0 while the car decelerates at a_dfco or harder above v_dfco without traction, else 1",
    );
    if !thermal {
        return Ok(Some("c_fuel".to_string()));
    }
    model.def(
        "c_fuel_s",
        "1 - 0.5*(1 + tanh((v - v_dfco)/0.02))*0.5*(1 + tanh((a_dfco - a_lag)/0.01))*(1 - 0.5*(1 + tanh((F_res + m_eff*a_lag)*v/10)))",
        "-",
        "fuel cut-off factor, smooth, at the lagged acceleration (for the thermal state)",
    );
    Ok(Some("c_fuel".to_string()))
}
