#pragma once
// Pieces shared by the subcommands: scene and method options, their validation, timing and the
// printed summary. Everything here throws formfactor::OptionError / InputError; main() turns
// them into one line on stderr and an exit code.

#include <CLI/CLI.hpp>
#include <chrono>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "formfactor/core/atomic_file.h"
#include "formfactor/matrix/form_factors.h"
#include "formfactor/matrix/memory.h"
#include "formfactor/matrix/reciprocity.h"
#include "formfactor/methods/method.h"
#include "formfactor/output/report.h"
#include "formfactor/pipeline.h"
#include "formfactor/scene/scene.h"
#include "formfactor/visibility/visibility.h"

namespace formfactor::cli {

/// The built-in scene names and the generators, comma-separated (for help texts).
std::string builtin_scene_list();
std::string generator_list();

/// The top-level --help's footer: scenes, generators, methods, matrix formats, exit codes,
/// licence (tests compare its lists with the README's).
std::string help_footer();

/// SCENE plus --subdivide N | --max-edge L.
struct SceneArgs {
    std::string scene;
    int subdivide = 1;
    double max_edge = 0.0;
    std::string zone;             ///< --zone NAME (EnergyPlus models)
    bool merge_coplanar = false;  ///< --merge-coplanar
    CLI::Option* subdivide_opt = nullptr;
    CLI::Option* max_edge_opt = nullptr;

    /// Registers SCENE (positional; required unless `default_scene` is given) and the
    /// subdivision options on `cmd`.
    void add_to(CLI::App* cmd, const std::string& default_scene = "");
    /// Throws OptionError for a bad value or for both options at once.
    void validate() const;
    /// The validated subdivision (n = 1 and no max edge when neither option was given).
    SubdivisionOptions subdivision() const;
    /// The pipeline's scene options: SCENE and subdivision().
    SceneOptions options() const;
    /// The options as JSON for the report.
    nlohmann::json to_json() const;
};

/// --method, --threads, --tolerance, --samples, --seed, --resolution, --points.
struct MethodArgs {
    std::string method;  ///< empty = default_method(scene)
    MethodOptions options;
    std::string sampler = "sobol";  ///< --sampler, parsed into options.sampler
    VisibilityOptions visibility;   ///< --ray-offset, --robust-rays
    long long samples = 0;  ///< parsed signed so that a negative value is caught, not wrapped
    long long seed = 1;
    bool tolerance_given = false;  ///< --tolerance also sets options.obstructed_tolerance

    void add_to(CLI::App* cmd);
    /// Throws OptionError for what only the command line can get wrong (a negative --samples or
    /// --seed, an unknown --method or --sampler), then validate(compute_options()): the library
    /// checks its own options and names their fields, which main() shows as flags (cli_flag()).
    void validate() const;
    /// The method options (samples, seed and sampler copied in).
    MethodOptions method_options() const;
    /// The pipeline's options: the method (unset without --method: the library chooses), its
    /// options and the ray tracer's.
    ComputeOptions compute_options() const;
    /// The method: --method, else default_method(scene).
    MethodKind resolved_kind(const Scene& scene) const;
    /// Every option as JSON for the report (with the resolved method name).
    nlohmann::json to_json(const std::string& resolved_method) const;
};

/// The scene of `args` through the pipeline (prepare_scene(): loaded, then subdivided, both
/// timed into `times`). With `needs`, a dense run that will not fit in memory is refused between
/// the two steps, before anything big exists: the patches `args` will make are counted, the
/// run's peak estimated with `needs` (its patch count is filled in here), and ResourceError names
/// what it needs, what is available and which flags to change. `needs` is a function of the
/// loaded scene (the method's needs depend on it).
Scene prepare_scene(const SceneArgs& args, StepTimes& times,
                    const std::function<DenseRunNeeds(const Scene&)>& needs = {});

/// The context of a report that every command fills alike: `command`, `method`, the scene's
/// options (SceneArgs::to_json()), the steps timed so far, the wall time since `total` started,
/// `threads`, the method's `details` and its reciprocity `promise`.
ReportContext report_context(const std::string& command, const std::string& method,
                             const SceneArgs& scene, const StepTimes& times, const Stopwatch& total,
                             int threads, const nlohmann::json& details,
                             const ReciprocityPromise& promise);

/// Stages `report` (json_text()) at `path` in `tx`.
void stage_report(OutputTransaction& tx, const std::string& path, const nlohmann::json& report);

/// For the commands that make F (compute, solve, run): a scene of one patch has the 1×1 matrix
/// [0] (a planar patch does not see itself: there is nothing to exchange with). When the scene
/// has one patch, prints that as a warning on stderr and adds it to scene.warnings (the report's
/// scene block).
void warn_single_patch(Scene& scene);
/// A warning on stderr when no row of F has anything in it although the patches are not all in
/// one plane: fronts that all face away from each other (a closed solid that faces outwards).
void warn_if_nothing_seen(const Scene& scene, double row_sum_max);

/// Per-patch emissivities from the scene's materials (for View3D's .txt).
std::vector<double> patch_emissivities(const Scene& scene);

/// A time for people: "0.012 s", "3.4 s", "2 min 05 s".
std::string format_seconds(double s);
/// "load 0.001 s, compute 1.2 s, ..., total 1.3 s".
std::string format_timings(const StepTimes& times, double total);

/// Prints the compute summary (N, method, row sums, reciprocity measured against `promise`,
/// timings) to stdout.
void print_matrix_summary(const Scene& scene, const std::string& method, int threads,
                          const FormFactors& ff, const Diagnostics& d,
                          const ReciprocityPromise& promise, const StepTimes& times, double total);

/// The reciprocity lines of the summaries: "reciprocity area-weighted …: verdict" and, when the
/// worst pair is not 0, "            worst pair (i, j): |A_i F_ij - A_j F_ji| / max(...) = x".
void print_reciprocity(const Diagnostics& d, const ReciprocityPromise& promise);

/// The flag of a library option field: "max_edge" → "--max-edge", "output" → "-o"; a flag stays
/// as it is.
std::string cli_flag(const std::string& field);

/// A library message as the CLI shows it: each option field quoted in backquotes ("raise
/// `max_iterations`") becomes its flag ("raise --max-iterations"), by cli_flag().
std::string cli_text(const std::string& message);

/// True when the two paths name the same file (after normalisation; they need not exist).
bool same_file(const std::string& a, const std::string& b);

/// True when `path`'s extension is `ext` (".vtu"; case-insensitive).
bool has_extension(const std::string& path, const std::string& ext);

/// Throws OptionError(option, ...) unless `path`'s extension is `ext` (case-insensitive).
void require_extension(const std::string& path, const std::string& ext, const std::string& option);

}  // namespace formfactor::cli
