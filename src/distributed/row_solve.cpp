// The solvers on rows of F spread over ranks (row_solve.h).

#include "row_solve.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <new>
#include <optional>
#include <utility>

#include "formfactor/core/cancel.h"
#include "formfactor/core/error.h"
#include "formfactor/core/parallel.h"
#include "formfactor/core/progress.h"
#include "formfactor/pipeline.h"
#include "formfactor/pipeline_sparse.h"

namespace formfactor::distributed {

namespace {

using RowVector = Eigen::Map<const Eigen::Matrix<double, 1, Eigen::Dynamic>>;

// The largest alignment Eigen gives a matrix (AVX-512): a row placed at the same address
// modulo this is summed in the same order.
constexpr std::size_t kAlignment = 64;

double max_abs(const Columns& x) { return x.size() ? x.cwiseAbs().maxCoeff() : 0.0; }

}  // namespace

KeptBlock keep_dense(RowRange rows, const double* data, std::size_t n) {
    KeptBlock b;
    b.rows = rows;
    const std::size_t count = rows.size() * n;
    b.storage.resize(count + kAlignment / sizeof(double));
    // Row `rows.begin` of the whole matrix starts begin·n doubles after an aligned address.
    const std::size_t want = (rows.begin * n * sizeof(double)) % kAlignment;
    const auto base = reinterpret_cast<std::uintptr_t>(b.storage.data());
    while ((base + b.offset * sizeof(double)) % kAlignment != want) ++b.offset;
    if (count) std::memcpy(b.storage.data() + b.offset, data, count * sizeof(double));
    return b;
}

KeptBlock keep_sparse(SparseRows rows, std::size_t n, double threshold, int threads,
                      double& dropped_max) {
    KeptBlock b;
    b.rows = {rows.first_row, rows.first_row + rows.size()};
    // The builder's first rows: the block's, counted from 0 (columns stay global).
    SparseBuilder builder(n, std::vector<double>(n, 0.0), threshold, false);
    rows.first_row = 0;
    builder.append(std::move(rows), threads);
    const SparseFormFactors& m = builder.current();
    b.indptr = m.indptr;
    b.indices = m.indices;
    b.values = m.values;
    dropped_max = 0.0;
    for (double v : m.dropped) dropped_max = std::max(dropped_max, v);
    return b;
}

std::vector<double> kept_row_sums(const KeptBlock& block, std::size_t n, bool sparse) {
    std::vector<double> sums(block.rows.size());
    for (std::size_t r = 0; r < sums.size(); ++r) {
        if (sparse) {
            double s = 0.0;
            for (auto k = block.indptr[r]; k < block.indptr[r + 1]; ++k)
                s += block.values[static_cast<std::size_t>(k)];
            sums[r] = s;
        } else {
            sums[r] =
                RowVector(block.row(block.rows.begin + r, n), static_cast<Eigen::Index>(n)).sum();
        }
    }
    return sums;
}

std::size_t kept_entries(const KeptBlock& block, std::size_t n, bool sparse) {
    return sparse ? block.values.size() : block.rows.size() * n;
}

namespace {

// One rank's part of a solve: its rows' products and sweeps, the exchanges, and its own failure.
class Runner {
  public:
    Runner(const KeptRows& rows, int rank, Exchange& exchange, int threads)
        : rows_(rows), rank_(rank), exchange_(exchange), threads_(threads) {
        // For the tests of a rank failing mid-solve: FORMFACTOR_TEST_FAIL_SOLVE_RANK=K fails
        // rank K's first product.
        if (const char* fail = std::getenv("FORMFACTOR_TEST_FAIL_SOLVE_RANK"))
            fail_ = std::atoi(fail) == rank;
        const std::size_t chunk = rows.sparse ? 256 : 32;
        for (std::size_t b = 0; b < rows.blocks.size(); ++b)
            for (std::size_t i = rows.blocks[b].rows.begin; i < rows.blocks[b].rows.end; i += chunk)
                chunks_.push_back({b, {i, std::min(rows.blocks[b].rows.end, i + chunk)}});
    }

