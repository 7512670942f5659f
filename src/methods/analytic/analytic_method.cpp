// The `analytic` method: the unobstructed form factors (kernels/unobstructed.h: every unordered
// pair once, exactly when near, by a Gauss rule with an a-priori error bound when far, the other
// entry by reciprocity). In obstructed scenes the obstruction pass
// (analytic_obstructed.cpp) then corrects the pairs that something may block.

#include "methods/analytic/analytic_method.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "formfactor/core/error.h"
#include "formfactor/core/parallel.h"
#include "formfactor/core/progress.h"
#include "formfactor/kernels/analytic.h"
#include "kernels/analytic_internal.h"

namespace formfactor {

void AnalyticMethod::check(const Scene&) const {
    // Every scene: obstructed ones go through the obstruction pass of compute().
}

double AnalyticMethod::visible_tolerance(const MethodOptions& options, bool obstructed) {
    if (!(options.tolerance > 0.0) || !std::isfinite(options.tolerance))
        throw OptionError("tolerance", "must be a positive number (absolute error per entry)");
    return obstructed ? std::min(options.tolerance, kVisibleTolerance) : options.tolerance;
}

MethodResult AnalyticMethod::compute(const MethodContext& ctx) const {
    const Scene& scene = ctx.scene;
    const MethodOptions& options = ctx.options;
    const std::size_t n = scene.patches.size();
    const RowRange rows = ctx.rows.clamped(n);
    // In an obstructed scene the unobstructed values (kept for the fully visible pairs, the
    // reference of the partly hidden ones) stay at ≤ 1e-10: they are cheap, and the closure of
    // the rows rests on them; options.obstructed_tolerance governs the partly hidden pairs.
    const bool obstructed = formfactor::may_obstruct(scene);
    const double tol = visible_tolerance(options, obstructed);
    MethodResult result;
    MethodReport& report = result.report;
    report.method = kind();
    if (ctx.sparse_rows) {
        // Rows emitted sparse (the pipeline asks only when the scene may obstruct): the pairs
        // the classification finds visible or partly hidden, nothing for the others.
        if (!obstructed)
            throw Error("analytic: sparse rows are emitted only for scenes that may obstruct");
        sparse_obstructed_rows(ctx, tol, result);
        return result;
    }
    FormFactors& out = result.form_factors;
    std::vector<const Polygon*> polys(n);
    for (std::size_t p = 0; p < n; ++p) polys[p] = &scene.patches[p].polygon;
    const bool whole = rows.size() == n;
    Progress progress("analytic", rows.size(), ctx.progress);
    detail::UnobstructedBlock block;
    const detail::UnobstructedStats total = detail::unobstructed_rows(
        polys, tol, options.threads, &progress, rows, block,
        ctx.upper_triangle_only && (!obstructed || ctx.partly_hidden), given_table(ctx));
    progress.finish();
    out.areas = block.areas;
    if (whole) out.F = std::move(block.F);
    Fields& details = report.details;
    Fields hist = Fields::object();
    for (int o = 1; o <= kMaxFarFieldOrder; ++o)
        if (total.order_hist[static_cast<std::size_t>(o)] > 0)
            hist[std::to_string(o)] = total.order_hist[static_cast<std::size_t>(o)];
    // Every unordered pair for the whole matrix; the pairs a block needed for a block.
    report.pairs =
        PairClasses{total.zero + total.exact + total.far, total.zero, total.exact, total.far};
    details["far_field_kernel_evaluations"] = total.points;
    details["far_field_orders"] = hist;
    details["tolerance"] = tol;
    // Far-field orders are chosen so that the calibrated bound is ≤ tolerance for F_ij and F_ji;
    // the exact path is accurate to ~1e-13 (docs/analytic.md).
    report.error_bound_per_entry = std::max(tol, 1e-12);
    details["exact_path_error"] = 1e-12;
    details["threads"] = effective_threads(options.threads);
    details["obstructed"] = obstructed;
    if (obstructed) {
        apply_obstructions(ctx, out, details, whole ? nullptr : &block);
        report.error_bound_per_entry =
            std::max(std::max(tol, 1e-12), details["obstructions"]["max_error_estimate"].real());
    }
    if (!whole) {
        out.F = std::move(block.F);
        out.first_row = rows.begin;
    }
    return result;
}

}  // namespace formfactor
