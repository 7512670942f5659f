// The analytic module against an independent route (point_to_polygon integrated numerically
// over the emitter by adaptive triangle refinement), and its properties: zero cases,
// reciprocity, invariance, additivity, the far-field bound, and the Method.

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <random>
#include <vector>

#include "core/fast_atan.h"
#include "formfactor/core/error.h"
#include "formfactor/kernels/analytic.h"
#include "formfactor/methods/method.h"
#include "formfactor/scene/scene.h"
#include "kernels/analytic_internal.h"
#include "kernels/unobstructed.h"
#include "methods/analytic/analytic_method.h"
#include "support/method_runner.h"
#include "support/scenes.h"

using formfactor::testing::run_method;

using namespace formfactor;

namespace {

Polygon quad(const Vec3& o, const Vec3& u, const Vec3& v) { return {{o, o + u, o + u + v, o + v}}; }

Polygon reversed(Polygon p) {
    std::reverse(p.vertices.begin(), p.vertices.end());
    return p;
}

// Adaptive Gauss–Kronrod (7/15) on [lo, hi], recursive bisection to an absolute tolerance.
double gk15(const std::function<double(double)>& f, double lo, double hi, double& err) {
    static const double xk[8] = {
        0.991455371120812639, 0.949107912342758525, 0.864864423359769073, 0.741531185599394440,
        0.586087235467691130, 0.405845151377397167, 0.207784955007898468, 0.0};
    static const double wk[8] = {0.022935322010529225, 0.063092092629978553, 0.104790010322250184,
                                 0.140653259715525919, 0.169004726639267903, 0.190350578064785410,
                                 0.204432940075298892, 0.209482141084727828};
    static const double wg[4] = {0.129484966168869693, 0.279705391489276668, 0.381830050505118945,
                                 0.417959183673469388};
    const double c = 0.5 * (lo + hi), h = 0.5 * (hi - lo);
    const double fc = f(c);
    double k = wk[7] * fc, g = wg[3] * fc;
    for (int j = 0; j < 7; ++j) {
        const double s = f(c - h * xk[j]) + f(c + h * xk[j]);
        k += wk[j] * s;
        if (j % 2 == 1) g += wg[j / 2] * s;
    }
    err = std::abs(k - g) * h;
    return k * h;
}

double adaptive(const std::function<double(double)>& f, double lo, double hi, double tol,
                int depth = 0) {
    double err = 0.0;
    const double v = gk15(f, lo, hi, err);
    if (err <= tol || depth >= 40 || hi - lo <= 1e-15 * (std::abs(lo) + std::abs(hi))) return v;
    const double mid = 0.5 * (lo + hi);
    return adaptive(f, lo, mid, 0.5 * tol, depth + 1) + adaptive(f, mid, hi, 0.5 * tol, depth + 1);
}

// ∫ over triangle (p0, p1, p2) as an iterated integral along an edge and across it.
double triangle_integral(const std::function<double(const Vec3&)>& f, const Vec3& p0,
                         const Vec3& p1, const Vec3& p2, double tol) {
    // x(s, t) = p0 + s (p1 − p0) + t s (p2 − p1), s, t ∈ [0, 1], dA = 2|T| s ds dt.
    const double two_area = (p1 - p0).cross(p2 - p1).norm();
    auto outer = [&](double s) {
        auto inner = [&](double t) { return f(p0 + s * (p1 - p0) + t * s * (p2 - p1)); };
        return s * adaptive(inner, 0.0, 1.0, tol / two_area);
    };
    return two_area * adaptive(outer, 0.0, 1.0, tol / two_area);
}

// The independent route: F_ab = 1/A_a ∫_a F_{dA→b}(x) dA over the part of a in front of b
// (the integrand vanishes behind b; clipping puts that kink on the boundary).
double numeric_form_factor(const Polygon& a, const Polygon& b, double tol = 1e-12) {
    const Vec3 n = normal(a);
    auto f = [&](const Vec3& x) { return point_to_polygon(x, n, b); };
    const Polygon ac = clip_to_front(a, plane_of(b));
    double s = 0.0;
    const double A = area(a);
    // Distance of a point from b's boundary: the integrand is singular only there.
    auto from_b = [&](const Vec3& x) {
        double d = std::numeric_limits<double>::infinity();
        for (std::size_t k = 0; k < b.size(); ++k) {
            const Vec3 e = b[(k + 1) % b.size()] - b[k];
            const double t = std::clamp((x - b[k]).dot(e) / e.squaredNorm(), 0.0, 1.0);
            d = std::min(d, (x - b[k] - t * e).norm());
        }
        return d;
    };
    for (const auto& t : triangulate(ac)) {
        Vec3 p[3] = {ac[static_cast<std::size_t>(t[0])], ac[static_cast<std::size_t>(t[1])],
                     ac[static_cast<std::size_t>(t[2])]};
        // The collapsed parametrisation handles a singular edge opposite p0 best (the inner
        // integrals stay smooth): put the edge nearest to b's boundary there.
        int best = 0;
        double far = std::numeric_limits<double>::infinity();
        for (int r = 0; r < 3; ++r) {
            const double d = from_b(0.5 * (p[(r + 1) % 3] + p[(r + 2) % 3]));
            if (d < far) {
                far = d;
                best = r;
            }
        }
        s += triangle_integral(f, p[best], p[(best + 1) % 3], p[(best + 2) % 3], tol * A);
    }
    return s / A;
}

Polygon transform(const Polygon& p, const Mat3& R, const Vec3& t, double s) {
    Polygon q;
    for (const Vec3& v : p.vertices) q.vertices.push_back(s * (R * v) + t);
    return q;
}

struct Config {
    const char* name;
    Polygon a, b;
    // Whether the numeric route is quick (< 0.1 s) for F_ab and F_ba; the slow directions run
    // in the "slow" test suite only.
    bool quick_ab = true, quick_ba = true;
};

std::vector<Config> configurations() {
    std::vector<Config> c;
    const double s60 = std::sqrt(3.0) / 2.0;
    c.push_back({"general position triangles",
                 Polygon{{Vec3(0, 0, 0), Vec3(1, 0.2, 0.1), Vec3(0.3, 0.9, -0.2)}},
                 Polygon{{Vec3(0.2, 0.1, 1.3), Vec3(0.4, 1.1, 0.9), Vec3(1.2, 0.3, 1.1)}}});
    // Quads sharing the vertex (0, 0, 0), the second tilted 60° about the x axis and rotated.
    c.push_back({"quads sharing a vertex", quad(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)),
                 quad(Vec3(0, 0, 0), Vec3(-0.6, 0.3, 0), Vec3(0, 0.5 * 0.7, s60 * 0.7)), false,
                 true});
    // Touching along part of an edge: b hinged on y = 0 for x in [0.4, 1.7], at 120° to a.
    c.push_back({"touching along part of an edge",
                 quad(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)),
                 quad(Vec3(0.4, 0, 0), Vec3(0, 0.5, s60), Vec3(1.3, 0, 0))});
    c.push_back({"shared edge at 60 degrees", quad(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)),
                 quad(Vec3(0, 0, 0), Vec3(0, 0.5, s60), Vec3(1, 0, 0)), true, false});
    c.push_back({"perpendicular with offset", quad(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)),
                 quad(Vec3(0.3, 1.2, 0.2), Vec3(1.1, 0, 0), Vec3(0, 0, 0.8))});
    // Crossing planes: b pierces a's plane (half of it is behind a) and a is half behind b.
    c.push_back({"crossing planes", quad(Vec3(-1, -1, 0), Vec3(2, 0, 0), Vec3(0, 2, 0)),
                 quad(Vec3(-0.7, 0.6, -0.5), Vec3(0, -0.3, 1.4), Vec3(1.5, 0, 0)), false, true});
    c.push_back({"L-shaped emitter and receiver",
                 Polygon{{Vec3(0, 0, 0), Vec3(2, 0, 0), Vec3(2, 1, 0), Vec3(1, 1, 0), Vec3(1, 2, 0),
                          Vec3(0, 2, 0)}},
                 Polygon{{Vec3(0.5, 0, 1), Vec3(0.5, 2, 1), Vec3(1.5, 2, 1), Vec3(1.5, 1.2, 1),
                          Vec3(2.5, 1.2, 1), Vec3(2.5, 0, 1)}}});
    c.push_back({"thin sliver", Polygon{{Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0.5, 1e-3, 0)}},
                 quad(Vec3(0, 0.2, 0.5), Vec3(0, 1, 0), Vec3(1, 0, 0))});
    c.push_back({"tiny versus huge", quad(Vec3(0.2, 0.3, 0.5), Vec3(1e-3, 0, 0), Vec3(0, 1e-3, 0)),
                 reversed(quad(Vec3(-20, -20, 1.5), Vec3(40, 0, 0), Vec3(0, 40, 0)))});
    c.push_back({"far apart", quad(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)),
                 reversed(quad(Vec3(3, 5, 40), Vec3(1, 0, 0.2), Vec3(0, 1.3, 0)))});
    return c;
}

