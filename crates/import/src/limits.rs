//! The physical range of every vehicle-file field the importer reads, in one table: a value outside it
//! (a transmission efficiency of 5 that would halve the fuel, an efficiency of 0 that divides by zero at run
//! time, a negative auxiliary load that would cancel the fuel) is refused naming the field, its value and
//! the range. Every number that enters the model goes through [`check`] (`Model::field` and the efficiency
//! tables of `curve.rs`); a field missing from the table is refused too, so none is imported unchecked.

use crate::error::ImportError;

/// An interval of allowed values: bounds (infinite for none), whether each bound is allowed, whether the
/// value must be a whole number.
#[derive(Debug, Clone, Copy)]
pub struct Range {
    pub lo: f64,
    pub lo_closed: bool,
    pub hi: f64,
    pub hi_closed: bool,
    pub integer: bool,
}

/// (0, ∞): masses, powers that must exist (peak powers), capacities, lengths, areas, specific energies.
const POSITIVE: Range = range(0.0, false, f64::INFINITY, false);
/// [0, ∞): loads drawn but never supplied (auxiliary load, idle fuel power), inertias, the drag coefficient.
const NON_NEGATIVE: Range = range(0.0, true, f64::INFINITY, false);
/// [−20, 0] m/s²: a deceleration threshold (an acceleration at or below zero; beyond 2 g no car brakes).
const DECELERATION: Range = range(-20.0, true, 0.0, true);
/// (0, 1]: an efficiency, output over input power: above 1 creates energy, 0 divides by zero.
const EFFICIENCY: Range = range(0.0, false, 1.0, true);
/// [0, 1]: a fraction (a load as a fraction of peak power; a rolling-resistance coefficient, force over
/// weight).
const FRACTION: Range = range(0.0, true, 1.0, true);
/// [−100, 100]: a C-rate, battery power over the power that empties the capacity in an hour (beyond ±100 C no
/// traction battery is tested).
const C_RATE: Range = range(-100.0, true, 100.0, true);
/// [−60, 120] °C: a battery cell temperature in its tables (beyond it, cells are destroyed).
const CELL_TEMPERATURE: Range = range(-60.0, true, 120.0, true);
/// The same range in kelvin.
const CELL_KELVIN: Range = range(213.15, true, 393.15, true);
/// [173.15, 473.15] K (−100 to 200 °C): an engine temperature, a thermostat's or a cold-efficiency
/// threshold (beyond it no coolant or oil works).
const ENGINE_KELVIN: Range = range(173.15, true, 473.15, true);
/// (0, 100] K: a temperature interval of the thermal model (a thermostat's opening range, a lag).
const KELVIN_INTERVAL: Range = range(0.0, false, 100.0, true);
/// [0, 1000] K: the cold-efficiency model's offset, an absolute temperature below the engine's.
const KELVIN_OFFSET: Range = range(0.0, true, 1000.0, true);
/// [0, 100] m/s: a speed threshold of the hybrid's controller (360 km/h).
const SPEED: Range = range(0.0, true, 100.0, true);
/// [0, 3600] s: a time of the hybrid's controller (the engine's least running time).
const SECONDS: Range = range(0.0, true, 3600.0, true);
/// [0, 100]: a factor of the hybrid's controller (a buffer's coefficient; a fraction of a power, which may
/// exceed 1).
const FACTOR: Range = range(0.0, true, 100.0, true);
/// A count: a whole number ≥ 1.
const COUNT: Range = Range {
    integer: true,
    ..range(1.0, true, f64::INFINITY, false)
};

const fn range(lo: f64, lo_closed: bool, hi: f64, hi_closed: bool) -> Range {
    Range {
        lo,
        lo_closed,
        hi,
        hi_closed,
        integer: false,
    }
}

