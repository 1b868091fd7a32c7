//! Adaptive Dormand–Prince 5(4) integration, shared by the zero dynamics, the verification replay and the
//! forward simulation.

use crate::simulate::SimulateError;

/// Adaptive Dormand–Prince 5(4) (Hairer, Nørsett & Wanner, *Solving ODEs I*, §II.5) with FSAL, the
/// standard error norm ‖e_i / (atol + rtol·max(|y_i|, |ŷ_i|))‖_rms ≤ 1 and the step size carried over from one
/// output interval to the next. All buffers are allocated once.
pub struct Dopri5 {
    rtol: f64,
    atol: f64,
    h: f64,
    k: [Vec<f64>; 7],
    y_stage: Vec<f64>,
    y_new: Vec<f64>,
    fsal: bool,
    /// Where and with which state the last failure happened (for diagnostics).
    pub t_fail: f64,
    pub y_fail: Vec<f64>,
}

const C2: f64 = 1.0 / 5.0;
const C3: f64 = 3.0 / 10.0;
const C4: f64 = 4.0 / 5.0;
const C5: f64 = 8.0 / 9.0;
const A21: f64 = 1.0 / 5.0;
const A31: f64 = 3.0 / 40.0;
const A32: f64 = 9.0 / 40.0;
const A41: f64 = 44.0 / 45.0;
const A42: f64 = -56.0 / 15.0;
const A43: f64 = 32.0 / 9.0;
const A51: f64 = 19372.0 / 6561.0;
const A52: f64 = -25360.0 / 2187.0;
const A53: f64 = 64448.0 / 6561.0;
const A54: f64 = -212.0 / 729.0;
const A61: f64 = 9017.0 / 3168.0;
const A62: f64 = -355.0 / 33.0;
const A63: f64 = 46732.0 / 5247.0;
const A64: f64 = 49.0 / 176.0;
const A65: f64 = -5103.0 / 18656.0;
const A71: f64 = 35.0 / 384.0;
const A73: f64 = 500.0 / 1113.0;
const A74: f64 = 125.0 / 192.0;
const A75: f64 = -2187.0 / 6784.0;
const A76: f64 = 11.0 / 84.0;
// Error coefficients b − b̂.
const E1: f64 = 71.0 / 57600.0;
const E3: f64 = -71.0 / 16695.0;
const E4: f64 = 71.0 / 1920.0;
const E5: f64 = -17253.0 / 339200.0;
const E6: f64 = 22.0 / 525.0;
const E7: f64 = -1.0 / 40.0;

impl Dopri5 {
    pub fn new(n: usize, rtol: f64, atol: f64, h0: f64) -> Self {
        Dopri5 {
            rtol,
            atol,
            h: h0,
            k: std::array::from_fn(|_| vec![0.0; n]),
            y_stage: vec![0.0; n],
            y_new: vec![0.0; n],
            fsal: false,
            t_fail: 0.0,
            y_fail: vec![0.0; n],
        }
    }

    /// Forget the FSAL stage and the step size (after a jump in the state).
    pub fn reset(&mut self, h0: f64) {
        self.fsal = false;
        self.h = h0;
    }

