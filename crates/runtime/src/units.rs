//! The units people report a car's consumption in: l/100 km, mpg (US and UK gallons), CO₂ g/km, kWh/100 km,
//! Wh/km, Wh/mi and mpgge, each from a figure per 100 km. Every constant is exact by definition or cited.

/// Litres in a US liquid gallon: 231 in³ × (2.54 cm)³ = 3.785411784 l, exact (NIST Handbook 44, Appendix C).
pub const LITRES_PER_US_GALLON: f64 = 3.785_411_784;

/// Litres in an imperial (UK) gallon, exact (UK Weights and Measures Act 1985, Schedule 1).
pub const LITRES_PER_UK_GALLON: f64 = 4.546_09;

/// Kilometres in an international mile (1 760 yd × 0.9144 m), exact.
pub const KM_PER_MILE: f64 = 1.609_344;

/// Electric energy counted as one US gallon of gasoline, kWh: the US EPA's gasoline-gallon equivalent for the
/// fuel economy label's MPGe (40 CFR 600.002, "gallon equivalent"; 76 FR 39478, 2011).
pub const KWH_PER_GALLON_EQUIVALENT: f64 = 33.705;

/// Molar masses, g/mol: IUPAC conventional standard atomic weights C 12.011, O 15.999; CO₂ = C + 2 O.
const MOLAR_MASS_C: f64 = 12.011;
const MOLAR_MASS_CO2: f64 = 12.011 + 2.0 * 15.999;

/// Miles per US gallon for `l_per_100km`: 100 km / l_per_100km litres, i.e.
/// mpg = (100 / 1.609344 mi) / (l_per_100km / 3.785411784 gal) = 235.2146 / l_per_100km.
pub fn mpg_us(l_per_100km: f64) -> f64 {
    100.0 * LITRES_PER_US_GALLON / (KM_PER_MILE * l_per_100km)
}

/// Miles per imperial gallon for `l_per_100km`: mpg = 100 · 4.54609 / (1.609344 · l_per_100km) =
/// 282.4809 / l_per_100km.
pub fn mpg_uk(l_per_100km: f64) -> f64 {
    100.0 * LITRES_PER_UK_GALLON / (KM_PER_MILE * l_per_100km)
}

/// Miles per gallon-equivalent for `kwh_per_100km` of electric energy: kWh per mile = kwh_per_100km ·
/// 1.609344 / 100, and mpgge = 33.705 / (kWh per mile).
pub fn mpgge(kwh_per_100km: f64) -> f64 {
    100.0 * KWH_PER_GALLON_EQUIVALENT / (KM_PER_MILE * kwh_per_100km)
}

/// Wh per km for `kwh_per_100km`: 1 kWh/100 km = 1000 Wh / 100 km = 10 Wh/km.
pub fn wh_per_km(kwh_per_100km: f64) -> f64 {
    10.0 * kwh_per_100km
}

/// Wh per mile for `kwh_per_100km`: Wh/km × 1.609344 km/mi.
pub fn wh_per_mile(kwh_per_100km: f64) -> f64 {
    wh_per_km(kwh_per_100km) * KM_PER_MILE
}

/// kg of CO₂ from burning 1 kg of a fuel of carbon mass fraction `carbon_fraction`, all its carbon oxidised
/// to CO₂: w_C · M(CO₂)/M(C) = w_C · 44.009/12.011 (3.173 for w_C = 0.866).
pub fn co2_per_kg_fuel(carbon_fraction: f64) -> f64 {
    carbon_fraction * MOLAR_MASS_CO2 / MOLAR_MASS_C
}

/// `amount` per 100 km over `distance_m` metres: amount · 1e5 / distance_m; `None` for a distance that is not
/// positive and finite.
pub fn per_100km(amount: f64, distance_m: f64) -> Option<f64> {
    (distance_m > 0.0 && distance_m.is_finite()).then(|| amount * 1e5 / distance_m)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64, tol: f64) {
        assert!((a - b).abs() <= tol, "{a} is not {b} ± {tol}");
    }

    /// 6.0 l/100 km: 100 km = 62.1371 mi on 6.0 l = 1.58503 US gal (6.0/3.785411784), 39.2024 mpg;
    /// = 1.31981 UK gal (6.0/4.54609), 47.0801 mpg.
    #[test]
    fn six_litres_per_100km_in_mpg() {
        close(mpg_us(6.0), 39.2024, 1e-4);
        close(mpg_uk(6.0), 47.0801, 1e-4);
        // 10 l/100 km, the round number people remember: 23.52 mpg (US), 28.25 mpg (UK).
        close(mpg_us(10.0), 23.5215, 1e-4);
        close(mpg_uk(10.0), 28.2481, 1e-4);
        // mpg times l/100 km is constant: 235.2146 (US), 282.4809 (UK).
        close(mpg_us(7.3) * 7.3, 235.214_583, 1e-6);
        close(mpg_uk(4.2) * 4.2, 282.480_936, 1e-6);
    }

    /// 15 kWh/100 km: 0.15 kWh/km × 1.609344 km/mi = 0.2414016 kWh/mi, so 150 Wh/km, 241.4016 Wh/mi and
    /// 33.705/0.2414016 = 139.622 mpgge.
    #[test]
    fn fifteen_kwh_per_100km_in_wh_and_mpgge() {
        close(wh_per_km(15.0), 150.0, 1e-12);
        close(wh_per_mile(15.0), 241.4016, 1e-9);
        close(mpgge(15.0), 139.622, 1e-3);
        // The EPA's convention: 33.705 kWh per mile is 1 mpgge, i.e. 2094.26 kWh/100 km.
        close(mpgge(33.705 * 100.0 / KM_PER_MILE), 1.0, 1e-12);
    }

    /// Petrol (w_C = 0.866, 745 kg/m³): 0.866 × 44.009/12.011 = 3.17307 kg CO₂/kg, × 0.745 kg/l = 2.3639 kg/l;
    /// 6.0 l/100 km = 0.06 l/km → 141.8 g/km. Diesel at 835 kg/m³: 2.6495 kg/l.
    #[test]
    fn co2_of_petrol_and_diesel() {
        close(co2_per_kg_fuel(0.866), 3.173_07, 1e-5);
        close(co2_per_kg_fuel(0.866) * 0.745, 2.363_94, 1e-5);
        close(co2_per_kg_fuel(0.866) * 0.835, 2.649_52, 1e-5);
        close(0.06 * 0.745 * co2_per_kg_fuel(0.866) * 1e3, 141.836, 1e-3);
        // Pure carbon: 44.009/12.011 = 3.66406.
        close(co2_per_kg_fuel(1.0), 3.664_06, 1e-5);
    }

    #[test]
    fn per_100km_needs_a_distance() {
        close(
            per_100km(0.7, 11_013.0).unwrap_or(f64::NAN),
            6.356_125,
            1e-6,
        );
        assert_eq!(per_100km(1.0, 0.0), None);
        assert_eq!(per_100km(1.0, f64::INFINITY), None);
    }
}
