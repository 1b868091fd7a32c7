//! FASTSim's hybrid controller (`pt_cntrl: RGWDB`, RESGreedyWithDynamicBuffers, FASTSim 3.1 hev.rs) as the
//! imported model's own rules for `--strategy rule-based` (`[hybrid]` `rule_request`, `rule_target`,
//! `rule_min_on`; docs/hybrids.md): the model runs as FASTSim's car by default.
//!
//! FASTSim forces the engine on where (any of) the speed exceeds `speed_fc_forced_on`, the SOC is below
//! soc_on(v) = min_soc + c · ½ m max(v_buf² − v², 0) / (E (max_soc − min_soc)) (v_buf, c:
//! `speed_soc_fc_on_buffer*`: the kinetic energy to be recovered), the wheels' power exceeds
//! `frac_pwr_demand_fc_forced_on` · (P_em,max + P_fc,max) or the machine's peak (then electric drive is
//! infeasible anyway) — the machine's allowed power, which FASTSim derates with the battery's discharge power
//! linearly to 0 over the SOC band c_d · ½ m max(v_d² − v², 0) / (E (max_soc − min_soc)) above min_soc
//! (`speed_soc_disch_buffer*`) —, or the engine started less than `fc_min_time_on` ago. Running, it delivers
//! P_e* = min(max(P_tx − P_em,max, f · P_peak), P_tx + P_em,max, P_fc,max), P_peak the power of the table's
//! (first) peak efficiency and f `frac_of_most_eff_pwr_to_run_fc`, the machine absorbing the surplus. With the
//! engine's thermal model (`thermal.rs`) the engine is also forced on while colder than `temp_fc_forced_on`
//! (FASTSim lets it off again above `temp_fc_allowed_off`, a hysteresis the request at the sample does not
//! hold). Where the engine is kept on at a standstill or while braking, FASTSim runs it at that choice too,
//! the machine taking its power to the battery: the model's `stop_charge` and `brake_charge` modes (hev.rs).

use crate::curve::table;
use crate::error::ImportError;
use crate::model::{number, Model};
use crate::yaml::Doc;

const BASE: &str = "pt_type.HEV.pt_cntrl.RGWDB";

/// The generated text the rules add: the `[hybrid]` keys.
pub struct Rules {
    pub hybrid_keys: String,
}

fn p(f: &str) -> String {
    format!("{BASE}.{f}")
}

