// The hierarchical operator (formfactor/matrix/hierarchical.h): products against the dense exact
// matrix within its error target, an error that falls with the target, reciprocity by
// construction, products bit-identical for any thread count, thermal and radiosity solves on it
// against the dense solves, the memory check of one process and of one rank's share, and the
// refusals (obstructed scenes, bad options, solvers that need F's entries).

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>

#include "formfactor/core/error.h"
#include "formfactor/distributed/distributed.h"
#include "formfactor/matrix/memory.h"
#include "formfactor/methods/hierarchical_build.h"
#include "formfactor/pipeline.h"
#include "formfactor/scene/room.h"
#include "formfactor/solve/properties.h"
#include "formfactor/solve/radiosity.h"
#include "formfactor/solve/thermal.h"

using namespace formfactor;

namespace {

DenseMatrix dense_of(const Scene& s) {
    ComputeOptions o;
    o.method = MethodKind::analytic;
    return compute_form_factors(s, o).form_factors.F;
}

// Relative 2-norm error of H x against F x over a few random x ≥ 0 and the column of ones.
double product_error(const HierarchicalFormFactors& H, const DenseMatrix& F, int threads = 0) {
    const auto n = static_cast<Eigen::Index>(H.size());
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    Eigen::MatrixXd X(n, 4), Y;
    for (Eigen::Index i = 0; i < n; ++i) {
        X(i, 0) = 1.0;
        for (int k = 1; k < 4; ++k) X(i, k) = u(rng);
    }
    H.multiply(X, Y, threads);
    const Eigen::MatrixXd exact = F * X;
    return (Y - exact).norm() / exact.norm();
}

}  // namespace

TEST_CASE("hierarchical: a closed room's products match the exact matrix within the target") {
    const Scene s = room_scene(12, RoomBox::kNone);  // 864 patches
    const DenseMatrix F = dense_of(s);
    HierarchicalOptions o;
    o.tolerance = 1e-6;
    o.leaf_size = 16;
    const HierarchicalFormFactors H = build_hierarchical(s, o);
    const HierarchicalStats& st = H.stats();
    CHECK(st.low_rank_blocks > 0);
    CHECK(st.zero_blocks > 0);
    CHECK(st.dense_blocks > 0);
    // Every unordered pair is covered once.
    const double n = static_cast<double>(s.patches.size());
    CHECK(st.pairs_zero + st.pairs_dense + st.pairs_low_rank == doctest::Approx(n * (n - 1) / 2));
    // Compressed: fewer values than the N²/2 of the pairs.
    CHECK(static_cast<double>(st.dense_values + st.low_rank_values) < 0.5 * n * n);
    const double err = product_error(H, F);
    MESSAGE("relative product error " << err << ", mean rank " << st.mean_rank);
    CHECK(err <= 10 * o.tolerance);
    // Rows of the closed room sum to 1 (the exact matrix's closure to 1e-10 plus the target).
    for (double r : H.row_sums()) CHECK(std::abs(r - 1.0) <= 1e-5);
    // Reciprocity holds by construction: A_i F_ij = A_j F_ji to rounding (relative to the pair,
    // or to A_i · 1e-12 for entries at rounding level, which low-rank blocks give to pairs that
    // touch a plane).
    const DenseMatrix D = H.to_dense();
    const double floor = 1e-12 * s.patches[0].area;
    double worst = 0.0;
    for (Eigen::Index i = 0; i < D.rows(); ++i)
        for (Eigen::Index j = 0; j < D.cols(); ++j) {
            const double a = H.areas()[static_cast<std::size_t>(i)] * D(i, j);
            const double b = H.areas()[static_cast<std::size_t>(j)] * D(j, i);
            worst = std::max(worst, std::abs(a - b) / std::max(std::max(a, b), floor));
        }
    CHECK(worst <= 1e-12);
    // The entries of the same wall are exactly zero (zero blocks), the diagonal too.
    for (Eigen::Index i = 0; i < D.rows(); ++i) CHECK(D(i, i) == 0.0);
}

