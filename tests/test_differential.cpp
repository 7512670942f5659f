// The differential harness of the obstructed `analytic` method (label obstructed-references):
// random obstructed scenes (support/random_geometry.h), each written in every form the project
// reads, and every form's matrix held against
//  - mc-target (Embree rays; knows nothing of shafts, shadows or blocker sets) within k standard
//    errors of its replicates plus the analytic method's own reported error bound;
//  - the unobstructed exact value (obstruction never adds light);
//  - closure of every row in closed scenes, within the sum of the reported per-entry bounds;
//  - the matrix of the in-memory form of the same geometry (every representation must agree);
//  - and, in the slow slice, a high-sample mc-target reference on the worst entries, which the
//    reported error bound must cover.
// A fast slice runs in the default suite; the long one is labelled `slow`.

#include <doctest/doctest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <numeric>
#include <sstream>
#include <string>
#include <vector>

#include "formfactor/core/random.h"
#include "formfactor/kernels/analytic.h"
#include "formfactor/methods/method.h"
#include "formfactor/scene/city.h"
#include "support/obstructed_checks.h"
#include "support/random_geometry.h"
#include "support/student_t.h"
#include "support/temp_dir.h"

using namespace formfactor;
using testing::AnalyticRun;
using testing::Form;
using testing::McReference;
using testing::run_analytic;

