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

/// Emit the parameters and definitions of the controls the file enables; returns the factor (with its
/// trailing `*`) that multiplies the fuel power, empty when none is enabled.
pub fn emit(
    doc: &Doc,
    model: &mut Model,
    base: &str,
    warnings: &mut Vec<String>,
) -> Result<String, ImportError> {
    let mut factors = Vec::new();
    if let Some(f) = stop_start(doc, model, base, warnings)? {
        factors.push(f);
    }
    if let Some(f) = fuel_cut_off(doc, model, base)? {
        factors.push(f);
    }
    Ok(factors.iter().map(|f| format!("{f}*")).collect())
}

/// `pt_cntrl`: `Normal` (the engine always runs) or `StartStop`; anything else is refused.
fn stop_start(
    doc: &Doc,
    model: &mut Model,
    base: &str,
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
    model.def(
        "c_run",
        "max(sign(v - v_stop), 0)",
        "-",
        "stop-start: 1 while the engine runs, 0 while the car stands (engine off, no fuel)",
    );
    let delay = doc.opt_num(&format!(
        "{ss}.time_delay_after_stop_until_fc_can_turn_off_seconds"
    ))?;
    let on = doc.opt_num(&format!("{ss}.fc_min_time_on_seconds"))?;
    warnings.push(format!(
        "`{ss}`: the engine stops as soon as the car stands; its delay after a stop ({} s) and minimum time \
         on ({} s) are not reproduced, nor the thermal model's temperature conditions",
        delay.map_or("-".to_string(), crate::model::number),
        on.map_or("-".to_string(), crate::model::number),
    ));
    doc.mark(&ss);
    Ok(Some("c_run".to_string()))
}

/// `dfco_cntrl`: with `dfco_enabled`, the fuel cut-off's speed and deceleration thresholds.
fn fuel_cut_off(doc: &Doc, model: &mut Model, base: &str) -> Result<Option<String>, ImportError> {
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
    Ok(Some("c_fuel".to_string()))
}
