//! The battery's efficiency (FASTSim `res.eff_interp`): a constant, or a table over the C-rate and the cell
//! temperature (`CRateTemperature`, the 2020 Bolt), bilinear as FASTSim interpolates it and held at the edge
//! values outside the grid (`extrapolate: Clamp`).
//!
//! The C-rate is the terminal power (the charge power limited to the battery's peak) over the power that
//! empties the capacity in one hour, C = P_el / (E_res / 3600 s), positive when discharging. The temperature is the signal `T_res` (°C): FASTSim's
//! lumped battery thermal model is not reproduced, so its default is the file's initial battery temperature
//! (22 °C without one) and `--signal T_res=…` (a constant or a time series) sets another.
//! Also the battery's peak power and capacity, which every electrified powertrain reads alike.

use crate::curve::scalar;
use crate::error::ImportError;
use crate::model::{LinearMap, Model, Signal};
use crate::yaml::{as_number, Doc};
use serde_yaml::Value;

/// The cell temperature when the file gives none, °C (FASTSim's default ambient).
const DEFAULT_TEMPERATURE_C: f64 = 22.0;

/// How the battery efficiency `eta_res` is given.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Efficiency {
    /// The parameter `eta_res`.
    Constant,
    /// The map `res_map` and the signal `T_res`: [`define_from_table`] defines `eta_res` once the terminal
    /// power `P_el` is defined.
    Table,
}

/// Emit the battery efficiency at `path`: the parameter `eta_res`, or the map over C-rate and temperature with
/// the temperature signal.
pub fn efficiency(
    doc: &Doc,
    model: &mut Model,
    path: &str,
    warnings: &mut Vec<String>,
) -> Result<Efficiency, ImportError> {
    let table = format!("{path}.CRateTemperature");
    if doc.get(&table).is_none() {
        let (eta, eta_path) = scalar(doc, path)?;
        model.field(
            "eta_res",
            eta,
            "-",
            "battery efficiency, each way (discharge P_el/eta, charge P_el*eta)",
            &eta_path,
        )?;
        return Ok(Efficiency::Constant);
    }
    let Table {
        c_rates,
        temps,
        values,
    } = read_table(doc, &table)?;
    model.maps.push(LinearMap {
        name: "res_map".to_string(),
        args: vec!["c_rate".to_string(), "T_res".to_string()],
        x: c_rates,
        y: temps,
        values,
        unit: "-".to_string(),
        doc: format!(
            "battery efficiency over the C-rate (discharge positive) and the cell temperature (°C), bilinear \
             as FASTSim interpolates it; FASTSim `{table}` (x: `data.grid[0]`, y: `data.grid[1]`, values: \
             `data.values`)"
        ),
    });
    let res = path.strip_suffix(".eff_interp").unwrap_or(path);
    let initial = initial_temperature(doc, res)?;
    model.signals.push(Signal {
        name: "T_res".to_string(),
        default: initial,
        unit: "degC".to_string(),
        doc: "battery cell temperature for the efficiency table; FASTSim's battery thermal model is not \
              reproduced, so it is held at the file's initial temperature unless --signal T_res=... sets it"
            .to_string(),
    });
    warnings.push(format!(
        "`{table}`: the battery efficiency is read at the temperature signal `T_res`, {} °C by default (the \
         battery's thermal model is not reproduced; set it with --signal T_res=...)",
        crate::model::number(initial)
    ));
    Ok(Efficiency::Table)
}

