//! The equivalence factor s of ECMS and the J1711 correction of the fuel to ΔSOC = 0.
//!
//! **The search.** ΔSOC(s), the run's change of charge, rises with s (a dearer battery is used less and
//! charged more). From s₀ = 2.5 (in round figures 1/(η_engine · η_electric), a petrol engine at 35 % and an
//! electric path at 85 % giving 3.4, a better engine less) the bracket is widened by factors of 2 until ΔSOC changes sign
//! (at most [`MAX_WIDEN`] steps each way, s in [2.5/2¹², 2.5·2¹²]); then regula falsi with the Illinois
//! modification (Dowell & Jarratt, BIT 1971) until |ΔSOC| ≤ the tolerance, within [`MAX_RUNS`] runs in all;
//! where the bracket's runs differ at one sample alone (ΔSOC jumps there), that sample is shared at once
//! ([`Share`]) rather than the bracket narrowed onto the jump. A
//! target no s in the bracket reaches (ΔSOC of one sign throughout, or a jump of ΔSOC across the tolerance
//! band where one sample's mode choice flips) is an error that names `--strategy ecms`, `--equivalence` and
//! `--soc-tolerance`.
//!
//! **SAE J1711 (2010), §6.5, linear correction.** Fuel consumption against the battery's net energy change is
//! a straight line through two tests; the fuel at zero change is read off it. Here the two tests are two runs
//! at different s: fuel_corr = fuel − ΔSOC · (fuel₂ − fuel)/(ΔSOC₂ − ΔSOC), the second run the search's other
//! bracket end (ΔSOC of the other sign), or, for a given s, a run at 1.05 s.

use super::ecms::{Ecms, Outcome, Share};
use super::ModalError;

/// Most runs of the search.
pub(crate) const MAX_RUNS: usize = 60;
/// Most widenings of the bracket each way.
pub(crate) const MAX_WIDEN: usize = 12;
/// The search's start.
const S0: f64 = 2.5;

/// The run at the given s and the second run of the correction: (run, runs, other).
pub(super) fn fixed(
    run: &Ecms<'_, '_, '_>,
    s: f64,
    x0: &[f64],
) -> Result<(Outcome, usize, Option<Outcome>), ModalError> {
    let best = run.run(s, x0)?;
    let other = run.run(1.05 * s, x0)?;
    Ok((best, 1, Some(other)))
}

/// The charge-sustaining run: (run, runs taken, the bracket's other end).
pub(super) fn search(
    run: &Ecms<'_, '_, '_>,
    tol: f64,
    x0: &[f64],
) -> Result<(Outcome, usize, Option<Outcome>), ModalError> {
    let mut runs = 1;
    let first = run.run(S0, x0)?;
    if first.delta_soc().abs() <= tol {
        let other = run.run(1.05 * S0, x0)?;
        return Ok((first, runs, Some(other)));
    }
    // Widen towards the sign change.
    let up = first.delta_soc() < 0.0;
    let mut near = first;
    let mut far = None;
    for _ in 0..MAX_WIDEN {
        let s = if up { near.s * 2.0 } else { near.s / 2.0 };
        let o = run.run(s, x0)?;
        runs += 1;
        if o.delta_soc().abs() <= tol {
            return Ok((o, runs, Some(near)));
        }
        if (o.delta_soc() < 0.0) != up {
            far = Some(o);
            break;
        }
        near = o;
    }
    let Some(far) = far else {
        return Err(unreachable(&near, tol));
    };
    // (lo, hi): ΔSOC(lo) < 0 < ΔSOC(hi).
    let (mut lo, mut hi) = if up { (near, far) } else { (far, near) };
    // Illinois: the value of an end kept while the other is replaced twice in a row is halved.
    let (mut scale_lo, mut scale_hi, mut last) = (1.0, 1.0, 0i8);
    let mut tried: Option<usize> = None;
    while runs < MAX_RUNS {
        let (wl, wh) = (scale_lo * lo.delta_soc(), scale_hi * hi.delta_soc());
        let mut s = hi.s - wh * (hi.s - lo.s) / (wh - wl);
        if !(s > lo.s && s < hi.s) {
            s = 0.5 * (lo.s + hi.s);
        }
        if hi.s - lo.s <= 1e-7 * hi.s {
            return relax(run, (lo, hi), (tol, x0), runs);
        }
        // The bracketing runs differ at one sample alone: share it now rather than narrow s onto the jump.
        // (Once per sample: where it cannot bridge the jump, narrowing goes on.)
        if let Some(k) = run
            .only_difference(&lo.rec, &hi.rec)
            .filter(|&k| tried != Some(k))
        {
            tried = Some(k);
            match relax_at(run, k, (lo, hi), (tol, x0), runs)? {
                Ok(found) => return Ok(found),
                Err((l, h, used)) => (lo, hi, runs) = (l, h, used),
            }
            if runs >= MAX_RUNS {
                break;
            }
        }
        let o = run.run(s, x0)?;
        runs += 1;
        if o.delta_soc().abs() <= tol {
            let other = if o.delta_soc() < 0.0 { hi } else { lo };
            return Ok((o, runs, Some(other)));
        }
        if o.delta_soc() < 0.0 {
            lo = o;
            scale_lo = 1.0;
            if last == -1 {
                scale_hi *= 0.5;
            }
            last = -1;
        } else {
            hi = o;
            scale_hi = 1.0;
            if last == 1 {
                scale_lo *= 0.5;
            }
            last = 1;
        }
    }
    Err(ModalError::Setup(format!(
        "--strategy ecms: the search for the equivalence factor took {MAX_RUNS} runs without |ΔSOC| ≤ {tol:e} \
         (ΔSOC {:+.3e} at s = {}, {:+.3e} at s = {}); give --equivalence S or a wider --soc-tolerance",
        lo.delta_soc(),
        lo.s,
        hi.delta_soc(),
        hi.s
    )))
}

