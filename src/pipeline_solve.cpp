// The pipeline's last steps: the hierarchical operator, the solves on F however it is held, and
// F per surface.

#include "formfactor/pipeline_solve.h"

#include "formfactor/scene/closure.h"

namespace formfactor {

SolverKind default_solver(Storage storage, bool thermal) {
    if (storage == Storage::hierarchical) return SolverKind::gmres;
    if (!thermal) return SolverKind::gauss_seidel;
    return storage == Storage::dense ? SolverKind::direct : SolverKind::gmres;
}

HierarchicalFormFactors compute_hierarchical_operator(const Scene& scene,
                                                      const HierarchicalOptions& options,
                                                      StepTimes* times) {
    Stopwatch sw;
    HierarchicalFormFactors H = build_hierarchical(scene, options);
    if (times) times->add("hierarchical operator", sw.lap());
    return H;
}

namespace detail {

ThermalOptions thermal_options(const Scene& scene, const SolveOptions& options) {
    ThermalOptions o;
    o.solver = options.solver;
    o.ambient_temperature = options.ambient_temperature;
    // A closed model loses nothing: a row deficit is the estimate's error, not an opening.
    o.closed = check_closure(scene).closed;
    return o;
}

}  // namespace detail

SolveResult solve(const Scene& scene, const FormFactors& F, const PatchProperties& props,
                  const SolveOptions& options) {
    return detail::solve_problem(scene, F, props, options);
}

SolveResult solve(const Scene& scene, const SparseFormFactors& F, const PatchProperties& props,
                  const SolveOptions& options) {
    return detail::solve_problem(scene, F, props, options);
}

SolveResult solve(const Scene& scene, const HierarchicalFormFactors& F,
                  const PatchProperties& props, const SolveOptions& options) {
    return detail::solve_problem(scene, F, props, options);
}

namespace {

template <class Matrix>
SurfaceFormFactors<Matrix> aggregated_per_surface(const Scene& scene, const Matrix& F) {
    SurfaceFormFactors<Matrix> out;
    out.groups = surface_groups(scene);
    if (!is_identity(out.groups)) out.aggregated = aggregate(F, out.groups);
    return out;
}

}  // namespace

SurfaceFormFactors<FormFactors> per_surface(const Scene& scene, const FormFactors& F) {
    return aggregated_per_surface(scene, F);
}

SurfaceFormFactors<SparseFormFactors> per_surface(const Scene& scene, const SparseFormFactors& F) {
    return aggregated_per_surface(scene, F);
}

SurfaceFormFactors<FormFactors> per_surface(const Scene& scene, const HierarchicalFormFactors& F,
                                            int threads) {
    return detail::per_surface_of_operator(scene, [&](const PatchGroups& groups) {
        return F.per_group(groups.group_of_patch, groups.size(), threads);
    });
}

SurfaceFormFactors<FormFactors> detail::per_surface_of_operator(
    const Scene& scene, const std::function<DenseMatrix(const PatchGroups&)>& per_group) {
    SurfaceFormFactors<FormFactors> out;
    out.groups = surface_groups(scene);
    FormFactors& G = out.aggregated.emplace();
    G.F = per_group(out.groups);
    G.areas.assign(out.groups.size(), 0.0);
    for (std::size_t i = 0; i < scene.patches.size(); ++i)
        G.areas[static_cast<std::size_t>(out.groups.group_of_patch[i])] += scene.patches[i].area;
    return out;
}

}  // namespace formfactor
