// mc-target: Monte-Carlo sampling on the target (Wallace, Elmquist & Haines 1989; DESIGN.md,
// method 7).
//
// For each pair (i, j): N rays from N/2 sender points x_g uniform on A_i; from each, two shadow
// rays towards directions drawn from the projected solid angle of A_j (ProjectedPolygonSampler:
// exact, no rejection; one set-up per sender point), so that every ray from x_g carries the same
// weight w_g = F_{dA(x_g)→A_j}. The estimate is the exact unoccluded F_ij (the analytic method's
// unobstructed pass, once per unordered pair, the other by reciprocity) times the visible fraction
//     ρ = Σ_rays w V / Σ_rays w,
// a ratio estimator: exact when nothing blocks (ρ = 1) or everything does (ρ = 0), consistent
// with O(1/N) bias otherwise. --samples = rays per patch pair. Standard error: F_unocc × the
// spread of the replicates' ρ (or, with the random sampler, the delta-method variance of ρ
// with the sender points as the independent units).
#include <atomic>

#include "formfactor/core/parallel.h"
#include "formfactor/core/progress.h"
#include "formfactor/geometry/sampling.h"
#include "formfactor/kernels/analytic.h"
#include "formfactor/visibility/visibility.h"
#include "kernels/unobstructed.h"
#include "methods/monte_carlo/mc_common.h"
#include "visibility/shaft_culler.h"

