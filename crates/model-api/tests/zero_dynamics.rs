//! The zero-dynamics module on a one-state model with known equilibria: Newton's method, its starting
//! points, its failures, the linearisation and the class.
#![cfg(feature = "linearize")]

use invsim_model_api::zero_dynamics::{
    critical_tol, default_starts, equilibrium, newton, EquilibriumFailure, Linearization,
    ZeroDynamicsClass, EQUILIBRIUM_MAX_ITER,
};
use invsim_model_api::{InverseModel, ModelError, ModelInfo};

/// x' = (x1, x2) with y = x1 and one internal coordinate whose zero dynamics are q = c·(1000 − η³): the
/// equilibrium is η = 10, ∂q/∂η = −3c·η² (singular at η = 0), stable for c > 0.
struct Cubic {
    info: ModelInfo,
    c: f64,
}

impl Cubic {
    fn new(c: f64) -> Cubic {
        Cubic {
            info: ModelInfo {
                name: "cubic".into(),
                states: vec!["x1".into(), "x2".into()],
                input: "u".into(),
                output: "x1".into(),
                relative_degree: 1,
                n_eta: 1,
                source_hash: None,
                description: String::new(),
                state_units: Vec::new(),
                input_unit: None,
                output_unit: None,
                input_min: None,
                input_max: None,
                outputs: Vec::new(),
                parameters: Vec::new(),
                ..Default::default()
            },
            c,
        }
    }
}

impl InverseModel for Cubic {
    fn info(&self) -> &ModelInfo {
        &self.info
    }
    fn params(&self) -> &[f64] {
        &[]
    }
    fn set_param(&mut self, name: &str, _value: f64) -> Result<(), ModelError> {
        Err(ModelError::UnknownParameter {
            name: name.to_string(),
            known: String::new(),
        })
    }
    fn h(&self, x: &[f64], _w: &[f64]) -> f64 {
        x[0]
    }
    fn psi(&self, x: &[f64], _w: &[f64], xi: &mut [f64], eta: &mut [f64]) {
        xi[0] = x[0];
        eta[0] = x[1];
    }
    fn psi_inv(
        &self,
        xi: &[f64],
        eta: &[f64],
        _w: &[f64],
        x: &mut [f64],
    ) -> Result<(), ModelError> {
        x[0] = xi[0];
        x[1] = eta[0];
        Ok(())
    }
    fn alpha(&self, _xi: &[f64], _eta: &[f64], _w: &[f64]) -> f64 {
        0.0
    }
    fn beta(&self, _xi: &[f64], _eta: &[f64], _w: &[f64]) -> f64 {
        1.0
    }
    fn zero_dynamics(&self, _xi: &[f64], eta: &[f64], _w: &[f64], _yr: f64, deta: &mut [f64]) {
        deta[0] = self.c * (1000.0 - eta[0].powi(3));
    }
    fn rhs(&self, x: &[f64], _w: &[f64], u: f64, dx: &mut [f64]) {
        dx[0] = u;
        dx[1] = self.c * (1000.0 - x[1].powi(3));
    }
    fn outputs(&self, _x: &[f64], _w: &[f64], _u: f64, _out: &mut [f64]) {}
}

#[test]
fn newton_finds_the_equilibrium_and_reports_a_singular_start() {
    let m = Cubic::new(1.0);
    let eta = newton(&m, &[0.0], &[], 0.0, vec![5.0], EQUILIBRIUM_MAX_ITER).unwrap();
    assert!((eta[0] - 10.0).abs() < 1e-12, "{eta:?}");
    let from_zero = newton(&m, &[0.0], &[], 0.0, vec![0.0], EQUILIBRIUM_MAX_ITER);
    assert_eq!(
        from_zero,
        Err(EquilibriumFailure::Singular { eta: vec![0.0] })
    );
    assert_eq!(
        from_zero.unwrap_err().to_string(),
        "met a singular Jacobian ∂q/∂η at η = [0]"
    );
}

#[test]
fn equilibrium_tries_the_starts_in_order() {
    let m = Cubic::new(1.0);
    assert_eq!(default_starts(0.0)[..3], [0.0, 1.0, -1.0]);
    assert_eq!(default_starts(2.0)[..3], [0.0, 2.0, 1.0]);
    // η = 0 is singular, η = y = 2 converges.
    let eta = equilibrium(&m, &[2.0], &[], 0.0, None, &default_starts(2.0)).unwrap();
    assert!((eta[0] - 10.0).abs() < 1e-12);
    // A guess comes first; with no start converging the first attempt's failure is reported.
    let e = equilibrium(&m, &[0.0], &[], 0.0, Some(&[0.0]), &[]).unwrap_err();
    assert!(matches!(e, EquilibriumFailure::Singular { .. }), "{e:?}");
    let nan = Cubic::new(f64::NAN);
    let e = equilibrium(&nan, &[0.0], &[], 0.0, None, &[0.0, 1.0]).unwrap_err();
    assert_eq!(e, EquilibriumFailure::NonFinite { eta: vec![0.0] });
}

#[test]
fn linearisation_threshold_and_class() {
    for (c, class) in [
        (1.0, ZeroDynamicsClass::MinimumPhase),
        (-1.0, ZeroDynamicsClass::NonMinimumPhase),
    ] {
        let m = Cubic::new(c);
        let lin = Linearization::at(&m, &[0.0], &[], &[10.0], 0.0);
        // ∂q/∂η = −3c·η² = −300c, by central differences.
        assert!((lin.jacobian[(0, 0)] + 300.0 * c).abs() < 1e-6);
        assert_eq!(lin.tol, critical_tol(lin.jacobian.as_slice()));
        assert_eq!(lin.class(), class);
        assert_eq!(lin.unstable_count(), usize::from(c < 0.0));
    }
    assert_eq!(critical_tol(&[-2.0, 0.5]), 1e-9 + 2e-7);
}
