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
    model.field(
        "P_idle",
        doc.num(&p("fc.pwr_idle_fuel_watts"))?,
        "W",
        "idle fuel power: the floor of the fuel power while the engine runs",
        &p("fc.pwr_idle_fuel_watts"),
    )?;
    let e_f_path = p("fs.specific_energy_joules_per_kilogram");
    // Unset (null or FASTSim's `.nan`): fuel as energy only; set: checked against its range like every field.
    let e_f = doc.opt_num(&e_f_path)?.filter(|x| !x.is_nan());
    match e_f {
        Some(e_f) => model.field("e_f", e_f, "J/kg", "fuel specific energy (lower heating value)", &e_f_path)?,
        None => warnings.push(format!(
            "`{e_f_path}` is not set: the fuel is reported as energy (fuel_energy, J) only, not as mass, and the model has no [headline]"
        )),
    }
    let curve = table(doc, &p("fc.eff_interp_from_pwr_out"))?;
    model.def("P_fc", "max(P_w, 0)/eta_t + P_aux/eta_alt", "W", "engine output power: traction through the transmission plus the auxiliary load through the alternator");
    let eff = efficiency::emit(model, "fc", &curve, "P_fc/P_fc_max", "engine efficiency")?;
    // A table with e(0) = 0 (a brake efficiency vanishes at zero load): P_fc/e is 0/0 there, with the limit
    // P_fc,max · x_1/e_1 of the first, linear segment, which max(e, 1e-12) keeps for every load above
    // 1e-12 · x_1/e_1; at zero load the quotient is 0 and the idle floor applies, as in FASTSim, whose
    // max(NaN, P_idle) is P_idle.
    let divisor = if crate::curve::zero_at_zero_load(&curve) {
        format!("max({eff}, 1e-12)")
    } else {
        eff.clone()
    };
    let thermal = doc.get(&p("fc.thrml.FuelConverterThermal")).is_some();
    let controls = crate::controls::emit(doc, model, BASE, thermal, warnings)?;
    let thermal =
        crate::thermal::emit(doc, model, BASE, &curve, &controls.run_s, &controls.fuel_s)?;
    let divisor = if thermal {
        format!("({divisor}*c_cold)")
    } else {
        divisor
    };
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
    if e_f.is_some() {
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
    conv_controls(doc, warnings);
    Ok(())
}

/// The engine's thermal model (FASTSim `fc.thrml`): `FuelConverterThermal` is reproduced (`thermal.rs`),
/// any other is named in a warning.
fn conv_controls(doc: &Doc, warnings: &mut Vec<String>) {
    let thrml = format!("{BASE}.fc.thrml");
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
