//! The posteriors of a mixture with a uniform outlier class, shared by the one-sided E-steps
//! of the articulated tracker ([`super::em`], Dewaele et al. 2006) and of the surface tracker
//! (`crate::surface::estep`, Cagniart et al. 2010): a Gaussian kernel per component
//! ([`GaussianKernel`]) and the normalisation of a datum's likelihoods against the outlier
//! class's term ([`Evidence`]). A datum's inlier posterior is the sum of its components'.

/// The outlier term of eq. (17)-(18) (Dewaele): `c = 3 sqrt(pi / 2)` when the model's small
/// volumes are negligible next to the working volume.
pub const DEWAELE_OUTLIER_CONSTANT: f64 = 3.759_942_411_946_42;

/// `exp(-x)` for `x >= 0` to a relative 2e-8 (a degree-7 polynomial on the fraction of
/// `x log2 e`): the articulated tracker's kernel (see [`GaussianKernel::fast`]).
#[inline]
pub fn exp_negative(x: f64) -> f64 {
    let t = -x * std::f64::consts::LOG2_E;
    if t < -1000.0 {
        return 0.0;
    }
    // Round to nearest by the 1.5 * 2^52 shift (exact for |t| < 2^51), not the library
    // call `round` is on targets without SSE4.1.
    const SHIFT: f64 = 6_755_399_441_055_744.0;
    let k = (t + SHIFT) - SHIFT;
    let f = (t - k) * std::f64::consts::LN_2;
    // e^f for |f| <= ln 2 / 2: Taylor to degree 7.
    let p = 1.0
        + f * (1.0
            + f * (0.5
                + f * (1.0 / 6.0
                    + f * (1.0 / 24.0 + f * (1.0 / 120.0 + f * (1.0 / 720.0 + f / 5040.0))))));
    p * f64::from_bits(((k as i64 + 1023) as u64) << 52)
}

/// The Gaussian kernel of width `sigma`, `exp(-d^2 / (2 sigma^2))` (Dewaele eq. 17,
/// Cagniart eq. 7), of a squared distance `d2`. Two evaluations, each one model's: their
/// results are reproducible bit for bit only with their own.
#[derive(Clone, Copy, Debug)]
pub struct GaussianKernel {
    /// `2 sigma^2`.
    two_sigma2: f64,
    /// `1 / (2 sigma^2)`.
    inv_two_sigma2: f64,
}

impl GaussianKernel {
    pub fn new(sigma: f64) -> Self {
        Self {
            two_sigma2: 2.0 * sigma * sigma,
            inv_two_sigma2: 0.5 / (sigma * sigma),
        }
    }

    /// With [`exp_negative`] (to a relative 2e-8): the articulated tracker's kernel (eq. 17).
    #[inline]
    pub fn fast(&self, d2: f64) -> f64 {
        exp_negative(d2 * self.inv_two_sigma2)
    }

    /// With the standard library's `exp`: the surface tracker's kernel (eq. 7).
    #[inline]
    pub fn exact(&self, d2: f64) -> f64 {
        (-d2 / self.two_sigma2).exp()
    }
}

/// A datum's evidence: its components' likelihoods `p_k` summed with the uniform outlier
/// class's term `c`, the denominator of its posteriors `p_k / (c + sum_k p_k)` (Dewaele
/// eq. 17, Cagniart eq. 8). Summed in one of two orders, each one model's: the components
/// first and `c` last ([`Evidence::new`], [`Evidence::normaliser`]), or from `c` on
/// ([`Evidence::starting_at`], [`Evidence::posterior`]).
#[derive(Clone, Copy, Debug)]
pub struct Evidence {
    total: f64,
}

impl Evidence {
    /// No likelihood yet; the outlier term comes last, in [`Evidence::normaliser`].
    #[inline]
    pub fn new() -> Self {
        Self { total: 0.0 }
    }

    /// The outlier class's term `c` first; [`Evidence::posterior`] divides by the total.
    #[inline]
    pub fn starting_at(outlier: f64) -> Self {
        Self { total: outlier }
    }

    /// Adds a component's likelihood.
    #[inline]
    pub fn add(&mut self, likelihood: f64) {
        self.total += likelihood;
    }

    /// The sum so far.
    #[inline]
    pub fn total(&self) -> f64 {
        self.total
    }

    /// For evidence begun with [`Evidence::new`]: `1 / (sum_k p_k + c)`, which times a
    /// likelihood is its posterior, and times [`Evidence::total`] the datum's inlier
    /// posterior (eq. 17).
    #[inline]
    pub fn normaliser(&self, outlier: f64) -> f64 {
        1.0 / (self.total + outlier)
    }

    /// For evidence begun with [`Evidence::starting_at`]: a component's posterior,
    /// `likelihood / (c + sum_k p_k)` (eq. 8).
    #[inline]
    pub fn posterior(&self, likelihood: f64) -> f64 {
        likelihood / self.total
    }
}

impl Default for Evidence {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fast_exponential_is_accurate() {
        for i in 0..10_000 {
            let x = i as f64 * 0.01;
            let (a, b) = (exp_negative(x), (-x).exp());
            assert!((a - b).abs() <= 2e-8 * b, "{x}: {a} vs {b}");
        }
        assert_eq!(exp_negative(1e6), 0.0);
    }

    #[test]
    fn both_orders_give_the_posteriors() {
        let (c, p) = (0.5, [0.25, 1.0, 0.125]);
        let mut last = Evidence::new();
        let mut first = Evidence::starting_at(c);
        for &x in &p {
            last.add(x);
            first.add(x);
        }
        let norm = last.normaliser(c);
        for &x in &p {
            approx::assert_relative_eq!(x * norm, first.posterior(x), max_relative = 1e-15);
            approx::assert_relative_eq!(x * norm, x / 1.875, max_relative = 1e-15);
        }
        approx::assert_relative_eq!(last.total() * norm, 1.375 / 1.875, max_relative = 1e-15);
    }

    #[test]
    fn kernels_agree() {
        let kernel = GaussianKernel::new(0.3);
        for i in 0..100 {
            let d2 = i as f64 * 0.01;
            let exact = (-d2 / (2.0 * 0.09)).exp();
            approx::assert_relative_eq!(kernel.exact(d2), exact, max_relative = 1e-15);
            approx::assert_relative_eq!(kernel.fast(d2), exact, max_relative = 3e-8);
        }
    }
}
