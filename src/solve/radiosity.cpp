#include "formfactor/solve/radiosity.h"

#include <fmt/format.h>

#include <cmath>

#include "formfactor/core/error.h"
#include "solve/linear_system.h"

namespace formfactor {

RadiosityBalance radiosity_balance(const FormFactors& ff, const PatchProperties& props,
                                   const std::vector<Rgb>& radiosity, int threads) {
    const Eigen::Index n = ff.F.rows();
    detail::Columns B(n, 3), H(n, 3);
    for (Eigen::Index i = 0; i < n; ++i) B.row(i) = radiosity[static_cast<std::size_t>(i)];
    detail::multiply(ff.F, B, H, threads);
    RadiosityBalance bal;
    for (Eigen::Index i = 0; i < n; ++i) {
        const auto si = static_cast<std::size_t>(i);
        const double a = ff.areas[si];
        const double open = 1.0 - ff.F.row(i).sum();
        for (int c = 0; c < 3; ++c) {
            bal.emitted[c] += a * props.emission[si][c];
            bal.absorbed[c] += a * (1.0 - props.reflectance[si][c]) * H(i, c);
            bal.escaped[c] += a * open * B(i, c);
        }
    }
    for (int c = 0; c < 3; ++c)
        if (bal.emitted[c] > 0.0)
            bal.relative_defect = std::max(
                bal.relative_defect,
                std::abs(bal.emitted[c] - bal.absorbed[c] - bal.escaped[c]) / bal.emitted[c]);
    return bal;
}

RadiosityResult solve_radiosity(const FormFactors& ff, const PatchProperties& props,
                                const SolverOptions& options) {
    detail::check_sizes(ff, props.size());
    validate_properties(props);
    const Eigen::Index n = ff.F.rows();
    detail::Columns d(n, 3), c(n, 3), x;
    for (Eigen::Index i = 0; i < n; ++i) {
        d.row(i) = props.reflectance[static_cast<std::size_t>(i)];
        c.row(i) = props.emission[static_cast<std::size_t>(i)];
    }
    RadiosityResult res;
    res.stats = detail::solve_linear(ff.F, ff.areas, d, c, options, x);
    res.radiosity.resize(static_cast<std::size_t>(n));
    for (Eigen::Index i = 0; i < n; ++i) res.radiosity[static_cast<std::size_t>(i)] = x.row(i);
    res.balance = radiosity_balance(ff, props, res.radiosity, options.threads);
    return res;
}

}  // namespace formfactor
