// mc-hemisphere: Monte-Carlo hemisphere (solid-angle) sampling (DESIGN.md, method 6).
//
// Row i at once: N rays from uniform points on patch i in cosine-distributed directions (both
// from one 4-D point set per replicate); the first surface hit takes the ray, and F_ij = (rays
// arriving on the front of patch j)/N. Rays that escape, hit an obstruction or the back of a
// patch count for no patch, so row sums are exactly (front hits)/N. --samples = rays per row.
// Standard error: sqrt(F(1−F)/N) for the random sampler (binomial), else the replicate spread.
// In a closed model (Visibility::closed()) no ray can leave: a miss or a back hit there is a
// ray the ray tracer lost, counted as `closed_model_escapes`, with `closed_model_warning` when
// there is one. Such a ray is left out of its row's estimate (F_ij = hits_j / (N − lost)), so
// that the row still sums to 1: a bug to report, not radiation that leaves the model.
#include <algorithm>
#include <atomic>
#include <string>

#include "formfactor/core/parallel.h"
#include "formfactor/core/progress.h"
#include "formfactor/geometry/sampling.h"
#include "formfactor/visibility/visibility.h"
#include "methods/monte_carlo/mc_common.h"

namespace formfactor {
namespace {

constexpr std::size_t kBatch = 256;

// A thread's working memory: hit counts of the current replicate (all zero between rows), the
// patches they touch, one batch of queries, hits and point coordinates.
struct Buffers {
    std::vector<std::uint32_t> count, touched;
    std::vector<std::uint32_t> row_touched;  // the row's patches hit in any replicate
    // Running totals and replicate second moments of a row emitted sparse (all zero between
    // rows; a dense row keeps them in its F and SE rows).
    std::vector<double> total, moment;
    std::vector<RayQuery> queries = std::vector<RayQuery>(kBatch);
    std::vector<RayHit> hits = std::vector<RayHit>(kBatch);
    std::vector<double> u[4] = {std::vector<double>(kBatch), std::vector<double>(kBatch),
                                std::vector<double>(kBatch), std::vector<double>(kBatch)};
    bool clean = true;  // false while a row is in flight (an exception may leave counts)
    void prepare(std::size_t n, bool sparse) {
        if (!clean || count.size() != n) count.assign(n, 0);
        if (sparse && (!clean || total.size() != n)) {
            total.assign(n, 0.0);
            moment.assign(n, 0.0);
        }
        touched.clear();
        row_touched.clear();
        clean = false;
    }
};

class McHemisphereMethod final : public mc::MonteCarloMethod {
  public:
    MethodKind kind() const override { return MethodKind::mc_hemisphere; }

    bool emits_sparse_rows() const override { return true; }

