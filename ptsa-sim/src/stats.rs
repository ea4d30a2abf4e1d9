//! Small dense weighted least squares and the tail probabilities the tests use.

use nalgebra::{DMatrix, DVector};
use statrs::distribution::{ChiSquared, ContinuousCDF, FisherSnedecor, Normal, StudentsT};

/// A least-squares fit of `z ≈ Σ_j β_j u_j` (columns already divided by the row sigmas).
#[derive(Clone, Debug)]
pub struct LsqFit {
    /// Coefficients, one per column, in the columns' units.
    pub beta: Vec<f64>,
    /// Covariance of `beta` for unit-variance `z` (i.e. trusting the stated sigmas).
    pub cov: DMatrix<f64>,
    /// Residual sum of squares (χ² against the stated sigmas).
    pub chi2: f64,
    /// Residuals `z − Σ β u`.
    pub resid: Vec<f64>,
    /// Leverage `h_ii` of every row (diagonal of the hat matrix).
    pub leverage: Vec<f64>,
    /// Heteroscedasticity-robust (HC3) standard error of every coefficient: the sandwich
    /// `(XᵀX)⁻¹ Xᵀ diag(e_i²/(1 − h_ii)²) X (XᵀX)⁻¹`, valid whatever the rows' variances.
    pub se_hc3: Vec<f64>,
}

/// Relative singular-value tolerance below which a design is treated as rank deficient.
pub const RANK_TOL: f64 = 1e-9;

/// Least squares of `z` on `cols` (each a column of length `z.len()`), by SVD.
/// With no columns, the fit is zero and `chi2 = Σ z²`. Returns `None` if the columns are
/// linearly dependent (smallest singular value below [`RANK_TOL`] × largest).
#[must_use]
pub fn lsq(z: &[f64], cols: &[&[f64]]) -> Option<LsqFit> {
    let n = z.len();
    let p = cols.len();
    if p == 0 {
        return Some(LsqFit {
            beta: vec![],
            cov: DMatrix::zeros(0, 0),
            chi2: z.iter().map(|v| v * v).sum(),
            resid: z.to_vec(),
            leverage: vec![0.0; n],
            se_hc3: vec![],
        });
    }
    if n < p {
        return None;
    }
    let a = DMatrix::from_fn(n, p, |i, j| cols[j][i]);
    let svd = a.clone().svd(true, true);
    let smax = svd.singular_values.max();
    let smin = svd.singular_values.min();
    if smax <= 0.0 || smin <= RANK_TOL * smax {
        return None;
    }
    let u = svd.u.as_ref()?;
    let vt = svd.v_t.as_ref()?;
    let zb = DVector::from_column_slice(z);
    let uz = u.transpose() * &zb;
    let mut w = uz.clone();
    for k in 0..p {
        w[k] /= svd.singular_values[k];
    }
    let beta = vt.transpose() * w;
    let mut cov = DMatrix::zeros(p, p);
    for k in 0..p {
        let s2 = svd.singular_values[k] * svd.singular_values[k];
        let v = vt.row(k).transpose();
        cov += (&v * v.transpose()) / s2;
    }
    let fitted = &a * &beta;
    let resid: Vec<f64> = (0..n).map(|i| z[i] - fitted[i]).collect();
    let chi2 = resid.iter().map(|v| v * v).sum();
    // Leverage from the left singular vectors; the sandwich through A = V S⁻¹ Uᵀ.
    let leverage: Vec<f64> = (0..n)
        .map(|i| (0..p).map(|k| u[(i, k)] * u[(i, k)]).sum::<f64>().min(1.0))
        .collect();
    let mut se_hc3 = vec![0.0; p];
    for (j, se) in se_hc3.iter_mut().enumerate() {
        let mut var = 0.0;
        for i in 0..n {
            let aji: f64 = (0..p)
                .map(|k| vt[(k, j)] / svd.singular_values[k] * u[(i, k)])
                .sum();
            let lev = (1.0 - leverage[i]).max(1e-9);
            var += aji * aji * resid[i] * resid[i] / (lev * lev);
        }
        *se = var.sqrt();
    }
    Some(LsqFit {
        beta: beta.iter().copied().collect(),
        cov,
        chi2,
        resid,
        leverage,
        se_hc3,
    })
}