/// Every field the importer reads: its path in the vehicle file (`[]` stands for any index of a table's
/// grid or values; a `{Constant: x}` efficiency is checked under the path of the field that holds it), its
/// range and what it is.
pub const FIELDS: &[(&str, Range, &str)] = &[
    ("mass_kilograms", POSITIVE, "the vehicle's total mass"),
    (
        "pwr_aux_base_watts",
        NON_NEGATIVE,
        "the auxiliary load (drawn, never supplied)",
    ),
    (
        "chassis.wheel_inertia_kilogram_square_meters",
        NON_NEGATIVE,
        "a wheel's rotating inertia",
    ),
    ("chassis.num_wheels", COUNT, "the number of wheels"),
    ("chassis.wheel_radius_meters", POSITIVE, "the wheel radius"),
    (
        "chassis.drag_coef",
        NON_NEGATIVE,
        "the aerodynamic drag coefficient",
    ),
    (
        "chassis.frontal_area_square_meters",
        POSITIVE,
        "the frontal area",
    ),
    (
        "chassis.wheel_rr_coef",
        FRACTION,
        "the rolling-resistance coefficient (force over weight)",
    ),
    (
        "pt_type.Conv.fc.pwr_out_max_watts",
        POSITIVE,
        "the engine's peak power",
    ),
    (
        "pt_type.Conv.transmission.eff_interp",
        EFFICIENCY,
        "the transmission efficiency",
    ),
    (
        "pt_type.Conv.alt_eff",
        EFFICIENCY,
        "the alternator efficiency",
    ),
    (
        "pt_type.Conv.fc.pwr_idle_fuel_watts",
        NON_NEGATIVE,
        "the idle fuel power",
    ),
    (
        "pt_type.Conv.pt_cntrl.StartStop.stopped_speed_threshold_meters_per_second",
        NON_NEGATIVE,
        "the speed below which stop-start counts the car as stopped",
    ),
    (
        "pt_type.Conv.dfco_cntrl.minimum_dfco_speed_meters_per_second",
        NON_NEGATIVE,
        "the lowest speed of the fuel cut-off",
    ),
    (
        "pt_type.Conv.dfco_cntrl.minimum_dfco_deceleration_meters_per_second_squared",
        DECELERATION,
        "the fuel cut-off's acceleration threshold (a deceleration)",
    ),
    (
        "pt_type.Conv.fc.thrml.FuelConverterThermal.heat_capacitance_joules_per_kelvin",
        POSITIVE,
        "the engine heat capacitance",
    ),
    (
        "pt_type.Conv.fc.thrml.FuelConverterThermal.length_for_convection_meters",
        POSITIVE,
        "the engine length for convection",
    ),
    (
        "pt_type.Conv.fc.thrml.FuelConverterThermal.htc_to_amb_stop_watts_per_square_meter_kelvin",
        NON_NEGATIVE,
        "the engine heat transfer coefficient to the ambient while standing",
    ),
    (
        "pt_type.Conv.fc.thrml.FuelConverterThermal.conductance_from_comb_watts_per_kelvin",
        NON_NEGATIVE,
        "the conductance from the flame to the engine",
    ),
    (
        "pt_type.Conv.fc.thrml.FuelConverterThermal.max_frac_from_comb",
        FRACTION,
        "the largest fraction of the losses heating the engine",
    ),
    (
        "pt_type.Conv.fc.thrml.FuelConverterThermal.tstat_te_sto_kelvin",
        ENGINE_KELVIN,
        "the temperature at which the thermostat starts to open",
    ),
    (
        "pt_type.Conv.fc.thrml.FuelConverterThermal.tstat_te_delta_kelvin",
        KELVIN_INTERVAL,
        "the thermostat's opening range",
    ),
    (
        "pt_type.Conv.fc.thrml.FuelConverterThermal.radiator_effectiveness",
        NON_NEGATIVE,
        "the radiator effectiveness",
    ),
    (
        "pt_type.Conv.fc.thrml.FuelConverterThermal.fc_eff_model.Exponential.offset",
        KELVIN_OFFSET,
        "the cold-efficiency offset temperature",
    ),
    (
        "pt_type.Conv.fc.thrml.FuelConverterThermal.fc_eff_model.Exponential.lag",
        KELVIN_INTERVAL,
        "the cold-efficiency temperature scale",
    ),
    (
        "pt_type.Conv.fc.thrml.FuelConverterThermal.fc_eff_model.Exponential.minimum",
        EFFICIENCY,
        "the cold-efficiency factor's lower bound",
    ),
    (
        "pt_type.Conv.fc.thrml.FuelConverterThermal.state.temperature_kelvin",
        ENGINE_KELVIN,
        "the engine's initial temperature",
    ),
    (
        "pt_type.Conv.pt_cntrl.StartStop.temp_fc_forced_on_kelvin",
        ENGINE_KELVIN,
        "the temperature below which stop-start keeps the engine running",
    ),
    (
        "pt_type.Conv.fs.specific_energy_joules_per_kilogram",
        POSITIVE,
        "the fuel's specific energy",
    ),
    (
        "pt_type.Conv.fc.eff_interp_from_pwr_out.data.grid[0][]",
        FRACTION,
        "a load grid point of the engine efficiency table (a fraction of peak power)",
    ),
    (
        "pt_type.Conv.fc.eff_interp_from_pwr_out.data.values[]",
        FRACTION,
        "an engine efficiency (0 only at zero load)",
    ),
    (
        "pt_type.BEV.transmission.eff_interp",
        EFFICIENCY,
        "the transmission efficiency",
    ),
    (
        "pt_type.BEV.res.eff_interp.CRateTemperature.data.grid[0][]",
        C_RATE,
        "a C-rate grid point of the battery efficiency table (discharge positive, charge negative)",
    ),
    (
        "pt_type.BEV.res.eff_interp.CRateTemperature.data.grid[1][]",
        CELL_TEMPERATURE,
        "a temperature grid point of the battery efficiency table, in °C",
    ),
    (
        "pt_type.BEV.res.eff_interp.CRateTemperature.data.values[][]",
        EFFICIENCY,
        "a battery efficiency",
    ),
    (
        "pt_type.BEV.res.thrml.RESLumpedThermal.state.temperature_kelvin",
        CELL_KELVIN,
        "the battery's initial temperature, in K",
    ),
    (
        "pt_type.BEV.em.pwr_out_max_watts",
        POSITIVE,
        "the electric machine's peak power",
    ),
    (
        "pt_type.BEV.res.eff_interp",
        EFFICIENCY,
        "the battery efficiency",
    ),
    (
        "pt_type.BEV.res.pwr_out_max_watts",
        POSITIVE,
        "the battery's peak power",
    ),
    (
        "pt_type.BEV.res.energy_capacity_joules",
        POSITIVE,
        "the battery capacity",
    ),
    (
        "pt_type.BEV.em.eff_interp_achieved.data.grid[0][]",
        FRACTION,
        "a load grid point of the machine efficiency table (a fraction of peak power)",
    ),
    (
        "pt_type.BEV.em.eff_interp_achieved.data.values[]",
        EFFICIENCY,
        "an electric machine efficiency",
    ),
    (
        "pt_type.HEV.fc.pwr_out_max_watts",
        POSITIVE,
        "the engine's peak power",
    ),
    (
        "pt_type.HEV.fc.pwr_idle_fuel_watts",
        NON_NEGATIVE,
        "the engine's idle fuel power",
    ),
    (
        "pt_type.HEV.fc.eff_interp_from_pwr_out.data.grid[0][]",
        FRACTION,
        "a load grid point of the engine efficiency table (a fraction of peak power)",
    ),
    (
        "pt_type.HEV.fc.eff_interp_from_pwr_out.data.values[]",
        FRACTION,
        "an engine efficiency (0 only at zero load)",
    ),
    (
        "pt_type.HEV.transmission.eff_interp",
        EFFICIENCY,
        "the transmission efficiency",
    ),
    (
        "pt_type.HEV.em.pwr_out_max_watts",
        POSITIVE,
        "the electric machine's peak power",
    ),
    (
        "pt_type.HEV.em.eff_interp_achieved.data.grid[0][]",
        FRACTION,
        "a load grid point of the machine efficiency table (a fraction of peak power)",
    ),
    (
        "pt_type.HEV.em.eff_interp_achieved.data.values[]",
        EFFICIENCY,
        "an electric machine efficiency",
    ),
    (
        "pt_type.HEV.res.eff_interp",
        EFFICIENCY,
        "the battery efficiency",
    ),
    (
        "pt_type.HEV.res.eff_interp.CRateTemperature.data.grid[0][]",
        C_RATE,
        "a C-rate grid point of the battery efficiency table (discharge positive, charge negative)",
    ),
    (
        "pt_type.HEV.res.eff_interp.CRateTemperature.data.grid[1][]",
        CELL_TEMPERATURE,
        "a temperature grid point of the battery efficiency table, in °C",
    ),
    (
        "pt_type.HEV.res.eff_interp.CRateTemperature.data.values[][]",
        EFFICIENCY,
        "a battery efficiency",
    ),
    (
        "pt_type.HEV.res.thrml.RESLumpedThermal.state.temperature_kelvin",
        CELL_KELVIN,
        "the battery's initial temperature, in K",
    ),
    (
        "pt_type.HEV.res.pwr_out_max_watts",
        POSITIVE,
        "the battery's peak power",
    ),
    (
        "pt_type.HEV.res.energy_capacity_joules",
        POSITIVE,
        "the battery capacity",
    ),
    (
        "pt_type.HEV.res.min_soc",
        FRACTION,
        "the battery's lowest state of charge",
    ),
    (
        "pt_type.HEV.res.max_soc",
        FRACTION,
        "the battery's highest state of charge",
    ),
    (
        "pt_type.HEV.res.state.soc",
        FRACTION,
        "the battery's initial state of charge",
    ),
    (
        "pt_type.HEV.pt_cntrl.RGWDB.speed_fc_forced_on_meters_per_second",
        SPEED,
        "the speed above which the hybrid's engine runs",
    ),
    (
        "pt_type.HEV.pt_cntrl.RGWDB.frac_pwr_demand_fc_forced_on",
        FACTOR,
        "the power demand (a fraction of the peaks) above which the hybrid's engine runs",
    ),
    (
        "pt_type.HEV.pt_cntrl.RGWDB.speed_soc_fc_on_buffer_meters_per_second",
        SPEED,
        "the speed of the hybrid's SOC reserve",
    ),
    (
        "pt_type.HEV.pt_cntrl.RGWDB.speed_soc_fc_on_buffer_coeff",
        FACTOR,
        "the factor of the hybrid's SOC reserve",
    ),
    (
        "pt_type.HEV.pt_cntrl.RGWDB.frac_of_most_eff_pwr_to_run_fc",
        FACTOR,
        "the hybrid engine's least power, a fraction of its peak-efficiency power",
    ),
    (
        "pt_type.HEV.pt_cntrl.RGWDB.fc_min_time_on_seconds",
        SECONDS,
        "the hybrid engine's least running time",
    ),
    (
        "pt_type.HEV.pt_cntrl.RGWDB.speed_soc_disch_buffer_meters_per_second",
        SPEED,
        "the speed of the hybrid battery's discharge derating band",
    ),
    (
        "pt_type.HEV.pt_cntrl.RGWDB.speed_soc_disch_buffer_coeff",
        FACTOR,
        "the factor of the hybrid battery's discharge derating band",
    ),
    (
        "pt_type.HEV.fc.thrml.FuelConverterThermal.heat_capacitance_joules_per_kelvin",
        POSITIVE,
        "the engine heat capacitance",
    ),
    (
        "pt_type.HEV.fc.thrml.FuelConverterThermal.length_for_convection_meters",
        POSITIVE,
        "the engine length for convection",
    ),
    (
        "pt_type.HEV.fc.thrml.FuelConverterThermal.htc_to_amb_stop_watts_per_square_meter_kelvin",
        NON_NEGATIVE,
        "the engine heat transfer coefficient to the ambient while standing",
    ),
    (
        "pt_type.HEV.fc.thrml.FuelConverterThermal.conductance_from_comb_watts_per_kelvin",
        NON_NEGATIVE,
        "the conductance from the flame to the engine",
    ),
    (
        "pt_type.HEV.fc.thrml.FuelConverterThermal.max_frac_from_comb",
        FRACTION,
        "the largest fraction of the losses heating the engine",
    ),
    (
        "pt_type.HEV.fc.thrml.FuelConverterThermal.tstat_te_sto_kelvin",
        ENGINE_KELVIN,
        "the temperature at which the thermostat starts to open",
    ),
    (
        "pt_type.HEV.fc.thrml.FuelConverterThermal.tstat_te_delta_kelvin",
        KELVIN_INTERVAL,
        "the thermostat's opening range",
    ),
    (
        "pt_type.HEV.fc.thrml.FuelConverterThermal.radiator_effectiveness",
        NON_NEGATIVE,
        "the radiator effectiveness",
    ),
    (
        "pt_type.HEV.fc.thrml.FuelConverterThermal.fc_eff_model.Exponential.offset",
        KELVIN_OFFSET,
        "the cold-efficiency offset temperature",
    ),
    (
        "pt_type.HEV.fc.thrml.FuelConverterThermal.fc_eff_model.Exponential.lag",
        KELVIN_INTERVAL,
        "the cold-efficiency temperature scale",
    ),
    (
        "pt_type.HEV.fc.thrml.FuelConverterThermal.fc_eff_model.Exponential.minimum",
        EFFICIENCY,
        "the cold-efficiency factor's lower bound",
    ),
    (
        "pt_type.HEV.fc.thrml.FuelConverterThermal.state.temperature_kelvin",
        ENGINE_KELVIN,
        "the engine's initial temperature",
    ),
    (
        "pt_type.HEV.pt_cntrl.RGWDB.temp_fc_forced_on_kelvin",
        ENGINE_KELVIN,
        "the temperature below which the hybrid's controller runs the engine",
    ),
];