namespace {

using Clock = std::chrono::steady_clock;

// The analytic method's default tolerance for partly hidden pairs (README: "≤ --tolerance per
// entry"): the reported bound must not exceed it (rounding aside).
constexpr double kTolerance = 1e-6 * (1 + 1e-9);

double seconds_since(Clock::time_point t0) {
    return std::chrono::duration<double>(Clock::now() - t0).count();
}

/// The worst of one check over a form's entries: the largest value/limit ratio and where.
struct Worst {
    double ratio = 0, value = 0, limit = 0;
    std::size_t i = 0, j = 0;
    void add(double v, double lim, std::size_t a, std::size_t b) {
        const double r = lim > 0 ? v / lim : (v > 0 ? INFINITY : 0.0);
        if (r > ratio) *this = Worst{r, v, lim, a, b};
    }
    std::string str() const {
        std::ostringstream s;
        s.precision(3);
        s << value << " (limit " << limit << ", x" << ratio << ") at [" << i << "," << j << "]";
        return s.str();
    }
};

/// What the harness found for one form of one geometry.
struct FormResult {
    std::string form;
    bool loaded = false;
    std::string load_error;
    double bound = 0, seconds = 0;
    Worst vs_mc;       // |a − m| against k·se + bound + allowance
    Worst above_free;  // a − unobstructed against the far-field tolerance
    Worst closure;     // |row sum − 1| (closed) or row sum − 1 (open) against Σ bounds
    Worst vs_scene;    // |a − a(scene form)| against the two bounds
    Worst referee;     // |a − high-sample mc-target| on the worst entry (slow slice)
    double max_abs_error_vs_mc = 0;
    bool ok() const {
        return loaded && vs_mc.ratio <= 1 && above_free.ratio <= 1 && closure.ratio <= 1 &&
               vs_scene.ratio <= 1 && referee.ratio <= 1 && bound <= kTolerance;
    }
};

struct HarnessOptions {
    std::uint64_t mc_samples = 1 << 13;
    std::size_t mc_patches = 10;  // patches in the mc-target sub-scene (0 = all)
    std::vector<Form> forms = testing::all_forms();
    int threads = 0;
    long style = -1;  // the foreign writers' style bits (-1: the geometry's own)
    /// > 0: the (up to three) entries where the forms are furthest from mc-target are estimated
    /// again with this many samples, and every form's reported bound must cover its error there.
    std::uint64_t referee_samples = 0;
};

Eigen::Index I(std::size_t x) { return static_cast<Eigen::Index>(x); }

// What mc-target's standard error does not cover, per entry, in units of the unobstructed
// value: the ray-end offsets of the visibility (blockers within a relative 1e-5 of the scene's
// diagonal from a ray end are missed, see visibility.h), the O(1/N) bias of its ratio
// estimator, and, where no ray (or every ray) was blocked so that its standard error is 0, a
// hidden (visible) fraction too small for N rays to meet (< 16/N: missed with probability
// ~e^-16); plus an absolute floor for the far-field tolerance.
double mc_allowance(double unobstructed, double se, std::uint64_t samples) {
    const double per_n = (se > 0 ? 4.0 : 16.0) / static_cast<double>(samples);
    return unobstructed * (per_n + 2e-5) + 1e-9;
}

std::vector<FormResult> check_geometry(const testing::Geometry& g, const HarnessOptions& h,
                                       std::uint64_t seed) {
    testing::TempDir dir;
    std::vector<Polygon> all = g.room;
    all.insert(all.end(), g.blockers.begin(), g.blockers.end());
    const std::size_t n_all = all.size(), n_room = g.room.size();

    // Exact unobstructed factors of every pair (the same polygons in every form).
    DenseMatrix free =
        DenseMatrix::Zero(static_cast<Eigen::Index>(n_all), static_cast<Eigen::Index>(n_all));
    for (std::size_t i = 0; i < n_all; ++i)
        for (std::size_t j = 0; j < n_all; ++j)
            if (i != j) free(I(i), I(j)) = polygon_to_polygon(all[i], all[j]);

    // The Monte-Carlo reference on a random subset of patches (room and blockers).
    std::vector<std::size_t> chosen(n_all);
    std::iota(chosen.begin(), chosen.end(), 0);
    if (h.mc_patches > 0 && h.mc_patches < n_all) {
        std::uint64_t state = splitmix64(seed * 7919 + 3);
        for (std::size_t k = n_all - 1; k > 0; --k)
            std::swap(chosen[k], chosen[splitmix64(state++) % (k + 1)]);
        chosen.resize(h.mc_patches);
    }
    const McReference mc = testing::mc_reference(all, {}, chosen, h.mc_samples, seed);
    const std::size_t nm = mc.patches.size();
    const double k = testing::simultaneous_k(double(nm * nm * h.forms.size()), mc.dof);

    std::vector<FormResult> results;
    std::vector<AnalyticRun> runs;  // per result (empty F when not loaded)
    AnalyticRun scene_r, scene_o;
    bool have_r = false, have_o = false;
    for (Form f : h.forms) {
        FormResult res;
        res.form = testing::form_name(f);
        const bool radiate = testing::blockers_radiate(f);
        const std::size_t n = radiate ? n_all : n_room;
        AnalyticRun run;
        try {
            // FF_DIFFERENTIAL_KEEP=dir keeps the written files there (a development aid).
            const char* keep = std::getenv("FF_DIFFERENTIAL_KEEP");
            const Scene s =
                testing::load_form(g, f, keep ? std::string(keep) : dir.path().string());
            if (s.patches.size() != n)
                throw std::runtime_error("loaded " + std::to_string(s.patches.size()) +
                                         " patches, expected " + std::to_string(n));
            run = run_analytic(s, h.threads);
            res.loaded = true;
            // Into the kScene numbering.
            const std::vector<std::size_t> order = testing::patch_order(g, f);
            DenseMatrix canonical(I(n), I(n));
            for (std::size_t a = 0; a < n; ++a)
                for (std::size_t b = 0; b < n; ++b)
                    canonical(I(order[a]), I(order[b])) = run.ff.F(I(a), I(b));
            run.ff.F = std::move(canonical);
        } catch (const std::exception& e) {
            res.load_error = e.what();
            results.push_back(res);
            runs.emplace_back();
            continue;
        }
        res.bound = run.bound;
        res.seconds = run.seconds;
        const DenseMatrix& F = run.ff.F;

        // Against mc-target.
        for (std::size_t a = 0; a < nm; ++a)
            for (std::size_t b = 0; b < nm; ++b) {
                const std::size_t i = mc.patches[a], j = mc.patches[b];
                if (i == j || i >= n || j >= n) continue;
                const double m = mc.F(I(a), I(b)), se = mc.se(I(a), I(b));
                const double diff = std::abs(F(I(i), I(j)) - m);
                res.max_abs_error_vs_mc = std::max(res.max_abs_error_vs_mc, diff);
                res.vs_mc.add(diff,
                              k * se + run.bound + mc_allowance(free(I(i), I(j)), se, mc.samples),
                              i, j);
            }
        // Never above the unobstructed value; rows.
        for (std::size_t i = 0; i < n; ++i) {
            double row = 0;
            for (std::size_t j = 0; j < n; ++j) {
                row += F(I(i), I(j));
                if (i != j)
                    res.above_free.add(F(I(i), I(j)) - free(I(i), I(j)), 1e-10 + 1e-12, i, j);
            }
            // Σ of the entries' bounds; with jitter the faces of a closed scene leave slits of
            // width ≤ ~3·jitter along their edges, a leak of at most ~jitter·n per row.
            const double slack = double(n) * (run.bound + 1e-10) + 4 * g.jitter * g.n;
            if (g.closed && radiate)
                res.closure.add(std::abs(row - 1), slack, i, i);
            else
                res.closure.add(row - 1, slack, i, i);
        }
        // Against the in-memory form (the room block for obstruction forms).
        if (f == Form::kScene) {
            scene_r = run;
            have_r = true;
        }
        if (f == Form::kSceneObstruction) {
            scene_o = run;
            have_o = true;
        }
        const AnalyticRun* ref =
            radiate ? (have_r ? &scene_r : nullptr) : (have_o ? &scene_o : nullptr);
        if (ref)
            for (std::size_t i = 0; i < n; ++i)
                for (std::size_t j = 0; j < n; ++j)
                    res.vs_scene.add(std::abs(F(I(i), I(j)) - ref->ff.F(I(i), I(j))),
                                     run.bound + ref->bound + 1e-10, i, j);
        if (!radiate && have_r)
            for (std::size_t i = 0; i < n; ++i)
                for (std::size_t j = 0; j < n; ++j)
                    res.vs_scene.add(std::abs(F(I(i), I(j)) - scene_r.ff.F(I(i), I(j))),
                                     run.bound + scene_r.bound + 1e-10, i, j);
        results.push_back(res);
        runs.push_back(run);
    }

    // The high-sample referee on the entries where the forms are furthest from mc-target (each
    // form's worst entry by ratio to its limit; up to three distinct entries, worst first).
    if (h.referee_samples > 0) {
        std::vector<std::pair<double, std::pair<std::size_t, std::size_t>>> worst;
        for (const FormResult& r : results)
            if (r.loaded && r.vs_mc.value > 0)
                worst.push_back({r.vs_mc.ratio, {r.vs_mc.i, r.vs_mc.j}});
        std::sort(worst.begin(), worst.end(),
                  [](const auto& x, const auto& y) { return x.first > y.first; });
        std::vector<std::pair<std::size_t, std::size_t>> entries;
        for (const auto& w : worst)
            if (entries.size() < 3 &&
                std::find(entries.begin(), entries.end(), w.second) == entries.end())
                entries.push_back(w.second);
        for (std::size_t e = 0; e < entries.size(); ++e) {
            const auto [ri, rj] = entries[e];
            const McReference hi =
                testing::mc_reference(all, {}, {ri, rj}, h.referee_samples, seed + 1000003 + e);
            const std::size_t a = ri < rj ? 0 : 1, b = 1 - a;
            const double m = hi.F(I(a), I(b)), se = hi.se(I(a), I(b));
            const double kr =
                testing::simultaneous_k(double(entries.size() * results.size()), hi.dof);
            for (std::size_t r = 0; r < results.size(); ++r) {
                if (!results[r].loaded || runs[r].ff.F.rows() <= I(std::max(ri, rj))) continue;
                const double f = runs[r].ff.F(I(ri), I(rj));
                results[r].referee.add(
                    std::abs(f - m),
                    kr * se + runs[r].bound + mc_allowance(free(I(ri), I(rj)), se, hi.samples), ri,
                    rj);
            }
        }
    }
    return results;
}

/// Which checks a form fails, as a short list ("vs-mc rows ...").
std::string failed_checks(const FormResult& r) {
    if (!r.loaded) return "load";
    std::string out;
    if (r.vs_mc.ratio > 1) out += " vs-mc";
    if (r.above_free.ratio > 1) out += " above-unobstructed";
    if (r.closure.ratio > 1) out += " rows";
    if (r.vs_scene.ratio > 1) out += " vs-scene";
    if (r.referee.ratio > 1) out += " referee";
    if (r.bound > kTolerance) out += " bound>tolerance";
    return out;
}

/// Runs the harness on the geometries of `seeds` and CHECKs every form of each. Prints, per
/// geometry as it is done, one line per form (its time, reported bound and the worst entry of
/// each check), and at the end the failing forms.
void run_harness(const std::vector<std::uint64_t>& seeds, const testing::GeneratorOptions& go,
                 const HarnessOptions& h) {
    std::size_t failures = 0, forms = 0;
    std::ostringstream summary;
    for (std::uint64_t seed : seeds) {
        testing::Geometry g = testing::random_geometry(seed, go);
        if (h.style >= 0) g.style = static_cast<std::uint64_t>(h.style);
        const auto t0 = Clock::now();
        const std::vector<FormResult> results = check_geometry(g, h, seed);
        const double secs = seconds_since(t0);
        CAPTURE(g.label);
        std::ostringstream table;
        table << g.label << " (" << g.room.size() << "+" << g.blockers.size() << " patches"
              << (g.closed ? ", closed" : "") << ", " << secs << " s)\n";
        for (const FormResult& r : results) {
            ++forms;
            if (!r.ok()) {
                ++failures;
                summary << "  seed " << seed << " " << r.form << ":" << failed_checks(r) << "\n";
            }
            if (!r.loaded) {
                table << "  FAIL " << r.form << ": LOAD ERROR " << r.load_error << "\n";
                continue;
            }
            table << "  " << (r.ok() ? "ok  " : "FAIL") << " " << r.form << " (" << r.seconds
                  << " s): bound " << r.bound << ", max |a-mc| " << r.max_abs_error_vs_mc
                  << "; vs mc " << r.vs_mc.str() << "; above free " << r.above_free.str()
                  << "; rows " << r.closure.str() << "; vs scene " << r.vs_scene.str();
            if (h.referee_samples > 0) table << "; referee " << r.referee.str();
            table << "\n";
        }
        MESSAGE(table.str());
        for (const FormResult& r : results) {
            CAPTURE(r.form);
            CHECK_MESSAGE(r.loaded, r.load_error);
            if (!r.loaded) continue;
            CHECK_MESSAGE(r.vs_mc.ratio <= 1, "analytic vs mc-target: " << r.vs_mc.str());
            CHECK_MESSAGE(r.above_free.ratio <= 1, "above unobstructed: " << r.above_free.str());
            CHECK_MESSAGE(r.closure.ratio <= 1, "row sums: " << r.closure.str());
            CHECK_MESSAGE(r.vs_scene.ratio <= 1, "vs in-memory form: " << r.vs_scene.str());
            CHECK_MESSAGE(r.referee.ratio <= 1, "vs high-sample mc-target: " << r.referee.str());
            CHECK_MESSAGE(r.bound <= kTolerance,
                          "reported error bound " << r.bound << " above the tolerance");
        }
    }
    MESSAGE("differential harness: " << failures << " of " << forms << " forms fail\n"
                                     << summary.str());
}

// The slow slice: rooms n = 2..4, up to three blockers split 1×1 or 2×2, every form,
// mc-target on 24 patches, and the three entries furthest from it estimated again with 2^20
// samples.
void long_settings(testing::GeneratorOptions& go, HarnessOptions& h) {
    go.room_n = {2, 3, 4};
    go.max_blockers = 3;
    go.blocker_split = {1, 2};
    h.mc_samples = 1 << 14;
    h.mc_patches = 24;
    h.referee_samples = 1 << 20;
}

std::vector<std::uint64_t> seed_range(std::uint64_t first, std::uint64_t last) {
    std::vector<std::uint64_t> v;
    for (std::uint64_t s = first; s <= last; ++s) v.push_back(s);
    return v;
}

}  // namespace

