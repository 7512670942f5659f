#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "formfactor/core/error.h"
#include "formfactor/kernels/analytic.h"
#include "formfactor/methods/method.h"
#include "support/method_runner.h"
#include "support/scenes.h"

using formfactor::testing::run_method;

using namespace formfactor;
using testing::quad;
using testing::scene_of;

namespace {

FormFactors run(const std::string& method, const Scene& s, std::uint64_t samples,
                std::uint64_t seed = 1, const std::string& sampler = "sobol", int threads = 0,
                nlohmann::json* details_out = nullptr) {
    MethodOptions o;
    o.samples = samples;
    o.seed = seed;
    o.sampler = parse_sampler(sampler);
    o.threads = threads;
    nlohmann::json details;
    FormFactors ff = run_method(*make_method(method), s, o, details);
    if (details_out) *details_out = details;
    return ff;
}

struct CatalogCase {
    const char* name;
    Scene scene;
    double exact;
};

std::vector<CatalogCase> catalog() {
    return {{"C-11 1x1x1", testing::parallel_rects(1, 1, 1), 0.19982489569838746},
            {"C-14 1x1x1", testing::perpendicular_squares(), 0.20004377607540316},
            {"C-11 2x1x1", testing::parallel_rects(2, 1, 1), 0.2858753848507147},
            {"C-11 10x10x1", testing::parallel_rects(10, 10, 1), 0.8269945223972565},
            {"C-11 0.2x0.2x1", testing::parallel_rects(0.2, 0.2, 1), 0.01240397731324307}};
}

// F(dA → polygon), exact (Lambert's contour formula, kernels/analytic.h).
double point_ff(const Vec3& x, const Vec3& n, const Polygon& p) {
    return point_to_polygon(x, n, p);
}

// Tolerance in standard errors. With `random` the error is normal with a well-estimated σ: 4σ.
// Other samplers estimate σ from 16 replicates, so (F − exact)/SE follows Student's t with 15
// degrees of freedom (checked: over 800 seeds |t| > 3 for 0.8–1.6 % and > 4 for 0–0.25 %): 5 SE
// has the tail probability (1.6e-4) of 3.8 normal σ.
double k_sigma(const std::string& sampler) { return sampler == "random" ? 4.0 : 5.0; }

const std::string kMethods[] = {"mc-area", "mc-hemisphere"};

}  // namespace

TEST_CASE("mc: catalog cases within 4 (i.i.d.) or 5 (replicates) standard errors") {
    for (const std::string& method : kMethods) {
        for (const std::string sampler : {"sobol", "halton", "stratified", "random"}) {
            for (const auto& c : catalog()) {
                CAPTURE(method);
                CAPTURE(sampler);
                const std::string name = c.name;
                CAPTURE(name);
                // mc-area with a shared edge: infinite variance, see the next test case.
                if (method == "mc-area" && name.starts_with("C-14")) continue;
                const FormFactors ff = run(method, c.scene, 8192, 1, sampler);
                REQUIRE(ff.standard_error);
                for (auto [i, j] : {std::pair{0, 1}, std::pair{1, 0}}) {
                    const double f = ff.F(i, j), se = (*ff.standard_error)(i, j);
                    CAPTURE(f);
                    CAPTURE(se);
                    CHECK(se > 0);
                    CHECK(se < 0.05);
                    CHECK(std::abs(f - c.exact) <= k_sigma(sampler) * se);
                }
                CHECK(ff.F(0, 0) == 0.0);
            }
        }
    }
}

TEST_CASE("mc: area sampling across a shared edge (infinite variance) still converges") {
    // Near the common edge of C-14 the kernel cosθ_i cosθ_j/(π r²) makes the estimator's second
    // moment diverge: the standard error is unreliable and single runs have heavy right tails
    // (over 64 seeds at N = 32768, Sobol: median 0.1967, extremes 0.188 and 0.218, RMS error
    // 0.0076). The estimate is unbiased and converges; check it is within 0.03.
    const FormFactors ff = run("mc-area", testing::perpendicular_squares(), 32768, 1, "sobol");
    CHECK(ff.F(0, 1) == doctest::Approx(0.20004377607540316).epsilon(0.03 / 0.2));
    CHECK(ff.F(1, 0) == doctest::Approx(0.20004377607540316).epsilon(0.03 / 0.2));
}

