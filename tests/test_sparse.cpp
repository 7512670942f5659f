// Sparse (CSR) form factors: the row-block pipeline against the dense matrix, the threshold's
// dropped mass, the conservative repair, and the sparse memory estimate.

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "formfactor/core/error.h"
#include "formfactor/matrix/memory.h"
#include "formfactor/matrix/sparse.h"
#include "formfactor/matrix/sparse_repair.h"
#include "formfactor/pipeline.h"
#include "formfactor/pipeline_sparse.h"
#include "formfactor/scene/city.h"
#include "formfactor/scene/room.h"
#include "formfactor/scene/scene.h"

using namespace formfactor;

namespace {

// Every stored entry equals the dense one bit for bit, every dense entry above the threshold
// is stored, and each row's dropped mass and computed sum are the dense row's.
void check_against_dense(const SparseFormFactors& S, const FormFactors& D, double threshold) {
    REQUIRE(S.n == D.size());
    S.check();
    for (std::size_t i = 0; i < S.n; ++i) {
        std::size_t stored = 0;
        double dropped = 0.0, sum = 0.0;
        for (std::size_t j = 0; j < S.n; ++j) {
            const double d = D.F(Eigen::Index(i), Eigen::Index(j));
            sum += d;
            if (d > threshold) {
                ++stored;
                CHECK(S.at(i, j) == d);
            } else {
                dropped += d;
                CHECK(S.at(i, j) == 0.0);
            }
        }
        CHECK(std::size_t(S.indptr[i + 1] - S.indptr[i]) == stored);
        CHECK(S.dropped[i] == doctest::Approx(dropped).epsilon(1e-12));
        CHECK(S.computed_row_sums[i] == doctest::Approx(sum).epsilon(1e-12));
    }
}

// |A_i F_ij − A_j F_ji| ≤ tol · max(...) for every stored pair, both directions stored.
void check_reciprocity(const SparseFormFactors& F, double tol) {
    for (std::size_t i = 0; i < F.n; ++i)
        for (auto k = F.indptr[i]; k < F.indptr[i + 1]; ++k) {
            const auto j = std::size_t(F.indices[std::size_t(k)]);
            const double g = F.areas[i] * F.values[std::size_t(k)];
            const double h = F.areas[j] * F.at(j, i);
            CHECK(h > 0.0);
            CHECK(std::abs(g - h) <= tol * std::max(g, h));
        }
}

// Rows a method emitted sparse against the dense rows it computes for the same range (row r of
// both): each row holds the dense row's non-zeros and nothing else, columns ascending, values
// (and standard errors, when the rows have them) bit for bit. Returns the entries.
std::size_t check_rows_against_dense(const SparseRows& rows, const FormFactors& dense) {
    REQUIRE(rows.size() == std::size_t(dense.F.rows()));
    if (rows.has_standard_errors()) REQUIRE(dense.standard_error.has_value());
    std::size_t mismatches = 0, entries = 0;
    for (std::size_t r = 0; r < rows.size(); ++r) {
        const auto i = Eigen::Index(r);
        std::size_t dense_nonzero = 0;
        for (Eigen::Index j = 0; j < dense.F.cols(); ++j) dense_nonzero += dense.F(i, j) != 0.0;
        CHECK(rows.values[r].size() == dense_nonzero);
        for (std::size_t k = 0; k < rows.values[r].size(); ++k) {
            const auto j = Eigen::Index(rows.indices[r][k]);
            if (k > 0) CHECK(rows.indices[r][k - 1] < rows.indices[r][k]);
            mismatches += rows.values[r][k] != dense.F(i, j);
            if (rows.has_standard_errors())
                mismatches += rows.standard_error[r][k] != (*dense.standard_error)(i, j);
        }
        entries += rows.values[r].size();
    }
    CHECK(mismatches == 0);
    return entries;
}

}  // namespace

