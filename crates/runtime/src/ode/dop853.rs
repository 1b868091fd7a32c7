//! The explicit Runge–Kutta pair of order 8 with error estimators of orders 5 and 3 by Prince & Dormand
//! (*High order embedded Runge–Kutta formulae*, J. Comput. Appl. Math. 7, 1981), as Hairer, Nørsett & Wanner
//! use it in the code DOP853 (*Solving ODEs I*, 2nd ed., §II.10): 12 stages per step and FSAL (the 13th
//! evaluation, f(t + h, y₁), is the next step's first). For the smooth right-hand sides of the zero dynamics at
//! tight tolerances it takes far fewer evaluations than [`Dopri5`](super::Dopri5): the step grows as
//! tol^(1/8) instead of tol^(1/5).
//!
//! Error estimate (Hairer I, §II.10): with e₅ = h Σ E5_i k_i and e₃ = h Σ E3_i k_i, scaled componentwise by
//! sc_i = atol + rtol·max(|y_i|, |y₁_i|),
//!
//! ```text
//! err = ‖e₅/sc‖² / √(n · (‖e₅/sc‖² + 0.01 ‖e₃/sc‖²)),
//! ```
//!
//! which behaves as O(h⁸); the step is accepted when err ≤ 1 and the next one is h·min(6, max(1/3, 0.9
//! err^(−1/8))) (the code's bounds; no growth right after a rejection). No dense output: the callers need the
//! solution at the ends of their intervals only.

// The coefficients are written with the 30 digits they are published with; f64 rounds them.
#![allow(clippy::excessive_precision)]

use super::{
    clip, h_min, steps_until, too_many_steps, too_small, Controller, OdeStats, StepFailure,
};

/// Stages per step.
const S: usize = 12;

/// Nodes c_i.
const C: [f64; S] = [
    0.0,
    0.526001519587677318785587544488e-1,
    0.789002279381515978178381316732e-1,
    0.118350341907227396726757197510,
    0.281649658092772603273242802490,
    0.333333333333333333333333333333,
    0.25,
    0.307692307692307692307692307692,
    0.651282051282051282051282051282,
    0.6,
    0.857142857142857142857142857142,
    1.0,
];

/// The coupling coefficients a_ij (row i, j < i), zero entries written out.
const A: [[f64; S]; S] = {
    let mut a = [[0.0; S]; S];
    a[1][0] = 5.26001519587677318785587544488e-2;
    a[2][0] = 1.97250569845378994544595329183e-2;
    a[2][1] = 5.91751709536136983633785987549e-2;
    a[3][0] = 2.95875854768068491816892993775e-2;
    a[3][2] = 8.87627564304205475450678981324e-2;
    a[4][0] = 2.41365134159266685502369798665e-1;
    a[4][2] = -8.84549479328286085344864962717e-1;
    a[4][3] = 9.24834003261792003115737966543e-1;
    a[5][0] = 3.7037037037037037037037037037e-2;
    a[5][3] = 1.70828608729473871279604482173e-1;
    a[5][4] = 1.25467687566822425016691814123e-1;
    a[6][0] = 3.7109375e-2;
    a[6][3] = 1.70252211019544039314978060272e-1;
    a[6][4] = 6.02165389804559606850219397283e-2;
    a[6][5] = -1.7578125e-2;
    a[7][0] = 3.70920001185047927108779319836e-2;
    a[7][3] = 1.70383925712239993810214054705e-1;
    a[7][4] = 1.07262030446373284651809199168e-1;
    a[7][5] = -1.53194377486244017527936158236e-2;
    a[7][6] = 8.27378916381402288758473766002e-3;
    a[8][0] = 6.24110958716075717114429577812e-1;
    a[8][3] = -3.36089262944694129406857109825;
    a[8][4] = -8.68219346841726006818189891453e-1;
    a[8][5] = 2.75920996994467083049415600797e1;
    a[8][6] = 2.01540675504778934086186788979e1;
    a[8][7] = -4.34898841810699588477366255144e1;
    a[9][0] = 4.77662536438264365890433908527e-1;
    a[9][3] = -2.48811461997166764192642586468;
    a[9][4] = -5.90290826836842996371446475743e-1;
    a[9][5] = 2.12300514481811942347288949897e1;
    a[9][6] = 1.52792336328824235832596922938e1;
    a[9][7] = -3.32882109689848629194453265587e1;
    a[9][8] = -2.03312017085086261358222928593e-2;
    a[10][0] = -9.3714243008598732571704021658e-1;
    a[10][3] = 5.18637242884406370830023853209;
    a[10][4] = 1.09143734899672957818500254654;
    a[10][5] = -8.14978701074692612513997267357;
    a[10][6] = -1.85200656599969598641566180701e1;
    a[10][7] = 2.27394870993505042818970056734e1;
    a[10][8] = 2.49360555267965238987089396762;
    a[10][9] = -3.0467644718982195003823669022;
    a[11][0] = 2.27331014751653820792359768449;
    a[11][3] = -1.05344954667372501984066689879e1;
    a[11][4] = -2.00087205822486249909675718444;
    a[11][5] = -1.79589318631187989172765950534e1;
    a[11][6] = 2.79488845294199600508499808837e1;
    a[11][7] = -2.85899827713502369474065508674;
    a[11][8] = -8.87285693353062954433549289258;
    a[11][9] = 1.23605671757943030647266201528e1;
    a[11][10] = 6.43392746015763530355970484046e-1;
    a
};

