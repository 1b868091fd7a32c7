//! The summary's `headline` block: the model's answer (the accumulated output its `[headline]` names) in the
//! units people report — l/100 km, mpg (US and UK) and CO₂ g/km for a fuel; kWh/100 km, Wh/km, Wh/mi and
//! mpgge for electric energy — computed from the output's integral over the run and the cycle's distance
//! (conversions: [`crate::units`]).

use std::collections::BTreeMap;
use std::fmt::Write as _;

use invsim_model_api::{Carrier, FuelFlow, FuelInfo, ModelInfo};
use serde::Serialize;

use crate::report::fmt_sig;
use crate::units;

/// The model's answer in the units people report (JSON `headline`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Headline {
    /// The accumulated output whose integral this is.
    pub output: String,
    /// `kind` (`fuel` or `electricity`) and the figures.
    #[serde(flatten)]
    pub figures: HeadlineFigures,
}

/// A fuel's or electric energy's figures.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum HeadlineFigures {
    Fuel(FuelFigures),
    Electricity(ElectricFigures),
}

/// A fuel over the run; the per-distance figures are `None` (JSON null) without a distance, and the mpg
/// figures also where no fuel was burnt.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FuelFigures {
    /// `petrol`, `diesel` or the model's name for its fuel.
    pub fuel: String,
    /// The density (kg/m³) and carbon mass fraction used.
    pub density_kg_per_m3: f64,
    pub carbon_fraction: f64,
    /// The fuel burnt over the run, in litres and kg, and the CO₂ from its carbon, kg.
    pub litres: f64,
    pub kg: f64,
    pub co2_kg: f64,
    pub l_per_100km: Option<f64>,
    pub mpg_us: Option<f64>,
    pub mpg_uk: Option<f64>,
    pub co2_g_per_km: Option<f64>,
}

/// Electric energy over the run; the per-distance figures are `None` without a distance, mpgge also where no
/// net energy was drawn.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ElectricFigures {
    pub kwh: f64,
    pub kwh_per_100km: Option<f64>,
    pub wh_per_km: Option<f64>,
    pub wh_per_mi: Option<f64>,
    pub mpgge: Option<f64>,
}

impl Headline {
    /// The headline of a run of `info`'s model with the parameters `params` over `distance_m` metres, from the
    /// integrals of its accumulated outputs by name; `None` for a model without `[headline]`.
    pub(crate) fn of(
        info: &ModelInfo,
        params: &[f64],
        integrals: &BTreeMap<String, f64>,
        distance_m: f64,
    ) -> Option<Headline> {
        let h = info.headline.as_ref()?;
        let output = info.outputs.get(h.output)?.name.clone();
        let integral = *integrals.get(&output)?;
        let figures = match &h.carrier {
            Carrier::Fuel(fuel) => {
                HeadlineFigures::Fuel(fuel_figures(fuel, params, integral, distance_m))
            }
            Carrier::Electricity { kwh_per_unit } => {
                HeadlineFigures::Electricity(electric_figures(integral * kwh_per_unit, distance_m))
            }
        };
        Some(Headline { output, figures })
    }

    /// Summary text: the line the summary leads with, e.g. `headline: 6.846 l/100 km = 34.36 mpg (US) =
    /// 41.26 mpg (UK), CO2 161.8 g/km (petrol; the output fuel_volume, 0.7536 l)`.
    pub(crate) fn write_text(&self, s: &mut String) {
        s.push_str("headline: ");
        let name = &self.output;
        match &self.figures {
            HeadlineFigures::Fuel(f) => {
                let figures = [
                    f.l_per_100km.map(|v| format!("{} l/100 km", fmt_sig(v, 4))),
                    f.mpg_us.map(|v| format!("{} mpg (US)", fmt_sig(v, 4))),
                    f.mpg_uk.map(|v| format!("{} mpg (UK)", fmt_sig(v, 4))),
                ];
                write_figures(s, &figures);
                if let Some(c) = f.co2_g_per_km {
                    let _ = write!(s, ", CO2 {} g/km", fmt_sig(c, 4));
                }
                let _ = write!(
                    s,
                    " ({}; the output {name}, {} l, {} kg CO2)",
                    f.fuel,
                    fmt_sig(f.litres, 4),
                    fmt_sig(f.co2_kg, 4)
                );
            }
            HeadlineFigures::Electricity(e) => {
                let figures = [
                    e.kwh_per_100km
                        .map(|v| format!("{} kWh/100 km", fmt_sig(v, 4))),
                    e.wh_per_km.map(|v| format!("{} Wh/km", fmt_sig(v, 4))),
                    e.wh_per_mi.map(|v| format!("{} Wh/mi", fmt_sig(v, 4))),
                    e.mpgge.map(|v| format!("{} mpgge", fmt_sig(v, 4))),
                ];
                write_figures(s, &figures);
                let _ = write!(
                    s,
                    " (electric energy; the output {name}, {} kWh)",
                    fmt_sig(e.kwh, 4)
                );
            }
        }
        s.push('\n');
    }
}