TEST_CASE("sparse: analytic row blocks equal the dense matrix above the threshold") {
    const Scene scene = city_scene(2);  // obstructed: the shaft pass runs per block
    ComputeOptions options;
    const ComputeResult dense = compute_form_factors(scene, options);
    for (double threshold : {0.0, 1e-3}) {
        CAPTURE(threshold);
        SparseOptions sparse;
        sparse.threshold = threshold;
        sparse.block_rows = 37;  // blocks that do not divide N = 129
        const SparseComputeResult r = compute_sparse_form_factors(scene, options, sparse);
        CHECK(r.run.blocks == 4);
        CHECK(r.run.block_rows == 37);
        check_against_dense(r.form_factors, dense.form_factors, threshold);
        CHECK(r.diagnostics.nonzeros == r.form_factors.nonzeros());
        CHECK(r.form_factors.nonzeros() < scene.patches.size() * scene.patches.size() / 2);
        CHECK(r.run.peak_memory_bytes > 0.0);
        CHECK_FALSE(r.repair.has_value());
    }
}

TEST_CASE("sparse: Monte-Carlo blocks keep their standard errors") {
    const Scene scene = load_scene("cornell");
    ComputeOptions options;
    options.method = MethodKind::mc_hemisphere;
    options.method_options.samples = 2000;
    const ComputeResult dense = compute_form_factors(scene, options);
    SparseOptions sparse;
    sparse.block_rows = 5;
    const SparseComputeResult r = compute_sparse_form_factors(scene, options, sparse);
    check_against_dense(r.form_factors, dense.form_factors, 0.0);
    REQUIRE(r.form_factors.standard_error.has_value());
    const SparseFormFactors& S = r.form_factors;
    for (std::size_t i = 0; i < S.n; ++i)
        for (auto k = S.indptr[i]; k < S.indptr[i + 1]; ++k)
            CHECK((*S.standard_error)[std::size_t(k)] ==
                  (*dense.form_factors.standard_error)(Eigen::Index(i),
                                                       Eigen::Index(S.indices[std::size_t(k)])));
}

TEST_CASE("sparse: to_sparse and the builder check their input") {
    FormFactors ff;
    ff.F = DenseMatrix::Zero(3, 3);
    ff.F << 0, 0.5, 0.25, 0.2, 0, 1e-5, 0.1, 2e-5, 0;
    ff.areas = {1, 2.5, 2.5};
    const SparseFormFactors S = to_sparse(ff, 1e-4);
    CHECK(S.nonzeros() == 4);
    CHECK(S.at(1, 2) == 0.0);
    CHECK(S.dropped[1] == 1e-5);
    CHECK(S.row_sum(0) == 0.75);
    CHECK(S.sky_factor(0) == 0.25);
    CHECK_THROWS_AS(SparseBuilder(3, {1, 2, 3}, -1.0, false), OptionError);
    SparseBuilder b(3, {1, 2, 3}, 0.0, false);
    FormFactors late = ff;
    late.F = ff.F.middleRows(1, 2);
    late.first_row = 1;
    CHECK_THROWS_AS(b.append(late), Error);  // rows must come in order
    CHECK_THROWS_AS(b.finish(), Error);      // not every row

    // Rows as a method emits them: the same CSR, row sums and dropped mass as the dense rows.
    SparseRows rows;
    rows.reset(0, 3, false);
    for (std::size_t i = 0; i < 3; ++i)
        for (std::size_t j = 0; j < 3; ++j)
            if (ff.F(Eigen::Index(i), Eigen::Index(j)) != 0.0) {
                rows.indices[i].push_back(static_cast<std::int32_t>(j));
                rows.values[i].push_back(ff.F(Eigen::Index(i), Eigen::Index(j)));
            }
    SparseBuilder e(3, ff.areas, 1e-4, false);
    e.append(rows);
    const SparseFormFactors E = e.finish();
    CHECK(E.indptr == S.indptr);
    CHECK(E.indices == S.indices);
    CHECK(E.values == S.values);
    CHECK(E.dropped == S.dropped);
    CHECK(E.computed_row_sums == S.computed_row_sums);
    SparseRows bad = rows;
    std::swap(bad.indices[0][0], bad.indices[0][1]);  // columns must ascend
    SparseBuilder b2(3, ff.areas, 0.0, false);
    CHECK_THROWS_AS(b2.append(bad), Error);
    bad = rows;
    bad.values[1].pop_back();  // arrays of one length
    SparseBuilder b3(3, ff.areas, 0.0, false);
    CHECK_THROWS_AS(b3.append(bad), Error);
    SparseBuilder b4(3, ff.areas, 0.0, true);  // standard errors asked for, none emitted
    CHECK_THROWS_AS(b4.append(rows), Error);
}

