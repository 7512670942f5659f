// Tests of obstructed form factors: the `analytic` method in scenes with blockers, and the
// point/polygon functions behind it, against exact values derived here.
//
// Reference values. Every configuration below is axis-aligned with parallel sender, receiver
// and blockers (or a vertical wall), so that seen from a sender point x the shadow of a blocker
// on the receiver's plane is a rectangle whose edges move affinely with x. The hidden part of the
// receiver is then a union of rectangles, and F(x → visible part) follows exactly from
// point_to_polygon() on rectangles by inclusion–exclusion. Integrated over the sender by tensor
// Gauss–Legendre rules (order 20) on the sub-rectangles between the sender positions where two
// of those edges coincide (where the integrand has kinks), the reference is exact to ~1e-14.

#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <functional>
#include <vector>

#include "formfactor/kernels/analytic.h"
#include "formfactor/methods/method.h"
#include "formfactor/methods/obstructed.h"
#include "formfactor/scene/room.h"
#include "formfactor/scene/scene.h"
#include "formfactor/scene/scene_io.h"
#include "kernels/analytic_internal.h"
#include "support/files.h"
#include "support/method_runner.h"
#include "support/scenes.h"

using formfactor::testing::run_method;

using namespace formfactor;

namespace {

struct Rect {
    double x0, x1, y0, y1;
};

// Axis-aligned rectangle at height z, facing +z (up) or −z.
Polygon rect(const Rect& r, double z, bool up) {
    Polygon p;
    p.vertices = {Vec3(r.x0, r.y0, z), Vec3(r.x1, r.y0, z), Vec3(r.x1, r.y1, z),
                  Vec3(r.x0, r.y1, z)};
    if (!up) std::reverse(p.vertices.begin(), p.vertices.end());
    return p;
}

// A horizontal blocker (either orientation blocks).
struct Plate {
    Rect r;
    double h;
};

// A vertical wall x = x0 from z = 0 to z = H, wide enough in y to cover every shadow.
struct Wall {
    double x0, H;
};

// The configuration: sender at z = 0 facing +z, receiver at z = c facing −z.
struct Config {
    Rect sender, receiver;
    double c = 1.0;
    std::vector<Plate> plates;
    std::vector<Wall> walls;

