//! The output grid t_k = t_0 + k·dt shared by the inverse and the forward simulation, its limits and the
//! check of dt.

use crate::error::RunError;

/// How many derivatives (orders 0 … 9) the smoother delivers per evaluation; bounds the relative degree (≤ 9).
pub const MAX_DERIVATIVES: usize = 10;

/// Largest number of output samples a run may produce (guards against absurd `--dt`).
pub const MAX_SAMPLES: usize = 50_000_000;

/// Most bytes the stored time series of a run (kept for `--out` and `--plot`) may take: samples × columns ×
/// 8 bytes ≤ 1 GiB, checked before it is allocated ([`check_record`]). Its CSV would be about 2.5 times
/// larger (some 20 characters a number): 1 GiB is 10 million samples of the 11 columns of `si_engine`, NEDC
/// at `--dt 1.1e-4` and a 3 GB file, beyond what a spreadsheet or a plot can use. NEDC at `--dt 3e-5` with
/// `--out` (39 million samples, 5 GB of memory) is refused at once; a run without a stored series (the
/// summary only) streams any sample count up to [`MAX_SAMPLES`].
pub const MAX_RECORD_BYTES: u64 = 1 << 30;

/// Fewest output samples a run may produce: fewer (`--dt` about as long as the cycle) leave no time series
/// worth the name and integrals of one or two trapezoids.
pub const MIN_SAMPLES: usize = 10;

/// `Err(InvalidDt)` unless dt is a positive, finite number of seconds.
pub fn check_dt(dt: f64) -> Result<(), RunError> {
    if dt > 0.0 && dt.is_finite() {
        Ok(())
    } else {
        Err(RunError::InvalidDt(dt))
    }
}

/// `Err(TooManySamples)` if `steps + 1` samples exceed [`MAX_SAMPLES`] (`duration` as reported).
pub fn check_samples(steps: f64, duration: f64, dt: f64) -> Result<(), RunError> {
    if steps + 1.0 > MAX_SAMPLES as f64 {
        return Err(RunError::TooManySamples {
            samples: steps + 1.0,
            duration,
            dt,
            max: MAX_SAMPLES,
        });
    }
    Ok(())
}

/// `Err(RecordTooLarge)` if a stored series of `samples` samples × `columns` columns of 8 bytes exceeds
/// [`MAX_RECORD_BYTES`] (`dt` for the message's advice: the step that would fit).
pub fn check_record(samples: usize, columns: usize, dt: f64) -> Result<(), RunError> {
    let bytes = samples as f64 * columns as f64 * 8.0;
    if bytes > MAX_RECORD_BYTES as f64 {
        return Err(RunError::RecordTooLarge {
            samples,
            columns,
            bytes,
            dt,
            // Rounded up by 1e-5 (the message prints six digits): the step advised fits.
            min_dt: dt * bytes / MAX_RECORD_BYTES as f64 * (1.0 + 1e-5),
            max_bytes: MAX_RECORD_BYTES,
        });
    }
    Ok(())
}

/// The output grid t_k = t_0 + k·dt, k = 0 … n.
#[derive(Debug, Clone, Copy)]
pub struct Grid {
    pub t0: f64,
    pub dt: f64,
    pub n: usize,
    /// Index of t_0 on the grid: the number of pre-actuation samples of a stable inversion (0 otherwise), so
    /// t_k = t_0 + (k − k0)·dt.
    pub k0: usize,
    /// 1/dt when that is an integer: then t_k = t_0 + k/(1/dt) is the correctly rounded k·dt (0.3, not
    /// 0.30000000000000004, at dt = 0.1).
    pub per_second: Option<f64>,
}

impl Grid {
    /// The grid over a cycle starting at `t0` of `duration` seconds: round(duration/dt) steps, checked against
    /// [`MAX_SAMPLES`] and [`MIN_SAMPLES`].
    pub fn new(t0: f64, duration: f64, dt: f64) -> Result<Grid, RunError> {
        check_dt(dt)?;
        let steps = (duration / dt).round();
        check_samples(steps, duration, dt)?;
        if steps + 1.0 < MIN_SAMPLES as f64 {
            return Err(RunError::TooFewSamples {
                samples: steps + 1.0,
                duration,
                dt,
                min: MIN_SAMPLES,
            });
        }
        let per_second = {
            let m = (1.0 / dt).round();
            (m >= 1.0 && (1.0 / dt - m).abs() <= 1e-9 * m).then_some(m)
        };
        Ok(Grid {
            t0,
            dt,
            n: steps as usize,
            k0: 0,
            per_second,
        })
    }

    /// t_k.
    pub fn time(&self, k: usize) -> f64 {
        // k − k0 as a signed integer, then one conversion: the same number as k as f64 − k0 as f64 (both below
        // MAX_SAMPLES < 2^53, so exact), without two unsigned conversions on the way to every t_k.
        let k = (k as i64 - self.k0 as i64) as f64;
        match self.per_second {
            Some(m) => self.t0 + k / m,
            None => self.t0 + k * self.dt,
        }
    }

    /// Number of samples, n + 1.
    pub fn samples(&self) -> usize {
        self.n + 1
    }
}
