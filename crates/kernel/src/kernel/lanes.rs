//! [`Kernel::corner_excess`] with its three polynomials side by side in the lanes of one 4-wide vector, for
//! the batched map evaluation: the same table, the same Estrin scheme, the same operations per lane, so the
//! same numbers.
//!
//! Piece `j` of the unit kernel holds `K₁, R₁` (degree 11, `Piece`) and `h/C₀` (degree 15) in the local
//! variable `s`. Interleaved per power of `s` as `[R₁, K₁, h/C₀, 0]`, with `K₁, R₁` padded by zero
//! coefficients up to degree 15, one Estrin evaluation of degree 15 gives all three: for the padded lanes the
//! top group `(c₁₂ + c₁₃ s) + (c₁₄ + c₁₅ s) s²` is exactly 0, so the sum reduces to the degree-11 scheme of
//! `estrin12` operation for operation (`lo + mid·s⁴ + hi·s⁸`, with `hi + 0·s⁴ = hi`). Without fused
//! multiply-adds (Rust never contracts `a + b·c`) every lane rounds as the scalar path does.

use super::{tables, Kernel, UnitTables};
use crate::construction::{COEFFS, DENSITY_COEFFS, PIECES};

/// Four lanes: `[R₁, K₁, h/C₀, 0]`.
type Lanes = [f64; 4];

/// The unit kernel's tables per piece and power of `s`, interleaved (built at compile time).
static CORNER_LANES: [[Lanes; DENSITY_COEFFS]; PIECES] = interleave();

const fn interleave() -> [[Lanes; DENSITY_COEFFS]; PIECES] {
    let mut out = [[[0.0; 4]; DENSITY_COEFFS]; PIECES];
    let mut j = 0;
    while j < PIECES {
        let mut i = 0;
        while i < DENSITY_COEFFS {
            let [k, r] = if i < COEFFS {
                tables::UNIT_PIECES[j][i]
            } else {
                [0.0, 0.0]
            };
            out[j][i] = [r, k, tables::UNIT_DENSITY[j][i], 0.0];
            i += 1;
        }
        j += 1;
    }
    out
}

/// `c0 + c1·x` per lane.
#[inline(always)]
fn lin4(c0: Lanes, c1: Lanes, x: f64) -> Lanes {
    [
        c0[0] + c1[0] * x,
        c0[1] + c1[1] * x,
        c0[2] + c1[2] * x,
        c0[3] + c1[3] * x,
    ]
}

/// The degree-15 polynomials of one piece by `estrin16`'s scheme, per lane.
#[inline(always)]
fn estrin16x4(c: &[Lanes; DENSITY_COEFFS], s: f64) -> Lanes {
    let s2 = s * s;
    let s4 = s2 * s2;
    let s8 = s4 * s4;
    let p = |i: usize| lin4(c[i], c[i + 1], s);
    let q = |i: usize| lin4(p(i), p(i + 2), s2);
    lin4(lin4(q(0), q(4), s4), lin4(q(8), q(12), s4), s8)
}

impl Kernel {
    /// [`Kernel::corner_excess`] (`[R(t) − t₊, K(t) − H(t), k(t)]`) from the interleaved table, the same
    /// numbers for every `t` but NaN, where it gives 0 (the batched map fills NaN for NaN arguments itself).
    /// No branch on `t`: outside the support the piece at `u = −1` is evaluated and discarded.
    #[inline(always)]
    pub(crate) fn corner_excess_lanes(&self, t: f64) -> [f64; 3] {
        let u = t * self.inv_a;
        let v = -u.abs();
        let inside = v > -1.0;
        let (j, s) = UnitTables::locate(if inside { v } else { -1.0 });
        let [r, k, d, _] = estrin16x4(&CORNER_LANES[j], s);
        let (k, r, d) = (k.max(0.0), r.max(0.0), d.max(0.0));
        let e = [self.a * r, if u > 0.0 { -k } else { k }, d * self.inv_a];
        if inside {
            e
        } else {
            [0.0; 3]
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Bit for bit the scalar corner excess, inside the support, at its ends and outside.
    #[test]
    fn lanes_equal_the_scalar_corner_excess() {
        for h in [0.7, 25.0, 1.0e4] {
            let kernel = Kernel::new(h);
            for i in 0..=100_003 {
                let t = h * (-1.2 + 2.4 * i as f64 / 100_003.0);
                let (lanes, scalar) = (kernel.corner_excess_lanes(t), kernel.corner_excess(t));
                for n in 0..3 {
                    assert_eq!(lanes[n].to_bits(), scalar[n].to_bits(), "h {h}, t {t}, entry {n}");
                }
            }
            for t in [-h, h, 0.0, -0.0, f64::INFINITY, f64::NEG_INFINITY] {
                assert_eq!(kernel.corner_excess_lanes(t), kernel.corner_excess(t), "t {t}");
            }
        }
    }
}
