//! The binomial coefficient C(n, k) = Π_(i<k) (n − i)/(i + 1) as a float, each step (C(n, i)·(n − i))/(i + 1)
//! = C(n, i + 1) an integer, so exact while every C(n, i)·(n − i) is below 2^53 (n ≤ 50 at least): the
//! smoothstep of the re-entry transitions, the forward driver's filter and the variation of constants' moment
//! tables share it.

/// C(n, k) (0 for k > n).
pub(crate) fn binomial(n: usize, k: usize) -> f64 {
    if k > n {
        return 0.0;
    }
    (0..k).fold(1.0, |c, i| c * (n - i) as f64 / (i + 1) as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Pascal's rule holds exactly up to n = 50 (every step's product an integer below 2^53),
    /// C(n, 0) = C(n, n) = 1, and C(11, 5) = 462 exactly (a product of the quotients (n − i)/(i + 1) alone
    /// gives 461.99999999999994).
    #[test]
    fn binomials_are_exact_integers() {
        for n in 1..=50 {
            assert_eq!((binomial(n, 0), binomial(n, n)), (1.0, 1.0));
            for k in 1..n {
                assert_eq!(
                    binomial(n, k),
                    binomial(n - 1, k - 1) + binomial(n - 1, k),
                    "C({n}, {k})"
                );
            }
        }
        assert_eq!(binomial(11, 5), 462.0);
        assert_eq!(binomial(3, 5), 0.0);
    }
}
