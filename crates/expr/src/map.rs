//! Lookup maps in expressions (contract §6): a map call is its own node kind, `M(a)` or `M(a, b)` and the
//! derivative maps `M_dK(a)` (d^K M / da^K) and `M_dIJ(a, b)` (∂^(I+J) M / ∂a^I ∂b^J), defined apart from the
//! function rules. This file holds what the rest of the crate needs to know about a map: its name, arity,
//! numeric data (the smooth map of `invsim-kernel`, for evaluation) and the generic surrogate the zero test
//! evaluates instead of the data.
//!
//! # The zero test never assumes a map zero
//!
//! A map's values can be replaced at run time (`--map`), so a derivation must not depend on them: a
//! constant map has zero derivative maps, but `eta_vol_d10` is not identically zero as a symbol. The zero
//! test therefore probes a map call with a generic analytic surrogate instead of the data,
//!
//! ```text
//! S(a, b) = Σ_{k=1,2} sin(c_k a/s_a + φ_k) · sin(d_k b/s_b + θ_k),
//! ∂^(I+J) S / ∂a^I ∂b^J = Σ_k (c_k/s_a)^I (d_k/s_b)^J sin(c_k a/s_a + φ_k + Iπ/2) sin(d_k b/s_b + θ_k + Jπ/2),
//! ```
//!
//! (1-D: the `a` factor alone) with constants drawn from the map's name (`s_a = s_b = 1`: the zero test probes
//! states at O(1) values), so that its derivative maps are consistent derivatives of it and no combination
//! of them vanishes identically by accident of the data.

use std::sync::Arc;

pub use invsim_kernel::map::{Extrapolate, Interp, Map, MapError, MapSettings};

/// Handle of a declared map in a [`crate::Pool`].
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, PartialOrd, Ord)]
pub struct MapId(pub(crate) u32);

impl MapId {
    /// Position of the map in declaration order.
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

/// Derivative orders of a map call: `[I, J]` (1-D maps: `[K, 0]`).
pub type MapOrders = [u8; 2];

/// Highest derivative order per argument that a printed name can carry (`M_d9`, `M_d99`).
pub const MAX_PRINTED_ORDER: u8 = 9;

/// A declared map: name, data and the zero test's surrogate.
#[derive(Debug, Clone)]
pub struct MapDecl {
    pub name: String,
    pub data: Arc<Map>,
    /// Surrogate constants `[c1, φ1, c2, φ2]` per argument, already divided by the argument's scale.
    surrogate: [[f64; 4]; 2],
}

impl MapDecl {
    /// A declaration of `name` with its data.
    pub fn new(name: &str, data: Arc<Map>) -> MapDecl {
        let mut seed = name.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
            (h ^ b as u64).wrapping_mul(0x100_0000_01b3)
        });
        let mut uniform = |lo: f64, hi: f64| {
            seed = seed.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = seed;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            lo + (hi - lo) * ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
        };
        let spans = [1.0, 1.0];
        let mut surrogate = [[0.0; 4]; 2];
        for (axis, s) in surrogate.iter_mut().enumerate() {
            *s = [
                uniform(0.7, 1.9) / spans[axis],
                uniform(0.2, 1.3),
                uniform(2.1, 3.7) / spans[axis],
                uniform(0.4, 2.9),
            ];
        }
        MapDecl {
            name: name.to_string(),
            data,
            surrogate,
        }
    }

    /// 1 or 2.
    pub fn arity(&self) -> usize {
        self.data.arity()
    }

    /// The surrogate's partial derivative of `orders` at `args` (see the module documentation), with a bound
    /// on its derivative with respect to each argument (for the zero test's error analysis).
    pub fn surrogate(&self, orders: MapOrders, args: &[f64]) -> (f64, [f64; 2]) {
        let half_pi = std::f64::consts::FRAC_PI_2;
        let factor = |axis: usize, k: usize, order: u8, a: f64| -> (f64, f64) {
            let (c, phi) = (self.surrogate[axis][2 * k], self.surrogate[axis][2 * k + 1]);
            let arg = c * a + phi + order as f64 * half_pi;
            (
                c.powi(order as i32) * arg.sin(),
                c.powi(order as i32 + 1) * arg.cos(),
            )
        };
        let mut value = 0.0;
        let mut slope = [0.0; 2];
        for k in 0..2 {
            let (fa, da) = factor(0, k, orders[0], args[0]);
            let (fb, db) = if self.arity() == 2 {
                factor(1, k, orders[1], args[1])
            } else {
                (1.0, 0.0)
            };
            value += fa * fb;
            slope[0] += (da * fb).abs();
            slope[1] += (fa * db).abs();
        }
        (value, slope)
    }
}

