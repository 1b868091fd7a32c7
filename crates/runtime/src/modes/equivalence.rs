//! The equivalence factor s of ECMS and the J1711 correction of the fuel to ΔSOC = 0.
//!
//! **The search.** ΔSOC(s), the run's change of charge, rises with s (a dearer battery is used less and
//! charged more). From s₀ = 3 (in round figures 1/(η_engine · η_electric), a petrol engine near 35 % and an
//! electric path near 95 %, a better engine less) the bracket is widened by a factor 1.25, then each time by
//! the square of the factor before (1.25, 1.56, 2.44, 5.96, …), until ΔSOC changes sign (s within
//! [3/2¹², 3·2¹²]): close to s₀ the bracket stays narrow, ΔSOC(s) being flat far from its root (the battery
//! drained or filled whatever s) where interpolation would crawl. Then Brent's root finder ([`narrow`])
//! until |ΔSOC| ≤ the tolerance, within [`MAX_RUNS`] runs in all; where the bracket's runs choose another mode
//! at one sample alone (ΔSOC jumps there), that sample is shared at once ([`Share`]) rather than the bracket
//! narrowed onto the jump, and so is the flip where the band lies across a jump ([`across_jump`]). With internal states besides the charge (an engine's temperature) a flip moves
//! later choices too: a bracket within 10⁻⁴ s, or narrowed to 10⁻⁷ s, is shared at every sample where its
//! runs chose other modes at once, with one θ ([`relax_modes`]). A
//! target no s in the bracket reaches (ΔSOC of one sign throughout, or a jump of ΔSOC across the tolerance
//! band where one sample's mode choice flips) is an error that names `--strategy ecms`, `--equivalence` and
//! `--soc-tolerance`.
//!
//! **SAE J1711 (2010), §6.5, linear correction.** Fuel consumption against the battery's net energy change is
//! a straight line through two tests; the fuel at zero change is read off it. Here the two tests are two runs
//! at different s: fuel_corr = fuel − ΔSOC · (fuel₂ − fuel)/(ΔSOC₂ − ΔSOC), the second run the search's other
//! bracket end (ΔSOC of the other sign), or, for a given s, a run at 1.05 s.

use super::ecms::{Ecms, Other, Outcome, Share};
use super::ModalError;

/// Most runs of the search.
pub(crate) const MAX_RUNS: usize = 60;
/// The bracket's reach each way from s₀: a factor 2^MAX_WIDEN.
pub(crate) const MAX_WIDEN: u32 = 12;
/// The search's start: about 1/(η_engine · η_electric), a petrol engine near 35 % and an electric path near
/// 95 % (a better engine less); the charge-sustaining s of the shipped hybrids lies within 15 % of it
/// (2.99 to 3.46 on UDDS, HWFET and WLTC 3b).
const S0: f64 = 3.0;
/// The bracket's first widening factor (each later one the square of the one before).
const FIRST_WIDENING: f64 = 1.25;

/// The run at the given s and the second run of the correction: (run, runs, other).
pub(super) fn fixed(
    run: &Ecms<'_, '_, '_>,
    s: f64,
    x0: &[f64],
) -> Result<(Outcome, usize, Option<Outcome>), ModalError> {
    let (best, other) = beside(spare_core(), || run.run(s, x0), || run.run(1.05 * s, x0));
    Ok((best?, 1, Some(other?)))
}

/// Is there a core to spare for a second run beside the first? Not inside a sweep (whose variants keep every
/// core busy), nor on one core.
fn spare_core() -> bool {
    rayon::current_thread_index().is_none()
        && std::thread::available_parallelism().is_ok_and(|n| n.get() > 1)
}