Mat3 rotation(double a, double b, double c) {
    return (Eigen::AngleAxisd(a, Vec3::UnitZ()) * Eigen::AngleAxisd(b, Vec3::UnitY()) *
            Eigen::AngleAxisd(c, Vec3::UnitX()))
        .toRotationMatrix();
}

}  // namespace

TEST_CASE("analytic: Gauss rules integrate polynomials exactly") {
    const Polygon tri{{Vec3(0.1, 0, 0), Vec3(1.3, 0.2, 0), Vec3(0.4, 0.9, 0)}};
    const Polygon par = quad(Vec3(0, 0, 0), Vec3(1, 0.3, 0), Vec3(-0.2, 0.8, 0));
    for (int n = 1; n <= 6; ++n) {
        for (const Polygon* p : {&tri, &par}) {
            const PolygonRule r = polygon_rule(*p, n);
            const PolygonRule ref = polygon_rule(*p, 12);
            // x^i y^k with i + k ≤ 2n − 1.
            for (int i = 0; i <= 2 * n - 1; ++i) {
                const int k = 2 * n - 1 - i;
                auto mono = [&](const Vec3& x) { return std::pow(x.x(), i) * std::pow(x.y(), k); };
                double s = 0.0, s_ref = 0.0;
                for (std::size_t m = 0; m < r.points.size(); ++m)
                    s += r.weights[m] * mono(r.points[m]);
                for (std::size_t m = 0; m < ref.points.size(); ++m)
                    s_ref += ref.weights[m] * mono(ref.points[m]);
                CHECK(std::abs(s - s_ref) <= 1e-14);
            }
        }
    }
}