    std::vector<Polygon> blockers() const {
        std::vector<Polygon> out;
        for (const Plate& p : plates) out.push_back(rect(p.r, p.h, true));
        for (const Wall& w : walls) {
            Polygon q;
            q.vertices = {Vec3(w.x0, -50, 0), Vec3(w.x0, 50, 0), Vec3(w.x0, 50, w.H),
                          Vec3(w.x0, -50, w.H)};
            out.push_back(q);
        }
        return out;
    }
};

Rect intersect(const Rect& a, const Rect& b) {
    return {std::max(a.x0, b.x0), std::min(a.x1, b.x1), std::max(a.y0, b.y0), std::min(a.y1, b.y1)};
}

// F from (x, y, 0) facing +z to the rectangle r at height c (facing −z); 0 when empty.
double f_rect(double x, double y, const Rect& r, double c) {
    if (!(r.x1 > r.x0) || !(r.y1 > r.y0)) return 0.0;
    return point_to_polygon(Vec3(x, y, 0), Vec3::UnitZ(), rect(r, c, false));
}

// The exact obstructed F(x → receiver), by inclusion–exclusion over the shadows.
double f_visible(const Config& cf, double x, double y) {
    std::vector<Rect> shadows;
    for (const Plate& p : cf.plates) {
        const double k = cf.c / p.h;
        Rect s{x + (p.r.x0 - x) * k, x + (p.r.x1 - x) * k, y + (p.r.y0 - y) * k,
               y + (p.r.y1 - y) * k};
        shadows.push_back(s);
    }
    for (const Wall& w : cf.walls) {
        const double xt = x + (w.x0 - x) * cf.c / w.H;
        if (x < w.x0)
            shadows.push_back({xt, 1e9, -1e9, 1e9});
        else
            shadows.push_back({-1e9, xt, -1e9, 1e9});
    }
    double hidden = 0.0;
    const std::size_t n = shadows.size();
    for (std::size_t mask = 1; mask < (std::size_t{1} << n); ++mask) {
        Rect r = cf.receiver;
        int bits = 0;
        for (std::size_t k = 0; k < n; ++k)
            if (mask & (std::size_t{1} << k)) {
                r = intersect(r, shadows[k]);
                ++bits;
            }
        hidden += (bits % 2 == 1 ? 1.0 : -1.0) * f_rect(x, y, r, cf.c);
    }
    return f_rect(x, y, cf.receiver, cf.c) - hidden;
}

// Sender positions (in x or in y) where two shadow/receiver edges coincide.
std::vector<double> breakpoints(const Config& cf, bool in_x) {
    // Edge positions p(t) = alpha + beta t as functions of the sender coordinate t.
    std::vector<std::array<double, 2>> lines;
    lines.push_back({in_x ? cf.receiver.x0 : cf.receiver.y0, 0.0});
    lines.push_back({in_x ? cf.receiver.x1 : cf.receiver.y1, 0.0});
    for (const Plate& p : cf.plates) {
        const double k = cf.c / p.h;
        lines.push_back({k * (in_x ? p.r.x0 : p.r.y0), 1.0 - k});
        lines.push_back({k * (in_x ? p.r.x1 : p.r.y1), 1.0 - k});
    }
    std::vector<double> cuts;
    const double lo = in_x ? cf.sender.x0 : cf.sender.y0, hi = in_x ? cf.sender.x1 : cf.sender.y1;
    if (in_x)
        for (const Wall& w : cf.walls) {
            const double k = cf.c / w.H;
            lines.push_back({k * w.x0, 1.0 - k});
            cuts.push_back(w.x0);
        }
    for (std::size_t a = 0; a < lines.size(); ++a)
        for (std::size_t b = a + 1; b < lines.size(); ++b) {
            const double db = lines[a][1] - lines[b][1];
            if (db == 0.0) continue;
            cuts.push_back((lines[b][0] - lines[a][0]) / db);
        }
    std::vector<double> out = {lo, hi};
    for (double t : cuts)
        if (t > lo && t < hi) out.push_back(t);
    std::sort(out.begin(), out.end());
    return out;
}

// The exact obstructed F_sender→receiver.
double reference(const Config& cf) {
    const auto& g = detail::gauss_legendre01(20);
    const std::vector<double> cx = breakpoints(cf, true), cy = breakpoints(cf, false);
    double sum = 0.0;
    for (std::size_t a = 0; a + 1 < cx.size(); ++a)
        for (std::size_t b = 0; b + 1 < cy.size(); ++b) {
            const double dx = cx[a + 1] - cx[a], dy = cy[b + 1] - cy[b];
            for (std::size_t i = 0; i < g.x.size(); ++i)
                for (std::size_t j = 0; j < g.x.size(); ++j)
                    sum += g.w[i] * g.w[j] * dx * dy *
                           f_visible(cf, cx[a] + dx * g.x[i], cy[b] + dy * g.x[j]);
        }
    const double area = (cf.sender.x1 - cf.sender.x0) * (cf.sender.y1 - cf.sender.y0);
    return sum / area;
}

ObstructedFormFactor compute(const Config& cf, double tol) {
    return polygon_to_polygon_obstructed(rect(cf.sender, 0, true), rect(cf.receiver, cf.c, false),
                                         cf.blockers(), tol);
}

void check_config(const Config& cf, double tol = 1e-6) {
    const double ref = reference(cf);
    const ObstructedFormFactor r = compute(cf, tol);
    INFO("reference ", ref, " computed ", r.value, " estimate ", r.error_estimate);
    CHECK(std::abs(r.value - ref) <= tol);
    CHECK(r.value <= r.unobstructed);
    CHECK(r.error_estimate <= tol);
    // The unobstructed value is the exact one.
    CHECK(std::abs(r.unobstructed - polygon_to_polygon(rect(cf.sender, 0, true),
                                                       rect(cf.receiver, cf.c, false))) <= 1e-15);
}

}  // namespace

