#include "formfactor/matrix/form_factors.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "formfactor/core/cancel.h"

namespace formfactor {

Diagnostics diagnose(const DenseMatrix& F, const std::vector<double>& areas,
                     const DenseMatrix* standard_error) {
    Diagnostics d;
    const std::size_t n = static_cast<std::size_t>(F.rows());
    d.n = n;
    if (n == 0) return d;
    const bool with_areas = areas.size() == n;
    const DenseMatrix* se =
        standard_error && standard_error->rows() == F.rows() && standard_error->cols() == F.cols()
            ? standard_error
            : nullptr;
    d.has_z = se != nullptr && with_areas;
    d.row_sum_min = std::numeric_limits<double>::infinity();
    d.row_sum_max = -std::numeric_limits<double>::infinity();
    double total = 0.0;
    // Per row: Σ_j |A_i F_ij − A_j F_ji|, A_i Σ_j F_ij, Σ_j A_j F_ji (finite entries only).
    std::vector<double> row_defect(n, 0.0), row_mass(n, 0.0), col_mass(n, 0.0);
    // Effective sample count per row (see Diagnostics::z_zero_entries).
    std::vector<double> samples(d.has_z ? n : 0, 0.0);
    // O(N²) on one thread: a signal must not wait for the end.
    const CancellationFlag& cancel = current_cancellation();
    if (d.has_z) {
        std::vector<double> r;
        for (std::size_t i = 0; i < n; ++i) {
            cancel.throw_if_requested();
            r.clear();
            for (std::size_t j = 0; j < n; ++j) {
                const auto ii = static_cast<Eigen::Index>(i), jj = static_cast<Eigen::Index>(j);
                const double f = F(ii, jj), e = (*se)(ii, jj);
                if (f > 0.0 && f < 1.0 && e > 0.0 && std::isfinite(e))
                    r.push_back(f * (1 - f) / (e * e));
            }
            if (r.empty()) continue;
            std::nth_element(r.begin(), r.begin() + static_cast<std::ptrdiff_t>(r.size() / 2),
                             r.end());
            samples[i] = r[r.size() / 2];
        }
    }
    double defect_sum = 0.0, exchange_sum = 0.0, z2_sum = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
        cancel.throw_if_requested();
        double s = 0.0;
        const auto ii = static_cast<Eigen::Index>(i);
        for (std::size_t j = 0; j < n; ++j) {
            const auto jj = static_cast<Eigen::Index>(j);
            const double f = F(ii, jj);
            if (!std::isfinite(f)) {
                ++d.nonfinite_entries;
                continue;
            }
            s += f;
            if (f < 0.0) ++d.negative_entries;
            if (f > 1.0) ++d.entries_above_one;
            if (!with_areas) continue;
            const double a = areas[i] * f;
            row_mass[i] += a;
            col_mass[j] += a;
            exchange_sum += a;
            if (j <= i) continue;
            const double g = F(jj, ii);
            if (!std::isfinite(g)) continue;
            const double b = areas[j] * g;
            const double diff = std::abs(a - b);
            row_defect[i] += diff;
            row_defect[j] += diff;
            defect_sum += 2.0 * diff;
            const double m = std::max(std::abs(a), std::abs(b));
            const double defect = m > 0.0 ? diff / m : 0.0;
            if (defect > d.max_reciprocity_defect) {
                d.max_reciprocity_defect = defect;
                d.reciprocity_i = i;
                d.reciprocity_j = j;
            }
            if (d.has_z) {
                const double ei = (*se)(ii, jj), ej = (*se)(jj, ii);
                double si = areas[i] * ei, sj = areas[j] * ej;
                // A zero entry from no hits: its standard error at the reciprocal value.
                auto at_reciprocal = [&](std::size_t row, double other) {
                    const double fr = std::min(1.0, other / areas[row]);
                    return areas[row] * std::sqrt(fr * (1.0 - fr) / samples[row]);
                };
                const bool zi = f == 0.0 && ei == 0.0 && b > 0.0 && samples[i] > 0.0;
                const bool zj = g == 0.0 && ej == 0.0 && a > 0.0 && samples[j] > 0.0;
                if (zi) si = at_reciprocal(i, b);
                if (zj) sj = at_reciprocal(j, a);
                if (zi || zj) ++d.z_zero_entries;
                const double den = std::sqrt(si * si + sj * sj);
                if (den > 0.0 && std::isfinite(den)) {
                    const double z = diff / den;
                    ++d.z_pairs;
                    z2_sum += z * z;
                    if (z > d.z_max) {
                        d.z_max = z;
                        d.z_i = i;
                        d.z_j = j;
                    }
                } else if (defect > 1e-9) {
                    ++d.z_undefined;
                }
            }
        }
        d.max_abs_diagonal = std::max(d.max_abs_diagonal, std::abs(F(ii, ii)));
        d.row_sum_min = std::min(d.row_sum_min, s);
        d.row_sum_max = std::max(d.row_sum_max, s);
        total += s;
    }
    d.row_sum_mean = total / static_cast<double>(n);
    if (exchange_sum > 0.0) d.reciprocity_area_weighted = defect_sum / exchange_sum;
    for (std::size_t i = 0; i < n; ++i) {
        const double mass = std::max(row_mass[i], col_mass[i]);
        const double r = mass > 0.0 ? row_defect[i] / mass : 0.0;
        if (r > d.reciprocity_row_max) {
            d.reciprocity_row_max = r;
            d.reciprocity_row = i;
        }
    }
    if (d.z_pairs > 0) d.z_rms = std::sqrt(z2_sum / static_cast<double>(d.z_pairs));
    return d;
}

Diagnostics diagnose(const FormFactors& ff) {
    return diagnose(ff.F, ff.areas, ff.standard_error ? &*ff.standard_error : nullptr);
}

}  // namespace formfactor
