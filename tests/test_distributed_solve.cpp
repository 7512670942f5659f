// The solvers on rows of F spread over ranks (src/distributed/row_solve.h), with the ranks played
// by threads that exchange through memory: the same iteration as under mpirun, no MPI needed.

#include <doctest/doctest.h>

#include <barrier>
#include <cstdlib>
#include <cstring>
#include <map>
#include <optional>
#include <random>
#include <set>
#include <thread>

#include "distributed/row_solve.h"
#include "formfactor/pipeline.h"
#include "formfactor/solve/thermal.h"
#include "solve/linear_system.h"

using namespace formfactor;
using namespace formfactor::distributed;

namespace {

bool same_bits(const Columns& a, const Columns& b) {
    return a.rows() == b.rows() && a.cols() == b.cols() &&
           std::memcmp(a.data(), b.data(), sizeof(double) * std::size_t(a.size())) == 0;
}

// F of the cube split 3×3 per face (54 patches), analytic; a grey system on it.
struct Problem {
    FormFactors ff;
    Columns d, c;
};

Problem cube_problem() {
    Scene scene = load_scene("cube");
    subdivide(scene, SubdivisionOptions{3, 0.0});
    Problem p;
    p.ff = compute_form_factors(scene).form_factors;
    const auto n = static_cast<Eigen::Index>(p.ff.size());
    p.d.resize(n, 1);
    p.c.resize(n, 1);
    for (Eigen::Index i = 0; i < n; ++i) {
        p.d(i, 0) = 0.2 + 0.7 * double(i % 7) / 6.0;  // 1 − ε
        p.c(i, 0) = 100.0 + double((i * 37) % 11);
    }
    return p;
}

// Rows [bounds[b], bounds[b + 1]) are block b; block b goes to rank owner[b].
struct Layout {
    std::vector<std::size_t> bounds;
    std::vector<int> owner;
    int ranks = 1;
};

std::vector<KeptRows> spread(const FormFactors& ff, const Layout& layout, bool sparse) {
    const std::size_t n = ff.size();
    std::vector<KeptRows> rows(static_cast<std::size_t>(layout.ranks));
    const SparseFormFactors csr = to_sparse(ff);
    for (KeptRows& r : rows) {
        r.n = n;
        r.sparse = sparse;
    }
    for (std::size_t b = 0; b + 1 < layout.bounds.size(); ++b) {
        const RowRange range{layout.bounds[b], layout.bounds[b + 1]};
        KeptBlock block;
        if (sparse) {
            block.rows = range;
            const auto first = csr.indptr[range.begin];
            for (std::size_t i = range.begin; i <= range.end; ++i)
                block.indptr.push_back(csr.indptr[i] - first);
            block.indices.assign(csr.indices.begin() + first,
                                 csr.indices.begin() + csr.indptr[range.end]);
            block.values.assign(csr.values.begin() + first,
                                csr.values.begin() + csr.indptr[range.end]);
        } else {
            block = keep_dense(range, ff.F.data() + range.begin * n, n);
        }
        rows[static_cast<std::size_t>(layout.owner[b])].blocks.push_back(std::move(block));
    }
    return rows;
}

// The exchange of ranks that are threads of this process.
class ThreadRanks {
  public:
    ThreadRanks(const Layout& layout, const std::vector<KeptRows>& rows)
        : sync_(layout.ranks),
          rows_(rows),
          x_(std::size_t(layout.ranks)),
          status_(std::size_t(layout.ranks)),
          change_(std::size_t(layout.ranks)) {}

    class Rank final : public Exchange {
      public:
        Rank(ThreadRanks& all, int rank) : all_(all), rank_(rank) {}
        Exchanged exchange(Columns& x, RankStatus status, double change) override {
            const auto me = std::size_t(rank_);
            all_.x_[me] = &x;
            all_.status_[me] = status;
            all_.change_[me] = change;
            all_.sync_.arrive_and_wait();
            Exchanged e;
            for (std::size_t r = 0; r < all_.x_.size(); ++r) {
                if (int(all_.status_[r]) > int(e.status)) {
                    e.status = all_.status_[r];
                    e.rank = int(r);
                }
                e.change = std::max(e.change, all_.change_[r]);
                if (r == me) continue;
                for (const KeptBlock& b : all_.rows_[r].blocks)
                    x.middleRows(Eigen::Index(b.rows.begin), Eigen::Index(b.rows.size())) =
                        all_.x_[r]->middleRows(Eigen::Index(b.rows.begin),
                                               Eigen::Index(b.rows.size()));
            }
            all_.sync_.arrive_and_wait();  // every rank has read every other's rows
            return e;
        }

