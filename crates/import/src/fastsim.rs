//! The FASTSim 3 import: the powertrain type decides the emitter; the header carries the attribution, the
//! physics reproduced and the fields left out.

use crate::error::ImportError;
use crate::model::Model;
use crate::yaml::{parse, Doc};
use crate::{bev, chassis, conv, hev, unsupported};
use serde_yaml::Value;

/// The powertrain types imported.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Powertrain {
    Conventional,
    BatteryElectric,
    /// FASTSim's parallel hybrid (`HEV`): a model with modes and a `[hybrid]` table.
    Hybrid,
}

/// A generated model file and the warnings of the import.
#[derive(Debug, Clone)]
pub struct Imported {
    pub model: String,
    pub name: String,
    pub powertrain: Powertrain,
    pub warnings: Vec<String>,
}

/// Import the FASTSim 3 vehicle file `text`; `source` names it in the generated header. A field error
/// carries the line and column of the field's value in `text` (when the file has the field).
pub fn import_fastsim(text: &str, source: &str) -> Result<Imported, ImportError> {
    import(text, source).map_err(|e| e.located(text))
}

fn import(text: &str, source: &str) -> Result<Imported, ImportError> {
    let doc = Doc::new(parse(text)?);
    let powertrain = powertrain(&doc)?;
    let vehicle = doc
        .get("name")
        .and_then(Value::as_str)
        .unwrap_or("unnamed FASTSim vehicle")
        .to_string();
    let mut model = Model {
        name: model_name(&vehicle),
        ..Model::default()
    };
    let mut warnings = Vec::new();
    chassis::emit(&doc, &mut model)?;
    match powertrain {
        Powertrain::Conventional => conv::emit(&doc, &mut model, &mut warnings)?,
        Powertrain::BatteryElectric => bev::emit(&doc, &mut model, &mut warnings)?,
        Powertrain::Hybrid => hev::emit(&doc, &mut model, &mut warnings)?,
    }
    let unused = unsupported::unused(&doc);
    if !unused.is_empty() {
        warnings.push(format!(
            "fields not modelled (ignored): {}",
            unused.join(", ")
        ));
    }
    model.description = description(&vehicle, powertrain);
    model.header = header(&vehicle, source, &warnings);
    Ok(Imported {
        model: model.render(),
        name: model.name,
        powertrain,
        warnings,
    })
}

/// `pt_type` is a mapping with one key, the variant: `Conv`, `BEV`, `HEV` (imported), `PHEV` and others
/// (refused).
fn powertrain(doc: &Doc) -> Result<Powertrain, ImportError> {
    let pt = doc
        .get("pt_type")
        .ok_or_else(|| ImportError::field("pt_type", "missing: not a FASTSim 3 vehicle file"))?;
    let kind = match pt {
        Value::Mapping(m) if m.len() == 1 => m.keys().next().and_then(Value::as_str).unwrap_or("?"),
        Value::String(s) => s.as_str(),
        _ => {
            return Err(ImportError::field(
                "pt_type",
                "expected a mapping with one powertrain type",
            ))
        }
    };
    match kind {
        "Conv" => Ok(Powertrain::Conventional),
        "BEV" => Ok(Powertrain::BatteryElectric),
        "HEV" => Ok(Powertrain::Hybrid),
        "PHEV" => Err(ImportError::Powertrain {
            kind: kind.to_string(),
            reason: "plug-in hybrids are not imported (their charge-depleting operation is not modelled); \
                     conventional (Conv), battery-electric (BEV) and hybrid (HEV) vehicles are. For a plug-in \
                     hybrid, write its model by hand with one mode per operating state (`[modes]`, see \
                     docs/modes.md)"
                .to_string(),
        }),
        other => Err(ImportError::Powertrain {
            kind: other.to_string(),
            reason: "unknown FASTSim powertrain type; conventional (Conv), battery-electric (BEV) and \
                     hybrid (HEV) vehicles are imported"
                .to_string(),
        }),
    }
}

/// A model name from the vehicle's: lowercase letters, digits and `_`, starting with a letter.
fn model_name(vehicle: &str) -> String {
    let mut s = String::new();
    for c in vehicle.chars() {
        if c.is_ascii_alphanumeric() {
            s.push(c.to_ascii_lowercase());
        } else if !s.ends_with('_') && !s.is_empty() {
            s.push('_');
        }
    }
    let s = s.trim_end_matches('_').to_string();
    if s.starts_with(|c: char| c.is_ascii_alphabetic()) {
        s
    } else {
        format!("fastsim_{s}")
    }
}

fn description(vehicle: &str, pt: Powertrain) -> String {
    let kind = match pt {
        Powertrain::Conventional => "conventional",
        Powertrain::BatteryElectric => "battery-electric",
        Powertrain::Hybrid => {
            return format!(
                "{vehicle} (hybrid), imported from FASTSim: FASTSim's quasi-static road load and energy flows of a \
                 parallel hybrid with the vehicle speed and the battery's charge as states, the engine's and the \
                 machine's shaft power and the friction brakes as inputs, the split decided by the strategy \
                 (modes hybrid, electric, brake, stop)"
            )
        }
    };
    format!(
        "{vehicle} ({kind}), imported from FASTSim: FASTSim's quasi-static road load and energy flows with the \
         vehicle speed as state and the tractive force at the wheels as input"
    )
}

fn header(vehicle: &str, source: &str, warnings: &[String]) -> Vec<String> {
    let mut h = vec![
        format!("{vehicle}: generated by `invsim import fastsim {source}`; do not edit (re-import instead)."),
        "Vehicle data: FASTSim (NREL, https://github.com/NREL/fastsim), Apache License 2.0.".to_string(),
        "The model reproduces FASTSim 3's physics: its road load (air density 1.17285 kg/m^3, g = 9.8 m/s^2,".to_string(),
        "the wheels' rotating inertia), transmission, auxiliary load and efficiency tables; FASTSim walks the".to_string(),
        "cycle in 1 s steps, invsim follows the smoothed cycle (see docs/vehicles.md).".to_string(),
    ];
    if !warnings.is_empty() {
        h.push(String::new());
        h.push("Import warnings:".to_string());
        for w in warnings {
            h.extend(wrap(&format!("- {w}"), 110));
        }
    }
    h
}

/// `text` broken at spaces into lines of at most `width` characters (continuations indented by two).
fn wrap(text: &str, width: usize) -> Vec<String> {
    let mut lines = Vec::new();
    let mut line = String::new();
    for word in text.split(' ') {
        if !line.is_empty() && line.len() + 1 + word.len() > width {
            lines.push(std::mem::replace(&mut line, "  ".to_string()));
        }
        if !line.is_empty() && line != "  " {
            line.push(' ');
        }
        line.push_str(word);
    }
    lines.push(line);
    lines
}
