//! The optional `[headline]` table: the accumulated output whose integral is the model's answer, so that the
//! summary leads with it in the units people report (l/100 km, mpg and CO₂ g/km for a fuel; kWh/100 km and
//! mpgge for electric energy).
//!
//! ```toml
//! [headline]
//! output = "fuel_volume"     # an accumulated, per-distance [outputs] entry
//! fuel = "petrol"            # fuel outputs: "petrol", "diesel" or another name
//! density = "rho_f"          # optional: kg/m^3, a number or a parameter's name (default: the fuel's)
//! carbon_fraction = 0.866    # optional: the fuel's carbon mass fraction (default: the fuel's)
//! ```
//!
//! The output's unit says what it measures: a fuel volume flow (`l/s`, `ml/s`, `m^3/s`), a fuel mass flow
//! (`kg/s`, `g/s`) or an electric power (`W`, `kW`, `Wh/s`, `kWh/s`). A fuel other than petrol and diesel
//! needs its `density` and `carbon_fraction` (the defaults and their sources: `invsim_model_api::headline`).

use invsim_model_api::{known_fuel, Carrier, Density, FuelFlow, FuelInfo, HeadlineInfo};

use super::error::{ModelError, ModelErrorKind};
use super::keys;
use super::spanned::Reader;
use super::tree::{get, tv_at, Kind, Tv};
use super::validated::{ExtraOutput, Parameter};

/// A value as written with its position.
type At<T> = (T, Option<usize>);

/// `[headline]` as written.
#[derive(Debug)]
pub(super) struct RawHeadline {
    at: Option<usize>,
    output: At<String>,
    fuel: Option<At<String>>,
    density: Option<At<RawDensity>>,
    carbon_fraction: Option<At<f64>>,
}

/// `density` as written: a number (kg/m³) or a parameter's name.
#[derive(Debug)]
enum RawDensity {
    Value(f64),
    Parameter(String),
}

/// What the unit of a headline output says it measures, with the factor from its integral's unit.
enum Measure {
    Litres(f64),
    Kilograms(f64),
    KilowattHours(f64),
}

/// The units a headline output may have, and what each measures.
const UNITS: [(&str, Measure); 9] = [
    ("l/s", Measure::Litres(1.0)),
    ("ml/s", Measure::Litres(1e-3)),
    ("m^3/s", Measure::Litres(1e3)),
    ("kg/s", Measure::Kilograms(1.0)),
    ("g/s", Measure::Kilograms(1e-3)),
    // Power: J = W s, and 1 kWh = 3.6e6 J.
    ("W", Measure::KilowattHours(1.0 / 3.6e6)),
    ("kW", Measure::KilowattHours(1.0 / 3600.0)),
    ("Wh/s", Measure::KilowattHours(1e-3)),
    ("kWh/s", Measure::KilowattHours(1.0)),
];

const UNITS_SHOWN: &str =
    "a fuel flow in l/s, ml/s, m^3/s, kg/s or g/s, or an electric power in W, kW, Wh/s \
                           or kWh/s";