TEST_CASE("differential: t quantiles for the replicate standard errors") {
    // Tables: t_{0.975, 15} = 2.131, t_{0.9995, 15} = 4.073, t_{0.975, 1} = 12.706.
    CHECK(testing::student_t_two_sided_quantile(0.05, 15) == doctest::Approx(2.1314).epsilon(1e-4));
    CHECK(testing::student_t_two_sided_quantile(0.001, 15) ==
          doctest::Approx(4.0728).epsilon(1e-4));
    CHECK(testing::student_t_two_sided_quantile(0.05, 1) == doctest::Approx(12.7062).epsilon(1e-4));
    CHECK(testing::student_t_two_sided_tail(0, 15) == doctest::Approx(1.0));
}

TEST_CASE("differential: the generator's forms describe one geometry") {
    for (std::uint64_t seed = 1; seed <= 12; ++seed) {
        const testing::Geometry g = testing::random_geometry(seed);
        CAPTURE(g.label);
        testing::TempDir dir;
        const Scene ref = testing::make_scene(g, true);
        for (Form f : testing::all_forms()) {
            CAPTURE(testing::form_name(f));
            const Scene s = testing::load_form(g, f, dir.path().string());
            const bool radiate = testing::blockers_radiate(f);
            REQUIRE(s.patches.size() == g.room.size() + (radiate ? g.blockers.size() : 0));
            double area_o = 0, area_ref = 0;
            for (const Surface& sf : s.surfaces)
                if (sf.obstruction) area_o += area(sf.polygon);
            for (const Polygon& p : g.obstructions) area_ref += area(p);
            CHECK(area_o == doctest::Approx(radiate ? 0.0 : area_ref).epsilon(1e-12));
            const std::vector<std::size_t> order = testing::patch_order(g, f);
            for (std::size_t i = 0; i < s.patches.size(); ++i) {
                const Patch& r = ref.patches[order[i]];
                CHECK((s.patches[i].centroid - r.centroid).norm() <= 1e-12);
                CHECK(s.patches[i].normal.dot(r.normal) >= 1 - 1e-12);
                CHECK(s.patches[i].area == doctest::Approx(r.area).epsilon(1e-12));
            }
        }
    }
}

