// The pipeline: the scene loaded and subdivided; options checked, memory estimated, the ray
// tracer built once, the method run on the rows asked for, repair and diagnostics; F from a file
// treated alike; point factors; the view of one point through a projection method.

#include "formfactor/pipeline.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <string>

#include "formfactor/core/error.h"
#include "formfactor/core/parallel.h"
#include "formfactor/core/phase.h"
#include "formfactor/matrix/memory.h"
#include "formfactor/methods/hemicube.h"
#include "formfactor/methods/hemiplane.h"
#include "formfactor/methods/point_factors.h"
#include "formfactor/scene/closure.h"
#include "formfactor/scene/energyplus.h"
#include "formfactor/scene/merge_coplanar.h"

namespace formfactor {

namespace {

void validate_threads(int threads) {
    if (threads < 0)
        throw OptionError("threads", fmt::format("must be ≥ 0 (0 = all cores), got {}", threads));
    if (threads > 4096)
        throw OptionError("threads", fmt::format("{} is too many (at most 4096)", threads));
}

// The flag a computation polls: its own, else the process-wide one; Cancelled when it is
// already requested.
const CancellationFlag& requested_flag(const CancellationFlag* own) {
    const CancellationFlag& flag = own ? *own : process_cancellation();
    flag.throw_if_requested();
    return flag;
}

}  // namespace

Scene load_scene(const SceneOptions& options) {
    if (options.zone.empty()) return load_scene(options.source);
    std::string ext = std::filesystem::path(options.source).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    if (ext != ".idf" && ext != ".epjson")
        throw OptionError("zone",
                          "chooses a zone of an EnergyPlus model (.idf, .epJSON), not of '" +
                              options.source + "'");
    return load_energyplus(options.source, options.zone);
}

Scene prepare_scene(const SceneOptions& options, StepTimes* times,
                    const std::function<void(const Scene&)>& before_subdivide) {
    Stopwatch sw;
    Scene scene = load_scene(options);
    if (times) times->add("load", sw.lap());
    if (options.merge_coplanar) {
        const MergeReport merged = merge_coplanar(scene);
        scene.warnings.push_back(fmt::format(
            "`merge_coplanar`: {} faces merged into {} surfaces{}", merged.faces_before,
            merged.faces_after,
            merged.regions_kept ? fmt::format(" ({} coplanar regions kept as faces: their "
                                              "boundary touches itself)",
                                              merged.regions_kept)
                                : std::string()));
        if (times) times->add("merge coplanar", sw.lap());
    }
    if (before_subdivide) before_subdivide(scene);
    sw.lap();
    subdivide(scene, options.subdivision);
    if (times) times->add("subdivide", sw.lap());
    return scene;
}

void validate(const ComputeOptions& options) {
    const MethodOptions& m = options.method_options;
    validate_threads(m.threads);
    if (!(std::isfinite(m.tolerance) && m.tolerance > 0.0))
        throw OptionError("tolerance",
                          fmt::format("must be a finite number > 0, got {}", m.tolerance));
    if (!(std::isfinite(m.obstructed_tolerance) && m.obstructed_tolerance > 0.0))
        throw OptionError("obstructed_tolerance", fmt::format("must be a finite number > 0, got {}",
                                                              m.obstructed_tolerance));
    if (m.resolution < 1)
        throw OptionError("resolution", fmt::format("must be ≥ 1, got {}", m.resolution));
    if (m.points < 1) throw OptionError("points", fmt::format("must be ≥ 1, got {}", m.points));
    const VisibilityOptions& v = options.visibility;
    if (!(std::isfinite(v.relative_epsilon) && v.relative_epsilon > 0.0 &&
          v.relative_epsilon < 0.01))
        throw OptionError("ray_offset",
                          fmt::format("must be in (0, 0.01), got {}", v.relative_epsilon));
    if (options.rows.begin > options.rows.end)
        throw OptionError("rows", "begin must not be after end");
}

ComputeResult compute_form_factors(const Scene& scene, const ComputeOptions& options) {
    validate(options);
    const CancellationScope scope(requested_flag(options.cancel));

    ComputeResult result;
    const MethodKind kind = options.method ? *options.method : default_method(scene);
    const std::size_t n = scene.patches.size();
    const RowRange rows = options.rows.clamped(n);
    const bool whole = rows.size() == n;
    if (!whole && options.repair.mode != RepairMode::none)
        throw OptionError("repair", "needs the whole matrix (a row range was asked for)");
    result.traits = method_traits(kind, options.method_options, &scene);

    const auto method = make_method(kind);
    const bool emit_sparse = options.sparse_rows && method->emits_sparse_rows(scene);
    if (emit_sparse && options.repair.mode != RepairMode::none)
        throw OptionError("repair", "rows emitted sparse are repaired by the sparse pipeline");
    // Memory before anything big exists: the rows, their standard errors, repair's copy. The
    // analytic method's block (and mc-target's, which takes its unobstructed values from it)
    // holds its rows and, for the rows before it, their pairs with the block (≤ N × rows).
    // Rows emitted sparse need none of it.
    const bool strip = (kind == MethodKind::analytic || kind == MethodKind::mc_target) && !whole;
    DenseRunNeeds needs;
    needs.patches = n;
    needs.matrix = whole;
    needs.standard_errors = result.traits.standard_errors && whole;
    needs.output_rows =
        whole || emit_sparse
            ? 0
            : rows.size() * ((result.traits.standard_errors ? 2 : 1) + (strip ? 1 : 0));
    if (emit_sparse) needs.matrix = needs.standard_errors = false;
    needs.repair = options.repair.mode != RepairMode::none;
    check_memory(needs, available_memory(),
                 "use a coarser subdivision, or compute the rows in blocks (ComputeOptions::rows)");

    method->check(scene);
    Stopwatch sw;
    std::unique_ptr<Visibility> visibility;
    const Visibility* vis = options.prebuilt_visibility;
    if (method->needs_visibility() && n > 0 && !vis) {
        announce_phase("visibility");
        visibility = make_visibility(scene, options.visibility);
        vis = visibility.get();
        result.timings.add("visibility", sw.lap());
    }
    MethodContext ctx{scene,
                      options.method_options,
                      vis,
                      options.progress,
                      rows,
                      emit_sparse ? options.sparse_rows : nullptr,
                      options.partly_hidden};
    ctx.upper_triangle_only = options.upper_triangle_only;
    announce_phase("rows");
    MethodResult computed = method->compute(ctx);
    result.timings.add("compute", sw.lap());
    result.form_factors = std::move(computed.form_factors);
    result.report = std::move(computed.report);
    result.threads = effective_threads(options.method_options.threads);

    if (whole && !emit_sparse) {
        announce_phase("diagnose");
        result.diagnostics = diagnose(result.form_factors);
    }
    if (options.repair.mode != RepairMode::none) {
        announce_phase("repair");
        RepairOptions ro = options.repair;
        ro.enclosure = known_enclosure(scene);
        result.repair = repair(result.form_factors.F, result.form_factors.areas, ro);
        result.timings.add("repair", sw.lap());
    }
    return result;
}

ComputeResult form_factors_from_matrix(const Scene& scene, DenseMatrix F,
                                       const RepairOptions& repair_options,
                                       const std::string& source) {
    const std::size_t n = scene.patches.size();
    if (static_cast<std::size_t>(F.rows()) != n || F.rows() != F.cols())
        throw InputError(source, 0,
                         fmt::format("a {}x{} matrix, the scene has {} patches (same scene and "
                                     "subdivision?)",
                                     F.rows(), F.cols(), n));
    ComputeResult result;
    result.form_factors.F = std::move(F);
    result.form_factors.areas.reserve(n);
    for (const Patch& p : scene.patches) result.form_factors.areas.push_back(p.area);
    announce_phase("diagnose");
    result.diagnostics = diagnose(result.form_factors);
    if (repair_options.mode != RepairMode::none) {
        announce_phase("repair");
        Stopwatch sw;
        RepairOptions ro = repair_options;
        ro.enclosure = known_enclosure(scene);
        result.repair = repair(result.form_factors.F, result.form_factors.areas, ro);
        result.timings.add("repair", sw.lap());
    }
    return result;
}

void validate(const PointOptions& options) {
    validate_threads(options.threads);
    if (options.positions.size() != options.normals.size())
        throw OptionError("normals", fmt::format("{} normals for {} positions (one each)",
                                                 options.normals.size(), options.positions.size()));
}

PointResult compute_point_form_factors(const Scene& scene, const PointOptions& options) {
    validate(options);
    const CancellationScope scope(requested_flag(options.cancel));
    DenseRunNeeds needs;
    needs.patches = scene.patches.size();
    needs.matrix = false;
    needs.output_rows = options.positions.size();
    check_memory(needs, available_memory(), "use fewer points or a coarser subdivision");
    PointResult result;
    Stopwatch sw;
    result.F = point_form_factors(scene, options.positions, options.normals, options.threads,
                                  options.progress);
    result.timings.add("compute", sw.lap());
    result.threads = effective_threads(options.threads);
    return result;
}

void validate(const ViewOptions& options) {
    if (options.method != MethodKind::hemicube && options.method != MethodKind::hemiplane)
        throw OptionError("method", "a view shows 'hemicube' or 'hemiplane', not '" +
                                        to_string(options.method) + "'");
    if (options.point && !options.point->allFinite())
        throw OptionError("point", "coordinates must be finite numbers");
    if (options.resolution < 0)
        throw OptionError(
            "resolution",
            fmt::format("must be ≥ 0 (0 = the method's default), got {}", options.resolution));
    if (!std::isfinite(options.rotation_degrees))
        throw OptionError("rotation", "must be a finite angle");
}

PatchView patch_view(const Scene& scene, const ViewOptions& options) {
    validate(options);
    const long long n = static_cast<long long>(scene.patches.size());
    if (options.patch < 0 || options.patch >= n)
        throw OptionError("patch", fmt::format("must be a patch index from 0 to {}, got {}", n - 1,
                                               options.patch));
    const Patch& p = scene.patches[static_cast<std::size_t>(options.patch)];
    const bool cube = options.method == MethodKind::hemicube;
    PatchView out;
    out.point = options.point ? *options.point : p.centroid;
    out.normal = p.normal;
    out.resolution = options.resolution > 0 ? options.resolution : (cube ? 256 : 512);
    const double angle = options.rotation_degrees * kPi / 180.0;
    const int exclude = static_cast<int>(options.patch);
    out.view = cube ? hemicube_view(scene, out.point, p.normal, out.resolution, angle, exclude)
                    : hemiplane_view(scene, out.point, p.normal, out.resolution, angle, exclude);

    std::map<int, double> seen;
    for (std::size_t k = 0; k < out.view.items.size(); ++k)
        if (out.view.items[k] != kViewUnused) seen[out.view.items[k]] += out.view.delta[k];
    std::vector<std::pair<double, int>> order;
    for (const auto& [item, f] : seen) order.emplace_back(f, item);
    std::sort(order.rbegin(), order.rend());
    for (const auto& [f, item] : order) out.seen.push_back({item, f});
    return out;
}

}  // namespace formfactor
