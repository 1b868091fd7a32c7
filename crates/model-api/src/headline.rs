//! The model's headline figure (the model file's `[headline]`): which accumulated output is the model's answer,
//! whether it is a fuel or electric energy, and the fuel's properties that turn its integral into litres,
//! kilograms and CO₂.
//!
//! Default fuel properties (used when `[headline]` names `fuel = "petrol"` or `"diesel"` without its own
//! `density` or `carbon_fraction`):
//!
//! - Carbon mass fraction w_C = 0.866 for both: UNECE Regulation No. 101, Annex 6, §1.4.3, the carbon-balance
//!   fuel consumption FC = (0.1154/D)·(0.866·HC + 0.429·CO + 0.273·CO₂) for petrol and (0.1155/D)·(…) for
//!   diesel, whose prefactor is 0.1/w_C (0.1/0.1154 = 0.8666, 0.1/0.1155 = 0.8658).
//! - Density at 15 °C: petrol 745 kg/m³ (EN 228 allows 720–775 kg/m³; the shipped models' `rho_f`), diesel
//!   835 kg/m³ (EN 590 allows 820–845 kg/m³; the middle of the reference diesel's 833–837 kg/m³ of UNECE
//!   Regulation No. 83, Annex 10).
//!
//! CO₂ per kg of fuel is w_C · M(CO₂)/M(C) (runtime `units.rs`): 3.173 kg/kg, so 2.364 kg CO₂ per litre of
//! petrol and 2.650 kg per litre of diesel. For comparison, the US EPA's 8 887 g CO₂ per gallon of gasoline
//! (2.348 kg/l) and 10 180 g per gallon of diesel (2.689 kg/l) (EPA-420-F-18-008, 2018): within 0.7 % and 1.5 %.

/// The model's headline: the accumulated output whose integral the summary leads with.
#[derive(Debug, Clone, PartialEq)]
pub struct HeadlineInfo {
    /// Index into [`crate::ModelInfo::outputs`].
    pub output: usize,
    /// What the output's integral measures.
    pub carrier: Carrier,
}

/// What a headline output's integral measures.
#[derive(Debug, Clone, PartialEq)]
pub enum Carrier {
    /// A liquid fuel.
    Fuel(FuelInfo),
    /// Electric energy; the integral times `kwh_per_unit` is in kWh (an output in W: 1/3.6e6).
    Electricity { kwh_per_unit: f64 },
}

/// A fuel headline: the fuel's name and properties and how the output's integral measures it.
#[derive(Debug, Clone, PartialEq)]
pub struct FuelInfo {
    /// `petrol`, `diesel` or the model's own name for its fuel.
    pub name: String,
    /// The integral as a volume or a mass.
    pub flow: FuelFlow,
    /// The fuel's density, kg/m³.
    pub density: Density,
    /// The fuel's carbon mass fraction w_C (kg of carbon per kg of fuel).
    pub carbon_fraction: f64,
}

/// How a fuel output's integral measures the fuel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FuelFlow {
    /// A volume flow: the integral times the factor is in litres (an output in l/s: 1).
    Litres(f64),
    /// A mass flow: the integral times the factor is in kilograms (an output in kg/s: 1).
    Kilograms(f64),
}

/// A fuel's density, kg/m³: a number or one of the model's parameters (so that `--set` changes it).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Density {
    Value(f64),
    /// Index into [`crate::ModelInfo::parameters`].
    Parameter(usize),
}

impl Density {
    /// The density in kg/m³ with the parameters `params` (in [`crate::ModelInfo::parameters`] order); NaN for
    /// a parameter index out of range.
    pub fn value(&self, params: &[f64]) -> f64 {
        match *self {
            Density::Value(v) => v,
            Density::Parameter(i) => params.get(i).copied().unwrap_or(f64::NAN),
        }
    }
}

/// A fuel whose properties invsim knows: name, density (kg/m³) and carbon mass fraction (see the module doc).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KnownFuel {
    pub name: &'static str,
    pub density: f64,
    pub carbon_fraction: f64,
}

/// The fuels a model may name without giving their properties.
pub const KNOWN_FUELS: [KnownFuel; 2] = [
    KnownFuel {
        name: "petrol",
        density: 745.0,
        carbon_fraction: 0.866,
    },
    KnownFuel {
        name: "diesel",
        density: 835.0,
        carbon_fraction: 0.866,
    },
];

/// The known fuel called `name`, if any.
pub fn known_fuel(name: &str) -> Option<KnownFuel> {
    KNOWN_FUELS.iter().copied().find(|f| f.name == name)
}