/// The table's key of a field path: a trailing `.Constant` dropped, every index written `[]` except a grid's
/// axis (`grid[1][4]` → `grid[1][]`, `values[3][2]` → `values[][]`).
fn key(path: &str) -> String {
    let path = path.strip_suffix(".Constant").unwrap_or(path);
    let mut out = String::with_capacity(path.len());
    let mut rest = path;
    while let Some(open) = rest.find('[') {
        let (head, tail) = rest.split_at(open);
        out.push_str(head);
        let close = tail.find(']').map_or(tail.len(), |c| c + 1);
        let index = &tail[..close];
        let numeric = index.len() > 2
            && index[1..index.len() - 1]
                .bytes()
                .all(|b| b.is_ascii_digit());
        if numeric && !out.ends_with("grid") {
            out.push_str("[]");
        } else {
            out.push_str(index);
        }
        rest = &tail[close..];
    }
    out.push_str(rest);
    out
}

/// `Ok` when the finite `value` of the field at `path` lies in the field's range; otherwise an error naming
/// the field, the value and the range.
pub fn check(path: &str, value: f64) -> Result<(), ImportError> {
    let key = key(path);
    let Some((_, r, what)) = FIELDS.iter().find(|(k, _, _)| *k == key) else {
        return Err(ImportError::field(
            path,
            "no physical range is known for this field (a defect of the importer: every field it reads has one)",
        ));
    };
    let above = if r.lo_closed {
        value >= r.lo
    } else {
        value > r.lo
    };
    let below = if r.hi_closed {
        value <= r.hi
    } else {
        value < r.hi
    };
    let whole = !r.integer || value.fract() == 0.0;
    if above && below && whole {
        return Ok(());
    }
    Err(ImportError::field(
        path,
        format!(
            "{value} is outside the range of {what}: expected {}",
            describe(r)
        ),
    ))
}

