#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "formfactor/kernels/analytic.h"
#include "formfactor/methods/method.h"
#include "formfactor/pipeline.h"
#include "formfactor/scene/scene.h"
#include "support/method_runner.h"
#include "support/scenes.h"

using formfactor::testing::run_method;

using namespace formfactor;
using testing::quad;
using testing::scene_of;

namespace {

FormFactors run_target(const Scene& s, std::uint64_t samples, std::uint64_t seed = 1,
                       const std::string& sampler = "sobol", int threads = 0) {
    MethodOptions o;
    o.samples = samples;
    o.seed = seed;
    o.sampler = parse_sampler(sampler);
    o.threads = threads;
    nlohmann::json details;
    return run_method(*make_method("mc-target"), s, o, details);
}

double k_sigma(const std::string& sampler) { return sampler == "random" ? 4.0 : 5.0; }

// A tiny sender at the origin facing +z, a 2×2 receiver at z = 2 and an obstruction at z = 1
// whose shadow falls inside the receiver: F = F(dA→receiver) − F(dA→blocker's underside).
struct ShadowCase {
    Scene scene;
    double exact;
};
ShadowCase shadow_case() {
    const double h = 5e-4;
    const Polygon sender = quad(Vec3(-h, -h, 0), Vec3(h, -h, 0), Vec3(h, h, 0), Vec3(-h, h, 0));
    const Polygon receiver = quad(Vec3(-1, 1, 2), Vec3(1, 1, 2), Vec3(1, -1, 2), Vec3(-1, -1, 2));
    const Polygon blocker =
        quad(Vec3(-0.3, -0.2, 1), Vec3(0.3, -0.2, 1), Vec3(0.3, 0.4, 1), Vec3(-0.3, 0.4, 1));
    Polygon underside = blocker;
    std::reverse(underside.vertices.begin(), underside.vertices.end());
    const Vec3 o(0, 0, 0), n(0, 0, 1);
    return {scene_of({sender, receiver}, {blocker}),
            point_to_polygon(o, n, receiver) - point_to_polygon(o, n, underside)};
}

}  // namespace

TEST_CASE("mc-target: exact when nothing blocks") {
    const std::pair<Scene, double> cases[] = {
        {testing::parallel_rects(1, 1, 1), 0.19982489569838746},
        {testing::perpendicular_squares(), 0.20004377607540316},
        {testing::parallel_rects(2, 1, 1), 0.2858753848507147},
        {testing::parallel_rects(10, 10, 1), 0.8269945223972565},
        {testing::parallel_rects(0.2, 0.2, 1), 0.01240397731324307}};
    for (const auto& [scene, exact] : cases) {
        for (const char* sampler : {"sobol", "random"}) {
            const FormFactors ff = run_target(scene, 64, 1, sampler);
            CHECK(std::abs(ff.F(0, 1) - exact) < 1e-12);
            CHECK(std::abs(ff.F(1, 0) - exact) < 1e-12);
            CHECK((*ff.standard_error)(0, 1) == 0.0);
        }
    }
    // A closed cube (convex: nothing blocks): rows sum to 1 to rounding.
    const FormFactors cube = run_target(testing::unit_cube(2), 16);
    for (Eigen::Index i = 0; i < cube.F.rows(); ++i)
        CHECK(cube.F.row(i).sum() == doctest::Approx(1.0).epsilon(1e-12));
}

TEST_CASE("mc-target: a blocker removes exactly F(dA -> blocker)") {
    const ShadowCase c = shadow_case();
    for (const std::string sampler : {"sobol", "halton", "stratified", "random"}) {
        CAPTURE(sampler);
        const FormFactors ff = run_target(c.scene, 16384, 1, sampler);
        const double se = (*ff.standard_error)(0, 1);
        CAPTURE(ff.F(0, 1));
        CAPTURE(c.exact);
        CHECK(se > 0);
        CHECK(std::abs(ff.F(0, 1) - c.exact) <= k_sigma(sampler) * se);
    }
}

TEST_CASE("mc-target: the error falls like 1/sqrt(N) or faster") {
    const ShadowCase c = shadow_case();
    for (const std::string sampler : {"random", "sobol"}) {
        CAPTURE(sampler);
        std::vector<double> rms;
        for (std::uint64_t N : {256, 1024, 4096}) {
            double e2 = 0;
            for (std::uint64_t seed = 1; seed <= 32; ++seed)
                e2 += std::pow(run_target(c.scene, N, seed, sampler).F(0, 1) - c.exact, 2) / 32;
            rms.push_back(std::sqrt(e2));
        }
        MESSAGE("mc-target " << sampler << " rms " << rms[0] << " " << rms[1] << " " << rms[2]);
        CHECK(rms[0] / rms[1] > 1.6);
        CHECK(rms[1] / rms[2] > 1.6);
    }
}