TEST_CASE("hierarchical: the error falls when the target is tightened") {
    const Scene s = room_scene(10, RoomBox::kNone);  // 600 patches
    const DenseMatrix F = dense_of(s);
    double previous = 1.0;
    std::size_t previous_values = 0;
    for (const double tol : {1e-2, 1e-4, 1e-7}) {
        HierarchicalOptions o;
        o.tolerance = tol;
        o.leaf_size = 8;
        const HierarchicalFormFactors H = build_hierarchical(s, o);
        const double err = product_error(H, F);
        MESSAGE("tolerance " << tol << ": error " << err << ", values " << H.stats().low_rank_values
                             << ", mean rank " << H.stats().mean_rank);
        CHECK(err <= 10 * tol);
        CHECK(err < previous);
        // Tighter targets store more (higher ranks, or blocks kept dense).
        const std::size_t values = H.stats().low_rank_values + H.stats().dense_values;
        CHECK(values >= previous_values);
        previous = err;
        previous_values = values;
    }
}

TEST_CASE("hierarchical: products are bit-identical for any thread count") {
    const Scene s = room_scene(8, RoomBox::kNone);
    HierarchicalOptions o;
    o.leaf_size = 8;
    o.threads = 1;
    const HierarchicalFormFactors H1 = build_hierarchical(s, o);
    o.threads = 2;
    const HierarchicalFormFactors H2 = build_hierarchical(s, o);
    const auto n = static_cast<Eigen::Index>(H1.size());
    const Eigen::MatrixXd X = Eigen::MatrixXd::Random(n, 2);
    Eigen::MatrixXd Y1, Y2, Y3;
    H1.multiply(X, Y1, 1);
    H2.multiply(X, Y2, 2);
    H1.multiply(X, Y3, 3);
    CHECK(Y1 == Y2);
    CHECK(Y1 == Y3);
}

TEST_CASE(
    "hierarchical: blocks computed in shares and held in runs of chunks give the whole "
    "operator's product bit for bit") {
    // What MPI ranks do (distributed/distributed.h): each computes some blocks, each holds a run
    // of the fixed chunks, and the partial sums go from part to part in chunk order.
    const Scene s = room_scene(8, RoomBox::kNone);
    HierarchicalOptions o;
    o.leaf_size = 8;
    o.threads = 2;
    const HierarchicalFormFactors H = build_hierarchical(s, o);
    const HierarchicalPlan plan(s, o);
    REQUIRE(plan.blocks() == H.blocks());
    REQUIRE(H.chunks() == HierarchicalFormFactors::kChunks);
    // Computed in three interleaved shares, in any order.
    std::vector<HierarchicalFormFactors::Block> blocks(plan.blocks());
    HierarchicalStats counts;
    for (std::size_t share = 0; share < 3; ++share) {
        std::vector<std::size_t> which;
        for (std::size_t k = 2 - share; k < plan.blocks(); k += 3) which.push_back(k);
        std::vector<HierarchicalFormFactors::Block> got = plan.compute(which, counts);
        for (std::size_t i = 0; i < which.size(); ++i) blocks[which[i]] = std::move(got[i]);
    }
    CHECK(counts.entries_computed == H.stats().entries_computed);
    std::vector<double> work;
    for (const auto& b : blocks) work.push_back(HierarchicalFormFactors::block_work(b));
    const std::vector<std::size_t> bounds = HierarchicalFormFactors::chunk_bounds(work);
    REQUIRE(bounds.size() == H.chunks() + 1);
    const auto n = static_cast<Eigen::Index>(H.size());
    const Eigen::MatrixXd X = Eigen::MatrixXd::Random(n, 3);
    Eigen::MatrixXd Y;
    H.multiply(X, Y, 2);
    // Runs of chunks: [0, 5), [5, 11), [11, 16) and the empty run [16, 16).
    const std::vector<std::size_t> runs = {0, 5, 11, 16, 16};
    Eigen::MatrixXd Yt = Eigen::MatrixXd::Zero(n, 3), Zt = Eigen::MatrixXd::Zero(n, 3);
    std::vector<HierarchicalFormFactors> parts;
    for (std::size_t r = 0; r + 1 < runs.size(); ++r) {
        const std::size_t b0 = bounds[runs[r]], b1 = bounds[runs[r + 1]];
        std::vector<HierarchicalFormFactors::Block> mine(blocks.begin() + std::ptrdiff_t(b0),
                                                         blocks.begin() + std::ptrdiff_t(b1));
        std::vector<std::size_t> local;
        for (std::size_t c = runs[r]; c <= runs[r + 1]; ++c) local.push_back(bounds[c] - b0);
        parts.push_back(HierarchicalFormFactors::part(plan.areas(), plan.order(), std::move(mine),
                                                      std::move(local), runs[r], H.stats()));
        CHECK_FALSE(parts.back().whole());
        CHECK(parts.back().chunks() == runs[r + 1] - runs[r]);
        HierarchicalFormFactors::add_partials(parts.back().partial_products(X, 1), Yt, Zt);
    }
    Eigen::MatrixXd Yp;
    parts.back().finish_product(Yt, Zt, Yp);
    CHECK(Yp == Y);
    // A part alone is no operator.
    CHECK_THROWS_AS(parts.front().multiply(X, Yp), Error);
}

