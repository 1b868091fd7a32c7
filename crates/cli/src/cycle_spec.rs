//! Whether a `--cycle` argument names a built-in cycle or a cycle file, answered from the names alone; and
//! the cycle's tolerance band from `--tolerance SPEED_KMH,TIME_S`.
//!
//! `Cycle::builtin` builds the cycle it finds (the NEDC from four ECE-15s and an EUDC); the checks a command
//! makes before it loads the cycle (which inputs are files, what the provenance records) need only the answer.

use invsim_runtime::cycle::Tolerance;
use invsim_runtime::Cycle;

use crate::error::Failure;

/// Is `spec` a name `Cycle::builtin` accepts (trimmed, ASCII case ignored: it lower-cases and matches the
/// names of `Cycle::builtin_names`)?
pub fn is_builtin(spec: &str) -> bool {
    let lower = spec.trim().to_ascii_lowercase();
    Cycle::builtin_names().contains(&lower.as_str())
}

/// `--tolerance SPEED_KMH,TIME_S` applied to `cycle` (without it the cycle keeps its regulation's band:
/// EPA ±2 mph, ±1 s for UDDS, HWFET and cycle files; UNECE ±2 km/h, ±1 s for the NEDC and the WLTC).
pub fn apply_tolerance(cycle: &mut Cycle, tolerance: Option<&str>) -> Result<(), Failure> {
    let Some(spec) = tolerance else {
        return Ok(());
    };
    let bad = |why: String| {
        Failure::user(format!(
            "--tolerance `{spec}`: {why}; expected SPEED_KMH,TIME_S, e.g. --tolerance 2,1 (±2 km/h, ±1 s)"
        ))
    };
    let (speed, time) = spec.split_once(',').ok_or_else(|| bad("no comma".into()))?;
    let number =
        |s: &str| crate::number_arg::parse_number(s).map_err(|e| bad(e.describe(s.trim())));
    cycle.tolerance =
        Tolerance::new(number(speed)?, number(time)?).map_err(|e| bad(e.to_string()))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `--tolerance` sets the band in m/s; bad values are refused with the expected form.
    #[test]
    fn tolerance_option() {
        let mut c = Cycle::builtin("udds").unwrap();
        assert_eq!(c.tolerance, Tolerance::EPA);
        assert!(apply_tolerance(&mut c, Some("3.6, 0.5")).is_ok());
        assert!((c.tolerance.speed_mps - 1.0).abs() < 1e-15 && c.tolerance.time_s == 0.5);
        for bad in [
            "3", "a,1", "1,b", "-1,1", "1,-1", "nan,1", "1,inf", "1e9,1", "1e-400,1", "2,1e-999",
        ] {
            let e = apply_tolerance(&mut c, Some(bad))
                .err()
                .map(|f| f.message)
                .unwrap_or_default();
            assert!(e.contains("SPEED_KMH,TIME_S"), "{bad}: {e}");
        }
    }

    /// The answer is `Cycle::builtin(spec).is_some()` for every name, in other cases, padded, and for names
    /// that are not built in.
    #[test]
    fn agrees_with_building_the_cycle() {
        let mut specs: Vec<String> = Vec::new();
        for name in Cycle::builtin_names() {
            specs.push(name.to_string());
            specs.push(name.to_ascii_uppercase());
            specs.push(format!("  {name}\t"));
            specs.push(format!("{name}x"));
            specs.push(format!("{name}.csv"));
        }
        specs.extend(
            [
                "",
                " ",
                "nedc2",
                "wltc3",
                "wltc3b-",
                "cycles/nedc.csv",
                "ＮＥＤＣ",
                "nedc\u{0}",
            ]
            .map(String::from),
        );
        for spec in &specs {
            assert_eq!(is_builtin(spec), Cycle::builtin(spec).is_some(), "`{spec}`");
        }
        assert!(is_builtin("NEDC") && is_builtin(" wltc3b-extra-high "));
        assert!(!is_builtin("../shared/cycles/udds.csv"));
    }
}
