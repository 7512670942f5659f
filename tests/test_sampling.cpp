#include <doctest/doctest.h>

#include <cmath>

#include "formfactor/core/error.h"
#include "formfactor/core/random.h"
#include "formfactor/geometry/sampling.h"
#include "formfactor/kernels/analytic.h"
#include "support/scenes.h"

using namespace formfactor;
using formfactor::testing::quad;

TEST_CASE("sampling: point sets are uniform and deterministic") {
    for (SamplerKind kind :
         {SamplerKind::sobol, SamplerKind::halton, SamplerKind::stratified, SamplerKind::random}) {
        CAPTURE(sampler_name(kind));
        const std::uint32_t n = 4096;
        PointSet4 set(kind, stream_key(7, 1, 2), n);
        PointSet4 same(kind, stream_key(7, 1, 2), n);
        double mean[4] = {}, prod = 0.0;
        for (std::uint32_t s = 0; s < n; ++s) {
            const auto u = set(s);
            CHECK(u == same(s));
            for (int d = 0; d < 4; ++d) {
                REQUIRE(u[static_cast<std::size_t>(d)] >= 0.0);
                REQUIRE(u[static_cast<std::size_t>(d)] < 1.0);
                mean[d] += u[static_cast<std::size_t>(d)] / n;
            }
            prod += u[0] * u[1] * u[2] * u[3] / n;
        }
        // i.i.d. standard errors: 1/sqrt(12 n) = 0.0045 for a mean; 4σ.
        for (double m : mean) CHECK(m == doctest::Approx(0.5).epsilon(0.018 / 0.5));
        CHECK(prod == doctest::Approx(1.0 / 16).epsilon(0.25));
    }
    CHECK_THROWS_AS(parse_sampler("qmc"), OptionError);
}

TEST_CASE("sampling: scrambled Sobol integrates a smooth function far better than random") {
    auto err = [](SamplerKind kind) {
        double rms = 0.0;
        for (int seed = 0; seed < 8; ++seed) {
            PointSet4 set(kind, stream_key(seed, 3, 4), 1024);
            double s = 0.0;
            for (std::uint32_t k = 0; k < 1024; ++k) {
                const auto u = set(k);
                s += u[0] * u[1] + std::sin(3 * u[2]) * u[3];
            }
            const double exact = 0.25 + 0.5 * (1 - std::cos(3.0)) / 3.0;
            rms += std::pow(s / 1024 - exact, 2) / 8;
        }
        return std::sqrt(rms);
    };
    CHECK(err(SamplerKind::sobol) < 0.1 * err(SamplerKind::random));
    CHECK(err(SamplerKind::halton) < 0.3 * err(SamplerKind::random));
    CHECK(err(SamplerKind::stratified) < 0.5 * err(SamplerKind::random));
}

TEST_CASE("sampling: uniform points on polygons stay inside and are area-uniform") {
    const Polygon ell{
        {Vec3(0, 0, 0), Vec3(2, 0, 0), Vec3(2, 1, 0), Vec3(1, 1, 0), Vec3(1, 2, 0), Vec3(0, 2, 0)}};
    PolygonSampler s(ell);
    PointSet4 set(SamplerKind::random, 11, 30000);
    int in_corner = 0;
    for (std::uint32_t k = 0; k < 30000; ++k) {
        const auto u = set(k);
        const Vec3 p = s(u[0], u[1]);
        REQUIRE(p.z() == 0.0);
        REQUIRE(!(p.x() > 1 && p.y() > 1));
        if (p.x() < 1 && p.y() < 1) ++in_corner;
    }
    // The unit square is 1/3 of the L: binomial σ = sqrt(2/9/30000) = 0.0027.
    CHECK(in_corner / 30000.0 == doctest::Approx(1.0 / 3).epsilon(0.011 / (1.0 / 3)));
}

namespace {

// Fraction of projected-solid-angle samples towards `target` from (x, n) that land in `part`
// (a sub-polygon of target, same plane), against F(part)/F(target).
// With `rejection`, directions come from sample(u, v, rng), by rejection from the proposal
// polygon (which set_origin() must have prepared), else from the inverse map sample(u, v).
void check_distribution(const Vec3& x, const Vec3& n, const Polygon& target, const Polygon& part,
                        double expected_f = -1, bool rejection = false) {
    ProjectedPolygonSampler whole(target), sub(part);
    const double F = whole.set_origin(x, n);
    const double Fp = sub.set_origin(x, n);
    if (rejection) CHECK(whole.uses_rejection());
    if (expected_f >= 0) CHECK(F == doctest::Approx(expected_f).epsilon(1e-12));
    REQUIRE(F > 0);
    const Vec3 nt = normal(target);
    const Vec3 p0 = target[0];
    const std::uint32_t N = 40000;
    PointSet4 set(SamplerKind::random, 99, N);
    int hits = 0;
    for (std::uint32_t k = 0; k < N; ++k) {
        const auto u = set(k);
        std::uint64_t rng = k;
        const Vec3 d = rejection ? whole.sample(u[0], u[1], rng) : whole.sample(u[0], u[1]);
        REQUIRE(std::abs(d.norm() - 1) < 1e-12);
        REQUIRE(d.dot(n) >= 0);
        const double t = nt.dot(p0 - x) / nt.dot(d);
        REQUIRE(t > 0);
        const Vec3 y = x + t * d;
        // Inside the part? (parts used here are axis-aligned rectangles)
        const Bounds3 b = bounds(part);
        const double tol = 1e-9;
        if ((y.array() >= b.lo.array() - tol).all() && (y.array() <= b.hi.array() + tol).all())
            ++hits;
    }
    const double p = Fp / F;
    const double sigma = std::sqrt(p * (1 - p) / N);
    CHECK(std::abs(hits / double(N) - p) < 4 * sigma + 1e-12);
}

}  // namespace