/// `a()` and `b()`, side by side on two threads where `parallel`, else one after the other.
fn beside<A: Send, B: Send>(
    parallel: bool,
    a: impl FnOnce() -> A + Send,
    b: impl FnOnce() -> B + Send,
) -> (A, B) {
    if !parallel {
        return (a(), b());
    }
    std::thread::scope(|scope| {
        let second = scope.spawn(b);
        let first = a();
        // A panic of the run beside is the same panic the sequential order would raise.
        let second = second
            .join()
            .unwrap_or_else(|p| std::panic::resume_unwind(p));
        (first, second)
    })
}

/// The charge-sustaining run: (run, runs taken, the bracket's other end). Where none is found in a model with
/// internal states besides the charge, the error names them as a likely cause: ECMS, pricing the interval
/// alone, keeps a cold engine (its efficiency factor c(T) low) off at every s that does not charge without
/// end (docs/hybrids.md).
pub(super) fn search(
    run: &Ecms<'_, '_, '_>,
    (tol, narrowing): (f64, Narrowing),
    x0: &[f64],
) -> Result<(Outcome, usize, Option<Outcome>), ModalError> {
    search_from_s0(run, (tol, narrowing), x0).map_err(|e| match e {
        ModalError::Setup(msg) if run.other_internal_states() => ModalError::Setup(format!(
            "{msg} (the model has internal states besides the charge, such as an engine's temperature: \
             ECMS does not foresee their later costs, so from a cold engine no s may sustain the charge; \
             start it warm with --initial NAME=VALUE, or use --strategy rule-based or dp)"
        )),
        other => other,
    })
}

/// How far the search narrows the equivalence factor's bracket before it shares the sample where a choice
/// flips (θ of its interval with each choice).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Narrowing {
    /// Shares as soon as the bracketing runs differ at one sample (or across a jump), else at a bracket of
    /// 10⁻⁷ of s: the fuel is then the optimum's to about 10⁻⁷ of itself, the decisions elsewhere those at the
    /// bracket's end.
    Figure,
    /// Narrows to 3·10⁻⁹ of s first: every other decision is then the one at the flip's own price, as the
    /// gradient's envelope theorem assumes (`gradient_strategy.rs`: the Lagrangian's partial derivative at the
    /// decisions and s held). Without it the gradient is off by (s_hi − s_tie)·∂E_batt/∂p, measured
    /// 1.4·10⁻⁴ of d(fuel)/d(k_fl) on hev_p2's NEDC (s_hi − s_tie = 3.6·10⁻⁴ of s); the narrowing by the flip's
    /// tie ([`tie_step`]) where it can, a few more runs (hev_p2 UDDS 9 → 12, WLTC 3b 12 → 15), the fuel within
    /// 10⁻⁷ of the other's.
    Multiplier,
}

impl Narrowing {
    /// The bracket's relative width at which the search shares the flip.
    fn close(self) -> f64 {
        match self {
            Narrowing::Figure => 1e-7,
            Narrowing::Multiplier => 3e-9,
        }
    }
}