void check_against_numeric(bool slow) {
    for (const Config& c : configurations()) {
        CAPTURE(std::string(c.name));
        const double fab = polygon_to_polygon(c.a, c.b), fba = polygon_to_polygon(c.b, c.a);
        CHECK(fab > 0.0);
        CHECK(fba > 0.0);
        if (c.quick_ab != slow) {
            const double numeric = numeric_form_factor(c.a, c.b);
            CAPTURE(fab);
            CAPTURE(numeric);
            CHECK(std::abs(fab - numeric) <= 1e-10);
        }
        if (c.quick_ba != slow) {
            const double numeric = numeric_form_factor(c.b, c.a);
            CAPTURE(fba);
            CAPTURE(numeric);
            CHECK(std::abs(fba - numeric) <= 1e-10);
        }
    }
}

TEST_CASE("analytic: polygon_to_polygon agrees with integrating point_to_polygon") {
    check_against_numeric(false);
}

TEST_CASE("analytic: polygon_to_polygon agrees with the numeric route (slow directions)" *
          doctest::test_suite("slow")) {
    check_against_numeric(true);
}

TEST_CASE("analytic: coplanar and facing-away pairs give zero") {
    const Polygon a = quad(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0));
    CHECK(polygon_to_polygon(a, quad(Vec3(1, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0))) == 0.0);
    CHECK(polygon_to_polygon(a, quad(Vec3(3, 2, 0), Vec3(1, 0, 0), Vec3(0, 1, 0))) == 0.0);
    // b above a but facing up (away from a).
    CHECK(polygon_to_polygon(a, quad(Vec3(0, 0, 1), Vec3(1, 0, 0), Vec3(0, 1, 0))) == 0.0);
    // b below a, facing a's back.
    CHECK(polygon_to_polygon(a, reversed(quad(Vec3(0, 0, -1), Vec3(1, 0, 0), Vec3(0, 1, 0)))) ==
          0.0);
    // b in front of a but a behind b.
    CHECK(polygon_to_polygon(a, quad(Vec3(0, 0, 1), Vec3(0, 1, 0), Vec3(1, 0, 0))) > 0.0);
    CHECK(point_to_polygon(Vec3(0.5, 0.5, 0), Vec3(0, 0, 1), a) == 0.0);
    CHECK(point_to_polygon(Vec3(0.5, 0.5, -1), Vec3(0, 0, 1), a) == 0.0);
    CHECK(point_to_polygon(Vec3(0.5, 0.5, 1), Vec3(0, 0, 1), a) == 0.0);
}

