#pragma once
/// The pipeline's last steps (DESIGN.md, "Data flow"): the hierarchical operator made, the
/// radiosity or thermal problem solved on F however it is held, and F per surface.
///
///     const formfactor::ComputeResult r = formfactor::compute_form_factors(scene);
///     formfactor::SolveOptions o;
///     o.thermal = true;
///     o.solver.solver = formfactor::default_solver(formfactor::Storage::dense, o.thermal);
///     const formfactor::SolveResult s =
///         formfactor::solve(scene, r.form_factors, formfactor::properties_from_scene(scene), o);
///     // s.thermal->temperature, s.thermal->net_flux, ...
///
/// The solvers themselves are those of formfactor/solve/; what the pipeline adds is the one
/// choice of the default solver per storage, and the scene's own facts (a closed model) that
/// the thermal solve needs.

#include <functional>
#include <optional>

#include "formfactor/core/timing.h"
#include "formfactor/matrix/aggregate.h"
#include "formfactor/matrix/form_factors.h"
#include "formfactor/matrix/hierarchical.h"
#include "formfactor/matrix/sparse.h"
#include "formfactor/methods/hierarchical_build.h"
#include "formfactor/scene/scene.h"
#include "formfactor/solve/properties.h"
#include "formfactor/solve/radiosity.h"
#include "formfactor/solve/thermal.h"

namespace formfactor {

/// How F is held: the whole matrix, CSR rows (formfactor/matrix/sparse.h) or the hierarchical
/// operator (formfactor/matrix/hierarchical.h), which gives products only.
enum class Storage { dense, sparse, hierarchical };

/// The solver of a problem on F held as `storage` when none is asked for: gmres on the
/// hierarchical operator; on a matrix gauss-seidel for radiosity, and for the thermal problem
/// direct when dense (small systems, possibly stiff) and gmres when sparse.
SolverKind default_solver(Storage storage, bool thermal);

/// The hierarchical operator of scene.patches (build_hierarchical(),
/// formfactor/methods/hierarchical_build.h), timed into *times ("hierarchical operator") when
/// it is given. Throws as build_hierarchical().
HierarchicalFormFactors compute_hierarchical_operator(const Scene& scene,
                                                      const HierarchicalOptions& options,
                                                      StepTimes* times = nullptr);

/// Everything solve() reads besides F and the patches' properties.
struct SolveOptions {
    /// The grey-body heat exchange (formfactor/solve/thermal.h); false: radiosity, per colour
    /// channel (formfactor/solve/radiosity.h).
    bool thermal = false;
    /// The solver (default_solver() gives the usual one), its stopping rule, threads, progress.
    SolverOptions solver;
    /// Thermal: the temperature (K, ≥ 0) of the environment the open part of each row sees.
    double ambient_temperature = 0.0;
};

/// What solve() returns: the solution of the problem asked for (the other is unset) and the
/// wall time of the step ("solve").
struct SolveResult {
    std::optional<RadiosityResult> radiosity;
    std::optional<ThermalResult> thermal;
    StepTimes timings;
};

/// Solves the problem of options on F of scene.patches with `props` (one per patch):
/// solve_radiosity(), or solve_thermal() with the scene solved as closed when it is a closed
/// model (check_closure(), formfactor/scene/closure.h: a row that sums to less than 1 is then
/// the estimate's error, not an opening). Throws as those solvers.
SolveResult solve(const Scene& scene, const FormFactors& F, const PatchProperties& props,
                  const SolveOptions& options);
SolveResult solve(const Scene& scene, const SparseFormFactors& F, const PatchProperties& props,
                  const SolveOptions& options);
SolveResult solve(const Scene& scene, const HierarchicalFormFactors& F,
                  const PatchProperties& props, const SolveOptions& options);

/// F per surface (View3D's rows: one per surface, subsurfaces apart from their base, cmb
/// surfaces combined; surface_groups(), formfactor/matrix/aggregate.h).
template <class Matrix>
struct SurfaceFormFactors {
    PatchGroups groups;
    /// F aggregated over the groups; unset when the groups are the patches in order
    /// (is_identity()): the patch matrix is then the per-surface one, not copied.
    std::optional<Matrix> aggregated;

    /// The per-surface matrix, given the patch matrix it was made from.
    const Matrix& of(const Matrix& patches) const { return aggregated ? *aggregated : patches; }
};

/// F of scene.patches per surface: aggregate() over surface_groups(scene), unless every surface
/// is one patch in order. Throws GeometryError as aggregate().
SurfaceFormFactors<FormFactors> per_surface(const Scene& scene, const FormFactors& F);
SurfaceFormFactors<SparseFormFactors> per_surface(const Scene& scene, const SparseFormFactors& F);
/// The hierarchical operator per surface from one product per surface
/// (HierarchicalFormFactors::per_group()), F never formed: always aggregated.
SurfaceFormFactors<FormFactors> per_surface(const Scene& scene, const HierarchicalFormFactors& F,
                                            int threads = 0);

namespace detail {

/// per_surface() of the hierarchical operator for any way of making its products (the
/// distributed module's operator spread over the ranks too): `per_group` gives the per-group
/// factors of the groups it is handed (HierarchicalFormFactors::per_group()).
SurfaceFormFactors<FormFactors> per_surface_of_operator(
    const Scene& scene, const std::function<DenseMatrix(const PatchGroups&)>& per_group);

/// The thermal solve's options for `scene` (ThermalOptions::closed from check_closure()).
ThermalOptions thermal_options(const Scene& scene, const SolveOptions& options);

/// solve() on any F the solvers take, their overloads found by argument-dependent lookup (the
/// distributed module's rows too).
template <class Matrix>
SolveResult solve_problem(const Scene& scene, const Matrix& F, const PatchProperties& props,
                          const SolveOptions& options) {
    Stopwatch sw;
    SolveResult result;
    if (options.thermal)
        result.thermal = solve_thermal(F, props, thermal_options(scene, options));
    else
        result.radiosity = solve_radiosity(F, props, options.solver);
    result.timings.add("solve", sw.lap());
    return result;
}

}  // namespace detail

}  // namespace formfactor
