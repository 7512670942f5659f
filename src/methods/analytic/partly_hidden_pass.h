#pragma once
// The partly hidden pass of the `analytic` method (not public API): every partly hidden pair
// settled by a body, in an order whose first pairs are a sample of the whole, so that the time
// they take, scaled, says what the pass will cost before the rest runs; and the partly hidden
// pairs given beforehand (MPI runs). What the dense pass and a block of rows
// (analytic_obstructed.cpp) and the sparse rows (sparse_rows.cpp) share. See docs/analytic.md,
// "What it will cost, said first".

#include <fmt/format.h>

#include <chrono>
#include <cstddef>
#include <string>

#include "formfactor/core/fields.h"
#include "formfactor/core/parallel.h"
#include "formfactor/core/phase.h"
#include "formfactor/core/progress.h"
#include "formfactor/methods/partly_hidden.h"
#include "methods/analytic/analytic_method.h"
#include "methods/analytic/classification.h"
#include "methods/analytic/partly_hidden_pairs.h"

namespace formfactor::detail {

// The partly hidden pass: body(k) for every pair k < count, in an order whose first pairs are
// spread evenly over the list (every stride-th), so that they are a sample of the whole: the
// progress bar's rate holds from the start, and the time they take, scaled, is the pass's.
// That estimate goes into the report before the rest runs and, when long, to the user with what
// would cost less. The values do not depend on the order.
inline constexpr double kNoteSeconds = 30.0;

inline std::string duration_text(double s) {
    if (s < 90.0) return fmt::format("{:.0f} s", s);
    if (s < 5400.0) return fmt::format("{:.0f} min", s / 60.0);
    return fmt::format("{:.1f} h", s / 3600.0);
}

// The pass over `count` pairs whose estimate speaks for `expected` pairs (more than count when
// they are the first block of a classification done in blocks, see sparse_obstructed_rows();
// `later_seconds`: the time the later blocks' classification will take besides), its progress
// counted on `progress`.
template <class Body>
void sampled_pass(std::size_t count, std::size_t expected, double later_seconds,
                  const MethodContext& ctx, double tol, Fields& o, Progress& progress,
                  const Body& body) {
    const MethodOptions& options = ctx.options;
    const std::size_t stride = sample_stride(count);
    auto order = [&](std::size_t j) { return detail::strided_pair(j, count, stride); };
    const std::size_t sampled = (count + stride - 1) / stride;
    announce_phase("analytic partly hidden pairs");
    const auto t0 = Clock::now();
    parallel_for(sampled, options.threads, [&](std::size_t j) {
        body(order(j));
        progress.advance();
    });
    const double sample_seconds = std::chrono::duration<double>(Clock::now() - t0).count();
    const double estimate =
        sampled > 0 ? sample_seconds * static_cast<double>(expected) / static_cast<double>(sampled)
                    : 0.0;
    o["sampled_pairs"] = sampled;
    o["estimated_seconds_partly_hidden"] = estimate;
    if (ctx.progress && estimate + later_seconds > kNoteSeconds) {
        const int threads = effective_threads(options.threads);
        std::string text = fmt::format(
            "analytic: {}{} partly hidden pairs, about {}{} on {} thread{} (from {} of them). "
            "Less: a looser `tolerance` (now {:g}), `method` mc-hemisphere with `samples` 100000 "
            "(standard error <= 1.6e-3 per entry)",
            expected > count ? "about " : "", expected, duration_text(estimate),
            later_seconds > 0.0
                ? fmt::format(" (and {} more of classification)", duration_text(later_seconds))
                : std::string(),
            threads, threads == 1 ? "" : "s", sampled, tol);
        if (ctx.scene.patches.size() >= 20000 && !ctx.sparse_rows)
            text += ", `output` F.h5 (sparse: only the entries that are not 0)";
        ctx.progress->note(text);
    }
    parallel_for(count - sampled, options.threads, [&](std::size_t j) {
        body(order(sampled + j));
        progress.advance();
    });
}

template <class Body>
void partly_hidden_pass(std::size_t count, const MethodContext& ctx, double tol, Fields& o,
                        const Body& body) {
    Progress progress("analytic (obstructed)", count, ctx.progress);
    sampled_pass(count, count, 0.0, ctx, tol, o, progress, body);
    progress.finish();
}

// The partly hidden pairs given beforehand (ctx.partly_hidden), checked against the run; null
// when they are to be computed here.
inline const PartlyHiddenPairs::Impl* given_pairs(const MethodContext& ctx, bool sparse) {
    if (!ctx.partly_hidden) return nullptr;
    const PartlyHiddenPairs::Impl& m = ctx.partly_hidden->impl();
    FF_ASSERT(&m.scene == &ctx.scene && m.has_values && m.sparse == sparse);
    return &m;
}

}  // namespace formfactor::detail
