//! The summary's figures differentiated: each accumulated output's integral, its per-100-km figure and the
//! headline's figures, from the integrals' derivatives (the distance is the cycle's: no parameter moves it).
//!
//! The headline's figures are functions of the integral I and the fuel's density ρ (a parameter where the
//! model file names one), differentiated in closed form ([`crate::headline`]'s formulas):
//! litres = I·f (or I·f·1000/ρ), kg = I·f·ρ/1000 (or I·f), CO₂ = kg·c, per 100 km = ·10⁵/distance, mpg = K/(l/100 km)
//! so d mpg = −mpg/(l/100 km) · d(l/100 km); kWh = I·k, Wh/km = 10·kWh/100 km, mpgge = K/(kWh/100 km).

use std::collections::BTreeMap;

use invsim_model_api::{Carrier, Density, FuelFlow, ModelInfo};

use crate::units;

/// d figure/d parameter for every figure, by the figure's name, then the parameter's.
pub type Figures = BTreeMap<String, BTreeMap<String, f64>>;

/// The integrals' values and their derivatives (`[a][c]`: accumulated output a, wanted parameter c).
pub(crate) struct Integrals<'a> {
    pub accumulate: &'a [usize],
    pub values: &'a [f64],
    pub derivatives: &'a [Vec<f64>],
}

/// What the derivatives are taken with respect to: each one's name in the gradient block (none: the
/// parameters' own) and the model parameter it moves (an index into the model's parameters: a gearbox's
/// `i_g[3]` moves `i_g` in third gear; P + g for grid value g, which moves no parameter), and every
/// parameter's value (the fuel's density, where it is one).
pub(crate) struct Wrt<'a> {
    pub names: &'a [String],
    pub params: &'a [usize],
    pub values: &'a [f64],
}

