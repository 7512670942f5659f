#pragma once
// Shared pieces of the Monte-Carlo methods (mc_area.cpp, mc_hemisphere.cpp, mc_target.cpp).

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <ctime>
#include <memory>
#include <string>
#include <vector>

#include "formfactor/core/error.h"
#include "formfactor/core/random.h"
#include "formfactor/matrix/form_factors.h"
#include "formfactor/methods/method.h"
#include "formfactor/visibility/visibility.h"

namespace formfactor {

std::unique_ptr<Method> make_mc_area_method();
std::unique_ptr<Method> make_mc_hemisphere_method();
std::unique_ptr<Method> make_mc_target_method();

namespace mc {

/// Sample count from the options (0 → the method's default), checked.
inline std::uint64_t sample_count(const MethodOptions& o, std::uint64_t fallback) {
    const std::uint64_t n = o.samples == 0 ? fallback : o.samples;
    if (n > 0xFFFFFFFFull) throw OptionError("samples", "at most 4294967295 per stream");
    return n;
}

/// The row-stream index used for methods that draw whole rows at once (no j).
inline constexpr std::uint64_t kRowStream = 0xFFFFFFFFFFFFFFFFull;

/// Mean and standard error from R replicates (independent randomisations of the point set).
/// Replicate r has n_r samples whose values sum to c_r; N = Σ n_r, n̄ = N/R, est = Σ c_r / N.
/// With replicate means m_r = c_r/n_r and weights w_r = n_r/n̄:
/// s² = Σ w_r (m_r − est)² / (R − 1) = (Q − R est²)/(R − 1) where Q = Σ c_r²/(n_r n̄), and
/// SE² = s²/R — the usual unbiased estimate when the n_r are equal. Accumulate Q and Σ c_r.
struct ReplicateMean {
    double total = 0.0;  // Σ c_r
    double q = 0.0;      // Q
    void add(double c, double n_r, double n_bar) {
        total += c;
        q += c * c / (n_r * n_bar);
    }
};
inline double replicate_mean(const ReplicateMean& a, double n) { return a.total / n; }
inline double replicate_standard_error(const ReplicateMean& a, double n, std::uint32_t r) {
    if (r < 2) return 0.0;
    const double est = a.total / n;
    const double s2 = (a.q - r * est * est) / (r - 1);
    return s2 > 0 ? std::sqrt(s2 / r) : 0.0;
}

/// What the three Monte-Carlo methods share as methods: they cast rays and need patches.
class MonteCarloMethod : public Method {
  public:
    bool needs_visibility() const override { return true; }
    void check(const Scene& scene) const override {
        if (scene.patches.empty()) throw GeometryError(name() + ": the scene has no patches");
    }
};

using Clock = std::chrono::steady_clock;

/// The start of every Monte-Carlo compute(): the scene checked, the sample and replicate
/// counts, the rows, the ray tracer (the context's, or one built here), the clock started.
struct Run {
    Run(const Method& method, const MethodContext& ctx, std::uint64_t default_samples)
        : scene(ctx.scene),
          options(ctx.options),
          t0(Clock::now()),
          kind(ctx.options.sampler),
          N(sample_count(ctx.options, default_samples)),
          R(replicate_count(kind, N)),
          n(ctx.scene.patches.size()),
          rows(ctx.rows.clamped(n)) {
        method.check(scene);
        if (ctx.visibility) {
            vis = ctx.visibility;
        } else {
            own = make_visibility(scene);
            vis = own.get();
        }
    }
    /// The result of a method that emits its rows into ctx.sparse_rows: F empty (0 × n), the
    /// areas, the rows reset (with standard errors).
    MethodResult sparse_rows(MethodKind method, SparseRows& out) const {
        MethodResult result;
        result.report.method = method;
        FormFactors& ff = result.form_factors;
        ff.first_row = rows.begin;
        ff.F = DenseMatrix::Zero(0, static_cast<Eigen::Index>(n));
        for (const Patch& p : scene.patches) ff.areas.push_back(p.area);
        out.reset(rows.begin, rows.size(), true);
        return result;
    }
    /// The result the row-by-row methods fill: F and its standard errors zero for the rows
    /// (rows × n), the patches' areas, the method named in the report.
    MethodResult zero_rows(MethodKind method) const {
        MethodResult result;
        result.report.method = method;
        FormFactors& ff = result.form_factors;
        ff.first_row = rows.begin;
        ff.F =
            DenseMatrix::Zero(static_cast<Eigen::Index>(rows.size()), static_cast<Eigen::Index>(n));
        ff.standard_error = DenseMatrix::Zero(ff.F.rows(), ff.F.cols());
        for (const Patch& p : scene.patches) ff.areas.push_back(p.area);
        return result;
    }

