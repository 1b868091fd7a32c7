//! A battery-electric vehicle (`pt_type: BEV`): transmission, electric machine with its efficiency table
//! (regeneration at the table's zero-load efficiency), battery with its efficiency each way (`battery.rs`).

use crate::curve::{scalar, table};
use crate::efficiency;
use crate::error::ImportError;
use crate::model::Model;
use crate::yaml::Doc;

const BASE: &str = "pt_type.BEV";

/// Emit the powertrain. FASTSim (transmission.rs, electric_machine.rs, reversible_energy_storage.rs):
/// P_em = P_w/η_t when driving, P_w η_t when braking, regeneration limited to the machine's peak power (the
/// rest goes to the friction brakes); P_el = P_em/e(P_em/P_em,max) when driving, P_em e(0) when regenerating,
/// plus P_aux; chemical power P_chem = P_el/η_res when discharging, P_el η_res when charging (the charge
/// power limited to the battery's peak power); the battery energy is ∫ P_chem = ΔSOC × capacity.
pub fn emit(doc: &Doc, model: &mut Model, warnings: &mut Vec<String>) -> Result<(), ImportError> {
    let p = |f: &str| format!("{BASE}.{f}");
    let (eta_t, eta_t_path) = scalar(doc, &p("transmission.eff_interp"))?;
    model.field("eta_t", eta_t, "-", "transmission efficiency", &eta_t_path)?;
    model.field(
        "P_em_max",
        doc.num(&p("em.pwr_out_max_watts"))?,
        "W",
        "electric machine peak power (drive and regeneration)",
        &p("em.pwr_out_max_watts"),
    )?;
    let battery = crate::battery::efficiency(doc, model, &p("res.eff_interp"), warnings)?;
    let peak = "battery peak power (discharge and charge)";
    crate::battery::peak_power_and_capacity(doc, model, &p("res"), peak)?;
    let curve = table(doc, &p("em.eff_interp_achieved"))?;
    if curve.x[0] != 0.0 {
        warnings.push(format!(
            "`{}` does not start at zero load: regeneration uses its first value",
            curve.x_path(0)
        ));
    }
    model.def("P_em", "max(P_w, 0)/eta_t + max(min(P_w, 0)*eta_t, -P_em_max)", "W", "electric machine shaft power: traction through the transmission, regeneration limited to the machine's peak power");
    let eff = efficiency::emit(
        model,
        "em",
        &curve,
        "P_em/P_em_max",
        "electric machine efficiency",
    )?;
    let zero_load = efficiency::at_zero_load("em", &curve);
    model.def("P_el", &format!("max(P_em, 0)/{eff} + min(P_em, 0)*{zero_load} + P_aux"), "W", "battery terminal power: machine input (regeneration at the zero-load efficiency) plus the auxiliary load");
    if battery == crate::battery::Efficiency::Table {
        crate::battery::define_from_table(model);
    }
    model.def(
        "P_chem",
        "max(P_el, 0)/eta_res + max(min(P_el, 0), -P_res_max)*eta_res",
        "W",
        "battery chemical power; its integral is FASTSim's `res.energy_out_chemical_joules`",
    );
    model.output("battery_energy", "P_chem/3.6e6", "kWh/s", "battery chemical energy drawn (net of regeneration) in kWh: its integral is delta SOC x capacity; the model's answer (the [headline], in kWh/100 km and mpgge)", true);
    model.headline("battery_energy", None);
    model.output(
        "battery_power",
        "P_chem",
        "W",
        "battery chemical power; its integral in J",
        true,
    );
    model.output(
        "soc_drop",
        "P_chem/E_res",
        "1/s",
        "rate of the state-of-charge drop; its integral is delta SOC",
        true,
    );
    model.output("P_wheel", "P_w", "W", "tractive power at the wheels", false);
    model.output(
        "P_motor",
        "P_em",
        "W",
        "electric machine shaft power",
        false,
    );
    model.output(
        "em_load",
        "P_em/P_em_max",
        "-",
        "machine load fraction; above 1 FASTSim would miss the trace",
        false,
    );
    model.output(
        "P_friction",
        "min(P_w, 0) - max(min(P_w, 0), -P_em_max/eta_t)",
        "W",
        "friction-brake power (braking beyond the regeneration limit)",
        false,
    );
    for f in ["em.eff_interp_at_max_input", "res.min_soc", "res.max_soc"] {
        doc.mark(&p(f));
    }
    Ok(())
}