      private:
        ThreadRanks& all_;
        int rank_;
    };

  private:
    std::barrier<> sync_;
    const std::vector<KeptRows>& rows_;
    std::vector<Columns*> x_;
    std::vector<RankStatus> status_;
    std::vector<double> change_;
};

struct RankResult {
    Columns x, fx;
    SolverStats stats;
    std::optional<RankStopped> stopped;
};

// solve_kept() on every rank of `layout`, each on a thread of its own.
std::vector<RankResult> solve_on_ranks(const Problem& p, const Layout& layout, bool sparse,
                                       const SolverOptions& o) {
    const std::vector<KeptRows> rows = spread(p.ff, layout, sparse);
    ThreadRanks all(layout, rows);
    std::vector<RankResult> out(std::size_t(layout.ranks));
    std::vector<std::thread> threads;
    for (int r = 0; r < layout.ranks; ++r)
        threads.emplace_back([&, r] {
            ThreadRanks::Rank exchange(all, r);
            RankResult& mine = out[std::size_t(r)];
            try {
                mine.stats =
                    solve_kept(rows[std::size_t(r)], r, exchange, p.d, p.c, o, mine.x, mine.fx);
            } catch (const RankStopped& e) {
                mine.stopped = e;
            }
        });
    for (std::thread& t : threads) t.join();
    return out;
}

const Layout kThreeRanks{{0, 10, 19, 27, 34, 40, 45, 49, 52, 54}, {0, 1, 2, 0, 2, 1, 1, 0, 2}, 3};
// The same blocks, held by other ranks.
const Layout kThreeRanksShuffled{
    {0, 10, 19, 27, 34, 40, 45, 49, 52, 54}, {2, 0, 1, 1, 0, 2, 0, 1, 2}, 3};

}  // namespace

TEST_CASE(
    "distributed rows: gmres and jacobi over 3 ranks give one process's solution bit for bit, "
    "dense and sparse") {
    const Problem p = cube_problem();
    for (const bool sparse : {false, true})
        for (const SolverKind kind : {SolverKind::gmres, SolverKind::jacobi}) {
            CAPTURE(sparse);
            CAPTURE(to_string(kind));
            SolverOptions o;
            o.solver = kind;
            o.residual = 1e-10;
            o.threads = 1;
            Columns expected;
            if (sparse)
                detail::solve_linear(to_sparse(p.ff), p.d, p.c, o, expected);
            else
                detail::solve_linear(p.ff.F, p.ff.areas, p.d, p.c, o, expected);
            const std::vector<RankResult> got = solve_on_ranks(p, kThreeRanks, sparse, o);
            for (const RankResult& r : got) {
                REQUIRE_FALSE(r.stopped);
                CHECK(same_bits(r.x, expected));
                CHECK(r.stats.converged);
            }
        }
}

TEST_CASE(
    "distributed rows: gauss-seidel over 3 ranks meets the tolerance of one process and does "
    "not depend on which rank holds which block") {
    const Problem p = cube_problem();
    for (const bool sparse : {false, true}) {
        CAPTURE(sparse);
        SolverOptions o;
        o.solver = SolverKind::gauss_seidel;
        o.residual = 1e-11;
        o.threads = 1;
        Columns serial;
        const SolverStats one = detail::solve_linear(p.ff.F, p.ff.areas, p.d, p.c, o, serial);
        const std::vector<RankResult> a = solve_on_ranks(p, kThreeRanks, sparse, o);
        const std::vector<RankResult> b = solve_on_ranks(p, kThreeRanksShuffled, sparse, o);
        for (std::size_t r = 0; r < a.size(); ++r) {
            REQUIRE_FALSE(a[r].stopped);
            REQUIRE_FALSE(b[r].stopped);
            CHECK(same_bits(a[r].x, a[0].x));
            CHECK(same_bits(b[r].x, a[0].x));
        }
        CHECK(a[0].stats.converged);
        CHECK(a[0].stats.residual <= o.residual);
        // Blocks swept from the start of the sweep: more sweeps than one process's, not many.
        CHECK(a[0].stats.iterations >= one.iterations);
        CHECK(a[0].stats.iterations <= 4 * one.iterations);
        const double scale = serial.cwiseAbs().maxCoeff();
        CHECK((a[0].x - serial).cwiseAbs().maxCoeff() <= 1e-9 * scale);
        // F x is the product of the returned solution.
        Columns fx;
        if (sparse)
            detail::multiply(to_sparse(p.ff), a[0].x, fx, 1);
        else
            detail::multiply(p.ff.F, a[0].x, fx, 1);
        CHECK(same_bits(a[0].fx, fx));
    }
}

