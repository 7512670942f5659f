// The pipeline API (formfactor/pipeline.h): typed options and results, row ranges that give the
// same rows bit for bit as the whole matrix, progress only when asked, a computation's own
// cancellation flag, errors that name option fields.

#include <doctest/doctest.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "formfactor/core/error.h"
#include "formfactor/core/progress.h"
#include "formfactor/methods/partly_hidden.h"
#include "formfactor/pipeline.h"
#include "formfactor/pipeline_sparse.h"
#include "formfactor/scene/scene.h"
#include "support/cli_runner.h"
#include "support/temp_dir.h"

using namespace formfactor;

namespace {

Scene cornell(int n) {
    Scene s = load_scene("cornell");
    SubdivisionOptions o;
    o.n = n;
    subdivide(s, o);
    return s;
}

ComputeOptions options_for(MethodKind kind) {
    ComputeOptions o;
    o.method = kind;
    o.method_options.samples = kind == MethodKind::mc_hemisphere ? 512 : 16;
    o.method_options.resolution = 64;
    return o;
}

// Counts what a sink receives.
class CountingSink final : public ProgressSink {
  public:
    void update(const std::string&, std::size_t done, std::size_t total, double) override {
        ++updates;
        last_done = done;
        last_total = total;
    }
    void finish(const std::string&) override { ++finishes; }
    int updates = 0, finishes = 0;
    std::size_t last_done = 0, last_total = 1;
};

}  // namespace

TEST_CASE("pipeline: any split of the rows gives the whole matrix bit for bit") {
    const Scene s = cornell(1);  // 20 patches, the two blocks obstruct
    const std::size_t n = s.patches.size();
    for (const MethodKind kind :
         {MethodKind::analytic, MethodKind::hemicube, MethodKind::hemiplane, MethodKind::mc_area,
          MethodKind::mc_hemisphere, MethodKind::mc_target}) {
        CAPTURE(to_string(kind));
        const ComputeOptions whole_options = options_for(kind);
        const ComputeResult whole = compute_form_factors(s, whole_options);
        REQUIRE(whole.form_factors.F.rows() == static_cast<Eigen::Index>(n));
        REQUIRE(whole.diagnostics);
        // Three uneven blocks.
        const std::size_t cuts[] = {0, 7, n / 2 + 3, n};
        REQUIRE(n / 2 + 3 < n);
        for (int b = 0; b < 3; ++b) {
            ComputeOptions o = whole_options;
            o.rows = {cuts[b], cuts[b + 1]};
            const ComputeResult part = compute_form_factors(s, o);
            const FormFactors& f = part.form_factors;
            CHECK(f.first_row == cuts[b]);
            REQUIRE(f.F.rows() == static_cast<Eigen::Index>(cuts[b + 1] - cuts[b]));
            REQUIRE(f.F.cols() == static_cast<Eigen::Index>(n));
            CHECK_FALSE(part.diagnostics);  // a block has no row sums of the matrix
            const auto expected =
                whole.form_factors.F.middleRows(static_cast<Eigen::Index>(cuts[b]), f.F.rows());
            CHECK((f.F.array() == expected.array()).all());
            if (whole.form_factors.standard_error) {
                REQUIRE(f.standard_error);
                const auto se = whole.form_factors.standard_error->middleRows(
                    static_cast<Eigen::Index>(cuts[b]), f.F.rows());
                CHECK((f.standard_error->array() == se.array()).all());
            }
        }
    }
}

TEST_CASE("pipeline: analytic row blocks of a room with obstruction records") {
    // The obstruction pass on a block: hidden and partly hidden pairs touching the block only,
    // their unobstructed values recovered as the whole matrix has them.
    const Scene s = load_scene(std::string(FF_TEST_DATA_DIR) + "/room-4-obstruction.vs3");
    const std::size_t n = s.patches.size();
    const ComputeResult whole = compute_form_factors(s);
    REQUIRE(whole.report.details.contains("obstructions"));
    for (const RowRange rows :
         {RowRange{0, 1}, RowRange{1, n / 3}, RowRange{n / 3, n - 2}, RowRange{n - 2, n}}) {
        CAPTURE(rows.begin);
        ComputeOptions o;
        o.rows = rows;
        const ComputeResult part = compute_form_factors(s, o);
        REQUIRE(part.form_factors.F.rows() == static_cast<Eigen::Index>(rows.size()));
        const auto expected = whole.form_factors.F.middleRows(
            static_cast<Eigen::Index>(rows.begin), static_cast<Eigen::Index>(rows.size()));
        CHECK((part.form_factors.F.array() == expected.array()).all());
        CHECK(part.report.pairs->pairs < whole.report.pairs->pairs);
    }
}