namespace formfactor {
namespace {

// Rays drawn from one sender point (one projected-solid-angle set-up). The set-up costs about
// twice a sample; sharing it halves the cost per ray while the sender points stay numerous.
constexpr std::uint32_t kDirectionsPerSender = 2;
constexpr std::size_t kBatch = 256;
constexpr std::uint32_t kGroupChunk = 128;  // sender points whose coordinates are made at once
// Absolute error of F_unocc from the far-field rule: that of the contour integral (~1e-12), so
// "exact when nothing blocks" means what it meant with the contour integral for every pair.
constexpr double kUnoccludedTolerance = 1e-12;
constexpr std::uint64_t kRetryStream = 0x7265747279ULL;  // "retry"

// One sender point's rays in the batch: queries [first, first + count), each of weight `weight`
// (F_{dA(x)→A_j}), for slot j·R + r.
struct Group {
    std::uint32_t first = 0, count = 0;
    double weight = 0;
    std::uint32_t slot = 0;
};

// A thread's working memory, reused across rows: per-row accumulators (zero between rows),
// the batch, and the point coordinates of one replicate.
struct RowBuffers {
    std::vector<double> W, V, A2, B2, C2, rho;
    std::vector<SegmentQuery> queries;
    std::vector<Group> groups;
    std::vector<std::uint8_t> blocked = std::vector<std::uint8_t>(kBatch);
    std::vector<double> sender_u[2], direction_u[4];  // one chunk of groups (direction_u[2, 3])
    ProjectedPolygonSampler target;
    // The accumulators are zero between rows: each row clears the slots it used (clean), and
    // a row that did not finish (an exception) leaves them to be cleared whole.
    bool clean = false;
    void prepare(std::size_t n, std::uint32_t R) {
        if (!clean || W.size() != n * R || A2.size() != n) {
            W.assign(n * R, 0.0);
            V.assign(n * R, 0.0);
            A2.assign(n, 0.0);
            B2.assign(n, 0.0);
            C2.assign(n, 0.0);
        }
        clean = false;
        rho.resize(R);
        queries.clear();
        groups.clear();
        queries.reserve(kBatch);
        groups.reserve(kBatch);
    }
    RowBuffers() {
        for (auto& v : sender_u) v.resize(kGroupChunk);
        for (int d = 2; d < 4; ++d) direction_u[d].resize(kGroupChunk * kDirectionsPerSender);
    }
};

// Pass 1b: pairs that nothing can block (a conservative shaft test, independent of the
// analytic method's) are settled without rays: F = F_unocc, standard error 0 — what their rays
// would give. Surfaces are tested whole first when they average two patches or more (a clear
// surface pair clears all its patch pairs). The whole matrix: bit j of row i for j > i (each
// unordered pair once); a block of rows: bit j of each of its rows, for every j (the same test
// on (min, max), so the same answer as the whole run's).
class ClearPairs {
  public:
    // unocc(i, j): the unobstructed F_ij of a row i of the run.
    template <class Unocc>
    ClearPairs(const mc::Run& run, bool whole, const Unocc& unocc)
        : rows_(run.rows), whole_(whole), words_((run.n + 63) / 64) {
        const ShaftCuller culler(run.scene);
        const std::size_t S = run.scene.surfaces.size();
        std::vector<int> surface_of(run.n, -1);
        std::vector<std::size_t> patches_of(S, 0);
        for (std::size_t p = 0; p < run.n; ++p) {
            const int sp = run.scene.patches[p].surface;
            if (sp >= 0 && static_cast<std::size_t>(sp) < S) {
                surface_of[p] = sp;
                ++patches_of[static_cast<std::size_t>(sp)];
            }
        }
        const bool by_surface = 2 * S <= run.n;
        std::vector<std::uint8_t> surface_clear(by_surface ? S * S : 0, 0);
        if (by_surface) {
            parallel_for(S, run.options.threads, [&](std::size_t a) {
                if (patches_of[a] == 0) return;
                for (std::size_t b = a + 1; b < S; ++b)
                    if (patches_of[b] > 0 && patches_of[a] + patches_of[b] > 2)
                        surface_clear[a * S + b] = culler.unoccluded(run.scene.surfaces[a].polygon,
                                                                     run.scene.surfaces[b].polygon);
            });
        }
        const std::size_t bit_rows = whole ? run.n : run.rows.size();
        bits_.assign(bit_rows * words_, 0);
        std::atomic<std::uint64_t> cleared_pairs{0};
        auto clear_test = [&](std::size_t lo, std::size_t hi) {
            const int a = surface_of[lo], b = surface_of[hi];
            const bool whole_pair = by_surface && a >= 0 && b >= 0 && a != b &&
                                    surface_clear[static_cast<std::size_t>(std::min(a, b)) * S +
                                                  static_cast<std::size_t>(std::max(a, b))];
            return whole_pair || culler.unoccluded(static_cast<int>(lo), static_cast<int>(hi));
        };
        parallel_for(bit_rows, run.options.threads, [&](std::size_t k) {
            const std::size_t i = whole ? k : run.rows.begin + k;
            std::uint64_t count = 0;
            for (std::size_t j = whole ? i + 1 : 0; j < run.n; ++j) {
                if (j == i || !(unocc(i, j) > 0)) continue;
                if (!clear_test(std::min(i, j), std::max(i, j))) continue;
                bits_[k * words_ + j / 64] |= std::uint64_t(1) << (j % 64);
                ++count;
            }
            cleared_pairs += count;
        });
        count_ = cleared_pairs.load();
    }

    // True when pair (i, j), i a row of the run, needs no rays.
    bool operator()(std::size_t i, std::size_t j) const {
        if (!whole_) {
            const std::size_t k = i - rows_.begin;
            return (bits_[k * words_ + j / 64] >> (j % 64)) & 1;
        }
        const std::size_t a = std::min(i, j), b = std::max(i, j);
        return (bits_[a * words_ + b / 64] >> (b % 64)) & 1;
    }
    // Pairs cleared: unordered for the whole matrix, (row, column) for a block.
    std::uint64_t count() const { return count_; }

  private:
    RowRange rows_;
    bool whole_;
    std::size_t words_;
    std::vector<std::uint64_t> bits_;
    std::uint64_t count_ = 0;
};

// What every row of one run shares: the sender samplers, the unobstructed F (ff.F, rows × N,
// row i at i − off) and the pairs that need no rays.
struct TargetRows {
    const mc::Run& run;
    const std::vector<PolygonSampler>& senders;
    const std::vector<char>& convex;
    FormFactors& ff;
    std::size_t off;
    const ClearPairs& cleared;