/// ΔSOC keeps its sign over the whole bracket.
fn unreachable(last: &Outcome, tol: f64) -> ModalError {
    ModalError::Setup(format!(
        "--strategy ecms: no equivalence factor ends the run charge-sustaining (|ΔSOC| ≤ {tol:e}): ΔSOC is \
         still {:+.3e} at s = {} after widening the search from s = {S0} by 2^{MAX_WIDEN}; the final SOC is \
         unreachable on this cycle (check the battery's bounds and the decided input's), or give \
         --equivalence S",
        last.delta_soc(),
        last.s
    ))
}

/// The search's result: (run, runs taken, the other run of the J1711 correction).
type Found = (Outcome, usize, Option<Outcome>);

/// Where ΔSOC(s) jumps across the band at s (lo and hi within 10⁻⁷ s of each other): the relaxed choice at
/// the first sample where the two runs differ ([`relax_at`]); a jump it cannot bridge is the error.
fn relax(
    run: &Ecms<'_, '_, '_>,
    (lo, hi): (Outcome, Outcome),
    (tol, x0): (f64, &[f64]),
    runs: usize,
) -> Result<Found, ModalError> {
    let Some(k) = run.first_difference(&lo.rec, &hi.rec) else {
        return Err(jump(&lo, &hi, tol));
    };
    match relax_at(run, k, (lo, hi), (tol, x0), runs)? {
        Ok(found) => Ok(found),
        Err((lo, hi, _)) => Err(jump(&lo, &hi, tol)),
    }
}

/// The relaxed choice at sample k ([`Share`]) between the runs at lo and hi, its share θ ∈ [0, 1] found by
/// regula falsi (Illinois) so that |ΔSOC| ≤ tol. Where ΔSOC(θ) does not change sign over [0, 1] (later
/// choices depend on that one, as with a start penalty, or the runs differ elsewhere by more than the
/// sample can make up) the bracket is handed back with the runs used.
#[allow(clippy::type_complexity)]
fn relax_at(
    run: &Ecms<'_, '_, '_>,
    k: usize,
    (lo, hi): (Outcome, Outcome),
    (tol, x0): (f64, &[f64]),
    mut runs: usize,
) -> Result<Result<Found, (Outcome, Outcome, usize)>, ModalError> {
    let at = |theta: f64| Share {
        k,
        other: lo.s,
        theta,
    };
    let mut a = (0.0, run.run_shared(hi.s, x0, Some(&at(0.0)))?);
    let mut b = (1.0, run.run_shared(hi.s, x0, Some(&at(1.0)))?);
    runs += 2;
    if a.1.delta_soc().abs() <= tol {
        return Ok(Ok((a.1, runs, Some(hi))));
    }
    if b.1.delta_soc().abs() <= tol {
        return Ok(Ok((b.1, runs, Some(lo))));
    }
    if (a.1.delta_soc() < 0.0) == (b.1.delta_soc() < 0.0) {
        return Ok(Err((lo, hi, runs)));
    }
    let (mut scale_a, mut scale_b, mut last) = (1.0, 1.0, 0i8);
    while runs < MAX_RUNS {
        let (fa, fb) = (scale_a * a.1.delta_soc(), scale_b * b.1.delta_soc());
        let mut th = b.0 - fb * (b.0 - a.0) / (fb - fa);
        if !(th > a.0 && th < b.0) {
            th = 0.5 * (a.0 + b.0);
        }
        let o = run.run_shared(hi.s, x0, Some(&at(th)))?;
        runs += 1;
        if o.delta_soc().abs() <= tol {
            let other = if o.delta_soc() < 0.0 { hi } else { lo };
            return Ok(Ok((o, runs, Some(other))));
        }
        if (o.delta_soc() < 0.0) == (a.1.delta_soc() < 0.0) {
            a = (th, o);
            scale_a = 1.0;
            if last == -1 {
                scale_b *= 0.5;
            }
            last = -1;
        } else {
            b = (th, o);
            scale_b = 1.0;
            if last == 1 {
                scale_a *= 0.5;
            }
            last = 1;
        }
    }
    Err(jump(&lo, &hi, tol))
}

/// ΔSOC jumps across the tolerance band between two equivalence factors that no longer differ.
fn jump(lo: &Outcome, hi: &Outcome, tol: f64) -> ModalError {
    ModalError::Setup(format!(
        "--strategy ecms: ΔSOC jumps from {:+.3e} to {:+.3e} at s = {} (a mode choice flips there), across the \
         tolerance |ΔSOC| ≤ {tol:e}; give a wider --soc-tolerance or --equivalence S",
        lo.delta_soc(),
        hi.delta_soc(),
        lo.s
    ))
}

/// The J1711 correction: (fuel at ΔSOC = 0, d fuel / d ΔSOC) from the line through `best` and `other`.
pub(super) fn correction(best: &Outcome, other: &Option<Outcome>) -> (Option<f64>, Option<f64>) {
    let Some(o) = other else {
        return (None, None);
    };
    let dd = o.delta_soc() - best.delta_soc();
    if dd == 0.0 || !dd.is_finite() {
        return (None, None);
    }
    let slope = (o.fuel - best.fuel) / dd;
    (Some(best.fuel - best.delta_soc() * slope), Some(slope))
}