TEST_CASE(
    "hierarchical: the memory check of one rank of several asks for its share of the blocks, not "
    "the whole operator") {
    const Scene s = room_scene(8, RoomBox::kNone);
    HierarchicalOptions o;
    o.leaf_size = 8;
    const HierarchicalPlan plan(s, o);
    std::vector<std::size_t> all(plan.blocks());
    std::iota(all.begin(), all.end(), 0);
    const MemoryEstimate whole = plan.estimate_memory(all, 1);
    REQUIRE(whole.items.size() == 2);
    const double tables = whole.items[0].bytes, blocks = whole.items[1].bytes;
    CHECK(tables == doctest::Approx(double(s.patches.size()) *
                                    (kBytesPerPatch + 8.0 * HierarchicalFormFactors::kChunks)));
    // Four ranks, each computing every fourth block: the tables, its blocks and a quarter of
    // all of them (its run of chunks).
    double largest = 0.0, computed = 0.0;
    std::vector<std::vector<std::size_t>> shares(4);
    for (std::size_t k = 0; k < all.size(); ++k) shares[k % 4].push_back(k);
    for (const auto& share : shares) {
        const MemoryEstimate e = plan.estimate_memory(share, 4);
        REQUIRE(e.items.size() == 3);
        CHECK(e.items[0].bytes == tables);
        CHECK(e.items[2].bytes == doctest::Approx(blocks / 4));
        computed += e.items[1].bytes;
        largest = std::max(largest, e.total());
    }
    CHECK(computed == doctest::Approx(blocks));
    REQUIRE(largest < whole.total());
    // Memory between a rank's share and the whole operator: every rank of four fits, one
    // process does not.
    const double available = 0.5 * (largest + whole.total());
    for (const auto& share : shares) CHECK_NOTHROW(plan.check_memory(share, 4, available));
    CHECK_THROWS_WITH_AS(plan.check_memory(all, 1, available),
                         doctest::Contains("hierarchical operator of 384 patches: needs about"),
                         ResourceError);
    CHECK_THROWS_WITH_AS(plan.check_memory(shares[0], 4, 0.5 * largest),
                         doctest::Contains("over 4 ranks: this rank needs about"), ResourceError);
    // Unknown memory (0): no check.
    CHECK_NOTHROW(plan.check_memory(all, 1, 0.0));
}