    /// y = F x, every row on every rank.
    void apply(const Columns& x, Columns& y) {
        const auto n = static_cast<Eigen::Index>(rows_.n);
        if (y.rows() != n || y.cols() != x.cols()) y.resize(n, x.cols());
        const RankStatus status = guarded([&] {
            if (fail_)
                throw Error(fmt::format(
                    "a failure injected on rank {} (FORMFACTOR_TEST_FAIL_SOLVE_RANK)", rank_));
            parallel_for(chunks_.size(), threads_,
                         [&](std::size_t c) { multiply(chunks_[c], x, y); });
        });
        exchange(y, status, 0.0);
    }

    /// One sweep over this rank's blocks (Gauss–Seidel within a block, every block from the
    /// values at the start of the sweep), then the exchange; returns the largest change.
    double sweep(const Columns& d, const Columns& c, Columns& x) {
        double change = 0.0;
        const RankStatus status = guarded([&] { change = sweep_own(d, c, x); });
        return exchange(x, status, change);
    }

  private:
    struct Chunk {
        std::size_t block;
        RowRange rows;
    };

    template <class Work>
    RankStatus guarded(const Work& work) {
        if (process_cancellation().requested()) return RankStatus::cancelled;
        try {
            work();
            return RankStatus::fine;
        } catch (const Cancelled&) {
            return RankStatus::cancelled;
        } catch (const std::bad_alloc&) {
            failure_ =
                "out of memory: the run needed more memory than this rank's machine could give "
                "(use fewer patches, or free memory)";
        } catch (const std::exception& e) {
            failure_ = e.what();
        }
        return RankStatus::failed;
    }

    double exchange(Columns& v, RankStatus status, double change) {
        const Exchanged e = exchange_.exchange(v, status, change);
        if (e.status != RankStatus::fine)
            throw RankStopped(e, e.rank == rank_ ? failure_ : std::string());
        return e.change;
    }

    void multiply(const Chunk& chunk, const Columns& x, Columns& y) const {
        const KeptBlock& b = rows_.blocks[chunk.block];
        const std::size_t n = rows_.n;
        for (std::size_t i = chunk.rows.begin; i < chunk.rows.end; ++i) {
            const auto row = static_cast<Eigen::Index>(i);
            if (rows_.sparse) {
                const std::size_t r = i - b.rows.begin;
                const auto begin = static_cast<std::size_t>(b.indptr[r]);
                const auto end = static_cast<std::size_t>(b.indptr[r + 1]);
                for (Eigen::Index k = 0; k < x.cols(); ++k) {
                    double s = 0.0;
                    for (std::size_t e = begin; e < end; ++e) s += b.values[e] * x(b.indices[e], k);
                    y(row, k) = s;
                }
            } else {
                const RowVector f(b.row(i, n), static_cast<Eigen::Index>(n));
                for (Eigen::Index k = 0; k < x.cols(); ++k) y(row, k) = f.dot(x.col(k));
            }
        }
    }

    // The sweeps of this rank's blocks: each block in place, then its start values put back so
    // that the next block sees them; the new values go in at the end.
    double sweep_own(const Columns& d, const Columns& c, Columns& x) {
        const std::size_t n = rows_.n;
        double change = 0.0;
        std::vector<Columns> swept;
        swept.reserve(rows_.blocks.size());
        for (const KeptBlock& b : rows_.blocks) {
            const auto first = static_cast<Eigen::Index>(b.rows.begin);
            const auto m = static_cast<Eigen::Index>(b.rows.size());
            const Columns start = x.middleRows(first, m);
            for (std::size_t i = b.rows.begin; i < b.rows.end; ++i) {
                const auto row = static_cast<Eigen::Index>(i);
                double changed = 0.0;
                if (rows_.sparse) {
                    const std::size_t r = i - b.rows.begin;
                    const auto begin = static_cast<std::size_t>(b.indptr[r]);
                    const auto end = static_cast<std::size_t>(b.indptr[r + 1]);
                    changed =
                        detail::gauss_seidel_row(row, b.indices.data() + begin,
                                                 b.values.data() + begin, end - begin, d, c, x);
                } else {
                    const RowVector f(b.row(i, n), static_cast<Eigen::Index>(n));
                    changed = detail::gauss_seidel_row(row, f, d, c, x);
                }
                change = std::max(change, changed);
            }
            swept.push_back(x.middleRows(first, m));
            x.middleRows(first, m) = start;
            current_cancellation().throw_if_requested();
        }
        for (std::size_t k = 0; k < rows_.blocks.size(); ++k)
            x.middleRows(static_cast<Eigen::Index>(rows_.blocks[k].rows.begin),
                         static_cast<Eigen::Index>(rows_.blocks[k].rows.size())) = swept[k];
        return change;
    }