/// The figures that exist, joined by ` = `, or a note that the run covered no distance.
fn write_figures(s: &mut String, figures: &[Option<String>]) {
    let present: Vec<&str> = figures.iter().flatten().map(String::as_str).collect();
    if present.is_empty() {
        s.push_str("no per-distance figures (the cycle covers no distance)");
    } else {
        s.push_str(&present.join(" = "));
    }
}

/// A fuel's figures from the integral of its output: litres = kg / ρ · 1000, CO₂ = kg · w_C · M(CO₂)/M(C).
fn fuel_figures(fuel: &FuelInfo, params: &[f64], integral: f64, distance_m: f64) -> FuelFigures {
    let density = fuel.density.value(params);
    let (litres, kg) = match fuel.flow {
        FuelFlow::Litres(f) => (integral * f, integral * f * density / 1000.0),
        FuelFlow::Kilograms(f) => (integral * f * 1000.0 / density, integral * f),
    };
    let co2_kg = kg * units::co2_per_kg_fuel(fuel.carbon_fraction);
    let l_per_100km = units::per_100km(litres, distance_m);
    let burnt = l_per_100km.filter(|&l| l > 0.0);
    FuelFigures {
        fuel: fuel.name.clone(),
        density_kg_per_m3: density,
        carbon_fraction: fuel.carbon_fraction,
        litres,
        kg,
        co2_kg,
        l_per_100km,
        mpg_us: burnt.map(units::mpg_us),
        mpg_uk: burnt.map(units::mpg_uk),
        // kg per 100 km → g/km: × 1000 g/kg / 100 km.
        co2_g_per_km: units::per_100km(co2_kg, distance_m).map(|c| c * 10.0),
    }
}

/// Electric energy's figures from `kwh` drawn over the run.
fn electric_figures(kwh: f64, distance_m: f64) -> ElectricFigures {
    let per_100km = units::per_100km(kwh, distance_m);
    ElectricFigures {
        kwh,
        kwh_per_100km: per_100km,
        wh_per_km: per_100km.map(units::wh_per_km),
        wh_per_mi: per_100km.map(units::wh_per_mile),
        mpgge: per_100km.filter(|&k| k > 0.0).map(units::mpgge),
    }
}

/// The sweep's columns of a fuel headline and of an electric one (the [`Headline::sweep_values`]).
const FUEL_COLUMNS: [&str; 4] = ["l_per_100km", "mpg_us", "mpg_uk", "co2_g_per_km"];
const ELECTRIC_COLUMNS: [&str; 2] = ["kwh_per_100km", "mpgge"];

/// The sweep's headline columns of `info`'s model: [`FUEL_COLUMNS`] or [`ELECTRIC_COLUMNS`], none without a
/// `[headline]`.
pub fn sweep_columns(info: &ModelInfo) -> Vec<String> {
    let names: &[&str] = match info.headline.as_ref().map(|h| &h.carrier) {
        Some(Carrier::Fuel(_)) => &FUEL_COLUMNS,
        Some(Carrier::Electricity { .. }) => &ELECTRIC_COLUMNS,
        None => &[],
    };
    names.iter().map(|n| n.to_string()).collect()
}