namespace {

// The analytic F of `s` from blocks of its upper triangle (upper_triangle_only), the rest
// filled as an MPI run's rank 0 does: by reciprocity, then the partly hidden pairs' own values
// (`pairs`, null where nothing obstructs). `upper_pairs`: the unordered pairs the blocks took.
DenseMatrix from_upper_blocks(const Scene& s, const PartlyHiddenPairs* pairs,
                              std::size_t& upper_pairs) {
    const std::size_t n = s.patches.size();
    const auto N = static_cast<Eigen::Index>(n);
    DenseMatrix F = DenseMatrix::Zero(N, N);
    std::vector<double> area;
    upper_pairs = 0;
    const std::size_t cuts[] = {0, 5, n / 3, n / 3 + 1, n};
    for (int b = 0; b < 4; ++b) {
        CAPTURE(cuts[b]);
        ComputeOptions o;
        o.rows = {cuts[b], cuts[b + 1]};
        o.upper_triangle_only = true;
        o.partly_hidden = pairs;
        const ComputeResult part = compute_form_factors(s, o);
        const DenseMatrix& P = part.form_factors.F;
        REQUIRE(P.rows() == static_cast<Eigen::Index>(cuts[b + 1] - cuts[b]));
        area = part.form_factors.areas;
        upper_pairs += part.report.pairs->pairs;
        for (Eigen::Index k = 0; k < P.rows(); ++k)
            for (Eigen::Index j = static_cast<Eigen::Index>(cuts[b]) + k + 1; j < N; ++j)
                F(static_cast<Eigen::Index>(cuts[b]) + k, j) = P(k, j);
    }
    for (std::size_t i = 0; i < n; ++i)
        for (std::size_t j = 0; j < i; ++j)
            F(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) =
                area[i] > 0.0 ? F(static_cast<Eigen::Index>(j), static_cast<Eigen::Index>(i)) *
                                    area[j] / area[i]
                              : 0.0;
    if (pairs) pairs->write_lower_values(F);
    return F;
}

}  // namespace

TEST_CASE(
    "pipeline: analytic blocks of their upper triangle, the rest filled by reciprocity and the "
    "partly hidden pairs' values, give the whole matrix bit for bit") {
    SUBCASE("a scene that obstructs nothing: each unordered pair once over the blocks") {
        Scene s = load_scene("cube");
        SubdivisionOptions sub;
        sub.n = 4;
        subdivide(s, sub);
        const ComputeResult whole = compute_form_factors(s);
        std::size_t upper_pairs = 0;
        const DenseMatrix F = from_upper_blocks(s, nullptr, upper_pairs);
        CHECK((F.array() == whole.form_factors.F.array()).all());
        CHECK(upper_pairs == whole.report.pairs->pairs);
        // A block leaves its entries below the diagonal to the caller.
        ComputeOptions o;
        o.rows = {10, 20};
        o.upper_triangle_only = true;
        const DenseMatrix P = compute_form_factors(s, o).form_factors.F;
        CHECK((P.leftCols(20).triangularView<Eigen::StrictlyLower>().toDenseMatrix().array() == 0.0)
                  .all());
        CHECK(P.leftCols(10).isZero(0.0));
    }
    SUBCASE("the Cornell box, with its partly hidden pairs given") {
        // The blocks' faces come after the walls and are smaller: the pairs are integrated
        // over the later patch of the two, whose entry below the diagonal is not the
        // reciprocal of the one above bit for bit.
        const Scene s = cornell(3);
        const ComputeResult whole = compute_form_factors(s);
        PartlyHiddenPairs pairs(s, ComputeOptions{}.method_options, false);
        REQUIRE(pairs.count() > 100);
        pairs.set_values(pairs.integrate({0, pairs.count()}));
        std::size_t upper_pairs = 0;
        const DenseMatrix F = from_upper_blocks(s, &pairs, upper_pairs);
        CHECK((F.array() == whole.form_factors.F.array()).all());
        // Classified in three parts elsewhere (as over MPI ranks), then given: the same pairs.
        PartlyHiddenPairs parts(s, ComputeOptions{}.method_options, false, false);
        const std::size_t tasks = parts.classification_tasks();
        REQUIRE(tasks > 3);
        const PartlyHiddenPairs classifier(s, ComputeOptions{}.method_options, false, false);
        std::vector<char> bytes;
        for (const RowRange r :
             {RowRange{0, 1}, RowRange{1, tasks / 2}, RowRange{tasks / 2, tasks}}) {
            const std::vector<char> b = classifier.classify(r);
            bytes.insert(bytes.end(), b.begin(), b.end());
        }
        std::vector<char> cut(bytes.begin(), bytes.end() - 1);
        CHECK_THROWS_AS(parts.set_classification(cut), Error);
        PartlyHiddenPairs again(s, ComputeOptions{}.method_options, false, false);
        again.set_classification(bytes);
        REQUIRE(again.count() == pairs.count());
        again.set_values(again.integrate({0, again.count()}));
        CHECK((from_upper_blocks(s, &again, upper_pairs).array() == F.array()).all());
        // Without the given pairs the option is ignored: whole rows.
        ComputeOptions o;
        o.rows = {3, 9};
        const ComputeResult rows = compute_form_factors(s, o);
        o.upper_triangle_only = true;
        CHECK((compute_form_factors(s, o).form_factors.F.array() == rows.form_factors.F.array())
                  .all());
    }
}