TEST_CASE("obstructed: point on the axis behind a smaller parallel blocker") {
    // The blocker's shadow lies inside the receiver: F = F(receiver) − F(blocker).
    const Polygon receiver = rect({-1, 1, -1, 1}, 1.0, false);
    for (double h : {0.4, 0.5, 0.9}) {
        const Polygon blocker_down = rect({-0.3, 0.3, -0.2, 0.25}, h, false);
        const Polygon blocker_up = rect({-0.3, 0.3, -0.2, 0.25}, h, true);
        const Vec3 x(0.05, -0.02, 0.0);
        const double expected = point_to_polygon(x, Vec3::UnitZ(), receiver) -
                                point_to_polygon(x, Vec3::UnitZ(), blocker_down);
        // Thin blockers block from both sides.
        for (const Polygon& b : {blocker_down, blocker_up}) {
            const double f = point_to_polygon_obstructed(x, Vec3::UnitZ(), receiver, {b});
            CHECK(f == doctest::Approx(expected).epsilon(1e-13));
        }
        // A blocker beyond the receiver or behind the point hides nothing.
        const double free = point_to_polygon(x, Vec3::UnitZ(), receiver);
        CHECK(point_to_polygon_obstructed(x, Vec3::UnitZ(), receiver,
                                          {rect({-0.3, 0.3, -0.2, 0.25}, 1.5, true)}) == free);
        CHECK(point_to_polygon_obstructed(x, Vec3::UnitZ(), receiver,
                                          {rect({-0.3, 0.3, -0.2, 0.25}, -0.5, true)}) == free);
    }
}

TEST_CASE("obstructed: area to area, shadow inside the receiver (closed form)") {
    // From every sender point the shadow lies inside the receiver, so F = F_sR − F_sB exactly.
    const Polygon s = rect({-0.1, 0.1, -0.1, 0.1}, 0, true);
    const Polygon r = rect({-1, 1, -1, 1}, 1, false);
    const Polygon b_down = rect({-0.2, 0.2, -0.15, 0.2}, 0.5, false);
    const double expected = polygon_to_polygon(s, r) - polygon_to_polygon(s, b_down);
    const ObstructedFormFactor f =
        polygon_to_polygon_obstructed(s, r, {rect({-0.2, 0.2, -0.15, 0.2}, 0.5, true)}, 1e-6);
    CHECK(std::abs(f.value - expected) <= 1e-6);
    CHECK(f.value <= f.unobstructed);
    // The reference integrator agrees with the closed form.
    Config cf{{-0.1, 0.1, -0.1, 0.1}, {-1, 1, -1, 1}, 1.0, {{{-0.2, 0.2, -0.15, 0.2}, 0.5}}, {}};
    CHECK(reference(cf) == doctest::Approx(expected).epsilon(1e-12));
}

TEST_CASE("obstructed: blocker cutting the receiver's edge") {
    check_config({{-0.2, 0.2, -0.2, 0.2}, {-1, 1, -1, 1}, 1.0, {{{0.3, 0.9, -0.2, 0.2}, 0.5}}, {}});
    check_config({{-0.5, 0.5, -0.3, 0.3}, {-1, 1, -1, 1}, 1.0, {{{0.5, 1.5, 0.4, 1.2}, 0.6}}, {}});
}

TEST_CASE("obstructed: several blockers overlapping in projection") {
    check_config({{-0.3, 0.3, -0.3, 0.3},
                  {-1, 1, -1, 1},
                  1.0,
                  {{{-0.3, 0.2, -0.3, 0.3}, 0.4}, {{0.0, 0.5, -0.1, 0.4}, 0.7}},
                  {}});
    check_config({{-0.2, 0.4, -0.2, 0.3},
                  {-1, 1, -0.8, 1},
                  1.0,
                  {{{-0.5, 0.1, -0.4, 0.1}, 0.3},
                   {{-0.2, 0.6, -0.1, 0.3}, 0.5},
                   {{0.1, 0.9, -0.6, 0.0}, 0.8}},
                  {}});
}