    double unocc_at(std::size_t i, std::size_t j) const {
        return ff.F(static_cast<Eigen::Index>(i - off), static_cast<Eigen::Index>(j));
    }

    // Pass 2, rays: every pair (i, j) of row i that rays must settle, into the accumulators of
    // buf. Rays of all pairs and replicates of the row share batches. A group is one sender
    // point and its (up to K) rays; groups never straddle a batch. Per slot j·R + r: Σw and
    // Σw·V; per j, for the delta method (R = 1) with groups as the units: Σ w²v², Σ w²v·m,
    // Σ w²m² (v visible rays of the group's m). Returns the rays cast.
    std::uint64_t trace_row(std::size_t i, RowBuffers& buf) const {
        const Patch& pi = run.scene.patches[i];
        const std::uint32_t K = kDirectionsPerSender;
        std::vector<double>&W = buf.W, &V = buf.V, &A2 = buf.A2, &B2 = buf.B2, &C2 = buf.C2;
        std::vector<SegmentQuery>& queries = buf.queries;
        std::vector<Group>& groups = buf.groups;
        std::uint8_t* blocked = buf.blocked.data();
        // Sender points use coordinates 0, 1 of their points, directions 2, 3.
        double* const us[4] = {buf.sender_u[0].data(), buf.sender_u[1].data(), nullptr, nullptr};
        double* const ud[4] = {nullptr, nullptr, buf.direction_u[2].data(),
                               buf.direction_u[3].data()};
        std::uint64_t row_rays = 0;
        auto flush = [&] {
            run.vis->occluded(queries, std::span<std::uint8_t>(blocked, queries.size()));
            row_rays += queries.size();
            for (const Group& g : groups) {
                std::uint32_t v = 0;
                for (std::uint32_t k = 0; k < g.count; ++k) v += blocked[g.first + k] ? 0 : 1;
                const double w = g.weight, m = g.count, w2 = w * w;
                const std::uint32_t j = g.slot / run.R;
                W[g.slot] += m * w;
                V[g.slot] += v * w;
                A2[j] += w2 * v * v;
                B2[j] += w2 * v * m;
                C2[j] += w2 * m * m;
            }
            queries.clear();
            groups.clear();
        };
        const int from = static_cast<int>(i);
        for (std::size_t j = 0; j < run.n; ++j) {
            if (j == i) continue;
            const double f_unocc = unocc_at(i, j);
            if (!(f_unocc > 0) || cleared(i, j)) continue;
            const Patch& pj = run.scene.patches[j];
            ProjectedPolygonSampler& target = buf.target;
            target.reset(pj.polygon, pj.normal, pj.centroid, convex[j] != 0);
            const int to = static_cast<int>(j);
            const double plane = pj.normal.dot(pj.centroid);
            for (std::uint32_t r = 0; r < run.R; ++r) {
                const auto nr = static_cast<std::uint32_t>(replicate_size(run.N, run.R, r));
                const std::uint64_t key = stream_key(run.options.seed, i, j, r);
                const PointSet4 set(run.kind, key, nr);
                // Further candidates of the rejection sampler: their own counter stream.
                std::uint64_t retry = splitmix64(key ^ kRetryStream);
                // Group g: the sender point of point g (dimensions 0, 1: the first points of
                // the set, so the sender points stay stratified), directions from points
                // gK … gK+K−1 (dimensions 2, 3). Each ray is still (x uniform on A_i,
                // direction by the projected solid angle of A_j from x); dimensions are
                // scrambled independently, so x and its directions are independent.
                const std::uint32_t n_groups = (nr + K - 1) / K;
                for (std::uint32_t g0 = 0; g0 < n_groups; g0 += kGroupChunk) {
                    const std::uint32_t gc = std::min(kGroupChunk, n_groups - g0);
                    const std::uint32_t d0 = g0 * K, dc = std::min(gc * K, nr - d0);
                    set.generate(g0, gc, us);
                    set.generate(d0, dc, ud);
                    for (std::uint32_t g = 0; g < gc; ++g) {
                        const std::uint32_t m = std::min(K, dc - g * K);
                        const Vec3 x = senders[i](us[0][g], us[1][g]);
                        const double w = target.set_origin(x, pi.normal);
                        if (!(w > 0)) continue;
                        if (queries.size() + m > kBatch) flush();
                        Group grp{static_cast<std::uint32_t>(queries.size()), 0, w,
                                  static_cast<std::uint32_t>(j * run.R + r)};
                        const double h = plane - pj.normal.dot(x);  // < 0: x in front
                        for (std::uint32_t k = g * K; k < g * K + m; ++k) {
                            const Vec3 d = target.sample(ud[2][k], ud[3][k], retry);
                            const double den = pj.normal.dot(d);
                            if (!(den < 0)) continue;  // grazing: measure zero
                            queries.push_back({x, x + (h / den) * d, from, to});
                            ++grp.count;
                        }
                        if (grp.count > 0) groups.push_back(grp);
                    }
                }
            }
        }
        if (!queries.empty()) flush();
        return row_rays;
    }

