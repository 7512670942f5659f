#pragma once
/// The pipeline API: what the CLI and the Python module call, and what another program embeds.
///
///     formfactor::Scene scene = formfactor::load_scene("room.obj");
///     formfactor::subdivide(scene, {.n = 4});
///     formfactor::ComputeOptions options;          // analytic (the default for every scene)
///     options.method = formfactor::MethodKind::mc_hemisphere;
///     options.method_options.samples = 100000;
///     const formfactor::ComputeResult r = formfactor::compute_form_factors(scene, options);
///     // r.form_factors.F(i, j): from patch i to patch j; r.report.error_bound_per_entry, ...
///
/// Options are typed (enums, not strings); errors name the option field (OptionError::field(),
/// e.g. "method_options.samples"), never a command-line flag. Nothing is drawn unless a progress
/// sink is given; a computation stops when its cancellation flag is requested (Cancelled).
/// Rows: ComputeOptions::rows computes a block [begin, end) of rows, bit-identical to the same
/// rows of the whole matrix (for a caller that distributes rows: MPI, a streaming writer).

#include <optional>

#include "formfactor/core/cancel.h"
#include "formfactor/core/progress.h"
#include "formfactor/core/timing.h"
#include "formfactor/matrix/form_factors.h"
#include "formfactor/matrix/repair.h"
#include "formfactor/methods/method.h"
#include "formfactor/methods/traits.h"
#include "formfactor/scene/scene.h"
#include "formfactor/visibility/visibility.h"

namespace formfactor {

/// Everything compute_form_factors() reads.
struct ComputeOptions {
    /// The estimator; unset: default_method(scene) (the most accurate that handles the scene).
    std::optional<MethodKind> method;
    MethodOptions method_options;
    /// The ray tracer's options, for the methods that cast rays.
    VisibilityOptions visibility;
    /// The rows of F to compute (every row by default).
    RowRange rows;
    /// Repair of F after the method (whole matrices only); RepairMode::none by default. The
    /// enclosure flag is taken from the scene.
    RepairOptions repair;
    /// Where progress goes; null (the default): nowhere.
    ProgressSink* progress = nullptr;
    /// Polled by every loop of the computation; null: the process-wide flag.
    const CancellationFlag* cancel = nullptr;
};

/// What compute_form_factors() returns.
struct ComputeResult {
    /// F (rows options.rows), its areas, and per-entry standard errors (Monte Carlo).
    FormFactors form_factors;
    /// The method's report: error bound, pair classes, rays, its own fields.
    MethodReport report;
    /// What the method promises (reciprocity verdict, standard errors).
    MethodTraits traits;
    /// Row sums, reciprocity (with z-scores for standard errors), signs of F as the method made
    /// it, before repair (repair->after describes the repaired one); only for whole matrices.
    std::optional<Diagnostics> diagnostics;
    /// What repair did, when it was asked for.
    std::optional<RepairReport> repair;
    /// Wall time per step: "visibility" (when built), "compute", "repair".
    StepTimes timings;
    /// Threads the computation used.
    int threads = 0;
};

/// Throws OptionError (naming the field) for an invalid option of `options`.
void validate(const ComputeOptions& options);

/// The form factors of scene.patches (subdivide first): validates the options, refuses a run
/// that will not fit in memory (ResourceError, before allocating), checks that the method can
/// handle the scene, builds the ray tracer once when the method casts rays, computes, repairs
/// and diagnoses.
ComputeResult compute_form_factors(const Scene& scene, const ComputeOptions& options = {});

}  // namespace formfactor
