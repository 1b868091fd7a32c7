//! ECMS's candidates' prices kept from one run of the equivalence factor's search to the next, where they do
//! not depend on the run's state.
//!
//! A candidate (m, d) at sample k is priced from the run's state x at t_k (`Ecms::price`): the inverse
//! at t_k and over the interval, the fuel's and the battery's energies. Its parts before s prices them
//! ([`Parts`]) are functions of (k, m, d) alone where mode m's free input and its fuel and battery outputs
//! are free of the internal states η (the model's [`invsim_model_api::EtaFree`], read off the derived
//! expressions: hev_p2's battery has a constant open-circuit voltage and resistance, so its charge enters
//! no price), and every run of the search — about a dozen, each at another s and so along another charge
//! trace — evaluates the same grid of decided values at every sample first ([`super::minimise`]). Those
//! grid points' parts are kept here, each computed once by whichever run reaches it first; a run's numbers
//! are bit for bit those it computes itself. The refinement's points, which move with s, are not kept.
//! Where every candidate's price is free of the state (and no start penalty ties a choice to the one
//! before), no choice depends on the run at all: each run then chooses every sample's candidate ahead, side
//! by side on the cores, and books them in turn (`Ecms::selected_ahead`).

use std::sync::OnceLock;

use super::minimise::grid_index;
use super::record::Ctx;
use super::scratch::Point;

/// Most kept prices (samples × candidates × grid points): 56 bytes each, 56 MB at most (WLTC 3b at dt 1 s
/// with hev_p2's grid of 11: about 60 000). A run beyond it keeps none and prices every candidate afresh.
const MAX_SLOTS: usize = 1_000_000;

/// The kept grid points' parts, by sample, candidate and grid point; empty where no candidate's price is
/// free of the state, or beyond [`MAX_SLOTS`].
#[derive(Default)]
pub(super) struct PriceCache {
    /// Sample k's slots start at `first[k]`: its candidates in order, `grid` slots each.
    first: Vec<usize>,
    /// Per slot: the parts (`None` where the evaluation failed) and whether they were priced lazily.
    slots: Vec<OnceLock<(Option<Parts>, bool)>>,
    grid: usize,
    /// Per mode: its price is free of the state.
    free: Vec<bool>,
}

impl PriceCache {
    /// The cache for `candidates` (per sample, the candidate modes), the decided inputs' grid of `grid`
    /// points; modes priced by outputs `fuel` and `battery`.
    pub(super) fn new(
        ctx: &Ctx<'_, '_>,
        candidates: &[Vec<usize>],
        grid: usize,
        (fuel, battery): (usize, usize),
    ) -> PriceCache {
        let free: Vec<bool> = ctx
            .spec
            .modes
            .iter()
            .map(|mode| {
                let f = &mode.model.info().eta_free;
                f.input && f.output(fuel) && f.output(battery)
            })
            .collect();
        let total = candidates
            .iter()
            .map(Vec::len)
            .sum::<usize>()
            .saturating_mul(grid);
        if !free.iter().any(|&f| f) || total > MAX_SLOTS || grid < 2 {
            return PriceCache::default();
        }
        let mut first = Vec::with_capacity(candidates.len() + 1);
        let mut at = 0;
        for c in candidates {
            first.push(at);
            at += c.len() * grid;
        }
        first.push(at);
        PriceCache {
            first,
            slots: (0..at).map(|_| OnceLock::new()).collect(),
            grid,
            free,
        }
    }

    /// Is mode m's price free of the state (and kept)?
    pub(super) fn state_free(&self, m: usize) -> bool {
        self.free.get(m).copied().unwrap_or(false)
    }

    /// The kept parts of `slot` ([`PriceCache::slot`]): (the parts, `None` where the evaluation failed;
    /// whether they were priced lazily), set once.
    pub(super) fn kept(&self, slot: usize) -> &OnceLock<(Option<Parts>, bool)> {
        &self.slots[slot]
    }

    /// The first slot of mode m's candidates at sample k, whose candidate modes are `candidates`: where m's
    /// price is free of the state and kept. Its decided input's grid point i is slot row + i (a mode without
    /// a decided input: its one value, slot row).
    pub(super) fn row(&self, candidates: &[usize], (m, k): (usize, usize)) -> Option<usize> {
        if !self.state_free(m) || self.slots.is_empty() {
            return None;
        }
        let c = candidates.iter().position(|&c| c == m)?;
        Some(self.first[k] + c * self.grid)
    }

    /// The slot of decided value d in `row` ([`PriceCache::row`]), d on the grid over `bounds` (`None`: a
    /// mode without a decided input).
    pub(super) fn slot(&self, row: usize, d: f64, bounds: Option<(f64, f64)>) -> Option<usize> {
        match bounds {
            None => Some(row),
            Some(b) => grid_index(b, self.grid, d).map(|i| row + i),
        }
    }
}

/// What a price (`Ecms::price`) evaluates of a candidate before s and E_start price it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Parts {
    /// Beyond its bounds at t_k, its interval not evaluated (a lazy price): the margin at t_k.
    Beyond { margin: f64 },
    /// At the last sample (no interval): the powers and the margin there.
    Last {
        p_fuel: f64,
        p_batt: f64,
        margin: f64,
    },
    /// Over [t_k, t_k+1]: the fuel's and the battery's energies, J, the larger of the two ends' margins and
    /// t_k's.
    Interval {
        fuel: f64,
        battery: f64,
        margin: f64,
        margin_at: f64,
    },
}

impl Parts {
    /// At the last sample: the powers and the margin at t_k (`at`).
    pub(super) fn last(at: &Point) -> Parts {
        Parts::Last {
            p_fuel: at.p_fuel,
            p_batt: at.p_batt,
            margin: at.margin,
        }
    }

    /// Over an interval of length h from the points at its ends (`at`, `end`) and the battery's power at
    /// the Runge–Kutta step's stages 2, 3 and 4: the fuel's trapezoid h/2 (P_fuel,1 + P_fuel,4), the
    /// battery's quadrature h/6 (P_batt,1 + 2 P_batt,2 + 2 P_batt,3 + P_batt,4), the larger margin; `None`
    /// where an energy is not finite.
    pub(super) fn interval(
        h: f64,
        at: &Point,
        [b2, b3, b4]: [f64; 3],
        end: &Point,
    ) -> Option<Parts> {
        let fuel = 0.5 * h * (at.p_fuel + end.p_fuel);
        let battery = h / 6.0 * (at.p_batt + 2.0 * b2 + 2.0 * b3 + b4);
        if !(fuel.is_finite() && battery.is_finite()) {
            return None;
        }
        Some(Parts::Interval {
            fuel,
            battery,
            margin: at.margin.max(end.margin),
            margin_at: at.margin,
        })
    }

    /// The parts a lazy price would have found: beyond the bounds at t_k, the interval left.
    pub(super) fn lazily(self) -> Parts {
        match self {
            Parts::Last { margin: at, .. } | Parts::Interval { margin_at: at, .. } if at > 1e-9 => {
                Parts::Beyond { margin: at }
            }
            p => p,
        }
    }
}