    // Pass 2, estimates: row i of F (F_unocc × the visible fraction) and of its standard error
    // from the accumulators, which are left zero for the next row. Counts the row's pairs and
    // those found unblocked.
    void estimate_row(std::size_t i, RowBuffers& buf, std::uint64_t& row_pairs,
                      std::uint64_t& row_unblocked) const {
        std::vector<double>&W = buf.W, &V = buf.V, &A2 = buf.A2, &B2 = buf.B2, &C2 = buf.C2;
        std::vector<double>& rho = buf.rho;
        for (std::size_t j = 0; j < run.n; ++j) {
            const double f_unocc = j == i ? 0.0 : unocc_at(i, j);
            if (!(f_unocc > 0)) continue;
            ++row_pairs;
            if (cleared(i, j)) {  // F_ij = F_unocc, standard error 0, as set
                ++row_unblocked;
                continue;
            }
            const auto ii = static_cast<Eigen::Index>(i - off);
            const auto jj = static_cast<Eigen::Index>(j);
            double w_sum = 0, v_sum = 0;
            std::uint32_t used = 0;
            for (std::size_t k = j * run.R; k < (j + 1) * run.R; ++k) {  // j's replicates
                w_sum += W[k];
                v_sum += V[k];
                if (W[k] > 0) rho[used++] = V[k] / W[k];
                W[k] = V[k] = 0.0;  // zero for the next row
            }
            const double a2 = A2[j], b2 = B2[j], c2 = C2[j];
            A2[j] = B2[j] = C2[j] = 0.0;
            if (!(w_sum > 0)) {
                // No sender point saw j (a sliver of visibility): unknown, and said so.
                ff.F(ii, jj) = f_unocc;
                (*ff.standard_error)(ii, jj) = f_unocc;
                continue;
            }
            const double ratio = v_sum / w_sum;
            if (v_sum == w_sum) ++row_unblocked;
            ff.F(ii, jj) = f_unocc * ratio;
            double se = 0;
            if (run.R > 1) {
                if (used > 1) {
                    double m = 0, s2 = 0;
                    for (std::uint32_t k = 0; k < used; ++k) m += rho[k] / used;
                    for (std::uint32_t k = 0; k < used; ++k) s2 += (rho[k] - m) * (rho[k] - m);
                    se = std::sqrt(s2 / (used - 1) / used);
                }
            } else {
                // Σ_g w_g²(v_g − ρ m_g)² over the groups (sender points).
                const double v = a2 - 2 * ratio * b2 + ratio * ratio * c2;
                se = std::sqrt(std::max(0.0, v)) / w_sum;
            }
            (*ff.standard_error)(ii, jj) = f_unocc * se;
        }
    }
};

class McTargetMethod final : public mc::MonteCarloMethod {
  public:
    MethodKind kind() const override { return MethodKind::mc_target; }