/// [`search`] itself.
fn search_from_s0(
    run: &Ecms<'_, '_, '_>,
    (tol, narrowing): (f64, Narrowing),
    x0: &[f64],
) -> Result<(Outcome, usize, Option<Outcome>), ModalError> {
    let mut runs = 1;
    let (first, mut ahead) = first_runs(run, x0);
    let first = first?;
    if first.delta_soc().abs() <= tol {
        let other = run.run(1.05 * S0, x0)?;
        return Ok((first, runs, Some(other)));
    }
    // Widen towards the sign change: by 1.25, then by the square of the last factor, to s₀ · 2^±12 at most.
    let up = first.delta_soc() < 0.0;
    let reach = f64::from(1u32 << MAX_WIDEN);
    let limit = if up { S0 * reach } else { S0 / reach };
    let mut near = first;
    let mut far = None;
    let mut factor = FIRST_WIDENING;
    while near.s != limit {
        let s = if up {
            (near.s * factor).min(limit)
        } else {
            (near.s / factor).max(limit)
        };
        factor *= factor;
        let o = match ahead.take() {
            Some(o) if s == S0 * FIRST_WIDENING => o?,
            _ => run.run(s, x0)?,
        };
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
    narrow(run, (near, far), (tol, x0), (runs, narrowing))
}

/// The run at s₀ and, on a spare core ([`spare_core`]), the run at s₀ · 1.25 beside it: the widening's first
/// step where ΔSOC(s₀) < 0, the usual case (the shipped hybrids' s lies near or above s₀), so the search waits
/// for one run fewer; where it is not needed it is dropped. Both are runs the sequential search makes, so the
/// outcome is the same.
fn first_runs(
    run: &Ecms<'_, '_, '_>,
    x0: &[f64],
) -> (
    Result<Outcome, ModalError>,
    Option<Result<Outcome, ModalError>>,
) {
    if !spare_core() {
        return (run.run(S0, x0), None);
    }
    let (first, ahead) = beside(
        true,
        || run.run(S0, x0),
        || run.run(S0 * FIRST_WIDENING, x0),
    );
    (first, Some(ahead))
}

/// How the bracket's runs are reconciled instead of narrowing s: at one sample ([`relax_at`]), at every
/// sample whose mode differs ([`relax_modes`]), or across a jump ([`bridge`]).
enum Reconcile {
    At(usize),
    Modes,
    Jump,
}

/// Brent's state started from the bracket (b, c): the previous best a = c and the last two steps b − c (the
/// secant through the bracket).
fn secant_start(b: &Outcome, c: &Outcome) -> ((f64, f64), f64, f64) {
    let d = b.s - c.s;
    ((c.s, c.delta_soc()), d, d)
}

/// Brent's root finder (*Algorithms for Minimization without Derivatives*, 1973, ch. 4, `zeroin`, with
/// Dekker's secant through the last two runs for its interpolation: [`zeroin_step`]) on ΔSOC(s) in the
/// bracket (b, c), ΔSOC of opposite signs there, bisection wherever the secant would not shrink the steps —
/// until |ΔSOC| ≤ the tolerance. Unlike regula falsi on the bracket's ends it does not creep where ΔSOC(s) is
/// a staircase of one sample's flips on a gentle slope: the secant follows the last runs on the slope, and
/// bisection closes on a flip. With [`Narrowing::Figure`], where the bracket's runs choose another mode at one
/// sample alone, that sample is shared at once ([`relax_at`]; the decided values elsewhere, continuous in s,
/// may differ); a bracket narrower than [`Narrowing::close`] of s is shared at its first difference
/// ([`relax`]).
fn narrow(
    run: &Ecms<'_, '_, '_>,
    (b, c): (Outcome, Outcome),
    (tol, x0): (f64, &[f64]),
    (mut runs, narrowing): (usize, Narrowing),
) -> Result<Found, ModalError> {
    let (mut b, mut c) = (b, c);
    // a: the previous best run's (s, ΔSOC); d the last step and e the one before.
    let (mut a, mut d, mut e) = secant_start(&b, &c);
    // The samples last shared: at one difference, at one mode difference.
    let mut tried: (Option<usize>, Option<usize>) = (None, None);
    let mut tried_modes = false;
    let mut tried_jump = false;
    let mut first = true;
    while runs < MAX_RUNS {
        if c.delta_soc().abs() < b.delta_soc().abs() {
            std::mem::swap(&mut b, &mut c);
            a = (c.s, c.delta_soc());
        }
        let (lo, hi) = if b.delta_soc() < 0.0 {
            (&b, &c)
        } else {
            (&c, &b)
        };
        // Shares before the bracket is narrow only where the figure alone is asked for.
        let early = narrowing == Narrowing::Figure;
        if (hi.s - lo.s).abs() <= narrowing.close() * hi.s.abs().max(lo.s.abs()) {
            let (lo, hi) = if b.delta_soc() < 0.0 { (b, c) } else { (c, b) };
            return relax(run, (lo, hi), (tol, x0), runs);
        }
        // The bracketing runs differ at one sample alone (in the mode or the decided value), or choose another
        // mode at one sample alone (the decided values elsewhere, continuous in s, differing a little): share
        // it now rather than narrow s onto the flip. (Once per sample and kind: where it cannot bridge the
        // jump, narrowing goes on.)
        let exact = run
            .only_difference(&lo.rec, &hi.rec)
            .filter(|&k| tried.0 != Some(k));
        let mode = || {
            run.only_mode_difference(&lo.rec, &hi.rec)
                .filter(|&k| tried.1 != Some(k))
        };
        let share = match exact {
            Some(k) => Some((k, true)),
            None => mode().map(|k| (k, false)),
        };
        // With internal states besides the charge, a bracket within 10⁻⁴ s whose runs choose other modes at
        // a few samples is shared at all of them at once (once): a flip there moves later choices too.
        let modes = !tried_modes
            && run.other_internal_states()
            && (hi.s - lo.s).abs() <= 1e-4 * hi.s.abs().max(lo.s.abs());
        let share = share.filter(|_| early);
        let how = match share {
            Some((k, is_exact)) => {
                if is_exact {
                    tried.0 = Some(k);
                } else {
                    tried.1 = Some(k);
                }
                Some(Reconcile::At(k))
            }
            None if modes => {
                tried_modes = true;
                Some(Reconcile::Modes)
            }
            None => None,
        };
        // Across a jump (once): bridged at once by sharing its flip, rather than narrowed onto it first.
        let how = match how {
            None if early && !tried_jump && across_jump(a, (b.s, b.delta_soc()), c.s, tol) => {
                tried_jump = true;
                Some(Reconcile::Jump)
            }
            how => how,
        };
        if let Some(how) = how {
            let (lo, hi) = if b.delta_soc() < 0.0 { (b, c) } else { (c, b) };
            let shared = match how {
                Reconcile::At(k) => relax_at(run, k, (lo, hi), (tol, x0), runs)?,
                Reconcile::Modes => relax_modes(run, (lo, hi), (tol, x0), runs)?,
                Reconcile::Jump => bridge(run, (lo, hi), (tol, x0), runs)?,
            };
            match shared {
                Ok(found) => return Ok(found),
                Err((l, h, used)) => {
                    // Interpolation starts afresh from the narrowed bracket (the secant).
                    runs = used;
                    (b, c) = (l, h);
                    (a, d, e) = secant_start(&b, &c);
                    continue;
                }
            }
        }
        // The first step aims at ΔSOC = 0 (where ΔSOC is linear in s, the secant lands on it); later ones just
        // inside the band's near edge, ΔSOC = ±0.9 tol on b's side: any run in the band ends the search, and
        // the shortest step along the slope into it stops short of a flip just beyond (a run without a shared
        // sample) rather than across.
        let target = if first {
            0.0
        } else {
            (0.9 * tol).copysign(b.delta_soc())
        };
        first = false;
        let shifted = |(s, f): (f64, f64)| (s, f - target);
        let tie = (!early)
            .then(|| tie_step(run, (&b, &c), narrowing))
            .flatten();
        (d, e) = match tie {
            Some(s) => (s - b.s, e),
            None => zeroin_step(
                (
                    shifted(a),
                    shifted((b.s, b.delta_soc())),
                    shifted((c.s, c.delta_soc())),
                ),
                (d, e),
            ),
        };
        a = (b.s, b.delta_soc());
        let o = run.run(b.s + d, x0)?;
        runs += 1;
        if o.delta_soc().abs() <= tol {
            let other = if (o.delta_soc() < 0.0) == (b.delta_soc() < 0.0) {
                c
            } else {
                b
            };
            return Ok((o, runs, Some(other)));
        }
        if (o.delta_soc() < 0.0) == (c.delta_soc() < 0.0) {
            // The new run and c on one side: b, the previous best, is the other end.
            c = std::mem::replace(&mut b, o);
            e = b.s - c.s;
            d = e;
        } else {
            b = o;
        }
    }
    let (lo, hi) = if b.delta_soc() < 0.0 { (b, c) } else { (c, b) };
    Err(ModalError::Setup(format!(
        "--strategy ecms: the search for the equivalence factor took {MAX_RUNS} runs without |ΔSOC| ≤ {tol:e} \
         (ΔSOC {:+.3e} at s = {}, {:+.3e} at s = {}); give --equivalence S or a wider --soc-tolerance",
        lo.delta_soc(),
        lo.s,
        hi.delta_soc(),
        hi.s
    )))
}

/// With [`Narrowing::Multiplier`], where the bracket's runs b and c choose other modes at one sample k alone:
/// the next s from the tie there, g(s) = J_(c's mode) − J_(b's mode) at sample k from each run's own state
/// (continuous in s within the bracket, where no other choice flips; of opposite signs at its ends), by the
/// secant through the ends, moved past its root by a third of [`Narrowing::close`] of s towards the end
/// farther from it. The run there lands across the flip and replaces that end, so the bracket closes onto the
/// flip from both sides in a few runs, where bisection on ΔSOC (a jump there) halves it per run. None where
/// the ends differ elsewhere too, or the secant leaves the bracket.
fn tie_step(
    run: &Ecms<'_, '_, '_>,
    (b, c): (&Outcome, &Outcome),
    narrowing: Narrowing,
) -> Option<f64> {
    let k = run.only_mode_difference(&b.rec, &c.rec)?;
    let modes = (b.rec.mode[k], c.rec.mode[k]);
    let (gb, gc) = (run.tie_gap(b, k, modes)?, run.tie_gap(c, k, modes)?);
    if !(gb >= 0.0 && gc <= 0.0 && gb > gc) {
        return None;
    }
    let root = b.s + gb * (c.s - b.s) / (gb - gc);
    let far = if (root - b.s).abs() > (c.s - root).abs() {
        b.s
    } else {
        c.s
    };
    let next = root + (narrowing.close() / 3.0 * root.abs()).copysign(far - root);
    let (lo, hi) = (b.s.min(c.s), b.s.max(c.s));
    (next > lo && next < hi).then_some(next)
}

/// One step from b (the best run) towards the root of ΔSOC(s) − target in the bracket (b, c), a the previous
/// best run, each (s, ΔSOC − target), with the last two steps (d, e): the new (d, e), b + d the next s. The
/// secant through a and b (Dekker's step: along the last two runs, which on a staircase of flips lie on one
/// stretch of the slope, where the bracket's far end lies across a jump), taken where it heads for c, stays
/// within three quarters of the way there and is less than half the step before last (Brent's safeguard:
/// the steps at least halve every other run); else bisection, d = (c − b)/2. A step is at least 10⁻⁹ |b|.
fn zeroin_step(
    ((sa, fa), (sb, fb), (sc, _)): ((f64, f64), (f64, f64), (f64, f64)),
    (d, e): (f64, f64),
) -> (f64, f64) {
    let tol1 = 1e-9 * sb.abs().max(1.0);
    let m = 0.5 * (sc - sb);
    let secant = -fb * (sb - sa) / (fb - fa);
    let (mut d, e) = if e.abs() >= tol1
        && secant.is_finite()
        && secant * m > 0.0
        && secant.abs() < 1.5 * m.abs() - 0.5 * tol1
        && secant.abs() < 0.5 * e.abs()
    {
        (secant, d)
    } else {
        (m, m)
    };
    if d.abs() < tol1 {
        d = tol1.copysign(m);
    }
    (d, e)
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

/// A relaxed choice's outcome: the run found, or the bracket (lo, hi) handed back with the runs used.
type Attempt = Result<Found, (Outcome, Outcome, usize)>;

/// Where ΔSOC(s) jumps across the band at s (lo and hi within 10⁻⁷ s of each other): [`bridge`]; a jump it
/// does not bridge is the error.
fn relax(
    run: &Ecms<'_, '_, '_>,
    (lo, hi): (Outcome, Outcome),
    (tol, x0): (f64, &[f64]),
    runs: usize,
) -> Result<Found, ModalError> {
    match bridge(run, (lo, hi), (tol, x0), runs)? {
        Ok(found) => Ok(found),
        Err((lo, hi, _)) => Err(jump(&lo, &hi, tol)),
    }
}

/// The relaxed choice across a jump of ΔSOC(s) between lo and hi: with internal states besides the charge at
/// every sample whose mode differs ([`relax_modes`]); else ([`relax_at`]) at the sample whose interval moves
/// the two runs' charges apart the most, then at the first sample where they differ, then at every sample
/// whose mode differs (several flipping at one s). Where none bridges it, the bracket is handed back with the
/// runs used.
fn bridge(
    run: &Ecms<'_, '_, '_>,
    (lo, hi): (Outcome, Outcome),
    (tol, x0): (f64, &[f64]),
    runs: usize,
) -> Result<Attempt, ModalError> {
    let Some(first) = run.first_difference(&lo.rec, &hi.rec) else {
        return Ok(Err((lo, hi, runs)));
    };
    // With internal states besides the charge a flip moves later choices too: every differing mode at once.
    let (lo, hi, runs) = if run.other_internal_states() {
        match relax_modes(run, (lo, hi), (tol, x0), runs)? {
            Ok(found) => return Ok(Ok(found)),
            Err(back) => back,
        }
    } else {
        (lo, hi, runs)
    };
    // The sample whose interval moves the two runs' charges apart the most (the flip itself, where the
    // first difference is a decided value a little apart), then the first difference.
    let widest = run.widest_step(&lo.rec, &hi.rec).unwrap_or(first);
    let (mut lo, mut hi, mut runs) = (lo, hi, runs);
    for k in [widest, first] {
        match relax_at(run, k, (lo, hi), (tol, x0), runs)? {
            Ok(found) => return Ok(Ok(found)),
            Err((l, h, used)) => (lo, hi, runs) = (l, h, used),
        }
        if widest == first {
            break;
        }
    }
    // Several samples flipping at the same s (a cycle repeating a phase, as the NEDC its four urban
    // segments, has the same demand, so the same tie, at each repeat): every differing mode at once.
    if !run.other_internal_states() {
        return relax_modes(run, (lo, hi), (tol, x0), runs);
    }
    Ok(Err((lo, hi, runs)))
}

/// Whether the band lies across a jump of ΔSOC(s) rather than on its slope: in a bracket within 10⁻⁴ s (far
/// from the root ΔSOC(s) bends, and a chord says nothing of a jump), a, the previous best run, on b's side of
/// the band, and the slope through a and b, followed from b all the way to c, still short of it
/// (|ΔSOC(b)| − |slope| |c − b| > tol) — a staircase whose step ends at b's side, which narrowing would only
/// close onto (to 10⁻⁷ s) before [`relax`] shares the flip anyway.
fn across_jump((sa, fa): (f64, f64), (sb, fb): (f64, f64), sc: f64, tol: f64) -> bool {
    let narrow = (sc - sb).abs() <= 1e-4 * sb.abs().max(sc.abs());
    if !narrow || (fa < 0.0) != (fb < 0.0) || sa == sb {
        return false;
    }
    let slope = (fb - fa) / (sb - sa);
    fb.abs() - slope.abs() * (sc - sb).abs() > tol
}

/// The relaxed choice at sample k ([`Share`]) between the runs at lo and hi, its share θ ∈ [0, 1] found by
/// regula falsi ([`falsi`]) so that |ΔSOC| ≤ tol. Where ΔSOC(θ) does not change sign over [0, 1] (later
/// choices depend on that one, as with a start penalty, or the runs differ elsewhere by more than the sample
/// can make up) the bracket is handed back with the runs used.
fn relax_at(
    run: &Ecms<'_, '_, '_>,
    k: usize,
    (lo, hi): (Outcome, Outcome),
    (tol, x0): (f64, &[f64]),
    runs: usize,
) -> Result<Attempt, ModalError> {
    let shares = vec![Share {
        k,
        own: None,
        other: Other::Factor(lo.s),
        theta: 0.0,
    }];
    relax_with(run, shares, (lo, hi), (tol, x0), runs)
}

/// Most samples [`relax_modes`] shares.
const MAX_SHARED: usize = 8;

/// The relaxed choice at every sample where the runs at lo and hi chose other modes (at most
/// [`MAX_SHARED`]), with one θ: each such interval θ in hi's mode and 1 − θ in lo's, the decided value of
/// each the best at hi's s from the run's state. Where a choice that flips at one sample moves an internal
/// state besides the charge (the engine's temperature), later choices near a tie flip with it, and sharing
/// one sample leaves ΔSOC(θ) with jumps; with the modes of every differing sample held, ΔSOC(θ) moves
/// continuously from about lo's to hi's.
fn relax_modes(
    run: &Ecms<'_, '_, '_>,
    (lo, hi): (Outcome, Outcome),
    (tol, x0): (f64, &[f64]),
    runs: usize,
) -> Result<Attempt, ModalError> {
    let n = lo.rec.mode.len().min(hi.rec.mode.len());
    let shares: Vec<Share> = (0..n)
        .filter(|&k| lo.rec.mode[k] != hi.rec.mode[k])
        .map(|k| Share {
            k,
            own: Some(hi.rec.mode[k]),
            other: Other::Mode(lo.rec.mode[k]),
            theta: 0.0,
        })
        .collect();
    if shares.is_empty() || shares.len() > MAX_SHARED {
        return Ok(Err((lo, hi, runs)));
    }
    relax_with(run, shares, (lo, hi), (tol, x0), runs)
}

/// The run at hi's s with `shares` at θ = 0, then [`falsi`] on θ where ΔSOC changes sign between it and θ = 1;
/// the bracket handed back where it does not. The run at θ = 1 is hi's own: each shared interval wholly in
/// the choice hi's run made there (1·a + 0·b = a exactly), every other sample chosen as hi's run chose it —
/// checked where debug assertions are on.
fn relax_with(
    run: &Ecms<'_, '_, '_>,
    mut shares: Vec<Share>,
    (lo, hi): (Outcome, Outcome),
    (tol, x0): (f64, &[f64]),
    mut runs: usize,
) -> Result<Attempt, ModalError> {
    let mut at = |theta: f64| -> Result<(f64, Outcome), ModalError> {
        for sh in shares.iter_mut() {
            sh.theta = theta;
        }
        Ok((theta, run.run_shared(hi.s, x0, &shares)?))
    };
    let a = at(0.0)?;
    runs += 1;
    if cfg!(debug_assertions) {
        let b = at(1.0)?;
        debug_assert_eq!(b.1.delta_soc().to_bits(), hi.delta_soc().to_bits());
    }
    if a.1.delta_soc().abs() <= tol {
        return Ok(Ok((a.1, runs, Some(hi))));
    }
    let b = (1.0, hi.delta_soc());
    if (a.1.delta_soc() < 0.0) == (b.1 < 0.0) {
        return Ok(Err((lo, hi, runs)));
    }
    match falsi(&mut at, ((a.0, a.1.delta_soc()), b), tol, &mut runs)? {
        Some(o) => {
            let other = if o.delta_soc() < 0.0 { hi } else { lo };
            Ok(Ok((o, runs, Some(other))))
        }
        None => Err(jump(&lo, &hi, tol)),
    }
}

/// Regula falsi (Illinois) on θ, `at(θ)` the relaxed run, from a and b (θ, ΔSOC) of opposite signs, until
/// |ΔSOC| ≤ tol: the run found, or `None` after [`MAX_RUNS`] runs in all.
fn falsi(
    at: &mut dyn FnMut(f64) -> Result<(f64, Outcome), ModalError>,
    (mut a, mut b): ((f64, f64), (f64, f64)),
    tol: f64,
    runs: &mut usize,
) -> Result<Option<Outcome>, ModalError> {
    let (mut scale_a, mut scale_b, mut last) = (1.0, 1.0, 0i8);
    while *runs < MAX_RUNS {
        let (fa, fb) = (scale_a * a.1, scale_b * b.1);
        let mut th = b.0 - fb * (b.0 - a.0) / (fb - fa);
        if !(th > a.0 && th < b.0) {
            th = 0.5 * (a.0 + b.0);
        }
        let (th, o) = at(th)?;
        *runs += 1;
        let f = o.delta_soc();
        if f.abs() <= tol {
            return Ok(Some(o));
        }
        if (f < 0.0) == (a.1 < 0.0) {
            a = (th, f);
            scale_a = 1.0;
            if last == -1 {
                scale_b *= 0.5;
            }
            last = -1;
        } else {
            b = (th, f);
            scale_b = 1.0;
            if last == 1 {
                scale_a *= 0.5;
            }
            last = 1;
        }
    }
    Ok(None)
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

#[cfg(test)]
mod tests {
    use super::{across_jump, zeroin_step};

    #[test]
    fn a_jump_is_told_from_a_slope_in_a_narrow_bracket_only() {
        // The Prius's UDDS: ΔSOC −3.23e-4 and −3.22e-4 at two s on one side, +1.96e-3 at c 10⁻⁴ away: the
        // slope through them reaches 10⁻⁵ by c, the band (10⁻⁴) lies across the jump.
        let (a, b, c) = (
            (2.699_172_6, -3.232e-4),
            (2.699_184_0, -3.222e-4),
            2.699_284_0,
        );
        assert!(across_jump(a, b, c, 1e-4));
        // A slope that reaches the band before c, a on the other side, or a wide bracket (the S-shaped far
        // phase, hev_p2 on UDDS: s = 3.0 and 3.17 both near −0.7, c = 3.75): no.
        assert!(!across_jump((2.699_174_0, -3.5e-4), b, c, 1e-4));
        assert!(!across_jump((2.699_300_0, 2.0e-3), b, c, 1e-4));
        assert!(!across_jump((3.0, -0.764), (3.1675, -0.701), 3.75, 1e-4));
    }

    #[test]
    fn a_step_is_the_secant_within_the_bracket_else_bisection() {
        // ΔSOC = 2 (s − 3.4) from the bracket (3.75, 3), b the end of the smaller |ΔSOC| (as `narrow` keeps
        // it), a = c (the first step): the secant lands on the root.
        let f = |s: f64| 2.0 * (s - 3.4);
        let (b, c) = ((3.75, f(3.75)), (3.0, f(3.0)));
        let (d, _) = zeroin_step((c, b, c), (b.0 - c.0, b.0 - c.0));
        assert!((b.0 + d - 3.4).abs() < 1e-15, "{}", b.0 + d);
        // The last two runs on a gentle stretch (a, b), the bracket's far end c across a jump: the secant
        // along the stretch, not the chord to c.
        let (a, b, c) = ((3.4014, -2.3e-4), (3.4015, -1.5e-4), (3.4020, 3.0e-3));
        let (d, e) = zeroin_step((a, b, c), (1e-4, 4e-4));
        assert!((b.0 + d - 3.401_687_5).abs() < 1e-12, "{}", b.0 + d);
        assert_eq!(e, 1e-4);
        // A secant beyond three quarters of the way to c, or not less than half the step before last:
        // bisection.
        let (a, b, c) = ((3.0, -1.0), (3.1, -0.999), (3.75, 1.0));
        let (d, e) = zeroin_step((a, b, c), (0.1, 0.75));
        let m = 0.5 * (c.0 - b.0);
        assert_eq!((d, e), (m, m));
    }
}
