// mc-area: Monte-Carlo area sampling (DESIGN.md, method 5).
//
// For each pair (i, j): N point pairs (x uniform on A_i, y uniform on A_j) from one 4-D point
// set per replicate, kernel K = cosθ_i cosθ_j/(π r²) · V(x, y), F_ij = A_j · mean K. Unbiased.
// The variance grows without bound as patches get close (with a shared edge the kernel's second
// moment diverges: the standard error is then only indicative). --samples = pairs per (i, j).
#include <atomic>

#include "formfactor/core/parallel.h"
#include "formfactor/core/progress.h"
#include "formfactor/geometry/sampling.h"
#include "formfactor/visibility/visibility.h"
#include "methods/monte_carlo/mc_common.h"

namespace formfactor {
namespace {

// True when no point of q is strictly in front of the plane of p (F_pq = 0 exactly).
bool behind(const Patch& p, const Patch& q) {
    const double tol = 1e-12 * diameter(p.polygon);
    for (const Vec3& v : q.polygon.vertices)
        if (p.normal.dot(v - p.centroid) > tol) return false;
    return true;
}

class McAreaMethod final : public mc::MonteCarloMethod {
  public:
    MethodKind kind() const override { return MethodKind::mc_area; }
    /// Rows go sparse when asked (MethodContext::sparse_rows): the pairs that face each other.
    bool emits_sparse_rows() const override { return true; }

    MethodResult compute(const MethodContext& ctx) const override {
        const mc::Run run(*this, ctx, 256);
        const mc::SegmentRecheckCount recheck(*run.vis);
        std::vector<PolygonSampler> samplers;
        samplers.reserve(run.n);
        for (const Patch& p : run.scene.patches) samplers.emplace_back(p.polygon);

        SparseRows* const out = ctx.sparse_rows;
        MethodResult result =
            out ? run.sparse_rows(this->kind(), *out) : run.zero_rows(this->kind());
        FormFactors& ff = result.form_factors;
        std::atomic<std::uint64_t> rays{0};
        Progress progress("mc-area", run.rows.size(), ctx.progress);
        constexpr std::size_t kBatch = 256;

        parallel_for(run.rows.size(), run.options.threads, [&](std::size_t row) {
            const std::size_t i = run.rows.begin + row;
            const Patch& pi = run.scene.patches[i];
            // Rays of all pairs and replicates of the row share batches; each remembers where
            // its kernel value goes: c[j·R + r] (replicate sums) and s2[j] (i.i.d. moments).
            std::vector<double> c(run.n * run.R, 0.0), s2(run.n, 0.0);
            std::vector<char> active(run.n, 0);
            std::vector<SegmentQuery> queries;
            std::vector<double> kernel;
            std::vector<std::uint32_t> slot;
            std::vector<std::uint8_t> blocked(kBatch);
            queries.reserve(kBatch);
            kernel.reserve(kBatch);
            slot.reserve(kBatch);
            std::uint64_t row_rays = 0;
            auto flush = [&] {
                run.vis->occluded(queries, std::span<std::uint8_t>(blocked.data(), queries.size()));
                row_rays += queries.size();
                for (std::size_t k = 0; k < queries.size(); ++k)
                    if (!blocked[k]) {
                        c[slot[k]] += kernel[k];
                        s2[slot[k] / run.R] += kernel[k] * kernel[k];
                    }
                queries.clear();
                kernel.clear();
                slot.clear();
            };
            for (std::size_t j = 0; j < run.n; ++j) {
                if (j == i) continue;
                const Patch& pj = run.scene.patches[j];
                if (behind(pi, pj) || behind(pj, pi)) continue;
                active[j] = 1;
                for (std::uint32_t r = 0; r < run.R; ++r) {
                    const std::uint64_t nr = replicate_size(run.N, run.R, r);
                    const PointSet4 set(run.kind, stream_key(run.options.seed, i, j, r),
                                        static_cast<std::uint32_t>(nr));
                    for (std::uint32_t s = 0; s < nr; ++s) {
                        const auto u = set(s);
                        const Vec3 x = samplers[i](u[0], u[1]);
                        const Vec3 y = samplers[j](u[2], u[3]);
                        const Vec3 d = y - x;
                        const double r2 = d.squaredNorm();
                        const double ci = pi.normal.dot(d), cj = -pj.normal.dot(d);
                        if (!(ci > 0 && cj > 0 && r2 > 0)) continue;
                        queries.push_back({x, y, static_cast<int>(i), static_cast<int>(j)});
                        kernel.push_back(ci * cj * kInvPi / (r2 * r2));
                        slot.push_back(static_cast<std::uint32_t>(j * run.R + r));
                        if (queries.size() == kBatch) flush();
                    }
                }
            }
            if (!queries.empty()) flush();
            const double n_bar = double(run.N) / run.R;
            for (std::size_t j = 0; j < run.n; ++j) {
                if (!active[j]) continue;
                mc::ReplicateMean acc;
                for (std::uint32_t r = 0; r < run.R; ++r)
                    acc.add(c[j * run.R + r], double(replicate_size(run.N, run.R, r)), n_bar);
                const double mean = acc.total / double(run.N);
                double se;
                if (run.R > 1) {
                    se = mc::replicate_standard_error(acc, double(run.N), run.R);
                } else {
                    const double var =
                        run.N > 1 ? (s2[j] - run.N * mean * mean) / double(run.N - 1) : 0.0;
                    se = std::sqrt(std::max(0.0, var) / double(run.N));
                }
                const double Aj = run.scene.patches[j].area;
                if (out) {
                    if (!(Aj * mean != 0.0)) continue;  // the dense row's zero
                    out->indices[row].push_back(static_cast<std::int32_t>(j));
                    out->values[row].push_back(Aj * mean);
                    out->standard_error[row].push_back(Aj * se);
                    continue;
                }
                const auto ii = static_cast<Eigen::Index>(row), jj = static_cast<Eigen::Index>(j);
                ff.F(ii, jj) = Aj * mean;
                (*ff.standard_error)(ii, jj) = Aj * se;
            }
            rays += row_rays;
            progress.advance();
        });
        progress.finish();
        const std::optional<mc::StandardErrorSummary> se_summary =
            out ? mc::summarize(*out, run.n) : mc::summarize(*ff.standard_error);
        mc::report(result.report, se_summary, run.kind, run.N, run.R, rays.load(),
                   mc::seconds_since(run.t0), run.vis->description(), "point pairs per patch pair");
        recheck.report(result.report.details);
        return result;
    }
};

}  // namespace

std::unique_ptr<Method> make_mc_area_method() { return std::make_unique<McAreaMethod>(); }

}  // namespace formfactor
