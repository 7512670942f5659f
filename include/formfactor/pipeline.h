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

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "formfactor/core/cancel.h"
#include "formfactor/core/progress.h"
#include "formfactor/core/timing.h"
#include "formfactor/matrix/form_factors.h"
#include "formfactor/matrix/repair.h"
#include "formfactor/methods/method.h"
#include "formfactor/methods/traits.h"
#include "formfactor/scene/obstruction.h"
#include "formfactor/scene/projection_view.h"
#include "formfactor/scene/scene.h"
#include "formfactor/visibility/visibility.h"

namespace formfactor {

/// Where a scene comes from and how its surfaces are split into patches.
struct SceneOptions {
    /// A file (.obj, .vs3) or a built-in scene name (builtin_scene_names()).
    std::string source;
    SubdivisionOptions subdivision;
    /// An EnergyPlus model's zone (formfactor/scene/energyplus.h); empty: its only zone. Only
    /// for `.idf` and `.epJSON` sources.
    std::string zone;
    /// Merge the coplanar, edge-connected faces of each surface group into polygons before
    /// subdividing (merge_coplanar(): a triangulated STL box becomes its 6 faces).
    bool merge_coplanar = false;
};

/// Loads options.source (and its zone), not subdivided. Throws InputError for a bad file,
/// OptionError("zone") for a zone given with a source that is not an EnergyPlus model.
Scene load_scene(const SceneOptions& options);

/// Loads options.source, merges its coplanar faces when options.merge_coplanar, and subdivides
/// it: the first step of every computation. The steps are timed into *times ("load",
/// "merge coplanar", "subdivide") when it is given. `before_subdivide`, when given, sees
/// the loaded scene before its patches exist: the place to refuse a run that would not fit
/// (subdivision_patch_count() counts the patches without making them). Throws InputError for a
/// bad file, OptionError("subdivide" / "max_edge") for a bad subdivision.
Scene prepare_scene(const SceneOptions& options, StepTimes* times = nullptr,
                    const std::function<void(const Scene&)>& before_subdivide = {});

/// Everything compute_form_factors() reads.
struct ComputeOptions {
    /// The estimator; unset: default_method(scene) (the most accurate that handles the scene).
    std::optional<MethodKind> method;
    MethodOptions method_options;
    /// The ray tracer's options, for the methods that cast rays.
    VisibilityOptions visibility;
    /// A ray tracer already built for this scene (make_visibility(scene, visibility)) to use
    /// instead of building one: a caller computing many row blocks of one scene builds it once.
    /// Null (the default): built here when the method casts rays.
    const Visibility* prebuilt_visibility = nullptr;
    /// Rows emitted sparse: when set and the method emits sparse rows
    /// (Method::emits_sparse_rows()), the rows go here and the result's form_factors.F is empty
    /// (0 × N); no rows × N block is made. compute_sparse_form_factors() uses it; null (the
    /// default): dense rows.
    SparseRows* sparse_rows = nullptr;
    /// analytic: MethodContext::partly_hidden (null by default).
    const PartlyHiddenPairs* partly_hidden = nullptr;
    /// analytic, a block of rows: MethodContext::upper_triangle_only (false by default).
    bool upper_triangle_only = false;
    /// The rows of F to compute (every row by default).
    RowRange rows;
    /// Repair of F after the method (whole matrices only); RepairMode::none by default. The
    /// enclosure flag is known_enclosure(scene): declared, or a closed model.
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

/// F made elsewhere (read from a file, another program) used as the pipeline's own: checks that
/// it is the square matrix of scene.patches (else InputError(source, 0, ...) naming both sizes),
/// takes the patches' areas, diagnoses it and repairs it as compute_form_factors() does. The
/// result's report names no method, its traits promise nothing (reciprocity unknown) and its
/// timings hold "repair" when it repaired.
ComputeResult form_factors_from_matrix(const Scene& scene, DenseMatrix F,
                                       const RepairOptions& repair = {},
                                       const std::string& source = "matrix");

/// Everything compute_point_form_factors() reads: M differential elements (sensors, the points
/// of a mean-radiant-temperature map), each a position and a front normal (normalised there).
struct PointOptions {
    std::vector<Vec3> positions;
    std::vector<Vec3> normals;
    /// Worker threads (0: all cores), as MethodOptions::threads.
    int threads = 0;
    /// Polled by the computation; null: the process-wide flag.
    const CancellationFlag* cancel = nullptr;
    /// Where progress goes; null (the default): nowhere.
    ProgressSink* progress = nullptr;
};

/// What compute_point_form_factors() returns.
struct PointResult {
    /// M × N: row m is point m, column j patch j of scene.patches (point_form_factors()).
    DenseMatrix F;
    /// Wall time: "compute".
    StepTimes timings;
    /// Threads the computation used.
    int threads = 0;
};

/// Throws OptionError (naming the field: "threads", "normals") for an invalid option.
void validate(const PointOptions& options);

/// F from each point of `options` to every patch of `scene`, exact with obstructions
/// (point_form_factors() in formfactor/methods/point_factors.h): validates, refuses an M × N
/// result that will not fit in memory (ResourceError), computes.
PointResult compute_point_form_factors(const Scene& scene, const PointOptions& options);

/// What one point of a patch sees through a projection method (`formfactor inspect`).
struct ViewOptions {
    /// MethodKind::hemicube or MethodKind::hemiplane.
    MethodKind method = MethodKind::hemicube;
    /// The patch whose point looks along its normal (its own cells are not drawn).
    long long patch = 0;
    /// The point; unset: the patch's centroid.
    std::optional<Vec3> point;
    /// Cells per side; 0: 256 for the hemicube, 512 for the hemiplane.
    int resolution = 0;
    /// Turn of the cube or plane about the normal, in degrees.
    double rotation_degrees = 0.0;
};

/// The share of a point's view that one item takes: a patch (item ≥ 0) or kViewNothing /
/// kViewBackFace / kViewObstruction, with the sum of the delta form factors of its cells.
struct ViewShare {
    int item = 0;
    double form_factor = 0.0;
};

/// What patch_view() returns.
struct PatchView {
    /// The item buffer with the delta form factor of every cell.
    ProjectionView view;
    /// The point that looks, and its normal (the patch's).
    Vec3 point = Vec3::Zero();
    Vec3 normal = Vec3::Zero();
    /// The resolution used (options.resolution or its default).
    int resolution = 0;
    /// What the point sees, largest share first.
    std::vector<ViewShare> seen;
};

/// Throws OptionError (naming the field: "method", "point", "resolution", "rotation") for an
/// invalid option; the patch index is checked against the scene by patch_view().
void validate(const ViewOptions& options);

/// The view from options.point (or the centroid) of patch options.patch through the hemicube or
/// the hemiplane (hemicube_view(), hemiplane_view()), and what it sees. Throws OptionError
/// ("patch") for an index outside the scene's patches, and as validate().
PatchView patch_view(const Scene& scene, const ViewOptions& options);

}  // namespace formfactor