TEST_CASE("mc-target: hidden receiver, additivity and thread independence") {
    const Polygon floor = quad(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0));
    const Polygon whole = quad(Vec3(0, 1, 1), Vec3(1, 1, 1), Vec3(1, 0, 1), Vec3(0, 0, 1));
    const Polygon left = quad(Vec3(0, 1, 1), Vec3(0.3, 1, 1), Vec3(0.3, 0, 1), Vec3(0, 0, 1));
    const Polygon right = quad(Vec3(0.3, 1, 1), Vec3(1, 1, 1), Vec3(1, 0, 1), Vec3(0.3, 0, 1));
    const Polygon small =
        quad(Vec3(0.2, 0.2, 0.5), Vec3(0.6, 0.2, 0.5), Vec3(0.6, 0.5, 0.5), Vec3(0.2, 0.5, 0.5));
    const Polygon big =
        quad(Vec3(-2, -2, 0.5), Vec3(3, -2, 0.5), Vec3(3, 3, 0.5), Vec3(-2, 3, 0.5));
    const FormFactors hidden = run_target(scene_of({floor, whole}, {big}), 1024);
    CHECK(hidden.F(0, 1) == 0.0);
    CHECK(hidden.F(1, 0) == 0.0);

    const FormFactors a = run_target(scene_of({floor, whole}, {small}), 8192, 4);
    const FormFactors b = run_target(scene_of({floor, left, right}, {small}), 8192, 4);
    const double se =
        std::sqrt(std::pow((*a.standard_error)(0, 1), 2) + std::pow((*b.standard_error)(0, 1), 2) +
                  std::pow((*b.standard_error)(0, 2), 2));
    CHECK(se > 0);
    CHECK(std::abs(a.F(0, 1) - b.F(0, 1) - b.F(0, 2)) <= k_sigma("sobol") * se);

    const Scene box = scene_of({floor, whole, left}, {small});
    const FormFactors t1 = run_target(box, 256, 42, "sobol", 1);
    const FormFactors t2 = run_target(box, 256, 42, "sobol", 2);
    CHECK(t1.F == t2.F);
    CHECK(*t1.standard_error == *t2.standard_error);
}

TEST_CASE("mc-target: pairs that nothing can block are settled without rays") {
    // The closed cube: every pair is clear (shaft test), so no ray is cast, F = F_unocc and the
    // standard errors are 0.
    Scene cube = load_scene("cube");
    subdivide(cube, SubdivisionOptions{3, 0.0});
    MethodOptions o;
    o.samples = 16;
    nlohmann::json d;
    const FormFactors ff = run_method(*make_method("mc-target"), cube, o, d);
    CHECK(d["rays_cast"].get<std::uint64_t>() == 0);
    CHECK(d["pairs_without_rays"] == d["pairs"]);
    CHECK(ff.standard_error->maxCoeff() == 0.0);
    for (Eigen::Index i = 0; i < ff.F.rows(); ++i)
        CHECK(ff.F.row(i).sum() == doctest::Approx(1.0).epsilon(1e-12));
    // A blocker inside the shaft: rays are cast for the pair, none settled by the shaft test.
    nlohmann::json d2;
    const ShadowCase c = shadow_case();
    run_method(*make_method("mc-target"), c.scene, o, d2);
    CHECK(d2["rays_cast"].get<std::uint64_t>() > 0);
    CHECK(d2["pairs_without_rays"].get<std::uint64_t>() == 0);
}

TEST_CASE("mc-target: a block of rows is the whole run's rows, without the whole matrix inside") {
    // The block takes its unobstructed values from the analytic method's row range and its
    // shaft culling for its own rows only; Cornell 2×2 per surface (80 patches, surfaces tested
    // whole first) split into uneven blocks gives the whole run's entries and standard errors
    // bit for bit.
    Scene scene = load_scene("cornell");
    SubdivisionOptions so;
    so.n = 2;
    subdivide(scene, so);
    const std::size_t n = scene.patches.size();
    ComputeOptions options;
    options.method = MethodKind::mc_target;
    options.method_options.samples = 256;
    const ComputeResult whole = compute_form_factors(scene, options);
    REQUIRE(whole.form_factors.standard_error);
    for (const RowRange rows : {RowRange{0, 13}, RowRange{13, 61}, RowRange{61, n}}) {
        CAPTURE(rows.begin);
        ComputeOptions o = options;
        o.rows = rows;
        const ComputeResult part = compute_form_factors(scene, o);
        const FormFactors& f = part.form_factors;
        REQUIRE(f.F.rows() == static_cast<Eigen::Index>(rows.size()));
        REQUIRE(f.standard_error);
        const auto b = static_cast<Eigen::Index>(rows.begin), m = f.F.rows();
        CHECK((f.F.array() == whole.form_factors.F.middleRows(b, m).array()).all());
        CHECK((f.standard_error->array() ==
               whole.form_factors.standard_error->middleRows(b, m).array())
                  .all());
        CHECK(part.report.details.at("pairs_without_rays").real() > 0);
    }
}