TEST_CASE("obstructed: blocker touching the sender") {
    // A wall standing on the sender's plane, crossing the sender, and along its edge.
    check_config({{-0.5, 0.5, -0.5, 0.5}, {-1, 1, -1, 1}, 1.0, {}, {{0.0, 0.5}}});
    check_config({{-0.5, 0.5, -0.5, 0.5}, {-1, 1, -1, 1}, 1.0, {}, {{0.5, 0.3}}});
    check_config({{-0.5, 0.5, -0.5, 0.5}, {-1, 1, -1, 1}, 1.0, {}, {{0.2, 0.7}}});
    // A wall and a plate.
    check_config({{-0.5, 0.5, -0.5, 0.5},
                  {-1, 1, -1, 1},
                  1.0,
                  {{{-0.6, 0.1, -0.3, 0.4}, 0.6}},
                  {{0.1, 0.4}}});
}

TEST_CASE("obstructed: the tolerance is met across tolerances and reported") {
    const Config cf{{-0.3, 0.3, -0.3, 0.3},
                    {-1, 1, -1, 1},
                    1.0,
                    {{{-0.3, 0.2, -0.3, 0.3}, 0.4}, {{0.0, 0.5, -0.1, 0.4}, 0.7}},
                    {{0.25, 0.3}}};
    const double ref = reference(cf);
    for (double tol : {1e-4, 1e-6, 1e-8}) {
        const ObstructedFormFactor r = compute(cf, tol);
        INFO("tol ", tol, " error ", r.value - ref, " estimate ", r.error_estimate);
        CHECK(std::abs(r.value - ref) <= tol);
        CHECK(r.error_estimate <= tol);
    }
}

// ---------------------------------------------------------------------------------------------
// The method.

namespace {

// Two unit squares (bottom facing up, top facing down) split n×n, plus obstruction-only plates.
Scene plates_scene(int n, const std::vector<Plate>& plates) {
    std::vector<Polygon> blockers;
    for (const Plate& p : plates) blockers.push_back(rect(p.r, p.h, true));
    return testing::scene_of({rect({0, 1, 0, 1}, 0, true), rect({0, 1, 0, 1}, 1, false)}, blockers,
                             n);
}

Rect patch_rect(const Patch& p) {
    const Bounds3 b = bounds(p.polygon);
    return {b.lo.x(), b.hi.x(), b.lo.y(), b.hi.y()};
}

}  // namespace

TEST_CASE("obstructed: analytic method on plates with obstructions, against exact values") {
    const std::vector<Plate> plates = {{{0.2, 0.6, 0.3, 0.7}, 0.5}, {{0.5, 1.3, -0.2, 0.4}, 0.3}};
    const Scene s = plates_scene(3, plates);
    const auto m = make_method("analytic");
    CHECK_NOTHROW(m->check(s));
    MethodOptions o;
    o.threads = 2;
    nlohmann::json d;
    const FormFactors f = run_method(*m, s, o, d);
    const std::size_t n = s.patches.size();
    REQUIRE(n == 18);
    double worst = 0.0;
    for (std::size_t i = 0; i < 9; ++i)
        for (std::size_t j = 9; j < 18; ++j) {
            Config cf;
            cf.sender = patch_rect(s.patches[i]);
            cf.receiver = patch_rect(s.patches[j]);
            cf.plates = plates;
            const double ref = reference(cf);
            const auto I = static_cast<Eigen::Index>(i), J = static_cast<Eigen::Index>(j);
            worst = std::max(worst, std::abs(f.F(I, J) - ref));
            worst =
                std::max(worst, std::abs(f.F(J, I) - ref * s.patches[i].area / s.patches[j].area));
            // Never more than the unobstructed value (visible pairs come from the far-field path,
            // within options.tolerance = 1e-10 of the exact value).
            CHECK(f.F(I, J) <=
                  polygon_to_polygon(s.patches[i].polygon, s.patches[j].polygon) + 1e-10);
        }
    CHECK(worst <= 1e-6);
    // Coplanar pairs stay 0; reciprocity holds exactly.
    for (std::size_t i = 0; i < n; ++i)
        for (std::size_t j = 0; j < n; ++j) {
            const auto I = static_cast<Eigen::Index>(i), J = static_cast<Eigen::Index>(j);
            if ((i < 9) == (j < 9)) CHECK(f.F(I, J) == 0.0);
            CHECK(std::abs(f.areas[i] * f.F(I, J) - f.areas[j] * f.F(J, I)) <= 1e-15);
        }
    REQUIRE(d.contains("obstructions"));
    const auto& ob = d["obstructions"];
    CHECK(d["obstructed"] == true);
    CHECK(ob["patch_pairs_partly_hidden"].get<std::size_t>() > 0);
    CHECK(ob["patch_pairs_visible"].get<std::size_t>() +
              ob["patch_pairs_hidden"].get<std::size_t>() +
              ob["patch_pairs_partly_hidden"].get<std::size_t>() ==
          81);
    CHECK(ob["max_error_estimate"].get<double>() <= 1e-6);
    CHECK(ob.contains("refinement_levels"));
    CHECK(d["error_bound_per_entry"].get<double>() <= 1e-6);
    // The pass's cost was estimated from a sample of its pairs before the rest ran (here all
    // of them: fewer than the sample size).
    CHECK(ob["sampled_pairs"].get<std::size_t>() ==
          ob["patch_pairs_partly_hidden"].get<std::size_t>());
    CHECK(ob["estimated_seconds_partly_hidden"].get<double>() >= 0.0);
}