/// Heteroscedasticity-robust (HC3-type) standard errors of a fit of `cols` with the
/// residuals `resid` of another, larger model (so that an effect outside `cols` does not
/// inflate them): the sandwich `(XᵀX)⁻¹ Xᵀ diag(e_i²/(1 − h_ii)²) X (XᵀX)⁻¹` with the
/// leverage `h` of `cols`. `None` if the columns are dependent.
#[must_use]
pub fn sandwich_se(cols: &[&[f64]], resid: &[f64]) -> Option<Vec<f64>> {
    let n = resid.len();
    let p = cols.len();
    if p == 0 || n < p {
        return None;
    }
    let a = DMatrix::from_fn(n, p, |i, j| cols[j][i]);
    let svd = a.svd(true, true);
    let smax = svd.singular_values.max();
    if smax <= 0.0 || svd.singular_values.min() <= RANK_TOL * smax {
        return None;
    }
    let u = svd.u.as_ref()?;
    let vt = svd.v_t.as_ref()?;
    let mut se = vec![0.0; p];
    for (j, out) in se.iter_mut().enumerate() {
        let mut var = 0.0;
        for i in 0..n {
            let h: f64 = (0..p).map(|k| u[(i, k)] * u[(i, k)]).sum::<f64>().min(1.0);
            let aji: f64 = (0..p)
                .map(|k| vt[(k, j)] / svd.singular_values[k] * u[(i, k)])
                .sum();
            let l = (1.0 - h).max(1e-9);
            var += aji * aji * resid[i] * resid[i] / (l * l);
        }
        *out = var.sqrt();
    }
    Some(se)
}

/// The part of `v` orthogonal to the span of `basis` (all of `v` if `basis` is empty or
/// dependent columns make the projection ill-posed).
#[must_use]
pub fn residualize(v: &[f64], basis: &[&[f64]]) -> Vec<f64> {
    lsq(v, basis).map_or_else(|| v.to_vec(), |f| f.resid)
}

/// The factor on a weighted fit's classical standard errors: the Birge ratio
/// `sqrt(χ²/dof)` when the residuals are inconsistent with the sigmas (`P(χ²_dof ≥ chi2)`
/// below 0.05: the sigmas are too small, so the errors are scaled up to the scatter), else
/// 1 (the sigmas are believed; scaling by a ratio that only fluctuates about 1 would make
/// the intervals too wide, about 96 % instead of 95 %).
#[must_use]
pub fn birge_ratio(chi2: f64, dof: usize) -> f64 {
    #[allow(clippy::cast_precision_loss)]
    let nu = dof as f64;
    if dof == 0 || chi2_sf(chi2, nu) >= 0.05 {
        1.0
    } else {
        (chi2 / nu).sqrt().max(1.0)
    }
}

/// Euclidean norm.
#[must_use]
pub fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// `|cos|` of the angle between two vectors (0 if either is zero).
#[must_use]
pub fn abs_cos(a: &[f64], b: &[f64]) -> f64 {
    let na = norm(a);
    let nb = norm(b);
    if na == 0.0 || nb == 0.0 {
        return 0.0;
    }
    (a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>() / (na * nb)).abs()
}

/// Upper tail `P(χ²_k > x)`.
#[must_use]
pub fn chi2_sf(x: f64, k: f64) -> f64 {
    if k <= 0.0 {
        return if x > 0.0 { 0.0 } else { 1.0 };
    }
    ChiSquared::new(k).map_or(f64::NAN, |d| d.sf(x.max(0.0)))
}

/// Upper tail `P(F(d1, d2) > x)`.
#[must_use]
pub fn f_sf(x: f64, d1: f64, d2: f64) -> f64 {
    if d2 <= 0.0 {
        return 1.0;
    }
    FisherSnedecor::new(d1, d2).map_or(f64::NAN, |d| d.sf(x.max(0.0)))
}

/// Two-sided `P(|t_k| > |t|)`.
#[must_use]
pub fn t_two_sided(t: f64, k: f64) -> f64 {
    if k <= 0.0 || !t.is_finite() {
        return if t.is_finite() { 1.0 } else { 0.0 };
    }
    StudentsT::new(0.0, 1.0, k).map_or(f64::NAN, |d| 2.0 * d.sf(t.abs()))
}

/// The `z` with two-sided `P(|Z| > z) = p` for a standard normal `Z` (`p` in `(0, 1)`).
#[must_use]
pub fn normal_two_sided_quantile(p: f64) -> f64 {
    Normal::new(0.0, 1.0).map_or(f64::NAN, |d| d.inverse_cdf(1.0 - 0.5 * p))
}

/// The `t` with two-sided `P(|t_k| > t) = p` (`p` in `(0, 1)`, `k > 0`): statrs' inverse
/// of Student's t distribution.
#[must_use]
pub fn t_two_sided_quantile(p: f64, k: f64) -> f64 {
    StudentsT::new(0.0, 1.0, k).map_or(f64::NAN, |d| d.inverse_cdf(1.0 - 0.5 * p))
}