impl Headline {
    /// The figures under [`sweep_columns`], NaN where the summary has null.
    pub fn sweep_values(&self) -> Vec<f64> {
        let figures = match &self.figures {
            HeadlineFigures::Fuel(f) => vec![f.l_per_100km, f.mpg_us, f.mpg_uk, f.co2_g_per_km],
            HeadlineFigures::Electricity(e) => vec![e.kwh_per_100km, e.mpgge],
        };
        figures.into_iter().map(|v| v.unwrap_or(f64::NAN)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use invsim_model_api::{Density, HeadlineInfo, OutputInfo};

    fn model(carrier: Carrier, unit: &str) -> ModelInfo {
        ModelInfo {
            outputs: vec![OutputInfo {
                name: "q".into(),
                unit: Some(unit.into()),
                accumulate: true,
                per_distance: true,
            }],
            parameters: vec!["rho_f".into()],
            headline: Some(HeadlineInfo { output: 0, carrier }),
            ..ModelInfo::default()
        }
    }

    fn petrol(flow: FuelFlow, density: Density) -> Carrier {
        Carrier::Fuel(FuelInfo {
            name: "petrol".into(),
            flow,
            density,
            carbon_fraction: 0.866,
        })
    }

    fn integrals(v: f64) -> BTreeMap<String, f64> {
        BTreeMap::from([("q".to_string(), v)])
    }

    /// 0.6 l over 10 km: 6.0 l/100 km = 39.20 mpg (US) = 47.08 mpg (UK); 0.6 l × 0.745 kg/l = 0.447 kg,
    /// × 3.17307 = 1.41836 kg CO₂, 141.8 g/km.
    #[test]
    fn a_volume_flow_in_litres_mpg_and_co2() {
        let info = model(petrol(FuelFlow::Litres(1.0), Density::Value(745.0)), "l/s");
        let h = Headline::of(&info, &[], &integrals(0.6), 10_000.0).expect("a headline");
        let HeadlineFigures::Fuel(f) = &h.figures else {
            panic!("a fuel: {h:?}")
        };
        assert!((f.l_per_100km.unwrap_or(0.0) - 6.0).abs() < 1e-12);
        assert!((f.mpg_us.unwrap_or(0.0) - 39.2024).abs() < 1e-4);
        assert!((f.mpg_uk.unwrap_or(0.0) - 47.0802).abs() < 1e-4);
        assert!((f.kg - 0.447).abs() < 1e-12);
        assert!((f.co2_g_per_km.unwrap_or(0.0) - 141.836).abs() < 1e-3);
        let mut text = String::new();
        h.write_text(&mut text);
        assert_eq!(
            text,
            "headline: 6 l/100 km = 39.2 mpg (US) = 47.08 mpg (UK), CO2 141.8 g/km (petrol; the output q, \
             0.6 l, 1.418 kg CO2)\n"
        );
    }

    /// A mass flow with the density a parameter: 0.447 kg at ρ = 745 kg/m³ is 0.6 l; with `--set rho_f=760`
    /// 0.5882 l, and the CO₂ (from the mass) unchanged.
    #[test]
    fn a_mass_flow_uses_the_density_parameter() {
        let info = model(
            petrol(FuelFlow::Kilograms(1.0), Density::Parameter(0)),
            "kg/s",
        );
        let at = |rho: f64| match Headline::of(&info, &[rho], &integrals(0.447), 10_000.0) {
            Some(Headline {
                figures: HeadlineFigures::Fuel(f),
                ..
            }) => f,
            other => panic!("a fuel: {other:?}"),
        };
        assert!((at(745.0).litres - 0.6).abs() < 1e-12);
        assert!((at(760.0).litres - 0.447 / 0.76).abs() < 1e-12);
        assert_eq!(at(745.0).co2_kg, at(760.0).co2_kg);
    }

    /// 1.5 kWh over 10 km (the integral in J of an output in W): 15 kWh/100 km = 150 Wh/km = 241.4 Wh/mi =
    /// 139.6 mpgge; over no distance, no per-distance figures.
    #[test]
    fn electric_energy_in_kwh_per_100km_and_mpgge() {
        let info = model(
            Carrier::Electricity {
                kwh_per_unit: 1.0 / 3.6e6,
            },
            "W",
        );
        let h = Headline::of(&info, &[], &integrals(1.5 * 3.6e6), 10_000.0).expect("a headline");
        let HeadlineFigures::Electricity(e) = &h.figures else {
            panic!("electricity: {h:?}")
        };
        assert!((e.kwh_per_100km.unwrap_or(0.0) - 15.0).abs() < 1e-12);
        assert!((e.wh_per_mi.unwrap_or(0.0) - 241.4016).abs() < 1e-9);
        assert!((e.mpgge.unwrap_or(0.0) - 139.622).abs() < 1e-3);
        let json = serde_json::to_value(&h).unwrap_or_default();
        assert_eq!(json["kind"], "electricity");
        assert_eq!(json["output"], "q");
        let still = Headline::of(&info, &[], &integrals(3.6e6), 0.0).expect("a headline");
        let mut text = String::new();
        still.write_text(&mut text);
        assert_eq!(
            text,
            "headline: no per-distance figures (the cycle covers no distance) (electric energy; the output q, \
             1 kWh)\n"
        );
    }

    #[test]
    fn no_headline_without_one_in_the_model() {
        let info = ModelInfo::default();
        assert_eq!(Headline::of(&info, &[], &integrals(1.0), 1.0), None);
    }
}