TEST_CASE("sparse: rows taken by the builder make the matrix of rows copied, and are released") {
    // 100 rows of pseudo-random entries, some at or below the threshold, appended as two blocks:
    // copied, and taken (released in chunks of rows as they join).
    const std::size_t n = 100;
    std::vector<double> areas(n);
    for (std::size_t i = 0; i < n; ++i) areas[i] = 1.0 + 0.01 * double(i);
    auto make_rows = [&](std::size_t first, std::size_t count) {
        SparseRows rows;
        rows.reset(first, count, true);
        for (std::size_t r = 0; r < count; ++r)
            for (std::size_t j = 0; j < n; ++j) {
                const std::size_t h = ((first + r) * 7919 + j * 104729) % 1000;
                if (h % 3 != 0) continue;
                rows.indices[r].push_back(static_cast<std::int32_t>(j));
                rows.values[r].push_back(1e-3 * double(h % 17));  // 0 up to 0.016
                rows.standard_error[r].push_back(1e-5 * double(h % 5));
            }
        return rows;
    };
    SparseBuilder copied(n, areas, 4.5e-3, true), taken(n, areas, 4.5e-3, true);
    for (const auto& [first, count] : {std::pair<std::size_t, std::size_t>{0, 40}, {40, 60}}) {
        const SparseRows rows = make_rows(first, count);
        copied.append(rows);
        SparseRows moved = rows;
        taken.append(std::move(moved));
        CHECK(std::all_of(moved.values.begin(), moved.values.end(),
                          [](const std::vector<double>& v) { return v.empty(); }));
    }
    const SparseFormFactors A = copied.finish(), B = taken.finish();
    CHECK(A.nonzeros() > 0);
    CHECK(B.indptr == A.indptr);
    CHECK(B.indices == A.indices);
    CHECK(B.values == A.values);
    CHECK(*B.standard_error == *A.standard_error);
    CHECK(B.dropped == A.dropped);
    CHECK(B.computed_row_sums == A.computed_row_sums);
    // A row out of order in a later chunk is found there too.
    SparseRows bad = make_rows(0, n);
    std::swap(bad.indices[90][0], bad.indices[90][1]);
    SparseBuilder b(n, areas, 0.0, true);
    CHECK_THROWS_AS(b.append(std::move(bad)), Error);
}

TEST_CASE(
    "sparse: mc-hemisphere and mc-area emit their rows sparse, as the dense run computes them") {
    // The method writes straight into SparseRows (no rows x N block): the same entries, standard
    // errors and report summary as its dense rows.
    const Scene scene = city_scene(2);
    for (const MethodKind kind : {MethodKind::mc_hemisphere, MethodKind::mc_area}) {
        CAPTURE(to_string(kind));
        ComputeOptions options;
        options.method = kind;
        options.method_options.samples = kind == MethodKind::mc_area ? 16 : 1000;
        const ComputeResult dense = compute_form_factors(scene, options);
        SparseRows rows;
        options.sparse_rows = &rows;
        const ComputeResult emitted = compute_form_factors(scene, options);
        CHECK(emitted.form_factors.F.rows() == 0);
        REQUIRE(rows.size() == scene.patches.size());
        REQUIRE(rows.has_standard_errors());
        CHECK(check_rows_against_dense(rows, dense.form_factors) > 0);
        const auto& a = dense.report.details;
        const auto& b = emitted.report.details;
        CHECK(b.at("standard_error_max").real() == a.at("standard_error_max").real());
        CHECK(b.at("row_sum_standard_error_max").real() ==
              doctest::Approx(a.at("row_sum_standard_error_max").real()).epsilon(1e-12));
        CHECK(b.at("standard_error_mean").real() ==
              doctest::Approx(a.at("standard_error_mean").real()).epsilon(1e-12));
    }
}

