// The pipeline: options checked, memory estimated, the ray tracer built once, the method run on
// the rows asked for, repair and diagnostics.

#include "formfactor/pipeline.h"

#include <cmath>
#include <string>

#include "formfactor/core/error.h"
#include "formfactor/core/parallel.h"
#include "formfactor/matrix/memory.h"

namespace formfactor {

void validate(const ComputeOptions& options) {
    const MethodOptions& m = options.method_options;
    if (m.threads < 0 || m.threads > 4096)
        throw OptionError("threads",
                          "must be from 0 (all cores) to 4096, got " + std::to_string(m.threads));
    if (!(std::isfinite(m.tolerance) && m.tolerance > 0.0))
        throw OptionError("tolerance", "must be a finite number > 0");
    if (!(std::isfinite(m.obstructed_tolerance) && m.obstructed_tolerance > 0.0))
        throw OptionError("obstructed_tolerance", "must be a finite number > 0");
    if (m.resolution < 1)
        throw OptionError("resolution", "must be ≥ 1, got " + std::to_string(m.resolution));
    if (m.points < 1) throw OptionError("points", "must be ≥ 1, got " + std::to_string(m.points));
    const VisibilityOptions& v = options.visibility;
    if (!(std::isfinite(v.relative_epsilon) && v.relative_epsilon > 0.0 &&
          v.relative_epsilon < 0.01))
        throw OptionError("ray_offset", "must be a relative offset in (0, 0.01)");
    if (options.rows.begin > options.rows.end)
        throw OptionError("rows", "begin must not be after end");
}

ComputeResult compute_form_factors(const Scene& scene, const ComputeOptions& options) {
    validate(options);
    const CancellationFlag& flag = options.cancel ? *options.cancel : process_cancellation();
    const CancellationScope scope(flag);
    flag.throw_if_requested();

    ComputeResult result;
    const MethodKind kind = options.method ? *options.method : default_method(scene);
    const std::size_t n = scene.patches.size();
    const RowRange rows = options.rows.clamped(n);
    const bool whole = rows.size() == n;
    if (!whole && options.repair.mode != RepairMode::none)
        throw OptionError("repair", "needs the whole matrix (a row range was asked for)");
    result.traits = method_traits(kind, options.method_options, &scene);

    // Memory before anything big exists: the rows, their standard errors, repair's copy.
    // mc-target still builds the whole matrix for a block of rows; the analytic method's block
    // holds its rows and, for the rows before it, their pairs with the block (≤ N × rows).
    const bool full_inside = kind == MethodKind::mc_target;
    const bool strip = kind == MethodKind::analytic && !whole;
    DenseRunNeeds needs;
    needs.patches = n;
    needs.matrix = whole || full_inside;
    needs.standard_errors = result.traits.standard_errors && (whole || full_inside);
    needs.output_rows =
        whole ? 0 : rows.size() * ((result.traits.standard_errors ? 2 : 1) + (strip ? 1 : 0));
    needs.repair = options.repair.mode != RepairMode::none;
    check_memory(needs, available_memory(),
                 "use a coarser subdivision, or compute the rows in blocks (ComputeOptions::rows)");

    const auto method = make_method(kind);
    method->check(scene);
    Stopwatch sw;
    std::unique_ptr<Visibility> visibility;
    if (method->needs_visibility() && n > 0) {
        visibility = make_visibility(scene, options.visibility);
        result.timings.add("visibility", sw.lap());
    }
    MethodContext ctx{scene, options.method_options, visibility.get(), options.progress, rows};
    MethodResult computed = method->compute(ctx);
    result.timings.add("compute", sw.lap());
    result.form_factors = std::move(computed.form_factors);
    result.report = std::move(computed.report);
    result.threads = effective_threads(options.method_options.threads);

    if (whole) result.diagnostics = diagnose(result.form_factors);  // before repair
    if (options.repair.mode != RepairMode::none) {
        RepairOptions ro = options.repair;
        ro.enclosure = scene.enclosure;
        result.repair = repair(result.form_factors.F, result.form_factors.areas, ro);
        result.timings.add("repair", sw.lap());
    }
    return result;
}

}  // namespace formfactor
