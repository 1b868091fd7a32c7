//! ECMS's prices kept across the equivalence factor's search (`crates/runtime/src/modes/price_cache.rs`)
//! and its samples chosen ahead side by side: hev_p2's runs (its battery's charge enters no price) equal bit
//! for bit the runs of the same modes whose descriptions say nothing of η (every price computed afresh, every
//! sample chosen in turn), on UDDS and WLTC 3b; and the modes' descriptions say what the derivation finds.

use crate::common;
use common::*;

use invsim_loader::EngineChoice;
use invsim_model_api::{map, EtaFree, InverseModel, ModelError, ModelInfo, ReferenceMap};
use invsim_runtime::modes::{
    simulate_hybrid, ModalOptions, ModalPlant, ModalSummary, StrategyOptions,
};
use invsim_runtime::Cycle;

/// A mode's model whose description keeps nothing free of η: the model itself otherwise.
struct Opaque {
    inner: &'static dyn InverseModel,
    info: ModelInfo,
}

impl InverseModel for Opaque {
    fn info(&self) -> &ModelInfo {
        &self.info
    }
    fn params(&self) -> &[f64] {
        self.inner.params()
    }
    fn set_param(&mut self, _: &str, _: f64) -> Result<(), ModelError> {
        unreachable!("the test sets no parameter")
    }
    fn maps(&self) -> &[map::Map] {
        self.inner.maps()
    }
    fn h(&self, x: &[f64], w: &[f64]) -> f64 {
        self.inner.h(x, w)
    }
    fn psi(&self, x: &[f64], w: &[f64], xi: &mut [f64], eta: &mut [f64]) {
        self.inner.psi(x, w, xi, eta)
    }
    fn psi_inv(&self, xi: &[f64], eta: &[f64], w: &[f64], x: &mut [f64]) -> Result<(), ModelError> {
        self.inner.psi_inv(xi, eta, w, x)
    }
    fn alpha(&self, xi: &[f64], eta: &[f64], w: &[f64]) -> f64 {
        self.inner.alpha(xi, eta, w)
    }
    fn beta(&self, xi: &[f64], eta: &[f64], w: &[f64]) -> f64 {
        self.inner.beta(xi, eta, w)
    }
    fn zero_dynamics(&self, xi: &[f64], eta: &[f64], w: &[f64], yr: f64, deta: &mut [f64]) {
        self.inner.zero_dynamics(xi, eta, w, yr, deta)
    }
    fn rhs(&self, x: &[f64], w: &[f64], u: f64, dx: &mut [f64]) {
        self.inner.rhs(x, w, u, dx)
    }
    fn outputs(&self, x: &[f64], w: &[f64], u: f64, out: &mut [f64]) {
        self.inner.outputs(x, w, u, out)
    }
    fn sensitivity(&self, x: &[f64], w: &[f64], u: f64, out: &mut [f64]) -> Result<(), ModelError> {
        self.inner.sensitivity(x, w, u, out)
    }
    fn reference(&self) -> ReferenceMap {
        self.inner.reference()
    }
    fn invert(
        &self,
        xi: &[f64],
        eta: &[f64],
        w: &[f64],
        yr: f64,
        x: &mut [f64],
    ) -> Result<f64, ModelError> {
        self.inner.invert(xi, eta, w, yr, x)
    }
}

/// hev_p2 compiled, and the same with every mode [`Opaque`].
fn plants() -> (ModalPlant, ModalPlant) {
    let kept = modal_plant("models/hev_p2.toml", EngineChoice::Compiled);
    let other: &'static ModalPlant = Box::leak(Box::new(modal_plant(
        "models/hev_p2.toml",
        EngineChoice::Compiled,
    )));
    let opaque = other
        .models()
        .map(|m| {
            let mut info = m.info().clone();
            info.eta_free = EtaFree::default();
            Box::new(Opaque { inner: m, info }) as Box<dyn InverseModel>
        })
        .collect();
    let fresh = kept.with_models(opaque).expect("as many models as modes");
    (kept, fresh)
}

/// The run's summary and series, bit for bit: (summary, the columns' bits, the modes).
fn run(p: &ModalPlant, cycle: &Cycle) -> (ModalSummary, Vec<Vec<u64>>, Vec<usize>) {
    let gears = p.gear_source(cycle, None).expect("a speed schedule");
    let opts = ModalOptions {
        dt: 1.0,
        ..ModalOptions::default()
    };
    let r = simulate_hybrid(
        &p.spec(gears),
        p.hybrid(),
        cycle,
        &opts,
        (&StrategyOptions::default(), &[]),
        &[],
    )
    .unwrap_or_else(|e| panic!("{} on {}: {e}", p.name(), cycle.name));
    let bits = r
        .data
        .iter()
        .map(|c| c.iter().map(|v| v.to_bits()).collect())
        .collect();
    (r.summary, bits, r.mode)
}

#[test]
fn kept_prices_and_choices_ahead_change_no_bit_of_the_run() {
    let (kept, fresh) = plants();
    for name in ["udds", "wltc3b"] {
        let cycle = Cycle::builtin(name).expect("built in");
        let (a, b) = (run(&kept, &cycle), run(&fresh, &cycle));
        assert_eq!(a.1, b.1, "{name}: the series differ");
        assert_eq!(a.2, b.2, "{name}: the modes differ");
        assert_eq!(a.0, b.0, "{name}: the summaries differ");
        let runs = a.0.hybrid.as_ref().expect("a hybrid block").search_runs;
        assert!(runs >= 5, "{name}: a search of {runs} runs");
    }
}

#[test]
fn hev_p2s_modes_price_free_of_the_charge() {
    let p = modal_plant("models/hev_p2.toml", EngineChoice::Interpreted);
    let outputs = &p.first().info().outputs;
    let at = |name: &str| outputs.iter().position(|o| o.name == name).expect(name);
    let (fuel, batt, engine) = (at("P_fuel"), at("P_batt"), at("n_e"));
    for m in p.models() {
        let free = &m.info().eta_free;
        assert!(
            free.input && free.output(fuel) && free.output(batt),
            "{free:?}"
        );
        assert!(free.output(engine), "{free:?}");
    }
}