TEST_CASE("pipeline: the classification's tasks come costliest first") {
    // Over MPI ranks the tasks go out in this order, so that the last ones are small. In room-16
    // the 15 pairs of walls have as many patch pairs and the same blockers in their root shafts,
    // but the box hides from 20 % to 60 % of them: what each classifies (its bytes) must not
    // grow much along the order.
    const Scene s = builtin_scene("room-16");
    const PartlyHiddenPairs pairs(s, ComputeOptions{}.method_options, false, false);
    const std::size_t tasks = pairs.classification_tasks();
    REQUIRE(tasks > 20);
    std::vector<double> size(tasks);
    for (std::size_t k = 0; k < tasks; ++k) size[k] = double(pairs.classify({k, k + 1}).size());
    double later_max = 0.0;
    std::size_t out_of_order = 0;
    for (std::size_t k = tasks; k-- > 0;) {
        if (size[k] < 0.7 * later_max) ++out_of_order;
        later_max = std::max(later_max, size[k]);
    }
    CHECK(out_of_order == 0);
}

TEST_CASE("pipeline: the default method, typed report, nothing drawn unless asked") {
    const Scene s = cornell(1);
    const ComputeResult r = compute_form_factors(s);
    CHECK(r.report.method == MethodKind::analytic);
    REQUIRE(r.report.error_bound_per_entry);
    CHECK(*r.report.error_bound_per_entry > 0.0);
    CHECK(*r.report.error_bound_per_entry <= 1e-6);
    REQUIRE(r.report.pairs);
    CHECK(r.report.pairs->pairs == s.patches.size() * (s.patches.size() - 1) / 2);
    CHECK(r.report.details.contains("obstructions"));
    CHECK(r.traits.reciprocity.kind == ReciprocityPromise::Kind::exact);
    REQUIRE(r.diagnostics);
    CHECK(r.diagnostics->n == s.patches.size());

    // A sink receives every phase, however short: an update at its end with done = total.
    CountingSink sink;
    ComputeOptions o = options_for(MethodKind::mc_hemisphere);
    o.progress = &sink;
    const ComputeResult mc = compute_form_factors(s, o);
    CHECK(sink.finishes >= 1);
    CHECK(sink.updates >= sink.finishes);
    CHECK(sink.last_done == sink.last_total);
    REQUIRE(mc.report.rays_cast);
    CHECK(*mc.report.rays_cast == 512 * s.patches.size());
    CHECK(mc.form_factors.standard_error);
}

TEST_CASE("pipeline: sparse analytic rows in one block show the method's own phases") {
    // The partly hidden pass's bar (and its note of what it will cost, when long) reaches the
    // caller's sink when the rows come as one block, as in a dense run.
    class LabelSink final : public ProgressSink {
      public:
        void update(const std::string& label, std::size_t, std::size_t, double) override {
            labels.insert(label);
        }
        void finish(const std::string&) override {}
        std::set<std::string> labels;
    };
    const Scene s = cornell(3);
    LabelSink sink;
    ComputeOptions o = options_for(MethodKind::analytic);
    o.progress = &sink;
    const SparseComputeResult r = compute_sparse_form_factors(s, o, SparseOptions{});
    REQUIRE(r.run.blocks == 1);
    CHECK(sink.labels.count("analytic (obstructed)") == 1);
    CHECK(sink.labels.count("sparse rows") == 1);
}