/// The grid (C-rates, temperatures) and the values row by row, each checked (`limits.rs`), the grids
/// strictly increasing, linear interpolation.
fn read_table(doc: &Doc, table: &str) -> Result<Table, ImportError> {
    let grid_path = format!("{table}.data.grid");
    let grid = doc
        .get(&grid_path)
        .and_then(Value::as_sequence)
        .filter(|g| g.len() == 2)
        .ok_or_else(|| {
            ImportError::field(
                &grid_path,
                "expected two lists: the C-rates and the temperatures",
            )
        })?;
    let c_rates = crate::curve::grid(&grid[0], &format!("{grid_path}[0]"))?;
    let temps = crate::curve::grid(&grid[1], &format!("{grid_path}[1]"))?;
    let values_path = format!("{table}.data.values");
    let rows = doc
        .get(&values_path)
        .and_then(Value::as_sequence)
        .filter(|r| r.len() == c_rates.len())
        .ok_or_else(|| {
            ImportError::field(
                &values_path,
                format!("expected {} rows, one per C-rate", c_rates.len()),
            )
        })?;
    let mut values = Vec::with_capacity(c_rates.len() * temps.len());
    for (i, row) in rows.iter().enumerate() {
        let row_path = format!("{values_path}[{i}]");
        let row = row
            .as_sequence()
            .filter(|r| r.len() == temps.len())
            .ok_or_else(|| {
                ImportError::field(
                    &row_path,
                    format!("expected {} values, one per temperature", temps.len()),
                )
            })?;
        for (j, v) in row.iter().enumerate() {
            values.push(number(v, &format!("{row_path}[{j}]"))?);
        }
    }
    let strategy = format!("{table}.strategy");
    if doc.get(&strategy).and_then(Value::as_str) != Some("Linear") {
        return Err(ImportError::field(
            &strategy,
            "only `Linear` interpolation of the battery table is supported",
        ));
    }
    let extrapolate = format!("{table}.extrapolate");
    if doc.get(&extrapolate).and_then(Value::as_str) != Some("Clamp") {
        return Err(ImportError::field(
            &extrapolate,
            "only `Clamp` (hold the edge values) is supported for the battery table",
        ));
    }
    Ok(Table {
        c_rates,
        temps,
        values,
    })
}

/// The battery table: its two grids and its values row by row (one row per C-rate).
struct Table {
    c_rates: Vec<f64>,
    temps: Vec<f64>,
    values: Vec<f64>,
}

/// A finite number in the field's range.
fn number(v: &Value, path: &str) -> Result<f64, ImportError> {
    let x = as_number(v)
        .filter(|x| x.is_finite())
        .ok_or_else(|| ImportError::field(path, "expected a finite number"))?;
    crate::limits::check(path, x)?;
    Ok(x)
}

/// The battery's initial temperature in °C from its lumped thermal model's state (under the battery `res`),
/// else 22 °C.
fn initial_temperature(doc: &Doc, res: &str) -> Result<f64, ImportError> {
    let path = format!("{res}.thrml.RESLumpedThermal.state.temperature_kelvin");
    match doc.opt_num(&path)? {
        Some(k) => {
            crate::limits::check(&path, k)?;
            Ok(k - 273.15)
        }
        None => Ok(DEFAULT_TEMPERATURE_C),
    }
}

/// The battery's peak power `P_res_max` (documented as `peak_doc`) and capacity `E_res`, from FASTSim's
/// `{res}.pwr_out_max_watts` and `{res}.energy_capacity_joules` (`res`: the battery's path).
pub fn peak_power_and_capacity(
    doc: &Doc,
    model: &mut Model,
    res: &str,
    peak_doc: &str,
) -> Result<(), ImportError> {
    for (name, field, unit, what) in [
        ("P_res_max", "pwr_out_max_watts", "W", peak_doc),
        ("E_res", "energy_capacity_joules", "J", "battery capacity"),
    ] {
        let path = format!("{res}.{field}");
        model.field(name, doc.num(&path)?, unit, what, &path)?;
    }
    Ok(())
}

/// The definition `eta_res` from the table (after `P_el`, which it uses).
pub fn define_from_table(model: &mut Model) {
    model.def(
        "eta_res",
        "res_map(max(P_el, -P_res_max)/(E_res/3600), T_res)",
        "-",
        "battery efficiency, each way, at the C-rate of the terminal power and the cell temperature",
    );
}
