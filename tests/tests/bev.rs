//! The battery-electric car `models/bev.toml` against a hand integration of the same equations: the motor
//! torque, the battery current and the energy on UDDS and HWFET from the reference alone (written out here
//! in plain Rust, independent of the symbolic engine), integrated by Simpson's rule, within 1 % of the
//! run's trapezoidal integral; the charge state falls wherever the battery delivers power and over the
//! cycle, and rises only where the motor recovers energy.

use invsim_model_api::InverseModel;
use invsim_runtime::{simulate, Cycle, SimulationOptions};

/// The energy drawn from the battery (kWh) by hand: T_m from v' = (η_g i_g T_m / r_w − F_res)/m_eff, then
/// P_el, P_batt = P_el + P_aux, I = (U_oc − √(U_oc² − 4 R_i P_batt))/(2 R_i), E = ∫ U_oc I dt.
fn hand_energy(model: &dyn InverseModel, v: &[f64], a: &[f64], dt: f64) -> (Vec<f64>, f64) {
    let info = model.info();
    let p = |name: &str| model.params()[info.parameters.iter().position(|q| q == name).unwrap()];
    let (m, r_w, i_g, eta_g, j_m) = (p("m"), p("r_w"), p("i_g"), p("eta_g"), p("J_m"));
    let m_eff = m + eta_g * i_g * i_g * j_m / (r_w * r_w);
    let (u_oc, r_i, eta_m, t_regen, t_eps) =
        (p("U_oc"), p("R_i"), p("eta_m"), p("T_regen"), p("T_eps"));
    let p_aux = 300.0;
    let mut torque = Vec::with_capacity(v.len());
    let power: Vec<f64> = v
        .iter()
        .zip(a)
        .map(|(&v, &a)| {
            let f_res = 0.5 * p("rho_a") * p("C_d") * p("A_f") * v * v
                + m * p("g_0") * p("c_r") * (v / p("v_eps")).tanh();
            let t = (m_eff * a + f_res) * r_w / (eta_g * i_g);
            torque.push(t);
            let w_m = i_g * v / r_w;
            let s = 0.5 * (1.0 + (t / t_eps).tanh());
            let p_el = w_m * (s * t / eta_m + (1.0 - s) * eta_m * t_regen * (t / t_regen).tanh());
            let current = (u_oc - (u_oc * u_oc - 4.0 * r_i * (p_el + p_aux)).sqrt()) / (2.0 * r_i);
            u_oc * current / 3.6e6
        })
        .collect();
    // Simpson's rule on the even part of the grid, the trapezoid on a last odd interval.
    let n = power.len() - 1;
    let even = n - n % 2;
    let mut e = 0.0;
    for k in (0..even).step_by(2) {
        e += dt / 3.0 * (power[k] + 4.0 * power[k + 1] + power[k + 2]);
    }
    if even < n {
        e += 0.5 * dt * (power[n - 1] + power[n]);
    }
    (torque, e)
}

#[test]
fn bev_energy_matches_a_hand_integration_and_the_charge_state_follows_the_battery() {
    let model = invsim_models::builtin("bev").expect("bev is built in");
    let dt = 0.1;
    for name in ["udds", "hwfet"] {
        let cycle = Cycle::builtin(name).unwrap();
        let opts = SimulationOptions {
            dt,
            ..SimulationOptions::default()
        };
        let res = simulate(&*model, &cycle, &opts).unwrap();
        let (v, a) = (res.yd(0).unwrap(), res.yd(1).unwrap());
        let (torque, hand) = hand_energy(&*model, v, a, dt);
        for (t, u) in torque.iter().zip(res.input()) {
            assert!(
                (t - u).abs() <= 1e-9 * (1.0 + t.abs()),
                "{name}: torque {u} vs hand {t}"
            );
        }
        let run = res.summary.totals.integrals["energy"];
        assert!(
            (run - hand).abs() < 0.01 * hand,
            "{name}: {run} kWh vs hand {hand} kWh"
        );
        eprintln!("{name}: energy {run:.6} kWh, hand quadrature {hand:.6} kWh");
        let soc = res.column("soc").unwrap();
        let p_bat = res.column("P_bat").unwrap();
        assert!(
            soc[0] == 0.9 && soc[soc.len() - 1] < soc[0],
            "{name}: soc {} → {}",
            soc[0],
            soc[soc.len() - 1]
        );
        for k in 1..soc.len() {
            // Between two samples where the battery delivers power the charge falls; it rises only where the
            // battery is recharged (P_bat < 0) at one end of the step.
            if p_bat[k - 1] > 0.0 && p_bat[k] > 0.0 {
                assert!(
                    soc[k] < soc[k - 1],
                    "{name}: soc rises at sample {k} while the battery delivers"
                );
            }
            if soc[k] > soc[k - 1] {
                assert!(
                    p_bat[k - 1] < 0.0 || p_bat[k] < 0.0,
                    "{name}: soc rises at sample {k}"
                );
            }
        }
    }
}
