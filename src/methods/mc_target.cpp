// mc-target: Monte-Carlo sampling on the target (Wallace, Elmquist & Haines 1989; DESIGN.md,
// method 7).
//
// For each pair (i, j): N sender points x_k uniform on A_i; from each, one shadow ray towards a
// direction drawn from the projected solid angle of A_j (ProjectedPolygonSampler: exact, no
// rejection), so that every ray from x_k carries the same weight w_k = F_{dA(x_k)→A_j}. The
// estimate is the exact unoccluded F_ij (polygon_to_polygon) times the visible fraction
//     ρ = Σ_k w_k V_k / Σ_k w_k,
// a ratio estimator: exact when nothing blocks (ρ = 1) or everything does (ρ = 0), consistent
// with O(1/N) bias otherwise. --samples = rays per patch pair. Standard error: F_unocc × the
// spread of the replicates' ρ (or, with the random sampler, the delta-method variance of ρ).
#include <atomic>

#include "formfactor/core/parallel.h"
#include "formfactor/core/progress.h"
#include "formfactor/geometry/sampling.h"
#include "formfactor/methods/analytic.h"
#include "formfactor/visibility/visibility.h"
#include "mc_common.h"

namespace formfactor {
namespace {

bool behind(const Patch& p, const Patch& q) {
    const double tol = 1e-12 * diameter(p.polygon);
    for (const Vec3& v : q.polygon.vertices)
        if (p.normal.dot(v - p.centroid) > tol) return false;
    return true;
}

class McTargetMethod final : public Method {
  public:
    std::string name() const override { return "mc-target"; }
    void check(const Scene& scene) const override {
        if (scene.patches.empty()) throw GeometryError("mc-target: the scene has no patches");
    }