TEST_CASE("differential: analytic against mc-target and itself on random scenes (fast)" *
          doctest::test_suite("obstructed-references")) {
    // Geometries chosen among the first seeds of the default generator for their spread (boxes
    // touching, resting on walls, open, a thin plate, a tilted box, a single quad with vertex
    // jitter) at a cost of seconds: rooms n = 2, 3; five forms; mc-target on 10 patches.
    testing::GeneratorOptions go;
    HarnessOptions h;
    h.mc_samples = 1 << 13;
    h.mc_patches = 10;
    h.forms = {Form::kScene, Form::kScenePermuted, Form::kObjObstruction, Form::kVs3,
               Form::kVs3Obstruction};
    run_harness({1, 5, 8, 24, 29}, go, h);
}

// Not in `make test`: with vertex jitter a geometry takes up to half an hour in every form (the
// obstructed method is slow on jittered scenes). Run it with
// `build/formfactor_tests -tc='*random scenes (long)*' --no-skip`.
TEST_CASE("differential: analytic against mc-target and itself on random scenes (long)" *
          doctest::test_suite("slow") * doctest::skip()) {
    testing::GeneratorOptions go;
    HarnessOptions h;
    long_settings(go, h);
    run_harness(seed_range(100, 119), go, h);
}

TEST_CASE("differential: seeds from FF_DIFFERENTIAL_SEEDS (a development aid)" * doctest::skip()) {
    // With --no-skip. FF_DIFFERENTIAL_SEEDS="first last [n ...]": the harness on those seeds,
    // rooms n from the list (default 2 3); FF_DIFFERENTIAL_LONG=1 takes the slow slice's
    // settings; FF_DIFFERENTIAL_FORMS="scene vs3-O ..." limits the forms;
    // FF_DIFFERENTIAL_STYLE=bits sets the foreign writers' style; FF_DIFFERENTIAL_REFEREE=N adds
    // the high-sample referee.
    // FF_DIFFERENTIAL_KEEP=dir keeps the files every form was written to.
    const char* env = std::getenv("FF_DIFFERENTIAL_SEEDS");
    REQUIRE(env != nullptr);
    std::istringstream in(env);
    std::uint64_t first = 1, last = 1;
    in >> first >> last;
    testing::GeneratorOptions go;
    HarnessOptions h;
    if (std::getenv("FF_DIFFERENTIAL_LONG")) long_settings(go, h);
    std::vector<int> ns;
    for (int n; in >> n;) ns.push_back(n);
    if (!ns.empty()) go.room_n = ns;
    if (const char* st = std::getenv("FF_DIFFERENTIAL_STYLE")) h.style = std::atol(st);
    if (const char* r = std::getenv("FF_DIFFERENTIAL_REFEREE")) h.referee_samples = std::atol(r);
    if (const char* forms = std::getenv("FF_DIFFERENTIAL_FORMS")) {
        h.forms.clear();
        for (Form f : testing::all_forms())
            if ((std::string(" ") + forms + " ").find(" " + testing::form_name(f) + " ") !=
                std::string::npos)
                h.forms.push_back(f);
    }
    run_harness(seed_range(first, last), go, h);
}