/// The weights b_i of the 8th-order solution.
const B: [f64; S] = [
    5.42937341165687622380535766363e-2,
    0.0,
    0.0,
    0.0,
    0.0,
    4.45031289275240888144113950566,
    1.89151789931450038304281599044,
    -5.8012039600105847814672114227,
    3.1116436695781989440891606237e-1,
    -1.52160949662516078556178806805e-1,
    2.01365400804030348374776537501e-1,
    4.47106157277725905176885569043e-2,
];

/// E5 = b − b̂₅: the 5th-order error estimator's weights.
const E5: [f64; S] = [
    0.1312004499419488073250102996e-1,
    0.0,
    0.0,
    0.0,
    0.0,
    -0.1225156446376204440720569753e1,
    -0.4957589496572501915214079952,
    0.1664377182454986536961530415e1,
    -0.3503288487499736816886487290,
    0.3341791187130174790297318841,
    0.8192320648511571246570742613e-1,
    -0.2235530786388629525884427845e-1,
];

/// E3 = b − b̂₃: b with the 3rd-order weights 0.2440…, 0.7338…, 0.0220… taken from stages 1, 9 and 12.
const E3: [f64; S] = {
    let mut e = B;
    e[0] -= 0.244094488188976377952755905512;
    e[8] -= 0.733846688281611857341361741547;
    e[11] -= 0.220588235294117647058823529412e-1;
    e
};

/// DOP853's controller: exponent 1/8, growth at most 6, shrinking at most to 1/3 (the code's bounds).
const CONTROL: Controller = Controller {
    exponent: 0.125,
    shrink: 1.0 / 3.0,
    grow: 6.0,
    reject_shrink: 1.0 / 3.0,
};

/// The DOP853 integrator: its tolerances, step size, FSAL stage and buffers (allocated once).
#[derive(Debug, Clone)]
pub struct Dop853 {
    rtol: f64,
    atol: f64,
    h: f64,
    /// k_1 … k_12, and k_13 = f(t + h, y₁) (the next k_1), stage after stage in one buffer: k_i's
    /// component c at `(i − 1)·n + c` (a system of one or two internal states runs through short loops, so
    /// one contiguous buffer instead of thirteen).
    k: Vec<f64>,
    n: usize,
    y_stage: Vec<f64>,
    y_new: Vec<f64>,
    fsal: bool,
    pub stats: OdeStats,
}

