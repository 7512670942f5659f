#include "formfactor/matrix/reciprocity.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "formfactor/matrix/memory.h"

namespace formfactor {

namespace {

// Continued fraction of the incomplete beta function (modified Lentz; Press et al., Numerical
// Recipes, betacf).
double beta_cf(double a, double b, double x) {
    constexpr double kTiny = 1e-300;
    const double qab = a + b, qap = a + 1.0, qam = a - 1.0;
    double c = 1.0, d = 1.0 - qab * x / qap;
    if (std::abs(d) < kTiny) d = kTiny;
    d = 1.0 / d;
    double h = d;
    for (int m = 1; m <= 1000; ++m) {
        const double m2 = 2.0 * m;
        double aa = m * (b - m) * x / ((qam + m2) * (a + m2));
        d = 1.0 + aa * d;
        if (std::abs(d) < kTiny) d = kTiny;
        c = 1.0 + aa / c;
        if (std::abs(c) < kTiny) c = kTiny;
        d = 1.0 / d;
        h *= d * c;
        aa = -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2));
        d = 1.0 + aa * d;
        if (std::abs(d) < kTiny) d = kTiny;
        c = 1.0 + aa / c;
        if (std::abs(c) < kTiny) c = kTiny;
        d = 1.0 / d;
        const double del = d * c;
        h *= del;
        if (std::abs(del - 1.0) < 1e-15) break;
    }
    return h;
}

// Regularised incomplete beta I_x(a, b).
double incomplete_beta(double a, double b, double x) {
    if (x <= 0.0) return 0.0;
    if (x >= 1.0) return 1.0;
    const double front = std::exp(std::lgamma(a + b) - std::lgamma(a) - std::lgamma(b) +
                                  a * std::log(x) + b * std::log1p(-x));
    if (x < (a + 1.0) / (a + b + 2.0)) return front * beta_cf(a, b, x) / a;
    return 1.0 - front * beta_cf(b, a, 1.0 - x) / b;
}

}  // namespace

double two_sided_tail(double t, double dof) {
    t = std::abs(t);
    if (!(dof > 0.0)) return std::erfc(t / std::sqrt(2.0));
    return incomplete_beta(0.5 * dof, 0.5, dof / (dof + t * t));
}

double two_sided_quantile(double p, double dof) {
    double lo = 0.0, hi = 1.0;
    while (two_sided_tail(hi, dof) > p && hi < 1e12) hi *= 2.0;
    for (int it = 0; it < 200 && hi - lo > 1e-12 * hi; ++it) {
        const double mid = 0.5 * (lo + hi);
        (two_sided_tail(mid, dof) > p ? lo : hi) = mid;
    }
    return 0.5 * (lo + hi);
}

ReciprocityVerdict assess_reciprocity(const Diagnostics& d, const ReciprocityPromise& promise) {
    ReciprocityVerdict v;
    const std::string who = promise.method.empty() ? "the method" : promise.method;
    using Kind = ReciprocityPromise::Kind;
    switch (promise.kind) {
        case Kind::exact: {
            const bool ok = d.reciprocity_row_max <= promise.tolerance;
            v.within = ok;
            v.text =
                ok ? fmt::format("within what {} promises (row-relative defect {:.2g} ≤ {:.2g})",
                                 who, d.reciprocity_row_max, promise.tolerance)
                   : fmt::format(
                         "NOT within what {} promises: row-relative defect {:.2g} > {:.2g} "
                         "(row {})",
                         who, d.reciprocity_row_max, promise.tolerance, d.reciprocity_row);
            return v;
        }
        case Kind::statistical: {
            if (!d.has_z) {
                v.text = "no standard errors to judge the Monte-Carlo defects by";
                return v;
            }
            const double K = static_cast<double>(std::max<std::size_t>(d.z_pairs, 1));
            const double nu = promise.degrees_of_freedom;
            v.z_max_limit = two_sided_quantile(1e-3 / K, nu);
            // E z² = 1 (normal) or ν/(ν − 2) (Student); the mean of K squares has the standard
            // deviation sqrt(Var z² / K), Var z² = 2 (normal) or 2ν²(ν − 1)/((ν − 2)²(ν − 4)).
            double mean = 1.0, var = 2.0;
            if (nu > 0.0) {
                mean = nu > 2.0 ? nu / (nu - 2.0) : 3.0;
                var = nu > 4.0 ? 2.0 * nu * nu * (nu - 1.0) / ((nu - 2.0) * (nu - 2.0) * (nu - 4.0))
                               : 10.0;
            }
            // A margin of 20 % on E z²: the standard errors are estimates themselves (few
            // samples hit a small pair).
            v.z_rms_limit = std::sqrt(1.2 * mean + 4.0 * std::sqrt(var / K));
            const bool ok =
                d.z_max <= v.z_max_limit && d.z_rms <= v.z_rms_limit && d.z_undefined == 0;
            v.within = ok;
            std::string what =
                fmt::format("max |z| {:.3g} {} {:.3g}, RMS z {:.3g} {} {:.3g} over {} pairs",
                            d.z_max, d.z_max <= v.z_max_limit ? "≤" : ">", v.z_max_limit, d.z_rms,
                            d.z_rms <= v.z_rms_limit ? "≤" : ">", v.z_rms_limit,
                            format_count(static_cast<double>(d.z_pairs)));
            if (d.z_undefined > 0)
                what += fmt::format(", {} pairs differ with zero standard errors",
                                    format_count(static_cast<double>(d.z_undefined)));
            v.text = ok ? "consistent with chance (" + what + ")"
                        : "NOT consistent with chance (" + what +
                              fmt::format("; worst z at patches {}, {})", d.z_i, d.z_j);
            return v;
        }
        case Kind::approximate:
            v.text = who +
                     " makes no reciprocity promise (aliasing and point sampling break it); the "
                     "reciprocity repair enforces it";
            return v;
        case Kind::unknown:
        default:
            v.text = "no promise to compare with (the method that made F is not known)";
            return v;
    }
}

}  // namespace formfactor
