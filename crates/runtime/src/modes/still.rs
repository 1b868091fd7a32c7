//! A mode's zero dynamics over an interval where the reference stands still, remembered bit for bit.
//!
//! On a still interval (a standstill more than a look-ahead from any corner, no transition under way) the
//! reference and the signals at every stage time are those of t₀, so the zero dynamics are autonomous,
//! η̇ = q(η; y, w), and the stage times enter nothing. An interval the integrator crosses in one accepted
//! step is then a function of η(t₀), y, w, the interval's length t₁ − t₀ and the first step's size alone: the
//! step is the whole interval (clipped to it), its result η(t₁) = η(t₀) + h Σ bᵢ kᵢ and the controller's next
//! step size follow from those numbers. So where the next still interval brings the same numbers, bit for
//! bit — an engine idling at its equilibrium, where a step no longer moves η by half an ulp (at dt = 0.1 s on
//! the UDDS, 996 of si_engine_5speed's 1 095 still intervals) — its result is the one remembered, the same
//! bits as integrating it again. An interval that took more steps or a rejection (whose steps' rounding
//! depends on t₀ and t₁ themselves) is not remembered.

/// The last still interval crossed in one accepted step: what went in and what came out.
#[derive(Default)]
pub(super) struct StillStep {
    /// The mode, η(t₀), y, w, t₁ − t₀ and the first step's size, as bits; empty: nothing remembered.
    key: Vec<u64>,
    /// η(t₁) and the step size the controller proposed after it.
    eta: Vec<f64>,
    h: f64,
    /// The key of the interval at hand (a buffer).
    next: Vec<u64>,
}

impl StillStep {
    /// Set the key of the interval at hand: mode `m` from `eta` on the reference `y`, the signals `w`, over
    /// `span` = t₁ − t₀ with first step `h0`.
    pub(super) fn key(
        &mut self,
        m: usize,
        eta: &[f64],
        (y, w): (&[f64], &[f64]),
        (span, h0): (f64, f64),
    ) {
        let next = &mut self.next;
        next.clear();
        next.push(m as u64);
        next.extend(
            eta.iter()
                .chain(y)
                .chain(w)
                .chain(&[span, h0])
                .map(|v| v.to_bits()),
        );
    }

    /// η(t₁) and the controller's next step size where the interval at hand is the one remembered.
    pub(super) fn recall(&self) -> Option<(&[f64], f64)> {
        (!self.key.is_empty() && self.key == self.next).then_some((&self.eta, self.h))
    }

    /// Remember the interval at hand as crossed in one accepted step to `eta` with next step size `h`.
    pub(super) fn remember(&mut self, eta: &[f64], h: f64) {
        std::mem::swap(&mut self.key, &mut self.next);
        self.eta.clear();
        self.eta.extend_from_slice(eta);
        self.h = h;
    }

    /// Forget the interval remembered (the one at hand was not crossed in one step).
    pub(super) fn forget(&mut self) {
        self.key.clear();
    }
}
