#include "formfactor/solve/radiosity.h"

#include <fmt/format.h>

#include <cmath>

#include "formfactor/core/error.h"
#include "solve/linear_system.h"

namespace formfactor {

namespace detail {

RadiosityBalance radiosity_balance_of(const std::vector<double>& areas,
                                      const std::vector<double>& row_sums,
                                      const PatchProperties& props, const detail::Columns& B,
                                      const detail::Columns& H) {
    const auto n = static_cast<Eigen::Index>(areas.size());
    RadiosityBalance bal;
    for (Eigen::Index i = 0; i < n; ++i) {
        const auto si = static_cast<std::size_t>(i);
        const double a = areas[si];
        const double open = 1.0 - row_sums[si];
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

void radiosity_system(const PatchProperties& props, Columns& d, Columns& c) {
    const auto n = static_cast<Eigen::Index>(props.size());
    d.resize(n, 3);
    c.resize(n, 3);
    for (Eigen::Index i = 0; i < n; ++i) {
        d.row(i) = props.reflectance[static_cast<std::size_t>(i)];
        c.row(i) = props.emission[static_cast<std::size_t>(i)];
    }
}

}  // namespace detail

namespace {

detail::Columns columns_of(const std::vector<Rgb>& radiosity) {
    detail::Columns B(static_cast<Eigen::Index>(radiosity.size()), 3);
    for (Eigen::Index i = 0; i < B.rows(); ++i) B.row(i) = radiosity[static_cast<std::size_t>(i)];
    return B;
}

}  // namespace

RadiosityBalance radiosity_balance(const FormFactors& ff, const PatchProperties& props,
                                   const std::vector<Rgb>& radiosity, int threads) {
    const detail::Columns B = columns_of(radiosity);
    detail::Columns H;
    detail::multiply(ff.F, B, H, threads);
    std::vector<double> sums(ff.size());
    for (Eigen::Index i = 0; i < ff.F.rows(); ++i)
        sums[static_cast<std::size_t>(i)] = ff.F.row(i).sum();
    return detail::radiosity_balance_of(ff.areas, sums, props, B, H);
}

RadiosityResult solve_radiosity(const FormFactors& ff, const PatchProperties& props,
                                const SolverOptions& options) {
    detail::check_sizes(ff, props.size());
    validate_properties(props);
    const Eigen::Index n = ff.F.rows();
    detail::Columns d, c, x;
    detail::radiosity_system(props, d, c);
    RadiosityResult res;
    res.stats = detail::solve_linear(ff.F, ff.areas, d, c, options, x);
    res.radiosity.resize(static_cast<std::size_t>(n));
    for (Eigen::Index i = 0; i < n; ++i) res.radiosity[static_cast<std::size_t>(i)] = x.row(i);
    res.balance = radiosity_balance(ff, props, res.radiosity, options.threads);
    return res;
}

RadiosityResult solve_radiosity(const HierarchicalFormFactors& ff, const PatchProperties& props,
                                const SolverOptions& options) {
    if (props.size() != ff.size())
        throw Error(fmt::format("solve: the scene has {} patches but the operator has {}",
                                props.size(), ff.size()));
    validate_properties(props);
    const auto n = static_cast<Eigen::Index>(ff.size());
    detail::Columns d, c, x;
    detail::radiosity_system(props, d, c);
    const detail::ApplyF apply = [&](const detail::Columns& v, detail::Columns& y) {
        ff.multiply(v, y, options.threads);
    };
    RadiosityResult res;
    res.stats = detail::solve_linear_operator(apply, n, d, c, options, x);
    res.radiosity.resize(static_cast<std::size_t>(n));
    for (Eigen::Index i = 0; i < n; ++i) res.radiosity[static_cast<std::size_t>(i)] = x.row(i);
    detail::Columns H;
    apply(x, H);
    res.balance =
        detail::radiosity_balance_of(ff.areas(), ff.row_sums(options.threads), props, x, H);
    return res;
}

RadiosityResult solve_radiosity(const SparseFormFactors& ff, const PatchProperties& props,
                                const SolverOptions& options) {
    detail::check_sizes(ff, props.size());
    detail::check_sparse_solver(options.solver);
    validate_properties(props);
    const auto n = static_cast<Eigen::Index>(ff.n);
    detail::Columns d, c, x;
    detail::radiosity_system(props, d, c);
    RadiosityResult res;
    res.stats = detail::solve_linear(ff, d, c, options, x);
    res.radiosity.resize(ff.n);
    for (Eigen::Index i = 0; i < n; ++i) res.radiosity[static_cast<std::size_t>(i)] = x.row(i);
    detail::Columns H;
    detail::multiply(ff, x, H, options.threads);
    std::vector<double> sums(ff.n);
    for (std::size_t i = 0; i < ff.n; ++i) sums[i] = ff.row_sum(i);
    res.balance = detail::radiosity_balance_of(ff.areas, sums, props, x, H);
    if (std::string w = detail::dropped_mass_warning(ff); !w.empty())
        res.stats.warnings.push_back(w);
    return res;
}

}  // namespace formfactor