TEST_CASE("hierarchical: thermal and radiosity solves agree with the dense solves") {
    const Scene s = room_scene(10, RoomBox::kNone);
    ComputeOptions co;
    co.method = MethodKind::analytic;
    const FormFactors ff = compute_form_factors(s, co).form_factors;
    HierarchicalOptions o;
    o.tolerance = 1e-6;
    o.leaf_size = 16;
    const HierarchicalFormFactors H = build_hierarchical(s, o);

    // Thermal: the floor (patches of surface 0) hot, the rest at fixed temperatures or
    // adiabatic, grey emissivities down to 0.1 (a stiff system for Jacobi).
    PatchProperties props = properties_from_scene(s);
    const std::size_t n = s.patches.size();
    for (std::size_t i = 0; i < n; ++i) {
        const int surf = s.patches[i].surface;
        props.emissivity[i] = 0.1 + 0.15 * (surf % 6);
        props.temperature[i] = std::numeric_limits<double>::quiet_NaN();
        props.net_flux[i] = std::numeric_limits<double>::quiet_NaN();
        if (surf % 6 == 0)
            props.temperature[i] = 1000.0;
        else if (surf % 6 == 1)
            props.temperature[i] = 300.0;
        else if (surf % 6 == 2)
            props.net_flux[i] = 0.0;
        else
            props.temperature[i] = 500.0 + 10.0 * static_cast<double>(i % 7);
    }
    ThermalOptions dense_o;  // direct
    const ThermalResult d = solve_thermal(ff, props, dense_o);
    ThermalOptions ho;
    ho.solver.solver = SolverKind::gmres;
    ho.solver.residual = 1e-10;
    const ThermalResult h = solve_thermal(H, props, ho);
    CHECK(h.stats.converged);
    double emitted = 0.0;
    for (std::size_t i = 0; i < n; ++i) emitted += std::abs(d.net_power[i]);
    double worst_j = 0.0, worst_q = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
        worst_j = std::max(worst_j, std::abs(h.radiosity[i] - d.radiosity[i]) / d.radiosity[i]);
        worst_q = std::max(worst_q, std::abs(h.net_power[i] - d.net_power[i]) / emitted);
    }
    MESSAGE("thermal: radiosity within " << worst_j << " relative, net power within " << worst_q
                                         << " of the total; " << h.stats.iterations << " products");
    CHECK(worst_j <= 1e-4);
    CHECK(worst_q <= 1e-4);
    CHECK(h.relative_balance_defect <= 1e-6);

    // Radiosity (RGB) with gmres and jacobi on the operator.
    const RadiosityResult rd = solve_radiosity(ff, props, SolverOptions{SolverKind::direct});
    for (const SolverKind k : {SolverKind::gmres, SolverKind::jacobi}) {
        SolverOptions so{k};
        so.residual = 1e-10;
        const RadiosityResult rh = solve_radiosity(H, props, so);
        CHECK(rh.stats.converged);
        double w = 0.0;
        for (std::size_t i = 0; i < n; ++i)
            for (int c = 0; c < 3; ++c)
                if (rd.radiosity[i][c] > 0.0)
                    w = std::max(
                        w, std::abs(rh.radiosity[i][c] - rd.radiosity[i][c]) / rd.radiosity[i][c]);
        CHECK(w <= 1e-4);
    }
    // Solvers that need F's entries are refused with the option named.
    CHECK_THROWS_AS(solve_radiosity(H, props, SolverOptions{SolverKind::gauss_seidel}),
                    OptionError);
    // gmres on the dense matrix agrees with the direct solve.
    SolverOptions g{SolverKind::gmres};
    g.residual = 1e-12;
    const RadiosityResult rg = solve_radiosity(ff, props, g);
    for (std::size_t i = 0; i < n; ++i)
        CHECK((rg.radiosity[i] - rd.radiosity[i]).norm() <= 1e-9 * (1.0 + rd.radiosity[i].norm()));
}

TEST_CASE("hierarchical: a closed room with no temperature is refused, as with the dense F") {
    // Row sums of the operator are 1 only to its error target: the closed-enclosure check must
    // still see a closed room (every patch adiabatic: temperatures only up to a constant).
    const Scene s = room_scene(8, RoomBox::kNone);
    HierarchicalOptions o;
    o.tolerance = 1e-6;
    o.leaf_size = 16;
    const HierarchicalFormFactors H = build_hierarchical(s, o);
    PatchProperties props = properties_from_scene(s);
    for (std::size_t i = 0; i < s.patches.size(); ++i) {
        props.temperature[i] = std::numeric_limits<double>::quiet_NaN();
        props.net_flux[i] = 0.0;
    }
    ThermalOptions t;
    t.solver.solver = SolverKind::gmres;
    CHECK_THROWS_WITH_AS(solve_thermal(H, props, t),
                         doctest::Contains("defined only up to a constant"), Error);
}