impl Dop853 {
    pub fn new(n: usize, rtol: f64, atol: f64, h0: f64) -> Self {
        Dop853 {
            rtol,
            atol,
            h: h0,
            k: vec![0.0; (S + 1) * n],
            n,
            y_stage: vec![0.0; n],
            y_new: vec![0.0; n],
            fsal: false,
            stats: OdeStats::default(),
        }
    }

    /// Forget the FSAL stage and set the step size (after a jump in the state or the right-hand side).
    pub fn reset(&mut self, h0: f64) {
        self.fsal = false;
        self.h = h0;
    }

    /// The step size the controller proposes for the next step.
    pub fn step_size(&self) -> f64 {
        self.h
    }

    /// Integrate y from `t0` to `t1` (> t0) in place.
    pub fn advance<F, E>(&mut self, t0: f64, t1: f64, y: &mut [f64], f: &mut F) -> Result<(), E>
    where
        F: FnMut(f64, &[f64], &mut [f64]) -> Result<(), E>,
        E: From<StepFailure>,
    {
        match steps_until(t0, t1, |t| self.step_to(t, t1, y, f))? {
            None => Ok(()),
            Some(t) => Err(E::from(too_many_steps(t))),
        }
    }

    /// One accepted step from (t, y) towards `t_end` (> t), retrying with smaller steps after rejections; y is
    /// updated in place and the new time returned (exactly `t_end` when the step reaches it).
    pub fn step_to<F, E>(&mut self, t: f64, t_end: f64, y: &mut [f64], f: &mut F) -> Result<f64, E>
    where
        F: FnMut(f64, &[f64], &mut [f64]) -> Result<(), E>,
        E: From<StepFailure>,
    {
        if !self.fsal {
            f(t, y, &mut self.k[..self.n])?;
            self.stats.evaluations += 1;
            self.fsal = true;
        }
        let mut rejected_last = false;
        loop {
            if self.h < h_min(t) || !self.h.is_finite() {
                return Err(too_small(t));
            }
            let (h, clipped) = clip(self.h, t, t_end);
            let err = self.step(t, h, y, f)?;
            let next = CONTROL.next(err, h, rejected_last);
            if err <= 1.0 {
                self.stats.accepted += 1;
                let t_new = if clipped { t_end } else { t + h };
                y.copy_from_slice(&self.y_new);
                self.k.copy_within(S * self.n.., 0);
                // A step shortened to land on t_end says little about the step size the solution allows.
                self.h = if clipped { next.max(self.h) } else { next };
                return Ok(t_new);
            }
            self.stats.rejected += 1;
            self.h = next;
            rejected_last = true;
        }
    }

