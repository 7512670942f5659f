#include "formfactor/matrix/form_factors.h"

#include <algorithm>
#include <cmath>

namespace formfactor {

Diagnostics diagnose(const DenseMatrix& F, const std::vector<double>& areas) {
    Diagnostics d;
    const std::size_t n = static_cast<std::size_t>(F.rows());
    d.n = n;
    if (n == 0) return d;
    d.row_sum_min = std::numeric_limits<double>::infinity();
    d.row_sum_max = -std::numeric_limits<double>::infinity();
    double total = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
        double s = 0.0;
        const auto ii = static_cast<Eigen::Index>(i);
        for (std::size_t j = 0; j < n; ++j) {
            const double f = F(ii, static_cast<Eigen::Index>(j));
            if (!std::isfinite(f)) {
                ++d.nonfinite_entries;
                continue;
            }
            s += f;
            if (f < 0.0) ++d.negative_entries;
            if (f > 1.0) ++d.entries_above_one;
            if (j > i && i < areas.size() && j < areas.size()) {
                const double a = areas[i] * f;
                const double b = areas[j] * F(static_cast<Eigen::Index>(j), ii);
                const double m = std::max(std::abs(a), std::abs(b));
                if (m > 0.0) {
                    const double defect = std::abs(a - b) / m;
                    if (defect > d.max_reciprocity_defect) {
                        d.max_reciprocity_defect = defect;
                        d.reciprocity_i = i;
                        d.reciprocity_j = j;
                    }
                }
            }
        }
        d.max_abs_diagonal = std::max(d.max_abs_diagonal, std::abs(F(ii, ii)));
        d.row_sum_min = std::min(d.row_sum_min, s);
        d.row_sum_max = std::max(d.row_sum_max, s);
        total += s;
    }
    d.row_sum_mean = total / static_cast<double>(n);
    return d;
}

}  // namespace formfactor