TEST_CASE("hierarchical: per-surface factors from the operator") {
    const Scene s = room_scene(8, RoomBox::kNone);
    const DenseMatrix F = dense_of(s);
    const HierarchicalFormFactors H = build_hierarchical(s, {});
    std::vector<int> group(s.patches.size());
    for (std::size_t i = 0; i < group.size(); ++i) group[i] = s.patches[i].surface;
    const std::size_t g = s.surfaces.size();
    const DenseMatrix G = H.per_group(group, g);
    // The same from the dense matrix.
    DenseMatrix E = DenseMatrix::Zero(static_cast<Eigen::Index>(g), static_cast<Eigen::Index>(g));
    std::vector<double> ag(g, 0.0);
    for (std::size_t i = 0; i < group.size(); ++i) {
        const double a = s.patches[i].area;
        ag[static_cast<std::size_t>(group[i])] += a;
        for (std::size_t j = 0; j < group.size(); ++j)
            E(group[i], group[j]) +=
                a * F(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j));
    }
    for (std::size_t r = 0; r < g; ++r) E.row(static_cast<Eigen::Index>(r)) /= ag[r];
    CHECK((G - E).cwiseAbs().maxCoeff() <= 1e-6);
    CHECK_THROWS_AS(H.per_group(std::vector<int>(3, 0), 1), Error);
}

TEST_CASE("hierarchical: to_dense of an operator held elsewhere is to_dense's, from its products") {
    const Scene s = room_scene(8, RoomBox::kNone);
    HierarchicalOptions o;
    o.leaf_size = 8;
    const HierarchicalFormFactors H = build_hierarchical(s, o);
    std::size_t products = 0;
    const DenseMatrix D = HierarchicalFormFactors::to_dense(
        H.size(), [&](const Eigen::MatrixXd& X, Eigen::MatrixXd& Y) {
            ++products;
            H.multiply(X, Y);
        });
    CHECK(D == H.to_dense());
    CHECK(products == (H.size() + 63) / 64);
}

TEST_CASE("hierarchical: the product of the operator kept for the ranks is multiply()'s") {
    // One process (no mpirun): distributed::build_hierarchical() keeps the whole operator here.
    const Scene s = room_scene(8, RoomBox::kNone);
    HierarchicalOptions o;
    o.leaf_size = 8;
    o.threads = 1;
    const distributed::DistributedHierarchical kept = distributed::build_hierarchical(s, o);
    const HierarchicalFormFactors H = build_hierarchical(s, o);
    const auto n = static_cast<Eigen::Index>(H.size());
    const Eigen::MatrixXd X = Eigen::MatrixXd::Random(n, 3);
    Eigen::MatrixXd Y1, Y2;
    distributed::multiply(kept, X, Y1, 2);
    H.multiply(X, Y2, 1);
    CHECK(Y1 == Y2);
    CHECK_THROWS_WITH_AS(distributed::multiply(kept, Eigen::MatrixXd::Ones(3, 1), Y1),
                         doctest::Contains("X has 3 rows"), Error);
    // A later build replaces it.
    const distributed::DistributedHierarchical later = distributed::build_hierarchical(s, o);
    CHECK_THROWS_WITH_AS(distributed::multiply(kept, X, Y1),
                         doctest::Contains("replaced by a later build"), Error);
    distributed::multiply(later, X, Y1);
    CHECK(Y1 == Y2);
}

TEST_CASE("hierarchical: obstructed scenes and bad options are refused") {
    CHECK_THROWS_WITH_AS(build_hierarchical(room_scene(4), {}), doctest::Contains("obstructions"),
                         Error);
    CHECK_THROWS_WITH_AS(build_hierarchical(room_scene(4), {}),
                         doctest::Contains("Use `storage` dense or sparse"), Error);
    const Scene s = room_scene(4, RoomBox::kNone);
    HierarchicalOptions o;
    o.tolerance = 0.0;
    CHECK_THROWS_AS(build_hierarchical(s, o), OptionError);
    o = {};
    o.eta = -1.0;
    CHECK_THROWS_AS(build_hierarchical(s, o), OptionError);
    o = {};
    o.leaf_size = 0;
    CHECK_THROWS_AS(build_hierarchical(s, o), OptionError);
}