TEST_CASE("analytic: reciprocity, invariance under rigid motion and scale") {
    const Mat3 R = rotation(0.7, -0.4, 1.9);
    for (const Config& c : configurations()) {
        CAPTURE(std::string(c.name));
        const double fab = polygon_to_polygon(c.a, c.b), fba = polygon_to_polygon(c.b, c.a);
        const double ga = area(c.a) * fab, gb = area(c.b) * fba;
        CHECK(std::abs(ga - gb) <= 1e-12 * std::max(ga, gb));
        for (double s : {1.0, 1e-3, 250.0}) {
            // The shift scales too: coordinates keep their relative precision (a shift of 14
            // on a 1e-3 sliver would move its vertices by ~1e-12 of its width... and change F).
            const Vec3 t = s * Vec3(12.5, -3.0, 7.25);
            const double moved =
                polygon_to_polygon(transform(c.a, R, t, s), transform(c.b, R, t, s));
            CAPTURE(s);
            CHECK(std::abs(moved - fab) <= 1e-12);
        }
    }
}

TEST_CASE("analytic: additivity under subdivision of the receiver and the sender") {
    // a and b at 70°, sharing the edge on the x axis; b split into b1 ∪ b2, a into a1 ∪ a2.
    const double t = 70.0 * kPi / 180.0;
    const Vec3 up(0, -0.4 * std::cos(t), 0.4 * std::sin(t));
    const Polygon a = quad(Vec3(0, 0, 0), Vec3(0, -0.8, 0), Vec3(1, 0, 0));
    const Polygon a1 = quad(Vec3(0, 0, 0), Vec3(0, -0.8, 0), Vec3(0.35, 0, 0));
    const Polygon a2 = quad(Vec3(0.35, 0, 0), Vec3(0, -0.8, 0), Vec3(0.65, 0, 0));
    const Polygon b = quad(Vec3(0, 0, 0), Vec3(1, 0, 0), up);
    const Polygon b1 = quad(Vec3(0, 0, 0), Vec3(0.6, 0, 0), up);
    const Polygon b2 = quad(Vec3(0.6, 0, 0), Vec3(0.4, 0, 0), up);
    const double f = polygon_to_polygon(a, b);
    CHECK(f > 0.01);
    CHECK(std::abs(f - polygon_to_polygon(a, b1) - polygon_to_polygon(a, b2)) <= 1e-12);
    const double sender =
        (area(a1) * polygon_to_polygon(a1, b) + area(a2) * polygon_to_polygon(a2, b)) / area(a);
    CHECK(std::abs(f - sender) <= 1e-12);
}

TEST_CASE("analytic: the far-field rule stays within its error bound") {
    std::mt19937_64 rng(2024);
    std::uniform_real_distribution<double> U(0.0, 1.0);
    std::normal_distribution<double> G;
    auto dir = [&] { return Vec3(G(rng), G(rng), G(rng)).normalized(); };
    auto shape = [&](bool tri) {
        Polygon p;
        if (tri) {
            do {
                p.vertices = {Vec3(U(rng), U(rng), 0), Vec3(U(rng), U(rng), 0),
                              Vec3(U(rng), U(rng), 0)};
                if (normal(p).z() < 0) std::swap(p[1], p[2]);
            } while (area(p) < 0.02);
        } else {
            p = quad(Vec3(0, 0, 0), Vec3(0.5 + U(rng), 0, 0), Vec3(U(rng) - 0.5, 0.5 + U(rng), 0));
        }
        return p;
    };
    auto place = [](const Polygon& p, const Vec3& n, const Vec3& c) {
        Vec3 u, v;
        orthonormal_basis(n, u, v);
        const Vec3 c0 = centroid(p);
        Polygon q;
        for (const Vec3& x : p.vertices)
            q.vertices.push_back(c + (x - c0).x() * u + (x - c0).y() * v);
        return q;
    };
    const double tol = 1e-10;
    int tested = 0;
    for (double rho : {0.1, 0.3, 0.5, 0.7, 0.85}) {
        for (int s = 0; s < 150; ++s) {
            const Polygon a = place(shape(s % 2 == 0), dir(), Vec3::Zero());
            const Polygon b0 = shape(s % 3 == 0);
            FarFieldPair pr;
            const Vec3 ca = centroid(a), cb = centroid(b0);
            for (const Vec3& x : a.vertices) pr.radius_a = std::max(pr.radius_a, (x - ca).norm());
            for (const Vec3& x : b0.vertices) pr.radius_b = std::max(pr.radius_b, (x - cb).norm());
            pr.distance = (pr.radius_a + pr.radius_b) / rho;
            Vec3 d = dir();
            if (d.dot(normal(a)) < 0) d = -d;
            Vec3 nb = dir();
            if (nb.dot(d) > 0) nb = -nb;
            const Polygon b = place(b0, nb, ca + pr.distance * d);
            bool front = true;
            for (const Vec3& x : b.vertices) front = front && plane_of(a).signed_distance(x) >= 0;
            for (const Vec3& x : a.vertices) front = front && plane_of(b).signed_distance(x) >= 0;
            if (!front) continue;
            pr.area_a = area(a);
            pr.area_b = area(b);
            const double exact = detail::polygon_to_polygon_contour(a, b, false);
            for (int n = 1; n <= kMaxFarFieldOrder; ++n) {
                // The reference (contour path) is itself exact to ~1e-14 here: hence the 5e-14.
                const double bound = far_field_error_bound(pr, n, n);
                if (!(bound <= tol)) continue;
                const double q = polygon_to_polygon_quadrature(a, b, n, n);
                CAPTURE(rho);
                CAPTURE(n);
                CHECK(std::abs(q - exact) <= bound + 5e-14);
                CHECK(std::abs(q - exact) * area(a) / area(b) <= bound + 5e-14);
                ++tested;
            }
        }
    }
    CHECK(tested > 500);
}