TEST_CASE("obstructed: fully hidden and fully visible pairs are settled without integration") {
    const auto m = make_method("analytic");
    MethodOptions o;
    // A plate wider than everything: every pair hidden, exactly 0.
    {
        const Scene s = plates_scene(4, {{{-1, 2, -1, 2}, 0.5}});
        nlohmann::json d;
        const FormFactors f = run_method(*m, s, o, d);
        CHECK(f.F.cwiseAbs().maxCoeff() == 0.0);
        CHECK(d["obstructions"]["patch_pairs_hidden"].get<std::size_t>() == 256);
        CHECK(d["obstructions"]["patch_pairs_partly_hidden"].get<std::size_t>() == 0);
    }
    // A plate outside the space between the squares: nothing changes.
    {
        const Scene s = plates_scene(4, {{{1.5, 2.5, 0, 1}, 0.5}});
        nlohmann::json d;
        const FormFactors f = run_method(*m, s, o, d);
        Scene free = plates_scene(4, {});
        nlohmann::json d2;
        const FormFactors g = run_method(*m, free, o, d2);
        CHECK((f.F - g.F).cwiseAbs().maxCoeff() == 0.0);
        CHECK(d["obstructions"]["patch_pairs_visible"].get<std::size_t>() == 256);
        CHECK(d2["obstructed"] == false);
    }
}

