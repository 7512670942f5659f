#pragma once
/// The JSON run report: what was computed, how, how long it took, and what the matrix looks like
/// (DESIGN.md, "Repair and diagnostics"). Users script against its keys: they are a contract —
/// add keys, never rename or remove them. Layout (every time in seconds of wall-clock time):
///
///     { "formfactor_version": "0.1.0", "timestamp": "2024-01-31T12:00:00Z",
///       "command": "compute", "scene": { scene_summary_json() }, "N": 42,
///       "method": "analytic", "options": { every option, as resolved },
///       "threads": 2, "timings": { "load": s, "subdivide": s, "compute": s, ..., "total": s },
///       "diagnostics": { diagnostics_json() }, "details": { the method's own fields },
///       "outputs": { "matrix": "F.npy", ... }, "memory": { "peak_bytes": bytes },
///       and the sections the run has: "storage", "repair", "per_surface", "solve", "render",
///       "rows", "note" (ReportContext) }

#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "formfactor/core/fields.h"
#include "formfactor/core/timing.h"
#include "formfactor/matrix/form_factors.h"
#include "formfactor/matrix/reciprocity.h"
#include "formfactor/matrix/repair.h"
#include "formfactor/scene/scene.h"

namespace formfactor {

/// Everything the report says that is not in the scene or the matrix: a front end fills in what
/// it has and make_report() writes the report's top-level keys from it (they are written nowhere
/// else). A section left null is left out of the report.
struct ReportContext {
    std::string command = "compute";                    ///< the CLI subcommand (or API caller)
    std::string method;                                 ///< Method::name()
    nlohmann::json options = nlohmann::json::object();  ///< every option, as resolved
    StepTimes timings;                                  ///< per step
    double total_seconds = 0.0;  ///< wall time from start to the report (≥ the sum of steps)
    int threads = 0;             ///< threads actually used
    nlohmann::json details = nlohmann::json::object();  ///< Method::compute()'s details
    nlohmann::json outputs = nlohmann::json::object();  ///< role → path of each file written
    /// What the method promises about reciprocity (method_traits()); unknown by default.
    ReciprocityPromise reciprocity;
    /// "storage": how F is held when it is not one dense matrix ({"kind", "why", ...}).
    nlohmann::json storage = nullptr;
    /// "diagnostics" of an F not held dense (a dense F's are computed from it by make_report()).
    nlohmann::json diagnostics = nullptr;
    /// "memory" of an F not held dense, {"peak_bytes", ...} (memory_json() for the peak alone).
    nlohmann::json memory = nullptr;
    nlohmann::json repair = nullptr;       ///< "repair": what the repair changed
    nlohmann::json per_surface = nullptr;  ///< "per_surface": the per-surface matrix written
    nlohmann::json solve = nullptr;        ///< "solve": the solution's summary
    nlohmann::json render = nullptr;       ///< "render": the image rendered
    std::string note;                      ///< "note" when not empty: a remark on the run
};

/// The diagnostics as JSON: {"row_sum": {"min", "max", "mean"}, "reciprocity": {...},
/// "negative_entries", "entries_above_one", "nonfinite_entries", "max_abs_diagonal"}, with
/// "reciprocity": {"max_defect", "i", "j": the worst pair, max |A_i F_ij − A_j F_ji| /
/// max(A_i F_ij, A_j F_ji) at (i, j), 0-based patch indices; "area_weighted": Σ_ij |A_i F_ij −
/// A_j F_ji| / Σ_ij A_i F_ij; "row_relative": {"max", "row"}: max_i Σ_j |A_i F_ij − A_j F_ji| /
/// (A_i Σ_j F_ij); "z": null, or with standard errors {"max", "rms", "pairs", "i", "j",
/// "zero_se_pairs", "zero_entries"}: the defect in units of its standard error (see
/// Diagnostics); "verdict": {"promise": "exact" |
/// "statistical" | "approximate" | "unknown", "within": true | false | null, "text", and
/// "tolerance" (exact) or "z_max_limit", "z_rms_limit" (statistical)}}. The verdict compares with
/// `promise` (assess_reciprocity()).
nlohmann::json diagnostics_json(const Diagnostics& d, const ReciprocityPromise& promise = {});

/// The one-line reciprocity summary the CLI prints: "area-weighted 1.2e-03, worst row 3.4e-03
/// (patch 7), z max 3.1 RMS 0.98: consistent with chance (...)".
std::string reciprocity_summary(const Diagnostics& d, const ReciprocityPromise& promise);

/// The per-entry standard errors of a Monte-Carlo estimate: {"max", "mean"} over the matrix, or
/// null when the method gives none (exact methods).
nlohmann::json standard_error_json(const FormFactors& ff);

/// A summary of a scene: {"name", "title", "surfaces" (those with rows: not obstructions),
/// "obstructions", "patches", "materials", "enclosure", "total_area", "patch_area": {"min",
/// "max"}, "bounds": {"min": [x,y,z], "max": [x,y,z]}, "warnings": [...]}.
nlohmann::json scene_summary_json(const Scene& scene);

/// The report of a run whose F is not one dense matrix (a sparse one, a hierarchical operator,
/// rows kept on MPI ranks): "formfactor_version", "timestamp", "command", "scene"
/// (scene_summary_json()), "N" (`n`, the patches), "method", "options", "threads", "timings"
/// (each step, and "total": the larger of ctx.total_seconds and the steps' sum), "details",
/// "outputs", and each section of `ctx` that is set.
nlohmann::json make_report(const Scene& scene, std::size_t n, const ReportContext& ctx);

/// The report for F computed on `scene`: make_report(scene, n, ctx) with "diagnostics"
/// (diagnose(ff), with the standard errors when ff has them; the reciprocity verdict against
/// ctx.reciprocity; and "standard_error": standard_error_json(ff)) and "memory": memory_json().
/// A block of rows has no row sums or reciprocity to diagnose: its "diagnostics" are
/// {"standard_error"} alone, "N" counts every patch and "rows" is [first, end) of the block.
nlohmann::json make_report(const Scene& scene, const FormFactors& ff, ReportContext ctx);

/// The report's "memory" section when the peak is all it says: {"peak_bytes": the process's
/// peak resident memory so far}.
nlohmann::json memory_json();

/// The report of repair(): mode, the diagnostics before and after, the changes, the closure
/// iterations, the warnings.
nlohmann::json to_json(const RepairReport& report);

/// A Fields tree as JSON (objects keep their keys; lists of reals become arrays).
nlohmann::json to_json(const Fields& fields);

/// The current UTC time as ISO 8601, e.g. "2024-01-31T12:00:00Z".
std::string utc_timestamp();

/// The report's text: two-space indentation, a final newline (NaN and Inf become null).
std::string json_text(const nlohmann::json& j);

/// Writes json_text(j) to `path` atomically.
void write_json_file(const std::string& path, const nlohmann::json& j);

}  // namespace formfactor