    /// Integrate y from `t0` to `t1` (> t0) in place.
    pub fn advance<F>(
        &mut self,
        t0: f64,
        t1: f64,
        y: &mut [f64],
        f: &mut F,
    ) -> Result<(), SimulateError>
    where
        F: FnMut(f64, &[f64], &mut [f64]) -> Result<(), SimulateError>,
    {
        const MAX_STEPS: usize = 1_000_000;
        let n = y.len();
        let mut t = t0;
        if !self.fsal {
            f(t, y, &mut self.k[0])?;
            self.fsal = true;
        }
        let mut rejected_last = false;
        for _ in 0..MAX_STEPS {
            let remaining = t1 - t;
            if remaining <= 0.0 {
                return Ok(());
            }
            let h_min = 16.0 * f64::EPSILON * t.abs().max(1.0);
            if self.h < h_min {
                self.t_fail = t;
                self.y_fail.copy_from_slice(y);
                return Err(SimulateError::Integration {
                    t,
                    reason: format!(
                        "the step size fell below {h_min:e} s (the right-hand side is not finite near this state, \
                         or the problem is too stiff)"
                    ),
                });
            }
            // Land exactly on t1 (and avoid a sliver of a last step).
            let clipped = self.h >= remaining * (1.0 - 1e-12) || self.h * 1.01 >= remaining;
            let h = if clipped { remaining } else { self.h };
            let err = self.step(t, h, y, f)?;
            if err <= 1.0 {
                // Accepted: t += h, y = ŷ, FSAL (k7 = f(t + h, ŷ) is the next k1).
                t = if clipped { t1 } else { t + h };
                y.copy_from_slice(&self.y_new[..n]);
                self.k.swap(0, 6);
                let grow = if rejected_last { 1.0 } else { 5.0 };
                let factor = if err == 0.0 {
                    grow
                } else {
                    (0.9 * err.powf(-0.2)).clamp(0.2, grow)
                };
                let proposed = h * factor;
                // A step shortened to land on t1 says little about the step size the solution allows.
                self.h = if clipped {
                    proposed.max(self.h)
                } else {
                    proposed
                };
                rejected_last = false;
            } else {
                let factor = if err.is_finite() {
                    (0.9 * err.powf(-0.2)).clamp(0.1, 0.9)
                } else {
                    0.1
                };
                self.h = h * factor;
                rejected_last = true;
            }
        }
        self.t_fail = t;
        self.y_fail.copy_from_slice(y);
        Err(SimulateError::Integration {
            t,
            reason: format!("more than {MAX_STEPS} steps in one output interval"),
        })
    }

    /// One step of size h from (t, y) with k1 = f(t, y) in k[0]; fills ŷ (5th order) and k[1..7], returns the
    /// error norm (NaN → rejected).
    pub fn step<F>(&mut self, t: f64, h: f64, y: &[f64], f: &mut F) -> Result<f64, SimulateError>
    where
        F: FnMut(f64, &[f64], &mut [f64]) -> Result<(), SimulateError>,
    {
        let n = y.len();
        let [k1, k2, k3, k4, k5, k6, k7] = &mut self.k;
        let ys = &mut self.y_stage;
        for i in 0..n {
            ys[i] = y[i] + h * A21 * k1[i];
        }
        f(t + C2 * h, ys, k2)?;
        for i in 0..n {
            ys[i] = y[i] + h * (A31 * k1[i] + A32 * k2[i]);
        }
        f(t + C3 * h, ys, k3)?;
        for i in 0..n {
            ys[i] = y[i] + h * (A41 * k1[i] + A42 * k2[i] + A43 * k3[i]);
        }
        f(t + C4 * h, ys, k4)?;
        for i in 0..n {
            ys[i] = y[i] + h * (A51 * k1[i] + A52 * k2[i] + A53 * k3[i] + A54 * k4[i]);
        }
        f(t + C5 * h, ys, k5)?;
        for i in 0..n {
            ys[i] =
                y[i] + h * (A61 * k1[i] + A62 * k2[i] + A63 * k3[i] + A64 * k4[i] + A65 * k5[i]);
        }
        f(t + h, ys, k6)?;
        let yn = &mut self.y_new;
        for i in 0..n {
            yn[i] =
                y[i] + h * (A71 * k1[i] + A73 * k3[i] + A74 * k4[i] + A75 * k5[i] + A76 * k6[i]);
        }
        f(t + h, yn, k7)?;
        let mut sum = 0.0;
        for i in 0..n {
            let e =
                h * (E1 * k1[i] + E3 * k3[i] + E4 * k4[i] + E5 * k5[i] + E6 * k6[i] + E7 * k7[i]);
            let sc = self.atol + self.rtol * y[i].abs().max(yn[i].abs());
            sum += (e / sc) * (e / sc);
        }
        let err = (sum / n.max(1) as f64).sqrt();
        Ok(if err.is_finite() { err } else { f64::NAN })
    }
}

