#include "formfactor/matrix/form_factors.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <type_traits>

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
    // The reverse entries F_ji of a strip of kStrip rows, copied column strip by column strip:
    // read one by one down a column, each would cost a cache line (a 7,680² matrix took 0.4 s).
    // The scan below keeps its order, so every sum is the same to the last bit.
    constexpr std::size_t kStrip = 64;
    std::vector<double> reverse, reverse_se;
    auto copy_strip = [&](const DenseMatrix& M, std::size_t i0, std::vector<double>& out) {
        const std::size_t w = std::min(kStrip, n - i0);
        out.resize(w * n);
        // Eight rows of M at a time: a cache line of each row of `out` per step.
        for (std::size_t j0 = i0; j0 < n; j0 += 8) {
            const std::size_t j1 = std::min(n, j0 + 8);
            for (std::size_t k = 0; k < w; ++k)
                for (std::size_t j = j0; j < j1; ++j) out[k * n + j] = M.data()[j * n + i0 + k];
        }
    };
    // Counters and running maxima in locals: d is the caller's memory, which the compiler would
    // have to read and write around every store to the per-row vectors.
    std::size_t nonfinite = 0, negative = 0, above_one = 0, z_pairs = 0, z_zero = 0,
                z_undefined = 0;
    double max_defect = d.max_reciprocity_defect, z_max = d.z_max;
    std::size_t defect_i = d.reciprocity_i, defect_j = d.reciprocity_j, z_i = d.z_i, z_j = d.z_j;
    for (std::size_t i = 0; i < n; ++i) {
        cancel.throw_if_requested();
        if (i % kStrip == 0 && with_areas) {
            copy_strip(F, i, reverse);
            if (d.has_z) copy_strip(*se, i, reverse_se);
        }
        const double* row = F.data() + i * n;
        const double* rev = with_areas ? reverse.data() + (i % kStrip) * n : nullptr;
        const double* row_se = d.has_z ? se->data() + i * n : nullptr;
        const double* rev_se = d.has_z ? reverse_se.data() + (i % kStrip) * n : nullptr;
        const double area_i = with_areas ? areas[i] : 0.0;
        double s = 0.0, mass = 0.0, defect_of_row = row_defect[i];
        // One loop per kind (with z-scores or not): fewer values live in the loop, so that its
        // running sums stay in registers.
        auto scan = [&](auto with_z) {
            constexpr bool kZ = decltype(with_z)::value;
            for (std::size_t j = 0; j < n; ++j) {
                const double f = row[j];
                if (!std::isfinite(f)) {
                    ++nonfinite;
                    continue;
                }
                s += f;
                negative += f < 0.0;
                above_one += f > 1.0;
                if (!with_areas) continue;
                const double a = area_i * f;
                mass += a;
                col_mass[j] += a;
                exchange_sum += a;
                if (j <= i) continue;
                const double g = rev[j];
                if (!std::isfinite(g)) continue;
                const double b = areas[j] * g;
                const double diff = std::abs(a - b);
                defect_of_row += diff;
                row_defect[j] += diff;
                defect_sum += 2.0 * diff;
                const double m = std::max(std::abs(a), std::abs(b));
                // The division only where the pair may be the worst so far (or for the z-scores):
                // diff / m > max_defect needs diff > max_defect · m, less a rounding or two.
                if (!kZ && !(diff > max_defect * m * (1.0 - 1e-12))) continue;
                const double defect = m > 0.0 ? diff / m : 0.0;
                if (defect > max_defect) {
                    max_defect = defect;
                    defect_i = i;
                    defect_j = j;
                }
                if (kZ) {
                    const double ei = row_se[j], ej = rev_se[j];
                    double si = area_i * ei, sj = areas[j] * ej;
                    // A zero entry from no hits: its standard error at the reciprocal value.
                    auto at_reciprocal = [&](std::size_t r, double other) {
                        const double fr = std::min(1.0, other / areas[r]);
                        return areas[r] * std::sqrt(fr * (1.0 - fr) / samples[r]);
                    };
                    const bool zi = f == 0.0 && ei == 0.0 && b > 0.0 && samples[i] > 0.0;
                    const bool zj = g == 0.0 && ej == 0.0 && a > 0.0 && samples[j] > 0.0;
                    if (zi) si = at_reciprocal(i, b);
                    if (zj) sj = at_reciprocal(j, a);
                    if (zi || zj) ++z_zero;
                    const double den = std::sqrt(si * si + sj * sj);
                    if (den > 0.0 && std::isfinite(den)) {
                        const double z = diff / den;
                        ++z_pairs;
                        z2_sum += z * z;
                        if (z > z_max) {
                            z_max = z;
                            z_i = i;
                            z_j = j;
                        }
                    } else if (defect > 1e-9) {
                        ++z_undefined;
                    }
                }
            }
        };
        if (d.has_z)
            scan(std::true_type{});
        else
            scan(std::false_type{});
        row_mass[i] = mass;
        row_defect[i] = defect_of_row;
        d.max_abs_diagonal = std::max(d.max_abs_diagonal, std::abs(row[i]));
        d.row_sum_min = std::min(d.row_sum_min, s);
        d.row_sum_max = std::max(d.row_sum_max, s);
        total += s;
    }
    d.nonfinite_entries = nonfinite;
    d.negative_entries = negative;
    d.entries_above_one = above_one;
    d.z_pairs = z_pairs;
    d.z_zero_entries = z_zero;
    d.z_undefined = z_undefined;
    d.max_reciprocity_defect = max_defect;
    d.reciprocity_i = defect_i;
    d.reciprocity_j = defect_j;
    d.z_max = z_max;
    d.z_i = z_i;
    d.z_j = z_j;
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