    FormFactors compute(const Scene& scene, const MethodOptions& options,
                        nlohmann::json& details) const override {
        check(scene);
        const auto t0 = mc::Clock::now();
        const SamplerKind kind = parse_sampler(options.sampler);
        const std::uint64_t N = mc::sample_count(options, 64);
        const std::uint32_t R = replicate_count(kind, N);
        const std::size_t n = scene.patches.size();
        auto vis = make_visibility(scene);
        std::vector<PolygonSampler> senders;
        senders.reserve(n);
        for (const Patch& p : scene.patches) senders.emplace_back(p.polygon);

        FormFactors ff;
        ff.F = DenseMatrix::Zero(static_cast<Eigen::Index>(n), static_cast<Eigen::Index>(n));
        ff.standard_error = DenseMatrix::Zero(ff.F.rows(), ff.F.cols());
        for (const Patch& p : scene.patches) ff.areas.push_back(p.area);
        std::atomic<std::uint64_t> rays{0}, unblocked_pairs{0}, pairs{0};
        Progress progress("mc-target", n, options.progress);
        constexpr std::size_t kBatch = 256;

        parallel_for(n, options.threads, [&](std::size_t i) {
            const Patch& pi = scene.patches[i];
            // Rays of all pairs and replicates of the row share batches; each remembers its
            // slot j·R + r. Per slot: Σw and Σw·V; per j: Σw², Σw²·V (delta method, R = 1).
            std::vector<double> W(n * R, 0.0), V(n * R, 0.0), W2(n, 0.0), W2V(n, 0.0);
            std::vector<double> f_unocc(n, 0.0);
            std::vector<SegmentQuery> queries;
            std::vector<double> weight;
            std::vector<std::uint32_t> slot;
            std::vector<std::uint8_t> blocked(kBatch);
            queries.reserve(kBatch);
            weight.reserve(kBatch);
            slot.reserve(kBatch);
            std::uint64_t row_rays = 0, row_pairs = 0, row_unblocked = 0;
            auto flush = [&] {
                vis->occluded(queries, std::span<std::uint8_t>(blocked.data(), queries.size()));
                row_rays += queries.size();
                for (std::size_t k = 0; k < queries.size(); ++k) {
                    const double w = weight[k];
                    const std::uint32_t j = slot[k] / R;
                    W[slot[k]] += w;
                    W2[j] += w * w;
                    if (!blocked[k]) {
                        V[slot[k]] += w;
                        W2V[j] += w * w;
                    }
                }
                queries.clear();
                weight.clear();
                slot.clear();
            };
            for (std::size_t j = 0; j < n; ++j) {
                if (j == i) continue;
                const Patch& pj = scene.patches[j];
                if (behind(pi, pj) || behind(pj, pi)) continue;
                f_unocc[j] = polygon_to_polygon(pi.polygon, pj.polygon);
                if (!(f_unocc[j] > 0)) continue;
                ProjectedPolygonSampler target(pj.polygon);
                for (std::uint32_t r = 0; r < R; ++r) {
                    const std::uint64_t nr = replicate_size(N, R, r);
                    const PointSet4 set(kind, stream_key(options.seed, i, j, r),
                                        static_cast<std::uint32_t>(nr));
                    for (std::uint32_t s = 0; s < nr; ++s) {
                        const auto u = set(s);
                        const Vec3 x = senders[i](u[0], u[1]);
                        const double w = target.set_origin(x, pi.normal);
                        if (!(w > 0)) continue;
                        const Vec3 d = target.sample(u[2], u[3]);
                        const double den = pj.normal.dot(d);
                        if (!(den < 0)) continue;  // grazing: measure zero
                        const double t = pj.normal.dot(pj.centroid - x) / den;
                        queries.push_back({x, x + t * d, static_cast<int>(i), static_cast<int>(j)});
                        weight.push_back(w);
                        slot.push_back(static_cast<std::uint32_t>(j * R + r));
                        if (queries.size() == kBatch) flush();
                    }
                }
            }
            if (!queries.empty()) flush();
            std::vector<double> rho(R);
            for (std::size_t j = 0; j < n; ++j) {
                if (!(f_unocc[j] > 0)) continue;
                ++row_pairs;
                const auto ii = static_cast<Eigen::Index>(i), jj = static_cast<Eigen::Index>(j);
                double w_sum = 0, v_sum = 0;
                std::uint32_t used = 0;
                for (std::uint32_t r = 0; r < R; ++r) {
                    w_sum += W[j * R + r];
                    v_sum += V[j * R + r];
                    if (W[j * R + r] > 0) rho[used++] = V[j * R + r] / W[j * R + r];
                }
                if (!(w_sum > 0)) {
                    // No sender point saw j (a sliver of visibility): unknown, and said so.
                    ff.F(ii, jj) = f_unocc[j];
                    (*ff.standard_error)(ii, jj) = f_unocc[j];
                    continue;
                }
                const double ratio = v_sum / w_sum;
                if (v_sum == w_sum) ++row_unblocked;
                ff.F(ii, jj) = f_unocc[j] * ratio;
                double se = 0;
                if (R > 1) {
                    if (used > 1) {
                        double m = 0, s2 = 0;
                        for (std::uint32_t k = 0; k < used; ++k) m += rho[k] / used;
                        for (std::uint32_t k = 0; k < used; ++k) s2 += (rho[k] - m) * (rho[k] - m);
                        se = std::sqrt(s2 / (used - 1) / used);
                    }
                } else {
                    const double v = (1 - 2 * ratio) * W2V[j] + ratio * ratio * W2[j];
                    se = std::sqrt(std::max(0.0, v)) / w_sum;
                }
                (*ff.standard_error)(ii, jj) = f_unocc[j] * se;
            }
            rays += row_rays;
            pairs += row_pairs;
            unblocked_pairs += row_unblocked;
            progress.advance();
        });
        progress.finish();
        mc::report(details, ff, kind, N, R, rays.load(), mc::seconds_since(t0), vis->description(),
                   "rays per patch pair");
        details["pairs"] = pairs.load();
        details["unblocked_pairs"] = unblocked_pairs.load();
        return ff;
    }
};

}  // namespace

std::unique_ptr<Method> make_mc_target_method() { return std::make_unique<McTargetMethod>(); }

}  // namespace formfactor