TEST_CASE(
    "analytic: method on a subdivided cube closes rows, is reciprocal and thread-independent") {
    const Scene scene = testing::unit_cube(4);
    const auto method = make_method("analytic");
    CHECK(method->name() == "analytic");
    method->check(scene);
    MethodOptions opt;
    opt.tolerance = 1e-12;
    opt.threads = 1;
    nlohmann::json d1, d2;
    const FormFactors f1 = run_method(*method, scene, opt, d1);
    opt.threads = 2;
    const FormFactors f2 = run_method(*method, scene, opt, d2);
    const std::size_t n = scene.patches.size();
    REQUIRE(f1.size() == n);
    CHECK(f1.F == f2.F);
    CHECK(d1["pairs"] == n * (n - 1) / 2);
    CHECK(d1["pairs_far_field"].get<std::size_t>() > 0);
    CHECK(d1["pairs_exact"].get<std::size_t>() > 0);
    for (std::size_t i = 0; i < n; ++i) {
        const auto ii = static_cast<Eigen::Index>(i);
        CHECK(f1.F(ii, ii) == 0.0);
        CHECK(std::abs(f1.F.row(ii).sum() - 1.0) <= 1e-10);
        for (std::size_t j = 0; j < n; ++j) {
            const auto jj = static_cast<Eigen::Index>(j);
            CHECK(f1.F(ii, jj) >= 0.0);
            CHECK(std::abs(f1.areas[i] * f1.F(ii, jj) - f1.areas[j] * f1.F(jj, ii)) <=
                  1e-15 * f1.areas[i]);
        }
    }
    // Against the exact path on a few entries.
    for (std::size_t k = 0; k < n; k += 7) {
        const std::size_t j = (k * 31 + 5) % n;
        const double exact = polygon_to_polygon(scene.patches[k].polygon, scene.patches[j].polygon);
        CHECK(std::abs(f1.F(static_cast<Eigen::Index>(k), static_cast<Eigen::Index>(j)) - exact) <=
              1e-12);
    }
}

TEST_CASE("analytic: check() accepts scenes with obstructions, may_obstruct() finds them") {
    const auto method = make_method("analytic");
    Scene cube = testing::unit_cube(1);
    CHECK_NOTHROW(method->check(cube));
    // Two parallel plates facing each other.
    Scene plates;
    for (const Polygon& p : {quad(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)),
                             reversed(quad(Vec3(0, 0, 1), Vec3(1, 0, 0), Vec3(0, 1, 0)))}) {
        Surface s;
        s.name = "plate";
        s.polygon = p;
        plates.surfaces.push_back(s);
        plates.patches.push_back(
            formfactor::make_patch(p, static_cast<int>(plates.surfaces.size()) - 1));
    }
    CHECK_NOTHROW(method->check(plates));
    // An obstruction-only surface.
    Scene obst = plates;
    Surface o;
    o.name = "blocker";
    o.obstruction = true;
    o.polygon = quad(Vec3(0.2, 0.2, 0.5), Vec3(0.5, 0, 0), Vec3(0, 0.5, 0));
    obst.surfaces.push_back(o);
    CHECK_NOTHROW(method->check(obst));
    CHECK(may_obstruct(obst));
    CHECK_FALSE(may_obstruct(plates));
    CHECK_FALSE(may_obstruct(cube));
    // A box inside a room: the box's faces have room faces on both sides of their planes.
    Scene room = testing::unit_cube(1);
    const Vec3 lo(0.4, 0.4, 0.0), e(0.2, 0.2, 0.2);
    Surface top;
    top.name = "box top";
    top.polygon = quad(lo + Vec3(0, 0, e.z()), Vec3(e.x(), 0, 0), Vec3(0, e.y(), 0));
    room.surfaces.push_back(top);
    Surface side;
    side.name = "box side";
    side.polygon = quad(lo, Vec3(0, 0, e.z()), Vec3(0, -e.y(), 0));
    room.surfaces.push_back(side);
    CHECK_NOTHROW(method->check(room));
    CHECK(may_obstruct(room));
    MethodOptions bad;
    bad.tolerance = -1.0;
    nlohmann::json d;
    CHECK_THROWS_AS(run_method(*method, cube, bad, d), OptionError);
    CHECK(default_method(cube) == MethodKind::analytic);
    const std::vector<std::string> names = method_names();
    CHECK(std::find(names.begin(), names.end(), "analytic") != names.end());
}