/// The figures' derivatives with respect to `wrt` for a cycle of `distance_m` metres.
pub(crate) fn figures(
    info: &ModelInfo,
    wrt: &Wrt<'_>,
    integrals: &Integrals<'_>,
    distance_m: f64,
) -> Figures {
    let (params, values) = (wrt.params, wrt.values);
    let by_param = |info: &ModelInfo, params: &[usize], d: &[f64]| named(info, wrt, params, d);
    let mut out = Figures::new();
    let has_distance = distance_m > 0.0 && distance_m.is_finite();
    for (a, &o) in integrals.accumulate.iter().enumerate() {
        let output = &info.outputs[o];
        let d = &integrals.derivatives[a];
        out.insert(output.name.clone(), by_param(info, params, d));
        if has_distance && output.per_distance {
            let per: Vec<f64> = d.iter().map(|v| v * 1e5 / distance_m).collect();
            out.insert(
                format!("{}_per_100km", output.name),
                by_param(info, params, &per),
            );
        }
    }
    if let Some(h) = &info.headline {
        if let Some(a) = integrals.accumulate.iter().position(|&o| o == h.output) {
            let (i, di) = (integrals.values[a], &integrals.derivatives[a]);
            let columns: Vec<Vec<(&'static str, f64)>> = params
                .iter()
                .zip(di)
                .map(|(&p, &d)| match &h.carrier {
                    Carrier::Fuel(f) => fuel(f, values, (i, d, p), distance_m),
                    Carrier::Electricity { kwh_per_unit } => {
                        electric(i * kwh_per_unit, d * kwh_per_unit, distance_m)
                    }
                })
                .collect();
            for (j, &(name, _)) in columns
                .first()
                .map(Vec::as_slice)
                .unwrap_or(&[])
                .iter()
                .enumerate()
            {
                let v: Vec<f64> = columns.iter().map(|c| c[j].1).collect();
                out.insert(format!("headline.{name}"), by_param(info, params, &v));
            }
        }
    }
    out
}

/// The derivatives `d` by name: `wrt`'s names where it has them, else the parameters' own.
fn named(info: &ModelInfo, wrt: &Wrt<'_>, params: &[usize], d: &[f64]) -> BTreeMap<String, f64> {
    params
        .iter()
        .zip(d)
        .enumerate()
        .map(|(c, (&p, &v))| {
            let name = wrt
                .names
                .get(c)
                .cloned()
                .unwrap_or_else(|| info.parameters[p].clone());
            (name, v)
        })
        .collect()
}

/// A fuel headline's figures' derivatives along dI (and dρ = 1 where the density is the parameter `p`).
fn fuel(
    f: &invsim_model_api::FuelInfo,
    values: &[f64],
    (i, di, p): (f64, f64, usize),
    distance_m: f64,
) -> Vec<(&'static str, f64)> {
    let rho = f.density.value(values);
    let drho = match f.density {
        Density::Parameter(k) if k == p => 1.0,
        _ => 0.0,
    };
    let (litres, dl, dkg) = match f.flow {
        FuelFlow::Litres(k) => (i * k, di * k, (di * rho + i * drho) * k / 1000.0),
        FuelFlow::Kilograms(k) => {
            let l = i * k * 1000.0 / rho;
            (l, di * k * 1000.0 / rho - l / rho * drho, di * k)
        }
    };
    let dco2 = dkg * units::co2_per_kg_fuel(f.carbon_fraction);
    let mut out = vec![("litres", dl), ("kg", dkg), ("co2_kg", dco2)];
    if let (Some(l100), Some(dl100)) = (
        units::per_100km(litres, distance_m),
        units::per_100km(dl, distance_m),
    ) {
        out.push(("l_per_100km", dl100));
        if l100 > 0.0 {
            out.push(("mpg_us", -units::mpg_us(l100) / l100 * dl100));
            out.push(("mpg_uk", -units::mpg_uk(l100) / l100 * dl100));
        }
        if let Some(c) = units::per_100km(dco2, distance_m) {
            out.push(("co2_g_per_km", c * 10.0));
        }
    }
    out
}

/// An electric headline's figures' derivatives along dkWh.
fn electric(kwh: f64, dkwh: f64, distance_m: f64) -> Vec<(&'static str, f64)> {
    let mut out = vec![("kwh", dkwh)];
    if let (Some(k100), Some(dk100)) = (
        units::per_100km(kwh, distance_m),
        units::per_100km(dkwh, distance_m),
    ) {
        out.push(("kwh_per_100km", dk100));
        out.push(("wh_per_km", units::wh_per_km(dk100)));
        out.push(("wh_per_mi", units::wh_per_mile(dk100)));
        if k100 > 0.0 {
            out.push(("mpgge", -units::mpgge(k100) / k100 * dk100));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::headline::{Headline, HeadlineFigures};
    use invsim_model_api::{FuelInfo, HeadlineInfo, OutputInfo};

    /// A model with one accumulated output `q` (per distance), the headline `carrier`, and the parameters
    /// `k` (which scales the integral in the tests) and `rho_f` (the fuel's density where it is a parameter).
    fn model(carrier: Carrier) -> ModelInfo {
        ModelInfo {
            outputs: vec![OutputInfo {
                name: "q".into(),
                unit: None,
                accumulate: true,
                per_distance: true,
            }],
            parameters: vec!["k".into(), "rho_f".into()],
            headline: Some(HeadlineInfo { output: 0, carrier }),
            ..ModelInfo::default()
        }
    }

    /// The headline's figures by their gradient names.
    fn named(h: &Headline) -> BTreeMap<String, f64> {
        let v: Vec<(&str, Option<f64>)> = match &h.figures {
            HeadlineFigures::Fuel(f) => vec![
                ("litres", Some(f.litres)),
                ("kg", Some(f.kg)),
                ("co2_kg", Some(f.co2_kg)),
                ("l_per_100km", f.l_per_100km),
                ("mpg_us", f.mpg_us),
                ("mpg_uk", f.mpg_uk),
                ("co2_g_per_km", f.co2_g_per_km),
            ],
            HeadlineFigures::Electricity(e) => vec![
                ("kwh", Some(e.kwh)),
                ("kwh_per_100km", e.kwh_per_100km),
                ("wh_per_km", e.wh_per_km),
                ("wh_per_mi", e.wh_per_mi),
                ("mpgge", e.mpgge),
            ],
        };
        v.into_iter()
            .filter_map(|(n, x)| x.map(|x| (format!("headline.{n}"), x)))
            .collect()
    }

    /// With the integral I = k·I₀ (so dI/dk = I₀) and the density ρ = rho_f, every headline figure's derivative
    /// in k and in rho_f equals the central difference of `Headline::of` (the summary's own formulas) within
    /// 1e-7 relative (the figures are at most reciprocal in I and ρ: the step 1e-4 relative leaves a truncation
    /// error ~1e-8).
    #[test]
    fn headline_derivatives_are_those_of_the_summary_s_formulas() {
        let fuel = |flow| {
            Carrier::Fuel(FuelInfo {
                name: "petrol".into(),
                flow,
                density: Density::Parameter(1),
                carbon_fraction: 0.866,
            })
        };
        let carriers = [
            fuel(FuelFlow::Litres(1.0)),
            fuel(FuelFlow::Kilograms(1.0)),
            Carrier::Electricity { kwh_per_unit: 2.0 },
        ];
        let (i0, distance) = (0.6, 11_013.0);
        for carrier in carriers {
            let info = model(carrier);
            let at = |k: f64, rho: f64| {
                let integrals = BTreeMap::from([("q".to_string(), k * i0)]);
                named(&Headline::of(&info, &[k, rho], &integrals, distance).expect("a headline"))
            };
            let (k, rho) = (1.0, 745.0);
            let integrals = Integrals {
                accumulate: &[0],
                values: &[k * i0],
                derivatives: &[vec![i0, 0.0]],
            };
            let values = [k, rho];
            let wrt = Wrt {
                names: &[],
                params: &[0, 1],
                values: &values,
            };
            let g = figures(&info, &wrt, &integrals, distance);
            for (c, name, h) in [(0, "k", 1e-4 * k), (1, "rho_f", 1e-4 * rho)] {
                let (plus, minus) = if c == 0 {
                    (at(k + h, rho), at(k - h, rho))
                } else {
                    (at(k, rho + h), at(k, rho - h))
                };
                for (figure, p) in &plus {
                    let fd = (p - minus[figure]) / (2.0 * h);
                    let exact = g[figure][name];
                    let tol = 1e-7 * fd.abs().max(1e-9 * plus[figure].abs());
                    assert!(
                        (exact - fd).abs() <= tol,
                        "d{figure}/d{name}: {exact:e} vs {fd:e}"
                    );
                }
                assert_eq!(
                    g.keys().filter(|f| f.starts_with("headline.")).count(),
                    plus.len()
                );
            }
        }
    }
}