TEST_CASE("sparse repair: open scene gets reciprocity and no row sum above its computed one") {
    // The Cornell box is open at the front; its patches differ in area, so that the threshold
    // keeps F_ij and drops F_ji for some pairs.
    Scene scene = load_scene("cornell");
    subdivide(scene, SubdivisionOptions{.n = 2});
    ComputeOptions options;
    options.repair.mode = RepairMode::reciprocity;
    SparseOptions sparse;
    sparse.threshold = 2e-3;
    const SparseComputeResult r = compute_sparse_form_factors(scene, options, sparse);
    REQUIRE(r.repair.has_value());
    const SparseFormFactors& F = r.form_factors;
    CHECK(r.diagnostics.asymmetric_entries > 0);  // the threshold made the pattern asymmetric
    CHECK(r.repair->entries_restored == r.diagnostics.asymmetric_entries);
    CHECK(r.repair->after.asymmetric_entries == 0);
    CHECK(r.repair->after.max_reciprocity_defect <= 1e-12);
    check_reciprocity(F, 1e-12);
    for (std::size_t i = 0; i < F.n; ++i) {
        CHECK(F.row_sum(i) <= F.computed_row_sums[i]);  // never raised
        CHECK(F.dropped[i] >= 0.0);
        CHECK(F.at(i, i) == 0.0);
    }
    CHECK(r.repair->max_row_increase <= 0.0);
    CHECK(r.repair->after.row_sum_max < 1.0);  // open: energy escapes to the sky
    CHECK(r.repair->after.sky_min > 0.0);
}

TEST_CASE("sparse repair: closed scene rows close to 1e-12 with reciprocity") {
    Scene scene = room_scene(4, RoomBox::kNone);  // a closed cube, 96 patches
    REQUIRE(scene.enclosure);
    ComputeOptions options;
    options.repair.mode = RepairMode::both;
    SparseOptions sparse;
    sparse.threshold = 1e-3;
    sparse.block_rows = 40;
    const SparseComputeResult r = compute_sparse_form_factors(scene, options, sparse);
    REQUIRE(r.repair.has_value());
    CHECK(r.diagnostics.dropped_max > 0.0);
    CHECK(r.repair->closure);
    CHECK(r.repair->rows_not_closable == 0);
    const SparseFormFactors& F = r.form_factors;
    for (std::size_t i = 0; i < F.n; ++i) CHECK(std::abs(F.row_sum(i) - 1.0) <= 1e-12);
    check_reciprocity(F, 1e-12);
    // Closure is refused for an open scene.
    SparseOptions s2;
    CHECK_THROWS_AS(compute_sparse_form_factors(city_scene(1), options, s2), OptionError);
}

TEST_CASE("sparse repair: a hand-made asymmetric pattern is made symmetric from the dropped mass") {
    // A_0 = 1, A_1 = 4: F_01 = 0.4 is kept, F_10 = 0.1 falls below the threshold 0.2.
    FormFactors ff;
    ff.F = DenseMatrix::Zero(2, 2);
    ff.F << 0, 0.4, 0.1, 0;
    ff.areas = {1, 4};
    SparseFormFactors S = to_sparse(ff, 0.2);
    CHECK(S.nonzeros() == 1);
    const SparseRepairReport rep = repair(S, SparseRepairOptions{});
    CHECK(rep.entries_restored == 1);
    CHECK(S.at(1, 0) == doctest::Approx(0.1).epsilon(1e-13));
    CHECK(S.at(0, 1) == doctest::Approx(0.4).epsilon(1e-13));
    CHECK(S.dropped[1] == doctest::Approx(0.0).scale(1.0));
    // Row 0 computed as 0.3 (noise) cannot keep 0.4: both directions scale down together.
    SparseFormFactors T = to_sparse(ff, 0.2);
    T.computed_row_sums[0] = 0.3;
    repair(T, SparseRepairOptions{});
    CHECK(T.row_sum(0) <= 0.3);
    CHECK(T.row_sum(0) == doctest::Approx(0.3).epsilon(1e-12));
    CHECK(1.0 * T.at(0, 1) == doctest::Approx(4.0 * T.at(1, 0)).epsilon(1e-15));
    CHECK(T.at(1, 0) < 0.1);
}

