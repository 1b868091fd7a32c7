//! The fuel data every engine import shares (conventional and hybrid): FASTSim's idle fuel power, the fuel's
//! specific energy (optional: without it the fuel is reported as energy only), and the efficiency divisor of
//! P_fuel = P/e(P/P_max) guarded where the table vanishes at zero load.

use crate::curve::Curve;
use crate::error::ImportError;
use crate::model::Model;
use crate::yaml::Doc;

/// `P_idle` from `{base}.fc.pwr_idle_fuel_watts` and `e_f` from `{base}.fs.specific_energy_joules_per_kilogram`;
/// an unset `e_f` (null or FASTSim's `.nan`) is a warning. Whether `e_f` is set.
pub fn idle_and_energy(
    doc: &Doc,
    model: &mut Model,
    base: &str,
    warnings: &mut Vec<String>,
) -> Result<bool, ImportError> {
    let idle_path = format!("{base}.fc.pwr_idle_fuel_watts");
    model.field(
        "P_idle",
        doc.num(&idle_path)?,
        "W",
        "idle fuel power: the floor of the fuel power while the engine runs",
        &idle_path,
    )?;
    let e_f_path = format!("{base}.fs.specific_energy_joules_per_kilogram");
    // Unset (null or FASTSim's `.nan`): fuel as energy only; set: checked against its range like every field.
    match doc.opt_num(&e_f_path)?.filter(|x| !x.is_nan()) {
        Some(e_f) => {
            model.field(
                "e_f",
                e_f,
                "J/kg",
                "fuel specific energy (lower heating value)",
                &e_f_path,
            )?;
            Ok(true)
        }
        None => {
            warnings.push(format!(
                "`{e_f_path}` is not set: the fuel is reported as energy (fuel_energy, J) only, not as mass, and the model has no [headline]"
            ));
            Ok(false)
        }
    }
}

/// The divisor e of P/e for the efficiency expression `eff` of `curve`. A table with e(0) = 0 (a brake
/// efficiency vanishes at zero load): P/e is 0/0 there, with the limit P_max · x_1/e_1 of the first, linear
/// segment, which max(e, 1e-12) keeps for every load above 1e-12 · x_1/e_1; at zero load the quotient is 0 and
/// the idle floor applies, as in FASTSim, whose max(NaN, P_idle) is P_idle.
pub fn divisor(curve: &Curve, eff: &str) -> String {
    if crate::curve::zero_at_zero_load(curve) {
        format!("max({eff}, 1e-12)")
    } else {
        eff.to_string()
    }
}