    const Scene& scene;
    const MethodOptions& options;
    Clock::time_point t0;
    SamplerKind kind;
    std::uint64_t N;  ///< samples per row or pair
    std::uint32_t R;  ///< replicates
    std::size_t n;    ///< patches
    RowRange rows;    ///< the rows to compute
    std::unique_ptr<Visibility> own;
    const Visibility* vis = nullptr;
};

/// The standard errors' summary of a report: largest, mean over every entry of the rows (zeros
/// included), largest root-sum-square of a row.
struct StandardErrorSummary {
    double max = 0.0, mean = 0.0, row_rss_max = 0.0;
};

inline StandardErrorSummary summarize(const DenseMatrix& se) {
    StandardErrorSummary s;
    s.max = se.size() ? se.maxCoeff() : 0.0;
    s.mean = se.size() ? se.mean() : 0.0;
    for (Eigen::Index i = 0; i < se.rows(); ++i)
        s.row_rss_max = std::max(s.row_rss_max, std::sqrt(se.row(i).squaredNorm()));
    return s;
}

/// The same from rows emitted sparse (the entries not stored are 0), n columns.
inline StandardErrorSummary summarize(const SparseRows& rows, std::size_t n) {
    StandardErrorSummary s;
    double sum = 0.0;
    for (const std::vector<double>& row : rows.standard_error) {
        double sq = 0.0;
        for (double e : row) {
            s.max = std::max(s.max, e);
            sum += e;
            sq += e * e;
        }
        s.row_rss_max = std::max(s.row_rss_max, std::sqrt(sq));
    }
    const double entries = double(rows.size()) * double(n);
    s.mean = entries > 0 ? sum / entries : 0.0;
    return s;
}

/// Fills what every Monte-Carlo method reports; `se` from the rows' standard errors, when the
/// method has them.
inline void report(MethodReport& rep, const std::optional<StandardErrorSummary>& se,
                   SamplerKind kind, std::uint64_t samples, std::uint32_t replicates,
                   std::uint64_t rays, double seconds, const std::string& visibility,
                   const std::string& samples_meaning) {
    Fields& details = rep.details;
    details["samples"] = samples;
    details["samples_meaning"] = samples_meaning;
    details["sampler"] = sampler_name(kind);
    details["replicates"] = replicates;
    details["standard_error_model"] =
        replicates > 1 ? "spread of independent randomisations (replicates) of the point set"
                       : "i.i.d. sample variance";
    rep.rays_cast = rays;
    rep.seconds = seconds;
    details["rays_per_second"] = seconds > 0 ? rays / seconds : 0.0;
    details["visibility"] = visibility;
    if (se) {
        details["standard_error_max"] = se->max;
        details["standard_error_mean"] = se->mean;
        details["row_sum_standard_error_max"] = se->row_rss_max;  // entries near-independent
    }
}

inline void report(MethodReport& rep, const FormFactors& ff, SamplerKind kind,
                   std::uint64_t samples, std::uint32_t replicates, std::uint64_t rays,
                   double seconds, const std::string& visibility,
                   const std::string& samples_meaning) {
    std::optional<StandardErrorSummary> se;
    if (ff.standard_error) se = summarize(*ff.standard_error);
    report(rep, se, kind, samples, replicates, rays, seconds, visibility, samples_meaning);
}

/// The segment queries' closed-model counts of a run (Visibility::rechecked_segments(),
/// segments_blocked_by_recheck()): taken when the run starts, reported when it ends.
class SegmentRecheckCount {
  public:
    explicit SegmentRecheckCount(const Visibility& vis)
        : vis_(vis),
          checked_(vis.rechecked_segments()),
          blocked_(vis.segments_blocked_by_recheck()) {}
    /// In a closed model: `closed_model`, `rechecked_segments` (clear segments near a triangle's
    /// edge, checked again in double precision) and `segments_through_model` (those found blocked:
    /// single precision had let them through a shared edge or vertex of the model; each is
    /// corrected, not lost).
    void report(Fields& details) const {
        if (!vis_.closed()) return;
        details["closed_model"] = true;
        details["rechecked_segments"] = vis_.rechecked_segments() - checked_;
        details["segments_through_model"] = vis_.segments_blocked_by_recheck() - blocked_;
    }

  private:
    const Visibility& vis_;
    std::uint64_t checked_, blocked_;
};

inline double seconds_since(Clock::time_point t0) {
    return std::chrono::duration<double>(Clock::now() - t0).count();
}

/// CPU seconds of the whole process so far (all threads; std::clock).
inline double process_cpu_seconds() { return static_cast<double>(std::clock()) / CLOCKS_PER_SEC; }

/// Wall and process-CPU time of the phases of a method, for its details.
class PhaseTimer {
  public:
    PhaseTimer() : wall_(Clock::now()), cpu_(process_cpu_seconds()) {}
    /// Records the time since the previous lap (or construction) under `name`.
    void lap(Fields& phases, const std::string& name) {
        const auto now = Clock::now();
        const double cpu = process_cpu_seconds();
        phases[name]["seconds"] = std::chrono::duration<double>(now - wall_).count();
        phases[name]["process_cpu_seconds"] = cpu - cpu_;
        wall_ = now;
        cpu_ = cpu;
    }

  private:
    Clock::time_point wall_;
    double cpu_;
};

}  // namespace mc
}  // namespace formfactor