TEST_CASE("sparse memory: estimate, block size, refusal and peak") {
    SparseRunNeeds needs;
    needs.patches = 100000;
    needs.block_strip = true;
    needs.block_rows = sparse_block_rows(needs, 512e6);
    CHECK(needs.block_rows == 320);  // 512 MB / (2 × 8 × 10^5 bytes per row)
    needs.nonzeros = 3e7;
    const MemoryEstimate e = estimate_sparse_memory(needs);
    CHECK(e.total() == doctest::Approx(320 * 1.6e6 + 3e7 * 12 + 100001 * 32 + 1e5 * 8192));
    CHECK_THROWS_AS(check_sparse_memory(needs, 1e9, "raise the threshold"), ResourceError);
    try {
        check_sparse_memory(needs, 1e9, "raise the threshold");
    } catch (const ResourceError& err) {
        const std::string msg = err.what();
        CHECK(msg.find("sparse run of 100,000 patches") != std::string::npos);
        CHECK(msg.find("raise the threshold") != std::string::npos);
    }
    CHECK_NOTHROW(check_sparse_memory(needs, 1e10, ""));
    SparseRunNeeds inside = needs;
    inside.whole_matrix_inside = true;  // mc-target: N² inside, said so
    CHECK(estimate_sparse_memory(inside).total() > 1.6e11);
    CHECK(peak_memory_bytes() > 1e6);
    CHECK(sparse_block_rows(needs, 1.0) == 1);
    CHECK(sparse_block_rows(needs, 1e15) == 100000);
}

namespace {

struct SparseRowsCase {
    std::string scene;
    int subdivide;
    RowRange rows;         // the default: every row
    double tolerance = 0;  // the partly hidden pairs' tolerance; 0: the default
};

// The analytic method's sparse rows of each case against the dense rows of the same row range:
// the same entries bit for bit, columns ascending, fewer unobstructed pairs than all of them.
void check_analytic_sparse_rows(const std::vector<SparseRowsCase>& cases) {
    for (const SparseRowsCase& c : cases) {
        CAPTURE(c.scene);
        CAPTURE(c.rows.begin);
        Scene scene = load_scene(c.scene);
        if (c.subdivide > 0) {
            SubdivisionOptions so;
            so.n = c.subdivide;
            subdivide(scene, so);
        }
        const std::size_t n = scene.patches.size();
        ComputeOptions options;
        options.rows = c.rows;
        if (c.tolerance > 0) options.method_options.obstructed_tolerance = c.tolerance;
        const RowRange block = options.rows.clamped(n);
        const ComputeResult dense = compute_form_factors(scene, options);  // its rows only
        SparseRows rows;
        options.sparse_rows = &rows;
        const ComputeResult emitted = compute_form_factors(scene, options);
        REQUIRE(emitted.report.details.contains("sparse_rows"));
        CHECK(emitted.form_factors.F.rows() == 0);
        REQUIRE(rows.size() == block.size());
        CHECK(rows.first_row == block.begin);
        CHECK(check_rows_against_dense(rows, dense.form_factors) > 0);
        // Fewer unobstructed pairs than all of them: those facing away, hidden or coplanar are
        // never computed.
        const auto computed =
            std::size_t(emitted.report.details.at("unobstructed_pairs_computed").real());
        CHECK(computed < n * (n - 1) / 2);
        CHECK(*emitted.report.error_bound_per_entry == *dense.report.error_bound_per_entry);
    }
}

}  // namespace