/// The Clopper–Pearson interval of a binomial rate, `k` of `n`, at the confidence `level`
/// (0.95 for 95 %): the exact interval from the Beta distribution's quantiles (`[0, …]`
/// when `k` is 0, `[…, 1]` when it is `n`; NaN for `n` = 0).
#[must_use]
pub fn clopper_pearson(k: u64, n: u64, level: f64) -> (f64, f64) {
    use statrs::distribution::{Beta, ContinuousCDF as _};
    if n == 0 || k > n {
        return (f64::NAN, f64::NAN);
    }
    let a = (1.0 - level) / 2.0;
    let (all, none) = (k == n, k == 0);
    #[allow(clippy::cast_precision_loss)]
    let (k, n) = (k as f64, n as f64);
    let lo = if none {
        0.0
    } else {
        Beta::new(k, n - k + 1.0).map_or(f64::NAN, |b| b.inverse_cdf(a))
    };
    let hi = if all {
        1.0
    } else {
        Beta::new(k + 1.0, n - k).map_or(f64::NAN, |b| b.inverse_cdf(1.0 - a))
    };
    (lo, hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lsq_recovers_an_exact_line_and_its_covariance() {
        let x1 = [1.0, 2.0, 3.0, 4.0];
        let x2 = [1.0, 0.0, 1.0, 0.0];
        let z: Vec<f64> = (0..4).map(|i| 2.0 * x1[i] - 3.0 * x2[i]).collect();
        let f = lsq(&z, &[&x1, &x2]).unwrap();
        assert!((f.beta[0] - 2.0).abs() < 1e-12 && (f.beta[1] + 3.0).abs() < 1e-12);
        assert!(f.chi2 < 1e-20);
        // single column: var = 1/Σx².
        let g = lsq(&z, &[&x1]).unwrap();
        assert!((g.cov[(0, 0)] - 1.0 / 30.0).abs() < 1e-12);
        assert!(lsq(&z, &[&x1, &x1]).is_none());
    }

    #[test]
    fn hc3_equals_the_classical_error_for_equal_residuals_and_leverage() {
        // Two groups of rows, the regressor ±1, residuals of equal size: the sandwich with
        // e²/(1 − h)² is the classical error scaled by that constant.
        let x = [1.0, -1.0, 1.0, -1.0, 1.0, -1.0];
        let z = [1.1, -0.9, 0.9, -1.1, 1.1, -0.9];
        let f = lsq(&z, &[&x]).unwrap();
        let h = 1.0 / 6.0;
        assert!(f.leverage.iter().all(|&l| (l - h).abs() < 1e-12));
        let e2 = f.resid.iter().map(|e| e * e).sum::<f64>();
        let want = (e2 / 36.0).sqrt() / (1.0 - h);
        assert!((f.se_hc3[0] - want).abs() < 1e-12, "{} {want}", f.se_hc3[0]);
    }

    #[test]
    fn tails() {
        assert!((t_two_sided(2.570_581_835_636_314, 5.0) - 0.05).abs() < 1e-6);
        assert!((chi2_sf(3.841_458_820_694_124, 1.0) - 0.05).abs() < 1e-9);
        assert!((f_sf(5.987_377_607_273_44, 1.0, 6.0) - 0.05).abs() < 1e-6);
    }

    /// Printed two-sided 5 % points of Student's t (5, 10, 23 and 1000 degrees of freedom).
    #[test]
    fn t_quantiles_match_the_tables() {
        for (k, t) in [
            (5.0, 2.5706),
            (10.0, 2.2281),
            (23.0, 2.0687),
            (1000.0, 1.9623),
        ] {
            let q = t_two_sided_quantile(0.05, k);
            assert!((q - t).abs() < 1e-4, "{k}: {q} against {t}");
        }
    }

    #[test]
    fn clopper_pearson_is_where_the_binomial_tails_reach_two_and_a_half_percent() {
        use statrs::distribution::{Binomial, DiscreteCDF as _};
        // 58 of 60 and 59 of 60: the identification campaign's rates, [88.5, 99.6] % and
        // [91.1, 100.0] % by bisection on the tails (ptsa-campaigns/src/sigma.rs).
        let (lo, hi) = clopper_pearson(58, 60, 0.95);
        assert!(
            (lo - 0.885).abs() < 5e-4 && (hi - 0.996).abs() < 5e-4,
            "{lo} {hi}"
        );
        let (lo, hi) = clopper_pearson(59, 60, 0.95);
        assert!(
            (lo - 0.911).abs() < 5e-4 && (hi - 1.0).abs() < 5e-4,
            "{lo} {hi}"
        );
        for (k, n) in [(1, 10), (7, 20), (50, 100), (999, 1000)] {
            let (lo, hi) = clopper_pearson(k, n, 0.95);
            // P(X >= k | lo) = 2.5 % and P(X <= k | hi) = 2.5 %.
            let at_lo = Binomial::new(lo, n).unwrap().sf(k - 1);
            let at_hi = Binomial::new(hi, n).unwrap().cdf(k);
            assert!((at_lo - 0.025).abs() < 1e-6, "{k}/{n}: {at_lo}");
            assert!((at_hi - 0.025).abs() < 1e-6, "{k}/{n}: {at_hi}");
        }
        assert!(clopper_pearson(0, 10, 0.95).0.to_bits() == 0.0_f64.to_bits());
        assert!(clopper_pearson(10, 10, 0.95).1.to_bits() == 1.0_f64.to_bits());
    }
}