TEST_CASE("pipeline: a computation stops at its own cancellation flag") {
    const Scene s = cornell(3);
    CancellationFlag flag;
    flag.request();
    ComputeOptions o = options_for(MethodKind::mc_hemisphere);
    o.cancel = &flag;
    CHECK_THROWS_AS(compute_form_factors(s, o), Cancelled);
    CHECK_FALSE(process_cancellation().requested());
    // Another computation, without that flag, is not affected.
    o.cancel = nullptr;
    CHECK_NOTHROW(compute_form_factors(s, o));

    // Requested from another thread while the rows run.
    CancellationFlag later;
    o.cancel = &later;
    o.method_options.samples = 200000;
    o.method_options.threads = 1;
    std::thread stopper([&] {
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
        later.request();
    });
    CHECK_THROWS_AS(compute_form_factors(s, o), Cancelled);
    stopper.join();
}

TEST_CASE("pipeline: errors name the option field, never a command-line flag") {
    const Scene s = cornell(1);
    auto field_of = [&](const ComputeOptions& o) -> std::string {
        try {
            compute_form_factors(s, o);
        } catch (const OptionError& e) {
            CHECK(std::string(e.what()).find("--") == std::string::npos);
            return e.field();
        }
        return "(no error)";
    };
    ComputeOptions o;
    o.method_options.tolerance = -1;
    CHECK(field_of(o) == "tolerance");
    o = {};
    o.method_options.threads = -2;
    CHECK(field_of(o) == "threads");
    o = {};
    o.rows = {5, 3};
    CHECK(field_of(o) == "rows");
    o = {};
    o.rows = {s.patches.size() + 1, RowRange::kEnd};
    CHECK(field_of(o) == "rows");
    o = options_for(MethodKind::mc_area);
    o.method_options.samples = std::uint64_t(1) << 40;
    CHECK(field_of(o) == "samples");
    o = {};
    o.repair.mode = RepairMode::both;
    o.rows = {0, 3};
    CHECK(field_of(o) == "repair");
    o = {};
    o.visibility.relative_epsilon = 0.5;
    CHECK(field_of(o) == "ray_offset");
    CHECK_THROWS_WITH_AS(parse_method("radiosity"),
                         "method: unknown method 'radiosity' (expected analytic, hemicube, "
                         "hemiplane, mc-area, mc-hemisphere or mc-target)",
                         OptionError);
    CHECK(parse_method("mc-target") == MethodKind::mc_target);
    CHECK(to_string(MethodKind::mc_area) == "mc-area");
}

TEST_CASE("pipeline: repair through the pipeline closes a Monte-Carlo matrix") {
    Scene s = load_scene("cube");
    SubdivisionOptions sub;
    sub.n = 2;
    subdivide(s, sub);
    ComputeOptions o = options_for(MethodKind::mc_hemisphere);
    o.repair.mode = RepairMode::both;
    const ComputeResult r = compute_form_factors(s, o);
    REQUIRE(r.repair);
    CHECK(r.repair->after.row_sum_min > 1 - 1e-9);
    CHECK(r.repair->after.row_sum_max < 1 + 1e-9);
    REQUIRE(r.diagnostics);  // of F as the method made it
    CHECK(r.diagnostics->reciprocity_area_weighted > r.repair->after.reciprocity_area_weighted);
}

TEST_CASE("pipeline: the CLI sets the ray tracer's options and maps fields to its flags") {
    formfactor::testing::Cli cli;
    auto r = cli.run("compute cube --method mc-hemisphere --samples 64 --ray-offset 0.5 -o F.csv");
    CHECK(r.code == 2);
    CHECK(r.err == "formfactor: --ray-offset: must be in (0, 0.01), got 0.5\n");
    r = cli.run(
        "compute cube --method mc-hemisphere --samples 64 --robust-rays --ray-offset 1e-6 "
        "-o F.csv");
    CHECK(r.code == 0);
    // An option field named by the library comes out as the flag the user typed.
    r = cli.run("compute cube --method mc-area --samples 8589934592 -o F.csv");
    CHECK(r.code == 2);
    CHECK(r.err.rfind("formfactor: --samples: ", 0) == 0);
    r = cli.run("compute cube --max-edge 0.5 --subdivide 3 -o F.csv");
    CHECK(r.code == 2);
    CHECK(r.err.rfind("formfactor: --subdivide: ", 0) == 0);
}