TEST_CASE("sparse: analytic emits an obstructed scene's rows sparse, the dense run's entries") {
    // Only the pairs the classification finds visible or partly hidden are computed (no N²
    // unobstructed pass, no rows × N block), and every entry is the dense matrix's, bit for bit.
    // Small scenes (this case runs under the sanitizers too); the next one takes users' files.
    check_analytic_sparse_rows({
        // At a loose tolerance: fewer points, the same code (cheap enough for the sanitizers).
        {"cornell", 0, {}, 1e-3},
        {"cornell", 0, {7, 13}, 1e-3},  // a block of rows
    });
}

TEST_CASE("sparse: analytic sparse rows of files as users write them, the dense run's entries") {
    // A VS3 file with obstruction records (as other tools write them), a mesh with shared
    // vertices and jitter (EnergyPlus's L-shaped zone), the jittered box on a wall (its graded
    // cut, 4,096-piece senders: its slow row as a block), the room with a floating box and a
    // block of the Cornell box 2 × 2.
    const std::string data = FF_TEST_DATA_DIR;
    check_analytic_sparse_rows({
        {"city-2", 0, {}},
        {"room-4", 0, {}},
        {"cornell", 2, {30, 47}},
        {data + "/room-4-obstruction.vs3", 0, {}},
        {data + "/repro/lshaped_zone.obj", 0, {}},
        {data + "/jitter_box_on_wall.vs3", 0, {57, 58}},
    });
}

TEST_CASE(
    "sparse: analytic sparse rows classified in blocks of tasks are the dense run's entries") {
    // city-3: 17 plane groups, 136 classification tasks, classified in blocks whose partly hidden
    // pairs are integrated before the next block is classified: the whole matrix and a block of
    // rows, every entry the dense run's bit for bit.
    check_analytic_sparse_rows({
        {"city-3", 0, {}, 1e-3},
        {"city-3", 0, {100, 140}, 1e-3},
    });
    Scene scene = load_scene("city-3");
    ComputeOptions options;
    options.method_options.obstructed_tolerance = 1e-3;
    SparseRows rows;
    options.sparse_rows = &rows;
    const ComputeResult r = compute_form_factors(scene, options);
    const auto& ob = r.report.details.at("obstructions");
    CHECK(ob.at("classification_blocks").real() >= 2.0);
    // The pass's estimate came from the first block's sample.
    CHECK(ob.at("sampled_pairs").real() > 0.0);
    CHECK(ob.at("sampled_pairs").real() < ob.at("patch_pairs_partly_hidden").real());
}

TEST_CASE("sparse: hemicube and hemiplane emit their rows sparse, as the dense run computes them") {
    // One row of N accumulators per thread, only the patches each projection drew read back:
    // the dense rows' entries bit for bit, with several points per patch (rows are sums of
    // projections) and through the sparse pipeline's blocks.
    const Scene scene = city_scene(2);
    for (const MethodKind kind : {MethodKind::hemicube, MethodKind::hemiplane}) {
        CAPTURE(to_string(kind));
        ComputeOptions options;
        options.method = kind;
        options.method_options.resolution = 64;
        options.method_options.points = 3;
        const ComputeResult dense = compute_form_factors(scene, options);
        SparseRows rows;
        ComputeOptions emitting = options;
        emitting.sparse_rows = &rows;
        const ComputeResult emitted = compute_form_factors(scene, emitting);
        CHECK(emitted.form_factors.F.rows() == 0);
        REQUIRE(rows.size() == scene.patches.size());
        CHECK_FALSE(rows.has_standard_errors());
        CHECK(check_rows_against_dense(rows, dense.form_factors) > 0);
        const char* count = kind == MethodKind::hemicube ? "hemicubes" : "hemiplanes";
        CHECK(emitted.report.details.at(count).real() == dense.report.details.at(count).real());
        SparseOptions sparse;
        sparse.block_rows = 50;
        const SparseComputeResult r = compute_sparse_form_factors(scene, options, sparse);
        check_against_dense(r.form_factors, dense.form_factors, 0.0);
    }
}