    const KeptRows& rows_;
    int rank_;
    Exchange& exchange_;
    int threads_;
    std::vector<Chunk> chunks_;
    std::string failure_;
    bool fail_ = false;
};

// ‖c + D y − x‖_∞ / ‖x‖_∞ for y = F x (0 when x = 0), as the single-process solvers measure it.
double residual_of(const Columns& d, const Columns& c, const Columns& x, const Columns& y) {
    double r = 0.0;
    for (Eigen::Index k = 0; k < x.cols(); ++k)
        for (Eigen::Index i = 0; i < x.rows(); ++i)
            r = std::max(r, std::abs(c(i, k) + d(i, k) * y(i, k) - x(i, k)));
    const double xm = max_abs(x);
    if (xm == 0.0) return r == 0.0 ? 0.0 : std::numeric_limits<double>::infinity();
    return r / xm;
}

}  // namespace

SolverStats solve_kept(const KeptRows& rows, int rank, Exchange& exchange, const Columns& d,
                       const Columns& c, const SolverOptions& options, Columns& x, Columns& fx) {
    const auto start = std::chrono::steady_clock::now();
    const auto n = static_cast<Eigen::Index>(rows.n);
    FF_ASSERT(d.rows() == n && c.rows() == n && d.cols() == c.cols());
    // Every rank stops together, through the exchange: no loop may stop on its own.
    const CancellationFlag never;
    const CancellationScope scope(never);
    Runner runner(rows, rank, exchange, options.threads);
    const detail::ApplyF apply = [&](const Columns& v, Columns& y) { runner.apply(v, y); };
    SolverStats st;
    if (options.solver == SolverKind::jacobi || options.solver == SolverKind::gmres) {
        st = detail::solve_linear_operator(apply, n, d, c, options, x);
        apply(x, fx);
        return st;
    }
    if (options.solver != SolverKind::gauss_seidel)
        throw OptionError("solver",
                          fmt::format("{} runs on one process; rows spread over ranks are solved "
                                      "by gauss-seidel, gmres or jacobi",
                                      to_string(options.solver)));
    if (!(options.residual > 0.0) || !std::isfinite(options.residual))
        throw OptionError("residual", "must be a positive number");
    if (options.max_iterations < 0)
        throw OptionError("max_iterations", "must be ≥ 0 (0 = automatic)");
    st.solver = to_string(options.solver);
    st.tolerance = options.residual;
    const long long max_it = options.max_iterations > 0 ? options.max_iterations : 10000;
    Progress progress("solve (" + st.solver + ")", static_cast<std::size_t>(max_it),
                      options.progress);
    x = c;
    // In the ∞-norm the residual after a sweep is at most the largest update (row sums of D F
    // ≤ 1), so a small update triggers the exact residual check, as on one process.
    double residual = 0.0;
    bool done = false;
    while (st.iterations < max_it && !done) {
        const double change = runner.sweep(d, c, x);
        ++st.iterations;
        progress.advance();
        const double xm = max_abs(x);
        if (change <= options.residual * xm || xm == 0.0) {
            apply(x, fx);
            residual = residual_of(d, c, x, fx);
            done = residual <= options.residual;
        }
    }
    progress.finish();
    if (!done) {
        apply(x, fx);
        residual = residual_of(d, c, x, fx);
    }
    st.residual = residual;
    st.converged = residual <= options.residual;
    st.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (!st.converged) {
        const std::string msg = fmt::format(
            "solve: {} did not converge in {} sweeps: relative residual {:.3g} > tolerance "
            "{:.3g} (raise `max_iterations` or loosen `residual`)",
            st.solver, st.iterations, st.residual, st.tolerance);
        if (options.fail_if_not_converged) throw Error(msg);
        st.warnings.push_back(msg);
    }
    return st;
}

KeptRows& kept_rows() {
    static KeptRows rows;
    return rows;
}

std::uint64_t& kept_id() {
    static std::uint64_t id = 0;
    return id;
}

void check_kept(const DistributedRows& rows) {
    if (rows.id == 0 || rows.id != kept_id() || rows.n != kept_rows().n)
        throw Error("solve: the rows of F were replaced by a later computation");
}

DistributedRows compute_rows_here(const Scene& scene, const ComputeOptions& options,
                                  const SparseOptions* sparse) {
    if (options.repair.mode != RepairMode::none)
        throw OptionError("repair", "needs the whole F on one process, not rows kept apart");
    KeptRows& kept = kept_rows();
    kept = KeptRows{};
    DistributedRows out;
    out.sparse = sparse != nullptr;
    if (sparse) {
        SparseComputeResult r = formfactor::compute_sparse_form_factors(scene, options, *sparse);
        const SparseFormFactors& F = r.form_factors;
        KeptBlock b;
        b.rows = {0, F.n};
        b.indptr = F.indptr;
        b.indices = F.indices;
        b.values = F.values;
        out.n = F.n;
        out.areas = F.areas;
        out.row_sums = kept_row_sums(b, F.n, true);
        out.dropped_max = detail::max_dropped(F);
        out.entries = double(F.nonzeros());
        out.threshold = F.threshold;
        out.report = std::move(r.report);
        out.traits = r.traits;
        out.timings = r.timings;
        out.threads = r.threads;
        kept.blocks.push_back(std::move(b));
    } else {
        ComputeResult r = formfactor::compute_form_factors(scene, options);
        const std::size_t n = r.form_factors.size();
        out.n = n;
        out.areas = r.form_factors.areas;
        KeptBlock b = keep_dense({0, n}, r.form_factors.F.data(), n);
        out.row_sums = kept_row_sums(b, n, false);
        out.entries = double(n) * double(n);
        out.report = std::move(r.report);
        out.traits = r.traits;
        out.timings = r.timings;
        out.threads = r.threads;
        kept.blocks.push_back(std::move(b));
    }
    kept.sparse = out.sparse;
    kept.n = out.n;
    out.rows_per_rank = {double(out.n)};
    out.id = ++kept_id();
    return out;
}

namespace {

// Contiguous blocks, one per rank, each with about 1/ranks of the total weight (`cumulative`
// holds the weight of rows [0, i] at i).
std::vector<RowRange> even_blocks(const std::vector<double>& cumulative, int ranks) {
    const std::size_t n = cumulative.size();
    const double total = n ? cumulative.back() : 0.0;
    std::vector<RowRange> blocks;
    std::size_t begin = 0;
    for (int r = 0; r < ranks; ++r) {
        std::size_t end = n;
        if (r + 1 < ranks) {
            const double target = total * double(r + 1) / double(ranks);
            // Up to and with the row where the weight reaches the target.
            end = std::size_t(std::lower_bound(cumulative.begin(), cumulative.end(), target) -
                              cumulative.begin()) +
                  1;
            end = std::clamp(end, begin, n);
        }
        blocks.push_back({begin, end});
        begin = end;
    }
    return blocks;
}

}  // namespace

WholeRows whole_rows(const FormFactors& F, int ranks) {
    if (F.is_block())
        throw Error("solve: the rows of F spread over ranks must be the whole matrix, not a block");
    WholeRows w;
    const std::size_t n = F.size();
    w.head.n = n;
    w.head.areas = F.areas;
    w.head.entries = double(n) * double(n);
    std::vector<double> cumulative(n);
    for (std::size_t i = 0; i < n; ++i) cumulative[i] = double(i + 1);
    w.blocks = even_blocks(cumulative, ranks);
    w.block = [&F, n](RowRange rows) { return keep_dense(rows, F.F.data() + rows.begin * n, n); };
    return w;
}

WholeRows whole_rows(const SparseFormFactors& F, int ranks) {
    F.check();
    WholeRows w;
    const std::size_t n = F.n;
    w.head.sparse = true;
    w.head.n = n;
    w.head.areas = F.areas;
    w.head.entries = double(F.nonzeros());
    w.head.threshold = F.threshold;
    w.head.dropped_max = detail::max_dropped(F);
    // A product's work: a row and its stored entries.
    std::vector<double> cumulative(n);
    for (std::size_t i = 0; i < n; ++i) cumulative[i] = double(i + 1) + double(F.indptr[i + 1]);
    w.blocks = even_blocks(cumulative, ranks);
    w.block = [&F](RowRange rows) {
        KeptBlock b;
        b.rows = rows;
        const std::int64_t first = F.indptr[rows.begin], last = F.indptr[rows.end];
        b.indptr.reserve(rows.size() + 1);
        for (std::size_t i = rows.begin; i <= rows.end; ++i)
            b.indptr.push_back(F.indptr[i] - first);
        b.indices.assign(F.indices.begin() + first, F.indices.begin() + last);
        b.values.assign(F.values.begin() + first, F.values.begin() + last);
        return b;
    };
    return w;
}

DistributedRows distribute_rows_here(const WholeRows& whole) {
    KeptRows& kept = kept_rows();
    kept = KeptRows{};
    DistributedRows out = whole.head;
    kept.sparse = out.sparse;
    kept.n = out.n;
    kept.blocks.push_back(whole.block({0, out.n}));
    out.row_sums = kept_row_sums(kept.blocks.back(), out.n, out.sparse);
    out.rows_per_rank = {double(out.n)};
    out.id = ++kept_id();
    return out;
}

namespace {

// One process: every row is already here.
class OwnRows final : public Exchange {
  public:
    Exchanged exchange(Columns& x, RankStatus status, double change) override {
        (void)x;
        return {status, 0, change};
    }
};

}  // namespace

SolverStats solve_rows_here(const DistributedRows& rows, const Columns& d, const Columns& c,
                            const SolverOptions& options, Columns& x, Columns& fx) {
    check_kept(rows);
    OwnRows own;
    try {
        return solve_kept(kept_rows(), 0, own, d, c, options, x, fx);
    } catch (const RankStopped& e) {
        if (e.state.status == RankStatus::cancelled) throw Cancelled();
        throw Error(e.own_message);
    }
}

// The rows follow the cost of computing them, which may differ from a product's (rows, or stored
// entries) many times over. While it helps, the busiest rank gives the least busy one its
// largest block that lowers the larger of the two loads. Deterministic: the same blocks give
// the same moves.
std::vector<Move> balancing_moves(Owners& owners, const std::map<std::size_t, double>& weights) {
    const std::size_t ranks = owners.size();
    std::vector<double> load(ranks, 0.0);
    for (std::size_t r = 0; r < ranks; ++r)
        for (const RowRange& b : owners[r]) load[r] += weights.at(b.begin);
    std::vector<Move> moves;
    for (std::size_t step = 0; step < weights.size(); ++step) {
        const auto most = std::size_t(std::max_element(load.begin(), load.end()) - load.begin());
        const auto least = std::size_t(std::min_element(load.begin(), load.end()) - load.begin());
        const double gap = load[most] - load[least];
        // A block of weight w < gap lowers max(load[most], load[least] + w).
        std::optional<std::size_t> pick;
        double best = 0.0;
        for (std::size_t k = 0; k < owners[most].size(); ++k) {
            const double w = weights.at(owners[most][k].begin);
            if (w < gap && w > best) {
                best = w;
                pick = k;
            }
        }
        if (!pick || best < 0.02 * load[most]) break;
        const RowRange b = owners[most][*pick];
        owners[most].erase(owners[most].begin() + std::ptrdiff_t(*pick));
        owners[least].push_back(b);
        load[most] -= best;
        load[least] += best;
        // A block that moved already goes on from its first rank: make_moves() sends only
        // what a rank holds before the moves (a chain 1 → 2 → 0 left rank 2 sending a block
        // it had not received, and ranks 0 and 1 waiting for it).
        const auto moved = std::find_if(moves.begin(), moves.end(),
                                        [&](const Move& m) { return m.rows.begin == b.begin; });
        if (moved == moves.end())
            moves.push_back({b, std::int32_t(most), std::int32_t(least)});
        else if (moved->from == std::int32_t(least))
            moves.erase(moved);  // back where it was
        else
            moved->to = std::int32_t(least);
    }
    for (auto& blocks : owners)
        std::sort(blocks.begin(), blocks.end(),
                  [](const RowRange& a, const RowRange& b) { return a.begin < b.begin; });
    return moves;
}

}  // namespace formfactor::distributed
