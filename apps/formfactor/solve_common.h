#pragma once
// Pieces shared by `solve`, `render` and `run`: solver and repair options, the
// stage that turns a scene and F into a solution, and the printed summaries.

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "common.h"
#include "formfactor/core/atomic_file.h"
#include "formfactor/distributed/distributed.h"
#include "formfactor/matrix/repair.h"
#include "formfactor/output/render.h"
#include "formfactor/pipeline_solve.h"
#include "formfactor/scene/scene.h"
#include "formfactor/solve/properties.h"
#include "formfactor/solve/radiosity.h"
#include "formfactor/solve/thermal.h"

namespace formfactor::cli {

/// --repair MODE and --force-closure.
struct RepairArgs {
    std::string mode = "none";
    bool force_closure = false;

    void add_to(CLI::App* cmd);
    /// Throws OptionError("--repair") for an unknown mode.
    RepairOptions options(const Scene& scene) const;
};

/// F as the pipeline computed it (formfactor/pipeline.h), with what the commands print and
/// report.
struct ComputedMatrix {
    FormFactors ff;                        ///< after repair, when asked
    nlohmann::json details;                ///< the method's report, as the run report's "details"
    std::optional<RepairReport> repaired;  ///< what repair did
    Diagnostics raw;                       ///< of F as the method made it (before repair)
};

/// Under mpirun: prints what each rank computed in the last run (rows, busy seconds,
/// imbalance); nothing on one process.
void print_rank_shares(int threads);

/// Computes F of `scene` through the pipeline (over every MPI rank under mpirun) with the method
/// and repair options, progress on the terminal; prints the repair line; adds the pipeline's
/// steps to `times`.
ComputedMatrix compute_matrix(const Scene& scene, const MethodArgs& method,
                              const RepairArgs& repair, StepTimes& times);

/// F read from `source` (--matrix) through the pipeline (form_factors_from_matrix(): its shape
/// checked against the scene, diagnosed, repaired); prints the repair line; adds the pipeline's
/// steps to `times`.
ComputedMatrix use_matrix(const Scene& scene, DenseMatrix F, const std::string& source,
                          const RepairArgs& repair, StepTimes& times);

/// --solver, --residual, --max-iterations, --allow-unconverged.
struct SolverArgs {
    std::string solver;  ///< empty = the default of the problem (gauss-seidel / direct)
    double residual = 1e-8;
    long long max_iterations = 0;
    bool allow_unconverged = false;

    void add_to(CLI::App* cmd);
    /// The solver asked for, else the pipeline's default for F held as `storage` and the
    /// problem (default_solver()). Throws OptionError for a bad value.
    SolverOptions options(Storage storage, bool thermal, int threads) const;
};

/// The hierarchical operator of `scene` at `error_target` (--error-target, checked here) as a
/// command holds it: under mpirun over the ranks (distributed::build_hierarchical(),
/// formfactor/distributed/distributed.h: the blocks stay on the ranks), else through the pipeline
/// in this process. Progress on the terminal; adds its step to `times` and prints the operator
/// line, and over the ranks a line of what the ranks did.
struct HeldOperator {
    std::optional<HierarchicalFormFactors> whole;                ///< one process
    std::optional<distributed::DistributedHierarchical> spread;  ///< over the ranks
    const HierarchicalStats& stats() const { return spread ? spread->stats : whole->stats(); }
};
HeldOperator held_operator(const Scene& scene, double error_target, int threads, StepTimes& times);
/// The operator's statistics for a report (details.hierarchical / storage).
nlohmann::json to_json(const HierarchicalStats& s);
/// What the ranks did for the operator (details.mpi of a report).
nlohmann::json to_json(const distributed::DistributedHierarchical& H);

/// Solves the problem of `options` on F (a FormFactors, a sparse F, the hierarchical operator,
/// or rows spread over MPI ranks) through the pipeline (solve(), formfactor/pipeline_solve.h),
/// prints the summary, stages the result at `output` (the table, or for a `.vtu` path the
/// patches of `scene` with the solution, area, row sum and sky factor) and returns the report's
/// "solve" section. Adds the solve's step to `times` and restarts `sw` after it.
template <class Matrix>
nlohmann::json solve_and_stage(const Matrix& F, const PatchProperties& props,
                               const SolveOptions& options, const std::string& output,
                               StepTimes& times, Stopwatch& sw, OutputTransaction& tx,
                               const Scene& scene);

/// Patches whose material emits (left out of the automatic exposure).
std::vector<bool> emitting_patches(const Scene& scene);

/// Prints the solve summary lines (solver, iterations, residual, time, energy
/// balance) and the warnings (to stderr, "formfactor: warning: ...").
void print_radiosity_summary(const RadiosityResult& r);
void print_thermal_summary(const ThermalResult& r);
void print_warnings(const std::vector<std::string>& warnings);
/// Prints the warnings a method's report carries (a closed model that lost rays).
void print_method_warnings(const MethodReport& report);

}  // namespace formfactor::cli