    MethodResult compute(const MethodContext& ctx) const override {
        const mc::Run run(*this, ctx, 64);
        const mc::SegmentRecheckCount recheck(*run.vis);
        mc::PhaseTimer phase_timer;
        Fields phases;
        std::vector<PolygonSampler> senders;
        senders.reserve(run.n);
        std::vector<char> convex(run.n);
        for (std::size_t p = 0; p < run.n; ++p) {
            const Patch& patch = run.scene.patches[p];
            senders.emplace_back(patch.polygon);
            convex[p] = is_convex(patch.polygon) ? 1 : 0;
        }
        phase_timer.lap(phases, "visibility");

        MethodResult result;
        result.report.method = this->kind();
        FormFactors& ff = result.form_factors;

        // Pass 1: the unobstructed F_ij of every pair (the analytic method's unobstructed pass:
        // the double contour integral for near pairs, the far-field rule where its a-priori
        // bound is ≤ kUnoccludedTolerance, once per unordered pair and the other entry by
        // reciprocity). ff.F holds F_unocc until pass 2 scales its own row. A block of rows gets
        // its rows and the pairs of the rows before it with its patches (the whole matrix's
        // values bit for bit): ff.F is then rows × N, row i at i − rows.begin.
        std::vector<const Polygon*> polys(run.n);
        for (std::size_t p = 0; p < run.n; ++p) polys[p] = &run.scene.patches[p].polygon;
        const bool whole = run.rows.size() == run.n;
        detail::UnobstructedBlock block;
        const detail::UnobstructedStats unocc = detail::unobstructed_rows(
            polys, kUnoccludedTolerance, run.options.threads, nullptr, run.rows, block);
        ff.F = std::move(block.F);
        ff.areas = std::move(block.areas);
        ff.first_row = run.rows.begin;
        ff.standard_error = DenseMatrix::Zero(ff.F.rows(), ff.F.cols());
        phase_timer.lap(phases, "unobstructed");

        const ClearPairs cleared(run, whole, [&](std::size_t i, std::size_t j) {
            return ff.F(static_cast<Eigen::Index>(i - run.rows.begin),
                        static_cast<Eigen::Index>(j));
        });
        phase_timer.lap(phases, "shaft_culling");

        // Pass 2 (rays) on the rows asked for.
        const TargetRows rows{run, senders, convex, ff, run.rows.begin, cleared};
        std::atomic<std::uint64_t> rays{0}, unblocked_pairs{0}, pairs{0};
        Progress progress("mc-target", run.rows.size(), ctx.progress);
        parallel_for(run.rows.size(), run.options.threads, [&](std::size_t row) {
            const std::size_t i = run.rows.begin + row;
            thread_local RowBuffers buf;
            buf.prepare(run.n, run.R);
            const std::uint64_t row_rays = rows.trace_row(i, buf);
            std::uint64_t row_pairs = 0, row_unblocked = 0;
            rows.estimate_row(i, buf, row_pairs, row_unblocked);
            buf.clean = true;
            rays += row_rays;
            pairs += row_pairs;
            unblocked_pairs += row_unblocked;
            progress.advance();
        });
        progress.finish();
        phase_timer.lap(phases, "rays");
        mc::report(result.report, ff, run.kind, run.N, run.R, rays.load(),
                   mc::seconds_since(run.t0), run.vis->description(), "rays per patch pair");
        Fields& details = result.report.details;
        details["pairs"] = pairs.load();
        details["phases"] = phases;
        // Both orders of each pair for the whole matrix; a block counts its rows' pairs.
        details["pairs_without_rays"] = cleared.count() * (whole ? 2 : 1);
        details["unoccluded_far_field_pairs"] = unocc.far;
        details["unoccluded_contour_pairs"] = unocc.exact;
        details["unblocked_pairs"] = unblocked_pairs.load();
        recheck.report(result.report.details);
        return result;
    }
};

}  // namespace

std::unique_ptr<Method> make_mc_target_method() { return std::make_unique<McTargetMethod>(); }

}  // namespace formfactor