TEST_CASE("obstructed: room scene, box as patches or as obstructions, VS3 round trip") {
    const auto m = make_method("analytic");
    MethodOptions o;
    o.tolerance = 1e-6;
    const Scene with_patches = room_scene(4, RoomBox::kPatches);
    const Scene with_obstruction = room_scene(4, RoomBox::kObstruction);
    REQUIRE(with_patches.patches.size() == 96 + 24);
    REQUIRE(with_obstruction.patches.size() == 96);
    nlohmann::json d1, d2;
    const FormFactors a = run_method(*m, with_patches, o, d1);
    const FormFactors b = run_method(*m, with_obstruction, o, d2);
    // The thread count changes nothing.
    MethodOptions one = o;
    one.threads = 1;
    nlohmann::json d0;
    CHECK((run_method(*m, with_patches, one, d0).F - a.F).cwiseAbs().maxCoeff() == 0.0);
    // The walls see each other past the same box either way.
    const double diff = (a.F.topLeftCorner(96, 96) - b.F).cwiseAbs().maxCoeff();
    CHECK(diff <= 2e-6);
    // Closed room: rows sum to 1 (each entry within the tolerance).
    const Diagnostics dg = diagnose(a.F, a.areas);
    CHECK(std::abs(dg.row_sum_min - 1.0) <= 120 * 1e-6);
    CHECK(std::abs(dg.row_sum_max - 1.0) <= 120 * 1e-6);
    CHECK(dg.negative_entries == 0);
    // Written as VS3 (every patch a surface, the box as O records) and read back: same matrix.
    const std::string path = (testing::scratch_dir() / "room-4-obstruction.vs3").string();
    save_vs3(with_obstruction, path);
    Scene back = load_scene(path);
    REQUIRE(back.patches.size() == 96);
    REQUIRE(back.obstruction_count() == 6);
    nlohmann::json d3;
    const FormFactors c = run_method(*m, back, o, d3);
    CHECK((c.F - b.F).cwiseAbs().maxCoeff() <= 1e-12);
    // The committed fixtures (tests/data/room-4*.vs3, written by save_vs3) give the same.
    nlohmann::json d4, d5;
    const FormFactors e = run_method(*m, load_scene(testing::data("room-4.vs3")), o, d4);
    const FormFactors g =
        run_method(*m, load_scene(testing::data("room-4-obstruction.vs3")), o, d5);
    CHECK((e.F - a.F).cwiseAbs().maxCoeff() <= 1e-12);
    CHECK((g.F - b.F).cwiseAbs().maxCoeff() <= 1e-12);
    // And the built-in names.
    CHECK(is_builtin_scene("room-4"));
    CHECK(is_builtin_scene("room-4-obstruction"));
    CHECK_FALSE(is_builtin_scene("room-x"));
    CHECK(load_scene("room-4-obstruction").obstruction_count() == 6);
}

TEST_CASE("obstructed: analytic agrees with mc-target on the room (independent check)") {
    // Monte Carlo with Embree rays knows nothing of shafts, shadows or event lines. mc-target
    // (exact unobstructed F × the visible fraction of projected-solid-angle samples) rather than
    // mc-area, whose replicate standard errors understate its heavy-tailed error at shared edges.
    const Scene s = room_scene(2, RoomBox::kPatches);
    MethodOptions o;
    o.tolerance = 1e-6;
    nlohmann::json d1, d2;
    const FormFactors a = run_method(*make_method("analytic"), s, o, d1);
    o.samples = 1 << 11;
    const FormFactors m = run_method(*make_method("mc-target"), s, o, d2);
    REQUIRE(m.standard_error);
    const auto n = static_cast<Eigen::Index>(s.patches.size());
    double worst_z = 0.0;
    std::size_t hidden_pairs_changed = 0;
    for (Eigen::Index i = 0; i < n; ++i)
        for (Eigen::Index j = 0; j < n; ++j) {
            const double se = (*m.standard_error)(i, j);
            const double diff = std::abs(a.F(i, j) - m.F(i, j));
            // 5σ, plus the ray end offset of the visibility (relative 1e-5 of the scene).
            worst_z = std::max(worst_z, diff / (se + 1e-5));
            const double free = polygon_to_polygon(s.patches[static_cast<std::size_t>(i)].polygon,
                                                   s.patches[static_cast<std::size_t>(j)].polygon);
            if (free - a.F(i, j) > 1e-3) ++hidden_pairs_changed;
        }
    MESSAGE("max |analytic − mc-target| / (σ + 1e-5): " << worst_z);
    CHECK(worst_z <= 5.0);
    CHECK(hidden_pairs_changed > 0);  // the box does hide something
}

namespace {
// max over the rows of |Σ_j F_ij − 1|: what a closed scene's rows must keep within the tolerance.
double largest_row_deviation(const DenseMatrix& F) {
    return (F.rowwise().sum().array() - 1.0).abs().maxCoeff();
}
}  // namespace