/// Emit the controller's parameters and the two rule outputs; the charge mode and the `[hybrid]` keys.
/// `thermal`: the model has the engine's temperature `T_fc`.
pub fn emit(
    doc: &Doc,
    model: &mut Model,
    thermal: bool,
    warnings: &mut Vec<String>,
) -> Result<Rules, ImportError> {
    if doc.get(BASE).is_none() {
        return Err(ImportError::field(
            "pt_type.HEV.pt_cntrl",
            "only FASTSim's `RGWDB` controller (RESGreedyWithDynamicBuffers) is imported",
        ));
    }
    for (name, f, unit, what) in [
        ("v_fc_on", "speed_fc_forced_on_meters_per_second", "m/s", "speed above which the engine runs"),
        ("f_dem", "frac_pwr_demand_fc_forced_on", "-", "wheel power, as a fraction of the engine's and the machine's peaks together, above which the engine runs"),
        ("v_soc_on", "speed_soc_fc_on_buffer_meters_per_second", "m/s", "speed whose kinetic energy sets the SOC below which the engine runs"),
        ("k_soc_on", "speed_soc_fc_on_buffer_coeff", "-", "factor of that kinetic energy"),
        ("f_run", "frac_of_most_eff_pwr_to_run_fc", "-", "the engine, when on, runs at least at this fraction of its peak-efficiency power"),
        ("v_disch", "speed_soc_disch_buffer_meters_per_second", "m/s", "speed whose kinetic energy sets the SOC band above the lowest in which the battery's discharge power is derated"),
        ("k_disch", "speed_soc_disch_buffer_coeff", "-", "factor of that kinetic energy"),
    ] {
        model.field(name, doc.num(&p(f))?, unit, what, &p(f))?;
    }
    let min_on = doc.num(&p("fc_min_time_on_seconds"))?;
    crate::limits::check(&p("fc_min_time_on_seconds"), min_on)?;
    let peak = peak_power(doc)?;
    model.constant("P_fc_peak", peak, "W", "engine power at its peak efficiency (FASTSim's fc.pwr_for_peak_eff: the load of the efficiency table's first maximum times the peak power)");
    model.def("soc_fc_on", "soc_min + k_soc_on*0.5*m*max(v_soc_on^2 - v^2, 0)/(E_res*(soc_max - soc_min))", "-", "SOC below which FASTSim's controller runs the engine (the kinetic energy above v to v_soc_on kept in reserve)");
    model.def(
        "P_tx",
        "max(P_w, 0)/eta_t + min(P_w, 0)*eta_t",
        "W",
        "transmission input power the wheels need",
    );
    model.def("soc_disch_band", "k_disch*0.5*m*max(v_disch^2 - v^2, 0)/(E_res*(soc_max - soc_min))", "-", "SOC band above the lowest in which FASTSim derates the battery's discharge power linearly to 0 (reversible_energy_storage.rs set_pwr_disch_max)");
    model.def("P_em_avail", "min(P_em_max, P_res_max*min(max((soc - soc_min)/max(soc_disch_band, 1e-12), 0), 1) - P_aux)", "W", "the machine's driving power FASTSim allows: its peak, at most the derated discharge power less the auxiliaries");
    let mut request = "max(max(sign(v - v_fc_on), sign(soc_fc_on - soc)), max(sign(P_w - f_dem*(P_em_max + P_fc_max)), sign(P_w - P_em_avail)))".to_string();
    let mut why = "speed, low SOC, power demand, the machine's allowed power";
    if cold_request(doc, model, thermal, warnings)? {
        request = format!("max({request}, sign(T_fc_on - T_fc))");
        why = "speed, low SOC, power demand, the machine's allowed power, a cold engine";
    }
    let doc_request = format!(
        "positive where FASTSim's controller runs the engine ({why}): the rules' `rule_request`"
    );
    model.output("fc_request", &request, "-", &doc_request, false);
    model.output("fc_target_error", "P_e - min(min(max(P_tx - P_em_avail, f_run*P_fc_peak), P_tx + P_em_max), P_fc_max)", "W", "engine power less FASTSim's choice with the engine on (at least its peak-efficiency power, the machine absorbing the surplus): the rules' `rule_target`", false);
    warnings.push(format!(
        "`{BASE}`: FASTSim's controller is the model's rules for `--strategy rule-based` ([hybrid] rule_request, rule_target, rule_min_on), evaluated at the sample rather than at the previous step; its regeneration buffer (speed_soc_regen_buffer*) is not reproduced"
    ));
    doc.mark(BASE);
    Ok(Rules {
        hybrid_keys: format!(
            "rule_request = \"fc_request\"\nrule_target = \"fc_target_error\"\nrule_min_on = {}\n",
            number(min_on)
        ),
    })
}

/// Whether the request has a term for a cold engine, `max(…, sign(T_fc_on - T_fc))`: with the thermal model and FASTSim's
/// `temp_fc_forced_on_kelvin` set, the engine runs while colder (its `temp_fc_allowed_off_kelvin`, the
/// temperature above which it may stop again, is warned: the request at the sample has no memory); without
/// the thermal model a set field is warned as not reproduced.
fn cold_request(
    doc: &Doc,
    model: &mut Model,
    thermal: bool,
    warnings: &mut Vec<String>,
) -> Result<bool, ImportError> {
    let on = p("temp_fc_forced_on_kelvin");
    if doc.opt_num(&on)?.is_none_or(f64::is_nan) {
        return Ok(false);
    }
    if !thermal {
        warnings.push(format!(
            "`{on}`: the engine kept on while cold is not reproduced (no engine thermal model)"
        ));
        return Ok(false);
    }
    model.field(
        "T_fc_on",
        doc.num(&on)?,
        "K",
        "the engine runs while its temperature is below this",
        &on,
    )?;
    let off = p("temp_fc_allowed_off_kelvin");
    if let Some(t) = doc.opt_num(&off)?.filter(|t| !t.is_nan()) {
        warnings.push(format!(
            "`{off}`: the engine is forced on below T_fc_on at each sample; FASTSim's hysteresis (on until {} K) \
             is not reproduced",
            crate::model::number(t)
        ));
    }
    Ok(true)
}

/// FASTSim's `pwr_for_peak_eff`: the peak power times the load of the efficiency table's first maximum.
fn peak_power(doc: &Doc) -> Result<f64, ImportError> {
    let curve = table(doc, "pt_type.HEV.fc.eff_interp_from_pwr_out")?;
    let mut best = 0;
    for k in 1..curve.y.len() {
        if curve.y[k] > curve.y[best] {
            best = k;
        }
    }
    Ok(curve.x[best] * doc.num("pt_type.HEV.fc.pwr_out_max_watts")?)
}