TEST_CASE("mc: the error falls like 1/sqrt(N) or faster") {
    // RMS error over 32 seeds at N, 4N, 16N on C-11 (1×1 at distance 1).
    const Scene s = testing::parallel_rects(1, 1, 1);
    const double exact = 0.19982489569838746;
    for (const std::string& method : kMethods) {
        for (const std::string sampler : {"random", "sobol"}) {
            CAPTURE(method);
            CAPTURE(sampler);
            std::vector<double> rms;
            for (std::uint64_t N : {1024, 4096, 16384}) {
                double e2 = 0;
                for (std::uint64_t seed = 1; seed <= 32; ++seed) {
                    const FormFactors ff = run(method, s, N, seed, sampler);
                    e2 += std::pow(ff.F(0, 1) - exact, 2) / 32;
                }
                rms.push_back(std::sqrt(e2));
            }
            MESSAGE(method << " " << sampler << " rms " << rms[0] << " " << rms[1] << " "
                           << rms[2]);
            CHECK(rms[0] / rms[1] > 1.6);
            CHECK(rms[1] / rms[2] > 1.6);
        }
    }
}

TEST_CASE("mc: the same seed gives the same matrix for any thread count") {
    const Scene s = testing::unit_cube(2);
    for (const std::string& method : kMethods) {
        for (const std::string sampler : {"sobol", "random"}) {
            CAPTURE(method);
            CAPTURE(sampler);
            const FormFactors a = run(method, s, 256, 42, sampler, 1);
            const FormFactors b = run(method, s, 256, 42, sampler, 2);
            CHECK(a.F == b.F);
            CHECK(*a.standard_error == *b.standard_error);
            const FormFactors c = run(method, s, 256, 43, sampler, 2);
            CHECK(a.F != c.F);
        }
    }
}

TEST_CASE("mc: rows of a closed cube sum to 1") {
    const Scene s = testing::unit_cube(2);
    nlohmann::json d;
    const FormFactors h = run("mc-hemisphere", s, 4000, 5, "sobol", 0, &d);
    // Every ray hits the front of some patch: exactly 1 (no leaks between the triangles).
    for (Eigen::Index i = 0; i < h.F.rows(); ++i)
        CHECK(h.F.row(i).sum() == doctest::Approx(1.0).epsilon(1e-12));
    CHECK(d["escaped_fraction"].get<double>() == 0.0);
    CHECK(d["rays_cast"].get<std::uint64_t>() == 24 * 4000);
    // mc-area: cube faces share edges, where the kernel's second moment diverges (infinite
    // variance): the standard error is indicative only and heavy tails are expected, so the
    // bound is looser (6 SE per row) and the mean row sum is checked too.
    const FormFactors a = run("mc-area", s, 4096, 5);
    double mean = 0;
    for (Eigen::Index i = 0; i < a.F.rows(); ++i) {
        const double se = std::sqrt(a.standard_error->row(i).squaredNorm());
        CHECK(std::abs(a.F.row(i).sum() - 1.0) <= 6 * se);
        mean += a.F.row(i).sum() / double(a.F.rows());
    }
    CHECK(mean == doctest::Approx(1.0).epsilon(0.01));
}