TEST_CASE("pipeline: every step of the CLI is an entry point with field-named errors") {
    StepTimes times;
    int seen_patches = -1;
    const Scene s = prepare_scene({"cube", {2, 0.0}, "", false}, &times, [&](const Scene& loaded) {
        seen_patches = static_cast<int>(loaded.patches.size());
    });
    CHECK(seen_patches == 6);  // the hook runs before subdividing: one patch per face
    REQUIRE(s.patches.size() == 24);
    REQUIRE(times.steps.size() == 2);
    CHECK(times.steps[0].first == "load");
    CHECK(times.steps[1].first == "subdivide");

    // F from elsewhere: checked, diagnosed, repaired like a computed one.
    const ComputeResult exact = compute_form_factors(s);
    const ComputeResult read = form_factors_from_matrix(s, exact.form_factors.F, {}, "F.npy");
    REQUIRE(read.diagnostics);
    CHECK(read.diagnostics->row_sum_max == exact.diagnostics->row_sum_max);
    CHECK_FALSE(read.repair);
    RepairOptions both;
    both.mode = RepairMode::both;
    CHECK(form_factors_from_matrix(s, exact.form_factors.F, both).repair);
    CHECK_THROWS_WITH_AS(form_factors_from_matrix(s, DenseMatrix::Zero(6, 6), {}, "F.npy"),
                         "F.npy: a 6x6 matrix, the scene has 24 patches (same scene and "
                         "subdivision?)",
                         InputError);

    // Points: the centre of the floor sees the whole closed cube.
    PointOptions p;
    p.positions = {Vec3(0.5, 0.5, 1e-9)};
    p.normals = {Vec3(0, 0, 1)};
    const PointResult pr = compute_point_form_factors(s, p);
    CHECK(pr.F.rows() == 1);
    CHECK(std::abs(pr.F.sum() - 1.0) < 1e-12);
    p.threads = -1;
    CHECK_THROWS_WITH_AS(validate(p), "threads: must be ≥ 0 (0 = all cores), got -1", OptionError);
    p.threads = 0;
    p.normals.clear();
    CHECK_THROWS_AS(compute_point_form_factors(s, p), OptionError);

    // The view of a patch: what it sees sums to 1 (the hemicube's delta form factors).
    ViewOptions v;
    v.patch = 3;
    v.resolution = 64;
    const PatchView view = patch_view(s, v);
    CHECK(view.resolution == 64);
    CHECK(view.point == s.patches[3].centroid);
    double sum = 0.0;
    for (std::size_t k = 0; k < view.seen.size(); ++k) {
        sum += view.seen[k].form_factor;
        if (k > 0) CHECK(view.seen[k - 1].form_factor >= view.seen[k].form_factor);
    }
    CHECK(std::abs(sum - 1.0) < 1e-9);
    auto field_of = [&](const ViewOptions& o) -> std::string {
        try {
            patch_view(s, o);
        } catch (const OptionError& e) {
            return e.field();
        }
        return "(no error)";
    };
    ViewOptions bad = v;
    bad.patch = 24;
    CHECK(field_of(bad) == "patch");
    bad = v;
    bad.method = MethodKind::analytic;
    CHECK(field_of(bad) == "method");
    bad = v;
    bad.rotation_degrees = std::nan("");
    CHECK(field_of(bad) == "rotation");
    bad = v;
    bad.point = Vec3(0, 0, INFINITY);
    CHECK(field_of(bad) == "point");
}

TEST_CASE("progress: a terminal bar's notes pass through its front end's words") {
    // The library names options in backquotes; the CLI's bar gives them as flags (cli_text()).
    testing::TempDir dir;
    const std::string path = (dir.path() / "stderr.txt").string();
    std::fflush(stderr);
    const int saved = ::dup(STDERR_FILENO);
    REQUIRE(saved >= 0);
    std::FILE* f = std::fopen(path.c_str(), "w");
    REQUIRE(f != nullptr);
    ::dup2(::fileno(f), STDERR_FILENO);
    {
        TerminalProgress words([](const std::string& t) {
            std::string out = t;
            for (std::size_t at; (at = out.find("`tolerance`")) != std::string::npos;)
                out.replace(at, 11, "--tolerance");
            return out;
        });
        words.note("a looser `tolerance`");
        TerminalProgress plain;
        plain.note("as `given`");
    }
    std::fflush(stderr);
    ::dup2(saved, STDERR_FILENO);
    ::close(saved);
    std::fclose(f);
    std::ifstream in(path);
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    CHECK(text == "formfactor: a looser --tolerance\nformfactor: as `given`\n");
}