namespace {

// The city of city_scene(n) as tools write it for View3D: every unit square as two triangles,
// each its own surface.
Scene triangulated_city(int n) {
    const Scene city = city_scene(n);
    std::vector<Polygon> tris;
    for (const Patch& p : city.patches) {
        const auto& v = p.polygon.vertices;
        tris.push_back(Polygon{{v[0], v[1], v[2]}});
        tris.push_back(Polygon{{v[0], v[2], v[3]}});
    }
    Scene s = testing::scene_of(tris);
    s.name = "city-" + std::to_string(n) + "-triangulated";
    return s;
}

// Every entry of a run at `tolerance` against a run at a tighter one: the difference within
// the two reported bounds, and the reported bound within the tolerance.
void check_bound_against_tighter(const Scene& s, const std::vector<double>& tolerances,
                                 double tight) {
    const AnalyticRun ref = run_analytic(s, 0, tight);
    REQUIRE(ref.bound <= tight * (1 + 1e-9));
    const auto n = ref.ff.F.rows();
    for (double t : tolerances) {
        CAPTURE(t);
        const AnalyticRun run = run_analytic(s, 0, t);
        CHECK(run.bound <= t * (1 + 1e-9));
        Worst w;
        double max_diff = 0;
        for (Eigen::Index i = 0; i < n; ++i)
            for (Eigen::Index j = 0; j < n; ++j) {
                const double d = std::abs(run.ff.F(i, j) - ref.ff.F(i, j));
                max_diff = std::max(max_diff, d);
                w.add(d, run.bound + ref.bound + 1e-10, static_cast<std::size_t>(i),
                      static_cast<std::size_t>(j));
            }
        MESSAGE(s.name << " (" << n << " patches) at tolerance " << t << ": " << run.seconds
                       << " s (" << ref.seconds << " s at " << tight << "), bound " << run.bound
                       << ", largest difference " << max_diff);
        CHECK_MESSAGE(w.ratio <= 1, "difference to the run at " << tight << ": " << w.str());
    }
}

}  // namespace

TEST_CASE("differential: the reported bound covers the error at every tolerance" *
          doctest::test_suite("obstructed-references")) {
    // Against a run 10× tighter than the tightest: random scenes (boxes touching, resting on
    // walls, a tilted box) and an urban array of triangles, where most pairs are partly
    // hidden by buildings.
    const std::vector<double> tolerances = {1e-4, 1e-5, 1e-6};
    for (std::uint64_t seed : {1, 5, 8}) {
        const testing::Geometry g = testing::random_geometry(seed);
        Scene s = testing::make_scene(g, true);
        s.name = g.label;
        check_bound_against_tighter(s, tolerances, 1e-7);
    }
    check_bound_against_tighter(triangulated_city(2), tolerances, 1e-7);
}
