#pragma once
// Student's t distribution for the statistical tests: a Monte-Carlo estimate whose standard
// error comes from R independent replicates satisfies (estimate − truth) / SE ~ t with R − 1
// degrees of freedom, so "within k standard errors" takes k from t, not from the normal law.

#include <algorithm>
#include <cmath>

namespace formfactor::testing {

/// Regularised incomplete beta function I_x(a, b) (continued fraction, modified Lentz;
/// Numerical Recipes §6.4), accurate to ~1e-14 for the arguments used here.
inline double incomplete_beta(double a, double b, double x) {
    if (x <= 0) return 0;
    if (x >= 1) return 1;
    const double ln_front =
        std::lgamma(a + b) - std::lgamma(a) - std::lgamma(b) + a * std::log(x) + b * std::log1p(-x);
    // The continued fraction converges fast for x < (a + 1)/(a + b + 2); use the symmetry else.
    if (x > (a + 1) / (a + b + 2)) return 1 - incomplete_beta(b, a, 1 - x);
    constexpr double tiny = 1e-300;
    double c = 1, d = 1 - (a + b) * x / (a + 1);
    if (std::abs(d) < tiny) d = tiny;
    d = 1 / d;
    double f = d;
    for (int m = 1; m < 500; ++m) {
        for (int half = 0; half < 2; ++half) {
            const double num = half == 0
                                   ? m * (b - m) * x / ((a + 2 * m - 1) * (a + 2 * m))
                                   : -(a + m) * (a + b + m) * x / ((a + 2 * m) * (a + 2 * m + 1));
            d = 1 + num * d;
            if (std::abs(d) < tiny) d = tiny;
            c = 1 + num / c;
            if (std::abs(c) < tiny) c = tiny;
            d = 1 / d;
            f *= c * d;
            if (half == 1 && std::abs(c * d - 1) < 1e-15) return std::exp(ln_front) * f / a;
        }
    }
    return std::exp(ln_front) * f / a;
}

/// P(|T| > t) for Student's t with `dof` degrees of freedom (dof ≥ 1, t ≥ 0).
inline double student_t_two_sided_tail(double t, double dof) {
    return incomplete_beta(dof / 2, 0.5, dof / (dof + t * t));
}

/// The k with P(|T| > k) = p (0 < p < 1) for Student's t with `dof` degrees of freedom: the
/// number of standard errors that a replicate estimate exceeds with probability p.
inline double student_t_two_sided_quantile(double p, double dof) {
    double lo = 0, hi = 1;
    while (student_t_two_sided_tail(hi, dof) > p) hi *= 2;
    for (int it = 0; it < 200 && hi - lo > 1e-12 * hi; ++it) {
        const double mid = 0.5 * (lo + hi);
        (student_t_two_sided_tail(mid, dof) > p ? lo : hi) = mid;
    }
    return 0.5 * (lo + hi);
}

/// k for `comparisons` simultaneous checks of replicate estimates with `dof` degrees of
/// freedom, so that all pass with probability ≥ 1 − family_p when every estimate is right
/// (Bonferroni).
inline double simultaneous_k(double comparisons, double dof, double family_p = 1e-3) {
    return student_t_two_sided_quantile(family_p / std::max(1.0, comparisons), dof);
}

}  // namespace formfactor::testing