TEST_CASE("distributed rows: a rank that fails mid-solve stops every rank, which name it") {
    const Problem p = cube_problem();
    SolverOptions o;
    o.solver = SolverKind::gmres;
    o.threads = 1;
    ::setenv("FORMFACTOR_TEST_FAIL_SOLVE_RANK", "1", 1);
    const std::vector<RankResult> got = solve_on_ranks(p, kThreeRanks, false, o);
    ::unsetenv("FORMFACTOR_TEST_FAIL_SOLVE_RANK");
    for (std::size_t r = 0; r < got.size(); ++r) {
        CAPTURE(r);
        REQUIRE(got[r].stopped);
        CHECK(got[r].stopped->state.status == RankStatus::failed);
        CHECK(got[r].stopped->state.rank == 1);
        CHECK((r == 1) == !got[r].stopped->own_message.empty());
    }
    CHECK(got[1].stopped->own_message.find("a failure injected on rank 1") != std::string::npos);
}

TEST_CASE(
    "distributed rows on one process: the thermal solve equals solve_thermal on the pipeline's F "
    "bit for bit") {
    Scene scene = load_scene("cube");
    subdivide(scene, SubdivisionOptions{3, 0.0});
    PatchProperties props = properties_from_scene(scene);
    for (std::size_t i = 0; i < props.size(); ++i) {
        props.emissivity[i] = 0.3 + 0.1 * double(i % 7);
        props.temperature[i] = 300.0 + double(i % 5) * 20.0;
    }
    ThermalOptions to;
    to.solver.solver = SolverKind::gmres;
    to.solver.threads = 1;
    const ThermalResult expected =
        formfactor::solve_thermal(compute_form_factors(scene).form_factors, props, to);
    for (const bool sparse : {false, true}) {
        CAPTURE(sparse);
        SparseOptions so;
        const DistributedRows rows =
            compute_distributed_rows(scene, ComputeOptions{}, sparse ? &so : nullptr);
        CHECK(rows.n == scene.patches.size());
        const ThermalResult got = distributed::solve_thermal(rows, props, to);
        if (!sparse) {
            CHECK(got.radiosity == expected.radiosity);
            CHECK(got.net_flux == expected.net_flux);
        } else {
            for (std::size_t i = 0; i < got.radiosity.size(); ++i)
                CHECK(got.radiosity[i] == doctest::Approx(expected.radiosity[i]).epsilon(1e-9));
        }
    }
    // A repair needs the whole F.
    ComputeOptions repaired;
    repaired.repair.mode = RepairMode::reciprocity;
    CHECK_THROWS_AS(compute_distributed_rows(scene, repaired, nullptr), OptionError);
}

TEST_CASE(
    "distributed rows from a whole F on one process: thermal and radiosity equal the solves of "
    "that F bit for bit") {
    Scene scene = load_scene("cube");
    subdivide(scene, SubdivisionOptions{3, 0.0});
    PatchProperties props = properties_from_scene(scene);
    for (std::size_t i = 0; i < props.size(); ++i) {
        props.emissivity[i] = 0.3 + 0.1 * double(i % 7);
        props.temperature[i] = 300.0 + double(i % 5) * 20.0;
        props.reflectance[i] = Rgb::Constant(0.2 + 0.1 * double(i % 5));
        props.emission[i] = Rgb::Constant(double(i % 3));
    }
    const FormFactors ff = compute_form_factors(scene).form_factors;
    const SparseFormFactors csr = to_sparse(ff);
    ThermalOptions to;
    to.solver.solver = SolverKind::gmres;
    to.solver.threads = 1;
    for (const SolverKind kind : {SolverKind::gmres, SolverKind::jacobi}) {
        CAPTURE(to_string(kind));
        to.solver.solver = kind;
        const ThermalResult dense = distributed::solve_thermal(distribute_rows(ff), props, to);
        CHECK(dense.radiosity == formfactor::solve_thermal(ff, props, to).radiosity);
        const ThermalResult sparse = distributed::solve_thermal(distribute_rows(csr), props, to);
        CHECK(sparse.radiosity == formfactor::solve_thermal(csr, props, to).radiosity);
        const RadiosityResult b =
            distributed::solve_radiosity(distribute_rows(csr), props, to.solver);
        CHECK(b.radiosity == formfactor::solve_radiosity(csr, props, to.solver).radiosity);
    }
    // Rows that a later distribution replaced are refused.
    const DistributedRows old = distribute_rows(ff);
    (void)distribute_rows(csr);
    CHECK_THROWS_AS(distributed::solve_thermal(old, props, to), Error);
}