TEST_CASE("mc: obstructed cases with exact answers") {
    const Polygon floor = quad(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0));
    const Polygon ceiling = quad(Vec3(0, 1, 1), Vec3(1, 1, 1), Vec3(1, 0, 1), Vec3(0, 0, 1));
    SUBCASE("a blocker hiding the receiver entirely gives 0") {
        const Scene s = scene_of({floor, ceiling}, {quad(Vec3(-2, -2, 0.5), Vec3(3, -2, 0.5),
                                                         Vec3(3, 3, 0.5), Vec3(-2, 3, 0.5))});
        for (const std::string& method : kMethods) {
            CAPTURE(method);
            const FormFactors ff = run(method, s, 2048);
            CHECK(ff.F.rows() == 2);
            CHECK(ff.F(0, 1) == 0.0);
            CHECK(ff.F(1, 0) == 0.0);
        }
    }
    SUBCASE("a blocker removes exactly F(dA -> blocker) when its shadow lies inside") {
        const double h = 5e-4;  // tiny sender: finite-size effects O(h²)
        const Polygon sender = quad(Vec3(-h, -h, 0), Vec3(h, -h, 0), Vec3(h, h, 0), Vec3(-h, h, 0));
        const Polygon receiver =
            quad(Vec3(-1, 1, 2), Vec3(1, 1, 2), Vec3(1, -1, 2), Vec3(-1, -1, 2));
        const Polygon blocker =
            quad(Vec3(-0.3, -0.2, 1), Vec3(0.3, -0.2, 1), Vec3(0.3, 0.4, 1), Vec3(-0.3, 0.4, 1));
        const Scene s = scene_of({sender, receiver}, {blocker});
        const Vec3 o(0, 0, 0), n(0, 0, 1);
        // The blocker's front faces away from the sender; F(dA → blocker) counts its back.
        Polygon blocker_back = blocker;
        std::reverse(blocker_back.vertices.begin(), blocker_back.vertices.end());
        const double exact = point_ff(o, n, receiver) - point_ff(o, n, blocker_back);
        for (const std::string& method : kMethods) {
            for (const std::string sampler : {"sobol", "random"}) {
                CAPTURE(method);
                CAPTURE(sampler);
                const FormFactors ff = run(method, s, 16384, 9, sampler);
                const double se = (*ff.standard_error)(0, 1);
                CAPTURE(ff.F(0, 1));
                CAPTURE(exact);
                CHECK(std::abs(ff.F(0, 1) - exact) <= k_sigma(sampler) * se);
                CHECK(se < 0.01);
            }
        }
    }
}

TEST_CASE("mc: splitting a receiver into pieces adds up") {
    const Polygon floor = quad(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0));
    const Polygon whole = quad(Vec3(0, 1, 1), Vec3(1, 1, 1), Vec3(1, 0, 1), Vec3(0, 0, 1));
    const Polygon left = quad(Vec3(0, 1, 1), Vec3(0.3, 1, 1), Vec3(0.3, 0, 1), Vec3(0, 0, 1));
    const Polygon right = quad(Vec3(0.3, 1, 1), Vec3(1, 1, 1), Vec3(1, 0, 1), Vec3(0.3, 0, 1));
    const Polygon blocker =
        quad(Vec3(0.2, 0.2, 0.5), Vec3(0.6, 0.2, 0.5), Vec3(0.6, 0.5, 0.5), Vec3(0.2, 0.5, 0.5));
    const Scene a = scene_of({floor, whole}, {blocker});
    const Scene b = scene_of({floor, left, right}, {blocker});
    // mc-hemisphere: row 0 casts the same rays in both scenes, so the counts split exactly.
    const FormFactors ha = run("mc-hemisphere", a, 5000, 4);
    const FormFactors hb = run("mc-hemisphere", b, 5000, 4);
    CHECK(ha.F(0, 1) == doctest::Approx(hb.F(0, 1) + hb.F(0, 2)).epsilon(1e-15));
    // mc-area: independent estimates, equal within their errors.
    const FormFactors aa = run("mc-area", a, 8192, 4);
    const FormFactors ab = run("mc-area", b, 8192, 4);
    const double se = std::sqrt(std::pow((*aa.standard_error)(0, 1), 2) +
                                std::pow((*ab.standard_error)(0, 1), 2) +
                                std::pow((*ab.standard_error)(0, 2), 2));
    CHECK(std::abs(aa.F(0, 1) - ab.F(0, 1) - ab.F(0, 2)) <= k_sigma("sobol") * se);
}

TEST_CASE("mc: bad options are reported") {
    const Scene s = testing::parallel_rects(1, 1, 1);
    MethodOptions o;
    CHECK_THROWS_AS(parse_sampler("qmc"), OptionError);
    o.samples = std::uint64_t(1) << 33;  // more than a stream holds
    nlohmann::json d;
    for (const std::string& method : kMethods)
        CHECK_THROWS_AS(run_method(*make_method(method), s, o, d), OptionError);
    CHECK_THROWS_AS(run_method(*make_method(kMethods[0]), Scene{}, MethodOptions{}, d),
                    GeometryError);
}