TEST_CASE("fast atan: atan2_upper within 2 ulp of the library's atan2 on [0, π]") {
    // Lambert's formula and the projected-solid-angle sampler take every edge's angle from it:
    // its error is part of "exact". Arguments across every range reduction (tan(3π/8), 0.66),
    // both signs of x, and magnitudes from 1e-300 to 1e300.
    std::mt19937_64 rng(17);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    std::uniform_int_distribution<int> exponent(-20, 20);
    double worst = 0.0;
    for (int k = 0; k < 200000; ++k) {
        const double y = std::ldexp(unit(rng), exponent(rng));
        double x = std::ldexp(unit(rng), exponent(rng));
        if (k % 2) x = -x;
        const double ref = std::atan2(y, x), got = formfactor::detail::atan2_upper(y, x);
        worst = std::max(worst, std::abs(got - ref) / std::max(ref, 1e-300));
    }
    CHECK(worst <= 4.5e-16);
    CHECK(formfactor::detail::atan2_upper(0.0, 1.0) == 0.0);
    CHECK(formfactor::detail::atan2_upper(0.0, -1.0) == doctest::Approx(formfactor::kPi));
    CHECK(formfactor::detail::atan2_upper(1.0, 0.0) == doctest::Approx(0.5 * formfactor::kPi));
    CHECK(formfactor::detail::atan2_upper(1e-300, 1e300) == 0.0);
    CHECK(formfactor::detail::atan2_upper(1e300, 1e-300) == doctest::Approx(0.5 * formfactor::kPi));
}

TEST_CASE("analytic: the facing test leaves out exactly the pairs the kernels give 0") {
    // The sparse rows leave pairs that face away out of their pair lists by
    // detail::faces_away(); every path of kernels/unobstructed.h gives those pairs 0 by the same
    // test. city-2: ground tiles behind walls and roofs, walls back to back across a building,
    // coplanar tiles; plus pairs of the whole matrix that straddle or face each other.
    const Scene scene = load_scene("city-2");
    const std::size_t n = scene.patches.size();
    std::vector<const Polygon*> polys(n);
    for (std::size_t p = 0; p < n; ++p) polys[p] = &scene.patches[p].polygon;
    const auto table = detail::make_patch_table(polys, 1);
    detail::UnobstructedBlock whole;
    const detail::UnobstructedStats st =
        detail::unobstructed_rows(polys, 1e-10, 1, nullptr, RowRange{}, whole, false, table.get());
    const double eps = detail::facing_eps(polys);
    std::size_t away = 0, zero_facing = 0;
    for (std::size_t i = 0; i < n; ++i)
        for (std::size_t j = i + 1; j < n; ++j) {
            const bool a = detail::faces_away(*table, polys, i, j, eps);
            CHECK(a == detail::faces_away(*table, polys, j, i, eps));
            const auto I = static_cast<Eigen::Index>(i), J = static_cast<Eigen::Index>(j);
            if (a) {
                ++away;
                CHECK(whole.F(I, J) == 0.0);
                CHECK(whole.F(J, I) == 0.0);
            } else if (whole.F(I, J) == 0.0) {
                ++zero_facing;
            }
        }
    // The kernels count as zero the pairs this test finds, and only those.
    CHECK(away == st.zero);
    CHECK(away > n);
    CHECK(away + zero_facing < n * (n - 1) / 2);
}
