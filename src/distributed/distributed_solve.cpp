// The radiosity and thermal solves on rows spread over the ranks
// (formfactor/distributed/distributed.h), with or without MPI: the problem is set up on rank 0
// as on one process, and only the linear solve (solve_rows()) involves every rank.

#include <fmt/format.h>

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

}  // namespace

ThermalResult solve_thermal(const DistributedRows& rows, const PatchProperties& props,
                            const ThermalOptions& options) {
    check_sizes(rows, props.size());
    check_solver(options.solver.solver);
    detail::ThermalSystem sys;
    sys.n = static_cast<Eigen::Index>(rows.n);
    sys.areas = &rows.areas;
    sys.row_sums = rows.row_sums;
    if (rows.sparse) sys.row_sum_tolerance = std::max(1e-9, 2.0 * rows.dropped_max);
    LastProduct last;
    // The thermal solve asks for F J once, after the solve, of the J the solve returned.
    sys.apply = [&](const Columns& x, Columns& y) {
        FF_ASSERT(x.rows() == last.x.rows() && x == last.x);
        y = last.fx;
    };
    sys.solve = [&](const Columns& d, const Columns& c, Columns& x) {
        const SolverStats st = solve_rows(rows, d, c, options.solver, x, last.fx);
        last.x = x;
        return st;
    };
    ThermalResult res = detail::solve_thermal_system(sys, props, options);
    if (std::string w = dropped_mass_warning(rows); !w.empty()) res.warnings.push_back(w);
    return res;
}

RadiosityResult solve_radiosity(const DistributedRows& rows, const PatchProperties& props,
                                const SolverOptions& options) {
    check_sizes(rows, props.size());
    check_solver(options.solver);
    validate_properties(props);
    Columns d, c, x, fx;
    detail::radiosity_system(props, d, c);
    RadiosityResult res;
    res.stats = solve_rows(rows, d, c, options, x, fx);
    res.radiosity.resize(rows.n);
    for (Eigen::Index i = 0; i < x.rows(); ++i)
        res.radiosity[static_cast<std::size_t>(i)] = x.row(i);
    res.balance = detail::radiosity_balance_of(rows.areas, rows.row_sums, props, x, fx);
    if (std::string w = dropped_mass_warning(rows); !w.empty()) res.stats.warnings.push_back(w);
    return res;
}

SolveResult solve(const Scene& scene, const DistributedRows& rows, const PatchProperties& props,
                  const SolveOptions& options) {
    return formfactor::detail::solve_problem(scene, rows, props, options);
}

ThermalResult solve_thermal(const DistributedHierarchical& op, const PatchProperties& props,
                            const ThermalOptions& options) {
    if (props.size() != op.n)
        throw Error(fmt::format("solve: the scene has {} patches but the operator has {}",
                                props.size(), op.n));
    detail::ThermalSystem sys;
    sys.n = static_cast<Eigen::Index>(op.n);
    sys.areas = &op.areas;
    sys.row_sums = op.row_sums;
    // As the single-process solve of the operator (solve/thermal.cpp).
    sys.row_sum_tolerance = std::max(1e-9, 10.0 * op.stats.tolerance);
    LastProduct last;
    sys.apply = [&](const Columns& x, Columns& y) {
        FF_ASSERT(x.rows() == last.x.rows() && x == last.x);
        y = last.fx;
    };
    sys.solve = [&](const Columns& d, const Columns& c, Columns& x) {
        const SolverStats st = solve_operator(op, d, c, options.solver, x, last.fx);
        last.x = x;
        return st;
    };
    return detail::solve_thermal_system(sys, props, options);
}

RadiosityResult solve_radiosity(const DistributedHierarchical& op, const PatchProperties& props,
                                const SolverOptions& options) {
    if (props.size() != op.n)
        throw Error(fmt::format("solve: the scene has {} patches but the operator has {}",
                                props.size(), op.n));
    validate_properties(props);
    Columns d, c, x, fx;
    detail::radiosity_system(props, d, c);
    RadiosityResult res;
    res.stats = solve_operator(op, d, c, options, x, fx);
    res.radiosity.resize(op.n);
    for (Eigen::Index i = 0; i < x.rows(); ++i)
        res.radiosity[static_cast<std::size_t>(i)] = x.row(i);
    res.balance = detail::radiosity_balance_of(op.areas, op.row_sums, props, x, fx);
    return res;
}

SolveResult solve(const Scene& scene, const DistributedHierarchical& op,
                  const PatchProperties& props, const SolveOptions& options) {
    return formfactor::detail::solve_problem(scene, op, props, options);
}

}  // namespace formfactor::distributed