TEST_CASE("obstructed: a closed room of triangles sums its rows to 1 within the tolerance at 1e-4" *
          doctest::test_suite("slow")) {
    // The room n = 16 with every patch as two triangles, as meshing tools write it (3,840
    // patches). A partly hidden pair whose unobstructed value is within its bracket share of the
    // tolerance takes a low-order estimate inside [0, unobstructed]: each such entry is within
    // the tolerance, but the similar pairs of one row err the same way, and with the whole
    // tolerance as the share rows reached 1.00032 (156 of them beyond 1e-4).
    const Scene room = room_scene(16, RoomBox::kPatches);
    std::vector<Polygon> triangles;
    for (const Patch& p : room.patches) {
        const Polygon& q = p.polygon;
        REQUIRE(q.size() == 4);
        triangles.push_back(Polygon{{q[0], q[1], q[2]}});
        triangles.push_back(Polygon{{q[0], q[2], q[3]}});
    }
    const Scene s = testing::scene_of(triangles);
    MethodOptions o;
    o.tolerance = o.obstructed_tolerance = 1e-4;  // as --tolerance 1e-4
    nlohmann::json d;
    const FormFactors f = run_method(*make_method("analytic"), s, o, d);
    const double worst = largest_row_deviation(f.F);
    MESSAGE("largest |row sum − 1| at tolerance 1e-4: " << worst);
    CHECK(worst <= 1e-4);
}

TEST_CASE("obstructed: the closed room n = 32 sums its rows to 1 within the tolerance at 1e-4" *
          doctest::test_suite("slow")) {
    // 7,680 patches, 767k partly hidden pairs; at 1e-4 187k of them are settled by their umbra
    // bounds, the value placed inside the bound from 4 points. At the 2 × 2 Gauss points those
    // missed the slivers of light along the umbrae's edges alike in the pairs of a row, and 36
    // rows fell more than 1e-4 short of 1 (to 1 − 1.39e-4); points drawn in the sender's
    // quarters do not err alike.
    const Scene room = room_scene(32, RoomBox::kPatches);
    MethodOptions o;
    o.tolerance = o.obstructed_tolerance = 1e-4;  // as --tolerance 1e-4
    nlohmann::json d;
    const FormFactors f = run_method(*make_method("analytic"), room, o, d);
    CHECK(d["obstructions"]["partly_hidden_pairs_settled_by_umbrae"].get<std::size_t>() > 100000);
    const double worst = largest_row_deviation(f.F);
    MESSAGE("largest |row sum − 1| at tolerance 1e-4: " << worst);
    CHECK(worst <= 1e-4);
}

TEST_CASE(
    "obstructed: the report counts the partly hidden pairs whose event cut spent its piece "
    "budget") {
    // Two facing unit squares 2 apart with a 6 × 6 grid of small squares between them at
    // heights between 0.6 and 1.4 (obstructions): their event lines cut the sender into more
    // than the budget's 1,024 pieces, and the lines left then are not cut. The report says how
    // many pairs that happened to; the two plates with one blocker cut into a few pieces, none.
    std::vector<Polygon> blockers;
    for (int i = 0; i < 6; ++i)
        for (int j = 0; j < 6; ++j) {
            const double x = 0.05 + 0.16 * i, y = 0.05 + 0.16 * j;
            const double z = 0.6 + 0.8 * std::fmod(0.37 * (i * 6 + j), 1.0);
            blockers.push_back(testing::quad(Vec3(x, y, z), Vec3(x + 0.09, y, z),
                                             Vec3(x + 0.09, y + 0.09, z), Vec3(x, y + 0.09, z)));
        }
    const Polygon sender =
        testing::quad(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0));
    const Polygon receiver =
        testing::quad(Vec3(0, 1, 2), Vec3(1, 1, 2), Vec3(1, 0, 2), Vec3(0, 0, 2));
    MethodOptions o;
    o.obstructed_tolerance = 1e-4;
    nlohmann::json d;
    run_method(*make_method("analytic"), testing::scene_of({sender, receiver}, blockers), o, d);
    CHECK(d["obstructions"]["patch_pairs_partly_hidden"].get<std::size_t>() == 1);
    CHECK(d["obstructions"]["partly_hidden_pairs_cut_budget_spent"].get<std::size_t>() == 1);
    nlohmann::json one;
    run_method(*make_method("analytic"), testing::scene_of({sender, receiver}, {blockers[14]}), o,
               one);
    CHECK(one["obstructions"]["patch_pairs_partly_hidden"].get<std::size_t>() == 1);
    CHECK(one["obstructions"]["partly_hidden_pairs_cut_budget_spent"].get<std::size_t>() == 0);
}