TEST_CASE("sampling: projected-solid-angle sampler gives the Lambert form factor") {
    // Catalog B-3 (a = b = c = 1): dA at the origin, normal +z, to a corner-aligned square.
    const Polygon sq = quad(Vec3(0, 1, 1), Vec3(1, 1, 1), Vec3(1, 0, 1), Vec3(0, 0, 1));
    ProjectedPolygonSampler s(sq);
    CHECK(s.set_origin(Vec3(0, 0, 0), Vec3(0, 0, 1)) ==
          doctest::Approx(0.13853160599489298).epsilon(1e-13));
    // B-4 (a = b = c = 1): perpendicular rectangle.
    const Polygon wall = quad(Vec3(0, 1, 0), Vec3(1, 1, 0), Vec3(1, 1, 1), Vec3(0, 1, 1));
    ProjectedPolygonSampler w(wall);
    CHECK(w.set_origin(Vec3(0, 0, 0), Vec3(0, 0, 1)) ==
          doctest::Approx(0.05573419700255351).epsilon(1e-13));
    // Seen from behind: nothing.
    CHECK(s.set_origin(Vec3(0, 0, 2), Vec3(0, 0, 1)) == 0.0);
}

TEST_CASE("sampling: projected-solid-angle samples are distributed by projected solid angle") {
    const Polygon sq = quad(Vec3(-1, 1, 1), Vec3(1, 1, 1), Vec3(1, -1, 1), Vec3(-1, -1, 1));
    const Polygon corner = quad(Vec3(0, 0.5, 1), Vec3(1, 0.5, 1), Vec3(1, -1, 1), Vec3(0, -1, 1));
    SUBCASE("zenith inside the target (sector fan)") {
        check_distribution(Vec3(0.1, 0.2, 0), Vec3(0, 0, 1), sq, corner);
    }
    SUBCASE("zenith outside the target (wedges)") {
        check_distribution(Vec3(3, 0.5, 0.2), Vec3(0, 0, 1), sq, corner);
        check_distribution(Vec3(3, 0.5, 0.2), Vec3(-0.6, 0, 0.8), sq, corner);
    }
    SUBCASE("zenith outside the target (rejection from the proposal polygon)") {
        check_distribution(Vec3(2, 0.5, 0.2), Vec3(0, 0, 1), sq, corner, -1, true);
        check_distribution(Vec3(2, 0.5, 0.2), Vec3(-0.6, 0, 0.8), sq, corner, -1, true);
        check_distribution(Vec3(3, 2, -2), Vec3(0, 0, 1), sq, corner, -1, true);
        check_distribution(Vec3(1.2, 0, 0.5), Vec3(0, 0, 1), sq, corner, -1, true);
    }
    SUBCASE("target clipped by the sender's plane") {
        const Polygon wall = quad(Vec3(0, 1, -1), Vec3(2, 1, -1), Vec3(2, 1, 1), Vec3(0, 1, 1));
        const Polygon top = quad(Vec3(0, 1, 0.5), Vec3(1, 1, 0.5), Vec3(1, 1, 1), Vec3(0, 1, 1));
        check_distribution(Vec3(0.3, 0, 0), Vec3(0, 0, 1), wall, top);
    }
    SUBCASE("non-convex target") {
        const Polygon ell{{Vec3(0, 0, 1), Vec3(0, 2, 1), Vec3(1, 2, 1), Vec3(1, 1, 1),
                           Vec3(2, 1, 1), Vec3(2, 0, 1)}};
        const Polygon part = quad(Vec3(0, 1, 1), Vec3(0, 2, 1), Vec3(1, 2, 1), Vec3(1, 1, 1));
        check_distribution(Vec3(0.5, 0.5, 0), Vec3(0, 0, 1), ell, part);
        check_distribution(Vec3(-1, 3, 0.3), Vec3(0, 0, 1), ell, part);
    }
}

