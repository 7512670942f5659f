// The radiosity and thermal solves on rows spread over the ranks
// (formfactor/distributed/distributed.h), with or without MPI: the problem is set up on rank 0
// as on one process, and only the linear solve (solve_rows()) involves every rank. The
// operator's per-surface matrix likewise: aggregated on rank 0, its one product over the ranks.

#include <fmt/format.h>

#include <algorithm>
#include <optional>

#include "formfactor/core/error.h"
#include "formfactor/distributed/distributed.h"
#include "hierarchical_solve.h"
#include "row_solve.h"

namespace formfactor::distributed {

namespace {

void check_sizes(const DistributedRows& rows, std::size_t properties) {
    if (rows.areas.size() != rows.n || rows.row_sums.size() != rows.n)
        throw Error(fmt::format("solve: rows of {} patches with {} areas and {} row sums", rows.n,
                                rows.areas.size(), rows.row_sums.size()));
    if (properties != rows.n)
        throw Error(
            fmt::format("solve: the scene has {} patches but the matrix is {}x{} (same scene and "
                        "subdivision?)",
                        properties, rows.n, rows.n));
}

void check_solver(SolverKind kind) {
    if (kind != SolverKind::jacobi && kind != SolverKind::gauss_seidel && kind != SolverKind::gmres)
        throw OptionError("solver", fmt::format("{} needs the whole F on one process; rows spread "
                                                "over ranks are solved by gauss-seidel, gmres or "
                                                "jacobi",
                                                to_string(kind)));
}

// As detail::dropped_mass_warning() says it of a whole sparse F.
std::string dropped_mass_warning(const DistributedRows& rows) {
    if (!rows.sparse || !(rows.dropped_max > 1e-9)) return {};
    return fmt::format(
        "the stored entries of a row carry up to {:.3g} less than the method computed (dropped "
        "mass: what a threshold dropped): the solve treats it as seen by the environment",
        rows.dropped_max);
}

// What the solve leaves for the product after it: F x of the solution it returned.
struct LastProduct {
    Columns x, fx;
};

// The thermal problem on F of n patches (areas, row sums) held over the ranks, whose linear
// solves are linear_solve(d, c, x, fx) (the rows' or the operator's): set up on rank 0 as on one
// process. The thermal solve asks for F J once, after the solve, of the J the solve returned.
template <class LinearSolve>
ThermalResult thermal_on_ranks(std::size_t n, const std::vector<double>& areas,
                               const std::vector<double>& row_sums,
                               std::optional<double> row_sum_tolerance,
                               const PatchProperties& props, const ThermalOptions& options,
                               const LinearSolve& linear_solve) {
    detail::ThermalSystem sys;
    sys.n = static_cast<Eigen::Index>(n);
    sys.areas = &areas;
    sys.row_sums = row_sums;
    if (row_sum_tolerance) sys.row_sum_tolerance = *row_sum_tolerance;
    LastProduct last;
    sys.apply = [&](const Columns& x, Columns& y) {
        FF_ASSERT(x.rows() == last.x.rows() && x == last.x);
        y = last.fx;
    };
    sys.solve = [&](const Columns& d, const Columns& c, Columns& x) {
        const SolverStats st = linear_solve(d, c, x, last.fx);
        last.x = x;
        return st;
    };
    return detail::solve_thermal_system(sys, props, options);
}

// The radiosity problem likewise.
template <class LinearSolve>
RadiosityResult radiosity_on_ranks(std::size_t n, const std::vector<double>& areas,
                                   const std::vector<double>& row_sums,
                                   const PatchProperties& props, const LinearSolve& linear_solve) {
    validate_properties(props);
    Columns d, c, x, fx;
    detail::radiosity_system(props, d, c);
    RadiosityResult res;
    res.stats = linear_solve(d, c, x, fx);
    res.radiosity.resize(n);
    for (Eigen::Index i = 0; i < x.rows(); ++i)
        res.radiosity[static_cast<std::size_t>(i)] = x.row(i);
    res.balance = detail::radiosity_balance_of(areas, row_sums, props, x, fx);
    return res;
}

void check_operator_size(const DistributedHierarchical& op, std::size_t properties) {
    if (properties != op.n)
        throw Error(fmt::format("solve: the scene has {} patches but the operator has {}",
                                properties, op.n));
}

}  // namespace

ThermalResult solve_thermal(const DistributedRows& rows, const PatchProperties& props,
                            const ThermalOptions& options) {
    check_sizes(rows, props.size());
    check_solver(options.solver.solver);
    std::optional<double> tolerance;
    if (rows.sparse) tolerance = std::max(1e-9, 2.0 * rows.dropped_max);
    ThermalResult res =
        thermal_on_ranks(rows.n, rows.areas, rows.row_sums, tolerance, props, options,
                         [&](const Columns& d, const Columns& c, Columns& x, Columns& fx) {
                             return solve_rows(rows, d, c, options.solver, x, fx);
                         });
    if (std::string w = dropped_mass_warning(rows); !w.empty()) res.warnings.push_back(w);
    return res;
}

RadiosityResult solve_radiosity(const DistributedRows& rows, const PatchProperties& props,
                                const SolverOptions& options) {
    check_sizes(rows, props.size());
    check_solver(options.solver);
    RadiosityResult res =
        radiosity_on_ranks(rows.n, rows.areas, rows.row_sums, props,
                           [&](const Columns& d, const Columns& c, Columns& x, Columns& fx) {
                               return solve_rows(rows, d, c, options, x, fx);
                           });
    if (std::string w = dropped_mass_warning(rows); !w.empty()) res.stats.warnings.push_back(w);
    return res;
}

SolveResult solve(const Scene& scene, const DistributedRows& rows, const PatchProperties& props,
                  const SolveOptions& options) {
    return formfactor::detail::solve_problem(scene, rows, props, options);
}

ThermalResult solve_thermal(const DistributedHierarchical& op, const PatchProperties& props,
                            const ThermalOptions& options) {
    check_operator_size(op, props.size());
    // The row-sum tolerance as the single-process solve of the operator's (solve/thermal.cpp).
    return thermal_on_ranks(op.n, op.areas, op.row_sums, std::max(1e-9, 10.0 * op.stats.tolerance),
                            props, options,
                            [&](const Columns& d, const Columns& c, Columns& x, Columns& fx) {
                                return solve_operator(op, d, c, options.solver, x, fx);
                            });
}

RadiosityResult solve_radiosity(const DistributedHierarchical& op, const PatchProperties& props,
                                const SolverOptions& options) {
    check_operator_size(op, props.size());
    return radiosity_on_ranks(op.n, op.areas, op.row_sums, props,
                              [&](const Columns& d, const Columns& c, Columns& x, Columns& fx) {
                                  return solve_operator(op, d, c, options, x, fx);
                              });
}

SolveResult solve(const Scene& scene, const DistributedHierarchical& op,
                  const PatchProperties& props, const SolveOptions& options) {
    return formfactor::detail::solve_problem(scene, op, props, options);
}

SurfaceFormFactors<FormFactors> per_surface(const Scene& scene, const DistributedHierarchical& op,
                                            int threads) {
    return formfactor::detail::per_surface_of_operator(scene, [&](const PatchGroups& groups) {
        return HierarchicalFormFactors::per_group(
            op.areas, groups.group_of_patch, groups.size(),
            [&](const Columns& X, Columns& Y) { multiply_operator(op, X, threads, Y); });
    });
}

void multiply(const DistributedHierarchical& op, const Eigen::MatrixXd& X, Eigen::MatrixXd& Y,
              int threads) {
    if (static_cast<std::size_t>(X.rows()) != op.n)
        throw Error(
            fmt::format("multiply: X has {} rows, the operator {} patches", X.rows(), op.n));
    multiply_operator(op, X, threads, Y);
}

}  // namespace formfactor::distributed