impl Reader<'_> {
    /// `[headline]`: `output` (required), `fuel`, `density`, `carbon_fraction`.
    pub(super) fn headline(&self, v: &Tv) -> Result<RawHeadline, ModelError> {
        let t = self.table(v, "[headline]")?;
        self.known_keys(t, keys::HEADLINE, "[headline]")?;
        let Some(output) = get(t, "output") else {
            return Err(self.err(
                tv_at(v),
                ModelErrorKind::Schema,
                "[headline] has no `output`; expected the name of an accumulated [outputs] entry, e.g. \
                 output = \"fuel\"",
            ));
        };
        let fuel = get(t, "fuel")
            .map(|f| Ok((self.string(f, "[headline]'s `fuel`")?, tv_at(f))))
            .transpose()?;
        let density = get(t, "density")
            .map(|d| Ok((self.density(d)?, tv_at(d))))
            .transpose()?;
        let carbon_fraction = get(t, "carbon_fraction")
            .map(|c| Ok((self.number(c, "[headline]'s `carbon_fraction`")?, tv_at(c))))
            .transpose()?;
        Ok(RawHeadline {
            at: tv_at(v),
            output: (self.string(output, "[headline]'s `output`")?, tv_at(output)),
            fuel,
            density,
            carbon_fraction,
        })
    }

    /// `density`: a number or a parameter's name.
    fn density(&self, v: &Tv) -> Result<RawDensity, ModelError> {
        match &v.kind {
            Kind::Str(name) => Ok(RawDensity::Parameter(name.clone())),
            _ => Ok(RawDensity::Value(self.number(
                v,
                "[headline]'s `density` (kg/m^3, or a parameter's name)",
            )?)),
        }
    }

    /// The `[headline]` resolved against the model's extra outputs and parameters.
    pub(super) fn resolve_headline(
        &self,
        raw: RawHeadline,
        outputs: &[ExtraOutput],
        parameters: &[Parameter],
    ) -> Result<HeadlineInfo, ModelError> {
        let (name, at) = &raw.output;
        let schema = |at: Option<usize>, message: String| {
            self.err(at.or(raw.at), ModelErrorKind::Schema, message)
        };
        let Some(index) = outputs.iter().position(|o| &o.name == name) else {
            let names: Vec<&str> = outputs.iter().map(|o| o.name.as_str()).collect();
            return Err(schema(
                *at,
                format!(
                    "[headline]'s `output` = \"{}\" is not an [outputs] entry (the model has: {}); name the \
                     accumulated output that is the model's answer",
                    name.escape_debug(),
                    if names.is_empty() { "none".to_string() } else { names.join(", ") }
                ),
            ));
        };
        let o = &outputs[index];
        if !o.accumulate || !o.per_distance {
            return Err(schema(
                *at,
                format!(
                    "[headline]'s output `{name}` must be accumulated and per distance (accumulate = true, \
                     per_distance not false): the headline is its integral per distance driven"
                ),
            ));
        }
        let unit = o.unit.as_deref().map(str::trim).unwrap_or("");
        let Some((_, measure)) = UNITS.iter().find(|(u, _)| *u == unit) else {
            return Err(schema(
                *at,
                format!(
                    "[headline]'s output `{name}` has the unit \"{}\"; a headline is {UNITS_SHOWN}",
                    unit.escape_debug()
                ),
            ));
        };
        let carrier = match *measure {
            Measure::Litres(f) => {
                Carrier::Fuel(self.fuel(&raw, FuelFlow::Litres(f), parameters)?)
            }
            Measure::Kilograms(f) => {
                Carrier::Fuel(self.fuel(&raw, FuelFlow::Kilograms(f), parameters)?)
            }
            Measure::KilowattHours(f) => {
                let fuel_key = raw.fuel.as_ref().map(|f| f.1);
                let key = raw.density.as_ref().map(|d| d.1);
                let key = key.or(raw.carbon_fraction.as_ref().map(|c| c.1));
                if let Some(at) = fuel_key.or(key) {
                    return Err(schema(
                        at,
                        format!(
                            "[headline]'s output `{name}` is an electric power ({unit}); `fuel`, `density` \
                             and `carbon_fraction` belong to a fuel flow"
                        ),
                    ));
                }
                Carrier::Electricity { kwh_per_unit: f }
            }
        };
        Ok(HeadlineInfo {
            output: index,
            carrier,
        })
    }

    /// The fuel of a fuel headline: its name, and its density and carbon fraction as given or by default.
    fn fuel(
        &self,
        raw: &RawHeadline,
        flow: FuelFlow,
        parameters: &[Parameter],
    ) -> Result<FuelInfo, ModelError> {
        let schema = |at: Option<usize>, message: String| {
            self.err(at.or(raw.at), ModelErrorKind::Schema, message)
        };
        let Some((name, at)) = &raw.fuel else {
            return Err(schema(
                raw.output.1,
                format!(
                    "[headline]'s output `{}` is a fuel flow: name the fuel, fuel = \"petrol\" or \"diesel\" \
                     (or another name with its density and carbon_fraction), for its litres and CO2",
                    raw.output.0
                ),
            ));
        };
        let known = known_fuel(name);
        let density = match &raw.density {
            Some((RawDensity::Value(v), at)) if *v <= 0.0 => {
                return Err(schema(
                    *at,
                    format!("[headline]'s `density` must be positive (kg/m^3), found {v}"),
                ))
            }
            Some((RawDensity::Value(v), _)) => Density::Value(*v),
            Some((RawDensity::Parameter(p), at)) => {
                let i = parameters.iter().position(|q| &q.name == p).ok_or_else(|| {
                    schema(
                        *at,
                        format!(
                            "[headline]'s `density` = \"{}\" is not a parameter of the model; give a number \
                             in kg/m^3 or a parameter's name",
                            p.escape_debug()
                        ),
                    )
                })?;
                if parameters[i].value <= 0.0 {
                    return Err(schema(
                        *at,
                        format!(
                            "[headline]'s `density` is the parameter `{p}`, whose value {} is not positive \
                             (kg/m^3)",
                            parameters[i].value
                        ),
                    ));
                }
                Density::Parameter(i)
            }
            None => Density::Value(
                known
                    .map(|k| k.density)
                    .ok_or_else(|| schema(*at, unknown_fuel(name, "density = 790.0 (kg/m^3)")))?,
            ),
        };
        let carbon_fraction = match raw.carbon_fraction {
            Some((c, at)) if !(c > 0.0 && c <= 1.0) => {
                return Err(schema(
                    at,
                    format!(
                        "[headline]'s `carbon_fraction` is a mass fraction in (0, 1], found {c}"
                    ),
                ))
            }
            Some((c, _)) => c,
            None => known
                .map(|k| k.carbon_fraction)
                .ok_or_else(|| schema(*at, unknown_fuel(name, "carbon_fraction = 0.52")))?,
        };
        Ok(FuelInfo {
            name: name.clone(),
            flow,
            density,
            carbon_fraction,
        })
    }
}

/// The message for a fuel invsim does not know that lacks the property `example` shows.
fn unknown_fuel(name: &str, example: &str) -> String {
    format!(
        "[headline]'s fuel \"{}\" is not one invsim knows (petrol, diesel): give its properties, e.g. {example}",
        name.escape_debug()
    )
}