    /// The stages k_2 … k_13 of a step of size h from (t, y) with k_1 in hand, y₁ into `y_new`; the error
    /// estimate (module docs).
    fn step<F, E>(&mut self, t: f64, h: f64, y: &[f64], f: &mut F) -> Result<f64, E>
    where
        F: FnMut(f64, &[f64], &mut [f64]) -> Result<(), E>,
    {
        let n = self.n;
        for i in 1..S {
            let (done, rest) = self.k.split_at_mut(i * n);
            for (c, (ys, &y0)) in self.y_stage.iter_mut().zip(y).enumerate() {
                let mut s = 0.0;
                for (j, a) in A[i][..i].iter().enumerate() {
                    s += a * done[j * n + c];
                }
                *ys = y0 + h * s;
            }
            f(t + C[i] * h, &self.y_stage, &mut rest[..n])?;
        }
        for (c, (y1, &y0)) in self.y_new.iter_mut().zip(y).enumerate() {
            let mut s = 0.0;
            for (j, b) in B.iter().enumerate() {
                s += b * self.k[j * n + c];
            }
            *y1 = y0 + h * s;
        }
        f(t + h, &self.y_new, &mut self.k[S * n..])?;
        self.stats.evaluations += S;
        let (mut e5, mut e3) = (0.0, 0.0);
        for (c, (&y0, &y1)) in y.iter().zip(&self.y_new).enumerate() {
            let sc = self.atol + self.rtol * y0.abs().max(y1.abs());
            let (mut d5, mut d3) = (0.0, 0.0);
            for (j, (e5j, e3j)) in E5.iter().zip(E3).enumerate() {
                let k = self.k[j * n + c];
                d5 += e5j * k;
                d3 += e3j * k;
            }
            e5 += (h * d5 / sc).powi(2);
            e3 += (h * d3 / sc).powi(2);
        }
        let den = e5 + 0.01 * e3;
        Ok(if den > 0.0 {
            e5 / (n as f64 * den).sqrt()
        } else {
            0.0
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// y' = −y + cos t + sin t has y = sin t + (y₀) e^(−t): integrated over [0, 10] the error is within the
    /// tolerance, and halving the fixed step of an order-8 method divides the error by about 2⁸.
    #[test]
    fn order_eight_and_the_tolerance_on_an_exact_solution() {
        let mut f = |t: f64, y: &[f64], d: &mut [f64]| -> Result<(), StepFailure> {
            d[0] = -y[0] + t.cos() + t.sin();
            Ok(())
        };
        let exact = |t: f64| t.sin() + (-t).exp();
        for rtol in [1e-6, 1e-10] {
            let mut ode = Dop853::new(1, rtol, rtol * 1e-2, 0.1);
            let mut y = [1.0];
            ode.advance(0.0, 10.0, &mut y, &mut f).expect("integrates");
            let e = (y[0] - exact(10.0)).abs();
            assert!(e < 10.0 * rtol, "rtol {rtol}: error {e:e}");
        }
        // Fixed steps: the adaptive controller with a tolerance so loose that every step is accepted.
        let mut fixed = |h: f64| {
            let mut ode = Dop853::new(1, 1e3, 1e3, h);
            let mut y = [1.0];
            let mut t = 0.0;
            while t < 2.0 - 1e-12 {
                ode.h = h;
                t = ode.step_to(t, 2.0, &mut y, &mut f).expect("step");
            }
            (y[0] - exact(2.0)).abs()
        };
        let (e1, e2) = (fixed(0.4), fixed(0.2));
        let order = (e1 / e2).log2();
        assert!(
            (7.5..9.5).contains(&order),
            "observed order {order} ({e1:e}, {e2:e})"
        );
    }

    /// A system: the harmonic oscillator over one period returns to its start within the tolerance, and
    /// takes far fewer evaluations than the 5th-order pair at 1e-10.
    #[test]
    fn the_oscillator_returns_in_fewer_evaluations_than_dopri5() {
        let mut f = |_: f64, y: &[f64], d: &mut [f64]| -> Result<(), StepFailure> {
            d[0] = y[1];
            d[1] = -y[0];
            Ok(())
        };
        let period = std::f64::consts::TAU;
        let mut ode = Dop853::new(2, 1e-10, 1e-12, 0.1);
        let mut y = [1.0, 0.0];
        ode.advance(0.0, period, &mut y, &mut f)
            .expect("integrates");
        assert!((y[0] - 1.0).abs() < 1e-9 && y[1].abs() < 1e-9, "{y:?}");
        let mut d5 = super::super::Dopri5::new(2, 1e-10, 1e-12, 0.1);
        let mut z = [1.0, 0.0];
        d5.advance(0.0, period, &mut z, &mut f).expect("integrates");
        assert!(
            2 * ode.stats.evaluations < d5.stats.evaluations,
            "DOP853 {} vs DOPRI5 {} evaluations",
            ode.stats.evaluations,
            d5.stats.evaluations
        );
    }
}