    MethodResult compute(const MethodContext& ctx) const override {
        const mc::Run run(*this, ctx, 10000);

        SparseRows* const out = ctx.sparse_rows;
        MethodResult result =
            out ? run.sparse_rows(this->kind(), *out) : run.zero_rows(this->kind());
        FormFactors& ff = result.form_factors;
        std::atomic<std::uint64_t> rays{0}, escaped{0}, back_hits{0}, obstruction_hits{0};
        Progress progress("mc-hemisphere", run.rows.size(), ctx.progress);
        const std::uint64_t recast_before = run.vis->recast_rays();

        parallel_for(run.rows.size(), run.options.threads, [&](std::size_t row) {
            const std::size_t i = run.rows.begin + row;
            const Patch& pi = run.scene.patches[i];
            const PolygonSampler sampler(pi.polygon);
            Vec3 t, b;
            orthonormal_basis(pi.normal, t, b);
            // Per-thread buffers, reused across rows (no allocation per row or batch).
            thread_local Buffers buf;
            buf.prepare(run.n, out != nullptr);
            // F holds the running totals, Q the replicate second moments: the dense row and its
            // SE row, or the thread's buffers for a row emitted sparse.
            const auto dense_row = static_cast<Eigen::Index>(row);
            double* const F = out ? buf.total.data() : ff.F.row(dense_row).data();
            double* const Q = out ? buf.moment.data() : ff.standard_error->row(dense_row).data();
            std::vector<std::uint32_t>& count = buf.count;
            std::vector<std::uint32_t>& touched = buf.touched;
            RayQuery* queries = buf.queries.data();
            RayHit* hits = buf.hits.data();
            double* const u[4] = {buf.u[0].data(), buf.u[1].data(), buf.u[2].data(),
                                  buf.u[3].data()};
            const int from = static_cast<int>(i);
            std::uint64_t esc = 0, back = 0, obst = 0;
            const bool closed = run.vis->closed();
            const double n_bar = double(run.N) / run.R;
            for (std::uint32_t r = 0; r < run.R; ++r) {
                const std::uint64_t nr = replicate_size(run.N, run.R, r);
                const PointSet4 set(run.kind, stream_key(run.options.seed, i, mc::kRowStream, r),
                                    static_cast<std::uint32_t>(nr));
                for (std::uint64_t s0 = 0; s0 < nr; s0 += kBatch) {
                    const std::size_t m =
                        static_cast<std::size_t>(std::min<std::uint64_t>(kBatch, nr - s0));
                    set.generate(static_cast<std::uint32_t>(s0), static_cast<std::uint32_t>(m), u);
                    for (std::size_t k = 0; k < m; ++k) {
                        const Vec3 d = cosine_direction(u[2][k], u[3][k]);
                        queries[k].origin = sampler(u[0][k], u[1][k]);
                        queries[k].direction = d.x() * t + d.y() * b + d.z() * pi.normal;
                        queries[k].from_patch = from;
                    }
                    run.vis->first_hit(std::span<const RayQuery>(queries, m),
                                       std::span<RayHit>(hits, m));
                    for (std::size_t k = 0; k < m; ++k) {
                        const RayHit& h = hits[k];
                        if (h.patch < 0) {
                            (h.patch == RayHit::kMiss ? esc : obst)++;
                        } else if (!h.front || h.patch == from) {
                            ++back;
                        } else {
                            const auto j = static_cast<std::uint32_t>(h.patch);
                            if (count[j]++ == 0) touched.push_back(j);
                        }
                    }
                }
                for (std::uint32_t j : touched) {
                    const double c = count[j];
                    if (F[j] == 0.0) buf.row_touched.push_back(j);
                    F[j] += c;
                    Q[j] += c * c / (double(nr) * n_bar);
                    count[j] = 0;
                }
                touched.clear();
            }
            // Only the entries the row's rays reached (not all N: a 10^5-patch row has a few
            // hundred).
            if (out) std::sort(buf.row_touched.begin(), buf.row_touched.end());
            // A closed model's lost rays are not part of the estimate (the rays that arrived
            // stand for the whole row).
            const std::uint64_t lost = closed ? esc + back : 0;
            const double kept =
                lost > 0 && lost < run.N ? double(run.N) / double(run.N - lost) : 1.0;
            for (const std::uint32_t j : buf.row_touched) {
                mc::ReplicateMean acc{F[j], Q[j]};
                const double f = F[j] / double(run.N);
                Q[j] = run.R > 1 ? mc::replicate_standard_error(acc, double(run.N), run.R)
                                 : std::sqrt(f * (1 - f) / double(run.N));
                F[j] = f;
                if (lost > 0) {
                    F[j] *= kept;
                    Q[j] *= kept;
                }
            }
            if (out) {
                std::vector<std::int32_t>& idx = out->indices[row];
                std::vector<double>& val = out->values[row];
                std::vector<double>& se = out->standard_error[row];
                idx.reserve(buf.row_touched.size());
                val.reserve(buf.row_touched.size());
                se.reserve(buf.row_touched.size());
                for (const std::uint32_t j : buf.row_touched) {
                    idx.push_back(static_cast<std::int32_t>(j));
                    val.push_back(F[j]);
                    se.push_back(Q[j]);
                    F[j] = Q[j] = 0.0;
                }
            }
            buf.clean = true;
            rays += run.N;
            escaped += esc;
            back_hits += back;
            obstruction_hits += obst;
            progress.advance();
        });
        progress.finish();
        const std::optional<mc::StandardErrorSummary> se =
            out ? mc::summarize(*out, run.n) : mc::summarize(*ff.standard_error);
        mc::report(result.report, se, run.kind, run.N, run.R, rays.load(),
                   mc::seconds_since(run.t0), run.vis->description(), "rays per patch (row)");
        Fields& details = result.report.details;
        const double total = double(rays.load());
        details["escaped_fraction"] = total > 0 ? escaped.load() / total : 0.0;
        details["back_hit_fraction"] = total > 0 ? back_hits.load() / total : 0.0;
        details["obstruction_hit_fraction"] = total > 0 ? obstruction_hits.load() / total : 0.0;
        if (run.vis->closed()) {
            const std::uint64_t lost = escaped.load() + back_hits.load();
            details["closed_model"] = true;
            details["closed_model_escapes"] = lost;
            details["recast_rays"] = run.vis->recast_rays() - recast_before;
            if (lost > 0) details["closed_model_warning"] = closed_model_escape_warning(lost);
        }
        return result;
    }
};

}  // namespace

std::unique_ptr<Method> make_mc_hemisphere_method() {
    return std::make_unique<McHemisphereMethod>();
}

}  // namespace formfactor