/// The range as text: `(0, 1]`, `[0, ∞)`, `a whole number in [1, ∞)`.
pub fn describe(r: &Range) -> String {
    let bound = |x: f64| {
        if x.is_infinite() {
            "∞".to_string()
        } else {
            format!("{x}")
        }
    };
    let text = format!(
        "{}{}, {}{}",
        if r.lo_closed { '[' } else { '(' },
        bound(r.lo),
        bound(r.hi),
        if r.hi_closed { ']' } else { ')' }
    );
    if r.integer {
        format!("a whole number in {text}")
    } else {
        format!("a value in {text}")
    }
}

#[cfg(test)]
mod tests {
    use super::{check, key};

    #[test]
    fn keys_and_ranges() {
        assert_eq!(
            key("pt_type.BEV.res.eff_interp.Constant"),
            "pt_type.BEV.res.eff_interp"
        );
        assert_eq!(
            key("pt_type.Conv.fc.eff_interp_from_pwr_out.data.grid[0][11]"),
            "pt_type.Conv.fc.eff_interp_from_pwr_out.data.grid[0][]"
        );
        assert_eq!(
            key("pt_type.BEV.res.eff_interp.CRateTemperature.data.values[3][2]"),
            "pt_type.BEV.res.eff_interp.CRateTemperature.data.values[][]"
        );
        assert_eq!(
            key("pt_type.BEV.res.eff_interp.CRateTemperature.data.grid[1][4]"),
            "pt_type.BEV.res.eff_interp.CRateTemperature.data.grid[1][]"
        );
        assert!(check("pt_type.Conv.transmission.eff_interp", 1.0).is_ok());
        let e = check("pt_type.Conv.transmission.eff_interp", 5.0).unwrap_err();
        assert_eq!(
            e.to_string(),
            "field `pt_type.Conv.transmission.eff_interp`: 5 is outside the range of the transmission \
             efficiency: expected a value in (0, 1]"
        );
        assert!(check("pt_type.Conv.transmission.eff_interp", 0.0).is_err());
        assert!(check("pwr_aux_base_watts", 0.0).is_ok());
        assert!(check("pwr_aux_base_watts", -700.0).is_err());
        assert!(check("chassis.num_wheels", 2.5).is_err());
        assert!(check("chassis.unknown_field", 1.0).is_err());
    }
}