TEST_CASE("distributed rows from a whole F: one contiguous block per rank of about equal work") {
    Scene scene = load_scene("cube");
    subdivide(scene, SubdivisionOptions{3, 0.0});
    const FormFactors ff = compute_form_factors(scene).form_factors;
    const std::size_t n = ff.size();
    for (const int ranks : {1, 3, 5, 100}) {
        CAPTURE(ranks);
        const WholeRows dense = whole_rows(ff, ranks);
        REQUIRE(dense.blocks.size() == std::size_t(ranks));
        std::size_t next = 0, smallest = n, largest = 0;
        for (const RowRange& b : dense.blocks) {
            CHECK(b.begin == next);
            next = b.end;
            smallest = std::min(smallest, b.size());
            largest = std::max(largest, b.size());
        }
        CHECK(next == n);
        CHECK(largest - smallest <= 1);
    }
    // Sparse: the work of a product (a row and its entries) evens out, not the rows.
    SparseFormFactors csr = to_sparse(ff);
    const WholeRows sparse = whole_rows(csr, 3);
    double most = 0.0, least = 1e300, total = 0.0, heaviest_row = 0.0;
    for (std::size_t i = 0; i < n; ++i)
        heaviest_row = std::max(heaviest_row, 1.0 + double(csr.indptr[i + 1] - csr.indptr[i]));
    for (const RowRange& b : sparse.blocks) {
        const double w = double(b.size()) + double(csr.indptr[b.end] - csr.indptr[b.begin]);
        total += w;
        most = std::max(most, w);
        least = std::min(least, w);
        const KeptBlock kept = sparse.block(b);
        CHECK(kept.values.size() == std::size_t(csr.indptr[b.end] - csr.indptr[b.begin]));
    }
    CHECK(most - least <= 2.0 * heaviest_row);
    CHECK(least > 0.0);
    // A block of rows is not a whole F.
    FormFactors block = ff;
    block.first_row = 1;
    CHECK_THROWS_AS(whole_rows(block, 2), Error);
}

TEST_CASE("distributed: kept blocks move at most once, from the rank that holds them") {
    // Each rank sends only the blocks it holds before the moves (make_moves()): a block passed
    // on (rank 1 to 2, then 2 to 0) would have rank 2 send what it has not received yet. Random
    // shares of 3 to 5 ranks, in which such chains arise when moves are not merged.
    std::mt19937 rng(11);
    std::size_t balanced = 0;
    for (int trial = 0; trial < 3000; ++trial) {
        const int ranks = 3 + int(rng() % 3), blocks = 3 + int(rng() % 10);
        Owners owners(static_cast<std::size_t>(ranks));
        std::map<std::size_t, double> weights;
        std::map<std::size_t, int> holder;
        for (int b = 0; b < blocks; ++b) {
            const std::size_t first = std::size_t(b) * 10;
            weights[first] = 0.1 + std::uniform_real_distribution<double>(0.0, 13.0)(rng);
            const int r = int(rng() % std::uint32_t(ranks));
            owners[std::size_t(r)].push_back({first, first + 10});
            holder[first] = r;
        }
        Owners after = owners;
        const std::vector<Move> moves = balancing_moves(after, weights);
        balanced += !moves.empty();
        std::map<std::size_t, int> now = holder;
        std::set<std::size_t> moved;
        for (const Move& m : moves) {
            CAPTURE(trial);
            CHECK(moved.insert(m.rows.begin).second);
            CHECK(m.from == holder.at(m.rows.begin));
            CHECK(m.to != m.from);
            now[m.rows.begin] = m.to;
        }
        // The moves take the holders to the owners balancing_moves() left.
        for (int r = 0; r < ranks; ++r)
            for (const RowRange& b : after[std::size_t(r)]) CHECK(now.at(b.begin) == r);
    }
    CHECK(balanced > 1000);
}