/// The printed name of a map call: `M`, `M_dK` (1-D), `M_dIJ` (2-D, I, J ≤ 9: contract §6), and beyond the
/// contract's orders `M_dI_J` (2-D with an order above 9; 1-D takes any K, `M_d12`). Every name parses back
/// ([`resolve_call_name`]) and no two orders share one.
pub fn call_name(name: &str, arity: usize, orders: MapOrders) -> String {
    match (arity, orders) {
        (_, [0, 0]) => name.to_string(),
        (1, [k, _]) => format!("{name}_d{k}"),
        (_, [i, j]) if i <= 9 && j <= 9 => format!("{name}_d{i}{j}"),
        (_, [i, j]) => format!("{name}_d{i}_{j}"),
    }
}

/// A derivative order written in decimal without leading zeros (so each order has one spelling).
fn order(digits: &str) -> Option<u8> {
    let canonical = !digits.is_empty()
        && digits.bytes().all(|b| b.is_ascii_digit())
        && (digits == "0" || !digits.starts_with('0'));
    canonical.then(|| digits.parse().ok()).flatten()
}

/// Splits a called name into a map name and derivative orders when it is one of `M`, `M_dK`, `M_dIJ`,
/// `M_dI_J` (see [`call_name`]) for a map `M` that `arity_of` knows (the name itself is tried first, so a map
/// may be named `x_d1`… only if no map `x` exists, which the reader enforces).
pub fn resolve_call_name(
    called: &str,
    arity_of: impl Fn(&str) -> Option<usize>,
) -> Option<(String, usize, MapOrders)> {
    if let Some(n) = arity_of(called) {
        return Some((called.to_string(), n, [0, 0]));
    }
    // The orders are digits (and one `_`), so they follow the last `_d`.
    let at = called.rfind("_d")?;
    let (base, digits) = (&called[..at], &called[at + 2..]);
    let arity = arity_of(base)?;
    Some((base.to_string(), arity, orders_of(arity, digits)?))
}

/// The orders that `digits` (what follows `M_d`) spell for a map of `arity`, in [`call_name`]'s spelling.
fn orders_of(arity: usize, digits: &str) -> Option<MapOrders> {
    match arity {
        1 => order(digits).filter(|&k| k > 0).map(|k| [k, 0]),
        2 => match digits.split_once('_') {
            Some((i, j)) => {
                let (i, j) = (order(i)?, order(j)?);
                (i > 9 || j > 9).then_some([i, j])
            }
            None => {
                let d = digits.as_bytes();
                let ok = d.len() == 2 && d.iter().all(u8::is_ascii_digit);
                let o = [d.first()?.wrapping_sub(b'0'), d.get(1)?.wrapping_sub(b'0')];
                (ok && o[0] + o[1] > 0).then_some(o)
            }
        },
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip() {
        let arity = |n: &str| match n {
            "eta" => Some(2),
            "c" => Some(1),
            _ => None,
        };
        assert_eq!(
            resolve_call_name("eta", arity),
            Some(("eta".into(), 2, [0, 0]))
        );
        assert_eq!(
            resolve_call_name("eta_d10", arity),
            Some(("eta".into(), 2, [1, 0]))
        );
        assert_eq!(
            resolve_call_name("c_d3", arity),
            Some(("c".into(), 1, [3, 0]))
        );
        assert_eq!(resolve_call_name("c_d0", arity), None);
        assert_eq!(resolve_call_name("eta_d00", arity), None);
        assert_eq!(resolve_call_name("eta_d1", arity), None);
        assert_eq!(resolve_call_name("c_d012", arity), None);
        assert_eq!(resolve_call_name("eta_d1_0", arity), None);
        assert_eq!(resolve_call_name("eta_d010_1", arity), None);
        assert_eq!(resolve_call_name("other_d1", arity), None);
        assert_eq!(call_name("eta", 2, [0, 2]), "eta_d02");
        assert_eq!(call_name("c", 1, [4, 0]), "c_d4");
        // Beyond the contract's orders 0…9: 1-D any K, 2-D `M_dI_J`; every name parses back.
        for (name, n, o) in [
            ("c", 1, [12, 0]),
            ("eta", 2, [10, 0]),
            ("eta", 2, [3, 11]),
            ("eta", 2, [9, 9]),
        ] {
            let printed = call_name(name, n, o);
            assert_eq!(
                resolve_call_name(&printed, arity),
                Some((name.to_string(), n, o)),
                "{printed}"
            );
        }
        assert_eq!(call_name("eta", 2, [10, 0]), "eta_d10_0");
        assert_eq!(call_name("c", 1, [12, 0]), "c_d12");
    }
}
