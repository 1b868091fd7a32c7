//! A conventional vehicle (`pt_type: Conv`): engine (fuel converter) with its efficiency curve over the load
//! fraction, transmission efficiency, alternator efficiency for the auxiliary load, idle fuel power.

use crate::curve::{scalar, table};
use crate::efficiency;
use crate::error::ImportError;
use crate::model::Model;
use crate::yaml::Doc;

const BASE: &str = "pt_type.Conv";

/// Emit the powertrain. FASTSim (fuel_converter.rs, conv.rs): P_fc = max(P_w, 0)/η_t + P_aux/η_alt (the
/// engine never absorbs braking power; the friction brakes do), η = e(P_fc / P_fc,max) from the table,
/// P_fuel = max(P_fc/η, P_idle) while the engine runs (always, without stop-start), fuel mass = ∫ P_fuel / e_f.
pub fn emit(doc: &Doc, model: &mut Model, warnings: &mut Vec<String>) -> Result<(), ImportError> {
    let p = |f: &str| format!("{BASE}.{f}");
    model.field(
        "P_fc_max",
        doc.num(&p("fc.pwr_out_max_watts"))?,
        "W",
        "engine peak power",
        &p("fc.pwr_out_max_watts"),
    )?;
    let (eta_t, eta_t_path) = scalar(doc, &p("transmission.eff_interp"))?;
    model.field("eta_t", eta_t, "-", "transmission efficiency", &eta_t_path)?;
    model.field(
        "eta_alt",
        doc.num(&p("alt_eff"))?,
        "-",
        "alternator efficiency (the auxiliary load drawn from the engine)",
        &p("alt_eff"),
    )?;
    let e_f = crate::fuel::idle_and_energy(doc, model, BASE, warnings)?;
    let curve = table(doc, &p("fc.eff_interp_from_pwr_out"))?;
    model.def("P_fc", "max(P_w, 0)/eta_t + P_aux/eta_alt", "W", "engine output power: traction through the transmission plus the auxiliary load through the alternator");
    let eff = efficiency::emit(model, "fc", &curve, "P_fc/P_fc_max", "engine efficiency")?;
    let divisor = crate::fuel::divisor(&curve, &eff);
    let thermal = doc.get(&p("fc.thrml.FuelConverterThermal")).is_some();
    let controls = crate::controls::emit(doc, model, BASE, thermal, warnings)?;
    let coupling = crate::thermal::Coupling {
        output_s: "P_w_pos_s/eta_t + P_aux/eta_alt",
        run_s: &controls.run_s,
        fuel_s: &controls.fuel_s,
        warm: false,
    };
    let thermal = crate::thermal::emit(doc, model, (BASE, &curve), &coupling)?;
    let divisor = crate::thermal::cold_divisor(divisor, thermal);
    let controls = controls.exact;
    let doc_fuel = if controls.is_empty() {
        "fuel power, at least the idle fuel power"
    } else {
        "fuel power, at least the idle fuel power while the engine runs and is fuelled (stop-start, fuel cut-off)"
    };
    model.def(
        "P_fuel",
        &format!("{controls}max(P_fc/{divisor}, P_idle)"),
        "W",
        doc_fuel,
    );
    if e_f {
        // FASTSim's conventional vehicles burn gasoline (its mpg counts 33.7 kWh of fuel energy per gallon).
        model.output("fuel", "P_fuel/e_f", "kg/s", "fuel mass flow: the model's answer (the [headline], in l/100 km, mpg and CO2 g/km as petrol)", true);
        model.headline("fuel", Some("petrol"));
    }
    model.output(
        "fuel_energy",
        "P_fuel",
        "W",
        "fuel power; its integral is FASTSim's `fc.energy_fuel_joules`",
        true,
    );
    model.output("P_wheel", "P_w", "W", "tractive power at the wheels", false);
    model.output(
        "P_engine",
        "P_fc",
        "W",
        "engine output power (traction and auxiliary load)",
        false,
    );
    model.output(
        "fc_load",
        "P_fc/P_fc_max",
        "-",
        "engine load fraction; above 1 FASTSim would miss the trace",
        false,
    );
    model.output("eff_engine", &eff, "-", "engine efficiency", false);
    crate::thermal::others(doc, BASE, warnings);
    Ok(())
}
