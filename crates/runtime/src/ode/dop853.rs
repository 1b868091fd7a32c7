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
//! err^(−1/8))) (the code's bounds; no growth right after a rejection).
//!
//! Continuous extension (optional, [`Dop853::with_dense_output`]): the code's interpolant of order 7 (Hairer I,
//! §II.6 and the code DOP853's `CONTD8`), which costs three more evaluations per accepted step, at
//! t + c h for c = 0.1, 0.2, 7/9 (stages 14 … 16, from the step's 13 stages by the rows A_14 … A_16), and
//! reads with θ = (t' − t)/h, θ' = 1 − θ
//!
//! ```text
//! y(t + θh) ≈ r1 + θ(r2 + θ'(r3 + θ(r4 + θ'(r5 + θ(r6 + θ'(r7 + θ r8)))))),
//! r1 = y₀, r2 = y₁ − y₀, r3 = h k₁ − r2, r4 = r2 − h k₁₃ − r3, r(4+i) = h Σ_j D_ij k_j (i = 1 … 4).
//! ```

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

/// The continuous extension's stage nodes c_14 … c_16.
const C_DENSE: [f64; 3] = [0.1, 0.2, 0.777777777777777777777777777778];

/// The rows a_14,j … a_16,j of the continuous extension's stages (j < 16 over the 13 stages of the step and
/// the extension's earlier ones), zero entries written out.
const A_DENSE: [[f64; 15]; 3] = {
    let mut a = [[0.0; 15]; 3];
    a[0][0] = 5.61675022830479523392909219681e-2;
    a[0][6] = 2.53500210216624811088794765333e-1;
    a[0][7] = -2.46239037470802489917441475441e-1;
    a[0][8] = -1.24191423263816360469010140626e-1;
    a[0][9] = 1.5329179827876569731206322685e-1;
    a[0][10] = 8.20105229563468988491666602057e-3;
    a[0][11] = 7.56789766054569976138603589584e-3;
    a[0][12] = -8.298e-3;
    a[1][0] = 3.18346481635021405060768473261e-2;
    a[1][5] = 2.83009096723667755288322961402e-2;
    a[1][6] = 5.35419883074385676223797384372e-2;
    a[1][7] = -5.49237485713909884646569340306e-2;
    a[1][10] = -1.08347328697249322858509316994e-4;
    a[1][11] = 3.82571090835658412954920192323e-4;
    a[1][12] = -3.40465008687404560802977114492e-4;
    a[1][13] = 1.41312443674632500278074618366e-1;
    a[2][0] = -4.28896301583791923408573538692e-1;
    a[2][5] = -4.69762141536116384314449447206;
    a[2][6] = 7.68342119606259904184240953878;
    a[2][7] = 4.06898981839711007970213554331;
    a[2][8] = 3.56727187455281109270669543021e-1;
    a[2][12] = -1.39902416515901462129418009734e-3;
    a[2][13] = 2.9475147891527723389556272149;
    a[2][14] = -9.15095847217987001081870187138;
    a
};

/// The weights D_ij of the continuous extension's r5 … r8 over the 16 stages (stages 2 … 5 have none).
const D_DENSE: [[f64; 16]; 4] = [
    [
        -0.84289382761090128651353491142e1,
        0.0,
        0.0,
        0.0,
        0.0,
        0.56671495351937776962531783590,
        -0.30689499459498916912797304727e1,
        0.23846676565120698287728149680e1,
        0.21170345824450282767155149946e1,
        -0.87139158377797299206789907490,
        0.22404374302607882758541771650e1,
        0.63157877876946881815570249290,
        -0.88990336451333310820698117400e-1,
        0.18148505520854727256656404962e2,
        -0.91946323924783554000451984436e1,
        -0.44360363875948939664310572000e1,
    ],
    [
        0.10427508642579134603413151009e2,
        0.0,
        0.0,
        0.0,
        0.0,
        0.24228349177525818288430175319e3,
        0.16520045171727028198505394887e3,
        -0.37454675472269020279518312152e3,
        -0.22113666853125306036270938578e2,
        0.77334326684722638389603898808e1,
        -0.30674084731089398182061213626e2,
        -0.93321305264302278729567221706e1,
        0.15697238121770843886131091075e2,
        -0.31139403219565177677282850411e2,
        -0.93529243588444783865713862664e1,
        0.35816841486394083752465898540e2,
    ],
    [
        0.19985053242002433820987653617e2,
        0.0,
        0.0,
        0.0,
        0.0,
        -0.38703730874935176555105901742e3,
        -0.18917813819516756882830838328e3,
        0.52780815920542364900561016686e3,
        -0.11573902539959630126141871134e2,
        0.68812326946963000169666922661e1,
        -0.10006050966910838403183860980e1,
        0.77771377980534432092869265740,
        -0.27782057523535084065932004339e1,
        -0.60196695231264120758267380846e2,
        0.84320405506677161018159903784e2,
        0.11992291136182789328035130030e2,
    ],
    [
        -0.25693933462703749003312586129e2,
        0.0,
        0.0,
        0.0,
        0.0,
        -0.15418974869023643374053993627e3,
        -0.23152937917604549567536039109e3,
        0.35763911791061412378285349910e3,
        0.93405324183624310003907691704e2,
        -0.37458323136451633156875139351e2,
        0.10409964950896230045147246184e3,
        0.29840293426660503123344363579e2,
        -0.43533456590011143754432175058e2,
        0.96324553959188282948394950600e2,
        -0.39177261675615439165231486172e2,
        -0.14972683625798562581422125276e3,
    ],
];

