//! The compiled template model against hand calculations.

use invsim_model_api::InverseModel;
use invsim_model_template::vehicle::{self, Params};

/// At constant speed v0 the traction force balances the driving resistance, F = c_a·v0² + f_r, and the
/// actuator is at rest, so the force demand equals it: u = F. With the defaults at 20 m/s:
/// 0.4 · 400 + 150 = 310 N.
#[test]
fn steady_state_matches_the_hand_calculation() {
    let model = vehicle::Model::default();
    let mut x = [0.0; 2];
    let u = model
        .invert(&[20.0, 0.0], &[], &[], 0.0, &mut x)
        .expect("closed-form inverse");
    assert!((x[0] - 20.0).abs() < 1e-12, "{x:?}");
    assert!((x[1] - 310.0).abs() < 1e-9, "{x:?}");
    assert!((u - 310.0).abs() < 1e-9, "{u}");
    // The original model is at rest there.
    let mut dx = [1.0; 2];
    model.rhs(&x, &[], u, &mut dx);
    assert!(dx.iter().all(|d| d.abs() < 1e-12), "{dx:?}");
}

/// Accelerating at a = 1 m/s² through 10 m/s with no jerk: F = m·a + c_a·v² + f_r = 1500 + 40 + 150 = 1690 N,
/// dF/dt = 2·c_a·v·a = 8 N/s, so u = F + τ·dF/dt = 1690 + 1.6 = 1691.6 N.
#[test]
fn acceleration_matches_the_hand_calculation() {
    let p = Params::default();
    let (x, u) = vehicle::invert(&p, &[10.0, 1.0], &[], 0.0);
    assert!((x[1] - 1690.0).abs() < 1e-9, "{x:?}");
    assert!((u - 1691.6).abs() < 1e-9, "{u}");
    assert!((vehicle::beta(&p, &[10.0, 1.0], &[]) - 1.0 / (p.m * p.tau)).abs() < 1e-15);
}

#[test]
fn parameters_by_name() {
    let mut model = vehicle::Model::default();
    assert_eq!(model.params(), &[1500.0, 0.4, 150.0, 0.2]);
    model.set_param("m", 1000.0).expect("m is a parameter");
    assert_eq!(model.parameters().m, 1000.0);
    assert!(model.set_param("mass", 1.0).is_err());
    assert!(model.set_param("m", f64::NAN).is_err());
    assert_eq!(vehicle::PARAMETERS, ["m", "c_a", "f_r", "tau"]);
    assert_eq!((vehicle::N, vehicle::R, vehicle::N_ETA), (2, 2, 0));
}