TEST_CASE("sampling: the rejection sampler is used where it pays, with Lambert's weight") {
    // A square seen from the side (zenith outside, one convex piece): set_origin() prepares
    // the rejection sampler (acceptance ≥ 1/2) and returns Lambert's form factor, and the
    // directions of sample(u, v, rng) hit the target. Low over its plane, the projected region
    // is a thin curved band that polygons bound poorly: the inverse map is kept there.
    const Polygon sq = quad(Vec3(-1, 1, 1), Vec3(1, 1, 1), Vec3(1, -1, 1), Vec3(-1, -1, 1));
    {
        ProjectedPolygonSampler low(sq);
        CHECK(low.set_origin(Vec3(9, -4, 0.5), Vec3(0, 0, 1)) > 0);
        CHECK(!low.uses_rejection());
    }
    int rejecting = 0;
    for (const Vec3& x : {Vec3(2, 0.5, 0.2), Vec3(3, 2, -2), Vec3(4, -3, -3)}) {
        ProjectedPolygonSampler s(sq);
        const Vec3 n(0, 0, 1);
        const double F = s.set_origin(x, n);
        CHECK(F == doctest::Approx(point_to_polygon(x, n, sq)).epsilon(1e-13));
        std::uint64_t rng = 7;
        for (int k = 0; k < 1000; ++k) {
            const Vec3 d = s.sample((k + 0.5) / 1000, std::fmod(k * 0.618034, 1.0), rng);
            REQUIRE(std::abs(d.norm() - 1) < 1e-12);
            const double t = (1 - x.z()) / d.z();
            REQUIRE(t > 0);
            const Vec3 y = x + t * d;
            CHECK(std::abs(y.x()) <= 1 + 1e-9);
            CHECK(std::abs(y.y()) <= 1 + 1e-9);
        }
        if (s.uses_rejection()) ++rejecting;
    }
    CHECK(rejecting == 3);
}

TEST_CASE("sampling: PointSet4::generate equals operator() bit for bit") {
    for (const SamplerKind kind :
         {SamplerKind::sobol, SamplerKind::halton, SamplerKind::stratified, SamplerKind::random}) {
        for (const std::uint32_t n : {1u, 7u, 625u, 5000u}) {
            const PointSet4 set(kind, stream_key(3, 5, 8, 1), n);
            for (const std::uint32_t first : {0u, 1u, 255u, n / 3}) {
                if (first >= n) continue;
                const std::uint32_t count = std::min<std::uint32_t>(n - first, 700);
                std::vector<double> u[4];
                for (auto& v : u) v.assign(count, -1.0);
                double* const out[4] = {u[0].data(), u[1].data(), u[2].data(), u[3].data()};
                set.generate(first, count, out);
                bool same = true;
                for (std::uint32_t k = 0; k < count; ++k) {
                    const auto p = set(first + k);
                    for (int d = 0; d < 4; ++d)
                        same = same && p[static_cast<std::size_t>(d)] == u[d][k];
                }
                // A null output skips its coordinate; the others are unchanged.
                std::vector<double> w(count, -1.0);
                double* const only2[4] = {nullptr, nullptr, w.data(), nullptr};
                set.generate(first, count, only2);
                for (std::uint32_t k = 0; k < count; ++k) same = same && w[k] == u[2][k];
                CAPTURE(sampler_name(kind));
                CAPTURE(n);
                CAPTURE(first);
                CHECK(same);
            }
        }
    }
}

TEST_CASE("sampling: cosine_direction is the concentric map lifted to the hemisphere") {
    // Reference: Shirley–Chiu with library sine and cosine. The inline polynomials must agree to
    // their truncation error (< 1e-11) and give unit vectors in the upper hemisphere.
    const PointSet4 set(SamplerKind::random, 5, 20000);
    double worst = 0, worst_len = 0;
    for (std::uint32_t k = 0; k < 20000; ++k) {
        const auto u = set(k);
        const double a = 2 * u[0] - 1, b = 2 * u[1] - 1;
        double r, phi;
        if (std::abs(a) > std::abs(b)) {
            r = a;
            phi = 0.25 * kPi * (b / a);
        } else {
            r = b;
            phi = b != 0 ? 0.5 * kPi - 0.25 * kPi * (a / b) : 0.0;
        }
        const double x = r * std::cos(phi), y = r * std::sin(phi);
        const Vec3 ref(x, y, std::sqrt(std::max(0.0, 1 - x * x - y * y)));
        const Vec3 d = cosine_direction(u[0], u[1]);
        CHECK(d.z() >= 0);
        worst = std::max(worst, (d - ref).head<2>().norm());
        worst_len = std::max(worst_len, std::abs(d.norm() - 1));
    }
    CHECK(worst < 1e-11);
    CHECK(worst_len < 1e-11);
}