/// DOP853's controller: exponent 1/8, growth at most 6, shrinking at most to 1/3 (the code's bounds).
const CONTROL: Controller = Controller {
    exponent: 0.125,
    shrink: 1.0 / 3.0,
    grow: 6.0,
    reject_shrink: 1.0 / 3.0,
};

/// The continuous extension of a step [t, t + h]: its stages k_14 … k_16 and r1 … r8 (r_i's component c at
/// `(i − 1)·n + c`).
#[derive(Debug, Clone)]
struct Extension {
    k: Vec<f64>,
    r: Vec<f64>,
    t: f64,
    h: f64,
}

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
    /// The continuous extension of the last accepted step, where it is wanted.
    ext: Option<Box<Extension>>,
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
            ext: None,
            n,
            y_stage: vec![0.0; n],
            y_new: vec![0.0; n],
            fsal: false,
            stats: OdeStats::default(),
        }
    }

    /// With the continuous extension of order 7 (module docs): three more evaluations per accepted step, and
    /// [`Dop853::dense`] and [`Dop853::continuous_extension`] read it.
    pub fn with_dense_output(mut self) -> Self {
        self.ext = Some(Box::new(Extension {
            k: vec![0.0; 3 * self.n],
            r: vec![0.0; 8 * self.n],
            t: 0.0,
            h: 0.0,
        }));
        self
    }

    /// Forget the FSAL stage and set the step size (after a jump in the state or the right-hand side).
    pub fn reset(&mut self, h0: f64) {
        self.fsal = false;
        self.h = h0;
    }

    /// Start afresh from (t, y): f(t, y) as the first stage (FSAL), and the starting step of `start.rs` (at
    /// most `h_max`) as the step size; one more evaluation.
    pub fn start<F, E>(&mut self, t: f64, y: &[f64], h_max: f64, f: &mut F) -> Result<(), E>
    where
        F: FnMut(f64, &[f64], &mut [f64]) -> Result<(), E>,
    {
        let n = self.n;
        let (f0, rest) = self.k.split_at_mut(n);
        f(t, y, f0)?;
        let bufs = (&mut self.y_stage[..], &mut rest[..n]);
        let tol = (self.rtol, self.atol);
        self.h = super::start::starting_step((t, y, f0), tol, 8, h_max, bufs, f)?;
        self.stats.evaluations += 2;
        self.fsal = true;
        Ok(())
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

    /// [`Dop853::advance`] (the same steps, bit for bit), calling `each(self, t, t_new)` after every accepted
    /// step [t, t_new], while [`Dop853::dense`] interpolates in it (with the continuous extension).
    pub fn advance_each<F, G, E>(
        &mut self,
        t0: f64,
        t1: f64,
        y: &mut [f64],
        f: &mut F,
        each: &mut G,
    ) -> Result<(), E>
    where
        F: FnMut(f64, &[f64], &mut [f64]) -> Result<(), E>,
        G: FnMut(&Dop853, f64, f64) -> Result<(), E>,
        E: From<StepFailure>,
    {
        let steps = steps_until(t0, t1, |t| -> Result<f64, E> {
            let t_new = self.step_to(t, t1, y, f)?;
            self.prepare_dense(f)?;
            each(self, t, t_new)?;
            Ok(t_new)
        })?;
        match steps {
            None => Ok(()),
            Some(t) => Err(E::from(too_many_steps(t))),
        }
    }

    /// The continuous extension of the last accepted step at `t` (module docs; NaN without it).
    pub fn dense(&self, t: f64, out: &mut [f64]) {
        match &self.ext {
            Some(e) => super::dense::nested(&e.r, self.n, (t - e.t) / e.h, out),
            None => out.fill(f64::NAN),
        }
    }

    /// The last accepted step's start, size and r1 … r8 (r_i's component c at `(i − 1)·n + c`; empty without
    /// the continuous extension).
    pub fn continuous_extension(&self) -> (f64, f64, &[f64]) {
        match &self.ext {
            Some(e) => (e.t, e.h, &e.r),
            None => (0.0, 0.0, &[]),
        }
    }

    /// The continuous extension of the step [t, t + h] just accepted ([`Dop853::step_to`] left its y₀ and k₁
    /// in r1 and r2, y₁ in `y_new` and k₂ … k₁₃ in place): stages 14 … 16 and r1 … r8 (module docs). Out of
    /// line: a plain run's step stays as small as it was. Nothing without the extension.
    #[inline(never)]
    fn prepare_dense<F, E>(&mut self, f: &mut F) -> Result<(), E>
    where
        F: FnMut(f64, &[f64], &mut [f64]) -> Result<(), E>,
    {
        let n = self.n;
        let Some(e) = self.ext.as_mut() else {
            return Ok(());
        };
        let (t, h) = (e.t, e.h);
        // Stage j's component c: k₁ saved in r2, k₂ … k₁₃ in `k`, k₁₄ … k₁₆ in the extension's.
        let stage = |k: &[f64], r: &[f64], kd: &[f64], j: usize, c: usize| {
            if j == 0 {
                r[n + c]
            } else if j <= S {
                k[j * n + c]
            } else {
                kd[(j - S - 1) * n + c]
            }
        };
        for (i, row) in A_DENSE.iter().enumerate() {
            let (done, rest) = e.k.split_at_mut(i * n);
            for c in 0..n {
                let mut s = 0.0;
                for (j, a) in row[..S + 1 + i].iter().enumerate() {
                    s += a * stage(&self.k, &e.r, done, j, c);
                }
                self.y_stage[c] = e.r[c] + h * s;
            }
            f(t + C_DENSE[i] * h, &self.y_stage, &mut rest[..n])?;
        }
        self.stats.evaluations += 3;
        let (k, kd, r) = (&self.k, &e.k, &mut e.r);
        for c in 0..n {
            let mut d = [0.0; 4];
            for (i, row) in D_DENSE.iter().enumerate() {
                for (j, dj) in row.iter().enumerate() {
                    d[i] += dj * stage(k, r, kd, j, c);
                }
            }
            let (y0, k1) = (r[c], r[n + c]);
            let ydiff = self.y_new[c] - y0;
            let bspl = h * k1 - ydiff;
            r[n + c] = ydiff;
            r[2 * n + c] = bspl;
            r[3 * n + c] = ydiff - h * k[S * n + c] - bspl;
            for (i, di) in d.iter().enumerate() {
                r[(4 + i) * n + c] = h * di;
            }
        }
        Ok(())
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
                if let Some(e) = self.ext.as_mut() {
                    // The step's y₀ and k₁, which the next lines overwrite, for its continuous extension
                    // ([`Dop853::prepare_dense`]).
                    let n = self.n;
                    e.r[..n].copy_from_slice(y);
                    e.r[n..2 * n].copy_from_slice(&self.k[..n]);
                    (e.t, e.h) = (t, h);
                }
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

    /// The continuous extension on y' = −y + cos t + sin t (y = sin t + e^(−t)): the steps and the result are
    /// the same bits as without it, it is exact at both ends of a step, and inside the steps its error falls
    /// as h⁸ (a local error of order 7 + 1) with fixed steps.
    #[test]
    fn the_continuous_extension_has_order_seven_and_leaves_the_steps_alone() {
        let mut f = |t: f64, y: &[f64], d: &mut [f64]| -> Result<(), StepFailure> {
            d[0] = -y[0] + t.cos() + t.sin();
            Ok(())
        };
        let exact = |t: f64| t.sin() + (-t).exp();
        let (mut plain, mut dense) = (
            Dop853::new(1, 1e-9, 1e-11, 0.1),
            Dop853::new(1, 1e-9, 1e-11, 0.1).with_dense_output(),
        );
        let (mut y, mut z) = ([1.0], [1.0]);
        plain.advance(0.0, 5.0, &mut y, &mut f).expect("integrates");
        let mut ends = 0.0f64;
        let mut each = |o: &Dop853, t: f64, t_new: f64| -> Result<(), StepFailure> {
            let (mut a, mut b) = ([0.0], [0.0]);
            o.dense(t, &mut a);
            o.dense(t_new, &mut b);
            ends = ends
                .max((b[0] - exact(t_new)).abs())
                .max((a[0] - exact(t)).abs());
            Ok(())
        };
        dense
            .advance_each(0.0, 5.0, &mut z, &mut f, &mut each)
            .expect("integrates");
        assert_eq!(y[0].to_bits(), z[0].to_bits());
        assert_eq!(plain.stats.accepted, dense.stats.accepted);
        assert!(ends < 1e-9, "at the steps' ends: {ends:e}");
        let mut fixed = |h: f64| {
            let mut ode = Dop853::new(1, 1e3, 1e3, h).with_dense_output();
            let (mut y, mut t, mut worst) = ([1.0], 0.0, 0.0f64);
            while t < 2.0 - 1e-12 {
                ode.h = h;
                let t_new = ode.step_to(t, 2.0, &mut y, &mut f).expect("step");
                ode.prepare_dense(&mut f).expect("stages");
                // The extension's own error: against the exact solution through the step's start.
                let y0 = ode.continuous_extension().2[0];
                for theta in [0.2, 0.5, 0.8] {
                    let s = t + theta * (t_new - t);
                    let mut v = [0.0];
                    ode.dense(s, &mut v);
                    let through = (s).sin() + (y0 - t.sin()) * (t - s).exp();
                    worst = worst.max((v[0] - through).abs());
                }
                t = t_new;
            }
            worst
        };
        let (e1, e2) = (fixed(0.4), fixed(0.2));
        let order = (e1 / e2).log2();
        assert!(
            (7.3..9.5).contains(&order),
            "observed local order {order} ({e1:e}, {e2:e})"
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
