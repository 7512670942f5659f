#include <doctest/doctest.h>

#include <cmath>
#include <vector>

#include "formfactor/core/error.h"
#include "formfactor/visibility/visibility.h"
#include "support/scenes.h"

using namespace formfactor;
using testing::quad;
using testing::scene_of;

namespace {

bool blocked(const Visibility& v, const SegmentQuery& q) {
    std::uint8_t b = 7;
    v.occluded(std::span<const SegmentQuery>(&q, 1), std::span<std::uint8_t>(&b, 1));
    return b != 0;
}

RayHit first(const Visibility& v, const RayQuery& q) {
    RayHit h;
    v.first_hit(std::span<const RayQuery>(&q, 1), std::span<RayHit>(&h, 1));
    return h;
}

// Floor (patch 0, facing up), ceiling (patch 1, facing down) at z = 1, and between them at
// z = 0.5 a blocker sheet with a square hole [0.4, 0.6]² (four obstruction quads).
Scene gap_scene() {
    const double z = 0.5;
    return scene_of({quad(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0)),
                     quad(Vec3(0, 1, 1), Vec3(1, 1, 1), Vec3(1, 0, 1), Vec3(0, 0, 1))},
                    {quad(Vec3(-1, -1, z), Vec3(2, -1, z), Vec3(2, 0.4, z), Vec3(-1, 0.4, z)),
                     quad(Vec3(-1, 0.6, z), Vec3(2, 0.6, z), Vec3(2, 2, z), Vec3(-1, 2, z)),
                     quad(Vec3(-1, 0.4, z), Vec3(0.4, 0.4, z), Vec3(0.4, 0.6, z), Vec3(-1, 0.6, z)),
                     quad(Vec3(0.6, 0.4, z), Vec3(2, 0.4, z), Vec3(2, 0.6, z), Vec3(0.6, 0.6, z))});
}

}  // namespace

TEST_CASE("visibility: occlusion through a gap, and first hits") {
    for (const Vec3& offset : {Vec3(0, 0, 0), Vec3(1e4, -2e4, 3e4)}) {
        CAPTURE(offset.transpose());
        const Scene s = testing::translated(gap_scene(), offset);
        auto v = make_visibility(s);
        CHECK(v->triangle_count() == 12);
        const Vec3 o = offset;
        // Through the hole: free; beside it: blocked, both ways (a single sheet blocks from both
        // sides).
        CHECK_FALSE(blocked(*v, {o + Vec3(0.5, 0.5, 0), o + Vec3(0.5, 0.5, 1), 0, 1}));
        CHECK_FALSE(blocked(*v, {o + Vec3(0.5, 0.5, 1), o + Vec3(0.5, 0.5, 0), 1, 0}));
        CHECK(blocked(*v, {o + Vec3(0.2, 0.5, 0), o + Vec3(0.2, 0.5, 1), 0, 1}));
        CHECK(blocked(*v, {o + Vec3(0.2, 0.5, 1), o + Vec3(0.2, 0.5, 0), 1, 0}));
        // Slanted through the hole edge: x crosses z = 0.5 at 0.41 (free) or 0.39 (blocked).
        CHECK_FALSE(blocked(*v, {o + Vec3(0.32, 0.5, 0), o + Vec3(0.50, 0.5, 1), 0, 1}));
        CHECK(blocked(*v, {o + Vec3(0.28, 0.5, 0), o + Vec3(0.50, 0.5, 1), 0, 1}));
        // First hit: the ceiling through the hole, the sheet (obstruction) beside it.
        RayHit h = first(*v, {o + Vec3(0.5, 0.5, 0), Vec3(0, 0, 1), 0});
        CHECK(h.patch == 1);
        CHECK(h.front);
        CHECK(h.distance == doctest::Approx(1.0).epsilon(1e-4));
        h = first(*v, {o + Vec3(0.1, 0.5, 0), Vec3(0, 0, 2), 0});
        CHECK(h.patch == RayHit::kObstructionHit);
        CHECK(h.distance == doctest::Approx(0.5).epsilon(1e-4));
        // Upwards from the ceiling's back side: nothing. Downwards from above: the ceiling's back.
        h = first(*v, {o + Vec3(0.5, 0.5, 1), Vec3(0, 0, 1), 1});
        CHECK_FALSE(h.hit());
        h = first(*v, {o + Vec3(0.5, 0.5, 3), Vec3(0, 0, -1), -1});
        CHECK(h.patch == 1);
        CHECK_FALSE(h.front);
    }
}

TEST_CASE(
    "visibility: a patch never shadows itself, nor do coplanar neighbours at grazing angles") {
    // A floor of two coplanar patches and a wall standing on the floor's far edge.
    const Scene s = scene_of({quad(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0)),
                              quad(Vec3(1, 0, 0), Vec3(2, 0, 0), Vec3(2, 1, 0), Vec3(1, 1, 0)),
                              quad(Vec3(2, 0, 0), Vec3(2, 1, 0), Vec3(2, 1, 1), Vec3(2, 0, 1))});
    auto v = make_visibility(s);
    // Grazing: from the first floor patch to the bottom of the wall, over the coplanar neighbour.
    for (double h : {1e-1, 1e-2, 1e-3}) {
        CAPTURE(h);
        CHECK_FALSE(blocked(*v, {Vec3(0.01, 0.5, 0), Vec3(2, 0.5, h), 0, 2}));
        CHECK_FALSE(blocked(*v, {Vec3(2, 0.5, h), Vec3(0.01, 0.5, 0), 2, 0}));
        const RayHit hit = first(*v, {Vec3(0.01, 0.5, 0), Vec3(1.99, 0, h), 0});
        CHECK(hit.patch == 2);
    }
    // Between two points of one patch, and between neighbours sharing an edge.
    CHECK_FALSE(blocked(*v, {Vec3(0.1, 0.1, 0), Vec3(0.9, 0.9, 0), 0, 0}));
    CHECK_FALSE(blocked(*v, {Vec3(0.9, 0.5, 0), Vec3(1.1, 0.5, 0), 0, 1}));
    // Floor to the wall's top: free.
    CHECK_FALSE(blocked(*v, {Vec3(0.5, 0.5, 0), Vec3(2, 0.5, 0.999), 0, 2}));
}

TEST_CASE("visibility: works at any scale and far from the origin") {
    for (double scale : {1e-3, 1.0, 1e3}) {
        for (double shift : {0.0, 1e4}) {
            CAPTURE(scale);
            CAPTURE(shift);
            Scene s = gap_scene();
            for (auto& sf : s.surfaces)
                for (auto& p : sf.polygon.vertices) p = p * scale + Vec3::Constant(shift * scale);
            for (auto& p : s.patches) {
                for (auto& q : p.polygon.vertices) q = q * scale + Vec3::Constant(shift * scale);
                p.centroid = centroid(p.polygon);
            }
            auto v = make_visibility(s);
            CHECK(v->epsilon() < 1e-4 * scale);
            const Vec3 o = Vec3::Constant(shift * scale);
            // Rays that pass 1 % of the hole width from its edge.
            CHECK_FALSE(blocked(
                *v, {o + scale * Vec3(0.402, 0.5, 0), o + scale * Vec3(0.402, 0.5, 1), 0, 1}));
            CHECK(blocked(
                *v, {o + scale * Vec3(0.398, 0.5, 0), o + scale * Vec3(0.398, 0.5, 1), 0, 1}));
            std::vector<SegmentQuery> q;
            for (int k = 0; k < 100; ++k) {
                const double x = 0.005 + 0.01 * k;
                q.push_back({o + scale * Vec3(x, 0.5, 0), o + scale * Vec3(x, 0.5, 1), 0, 1});
            }
            std::vector<std::uint8_t> b(q.size());
            v->occluded(q, b);
            int free = 0;
            for (auto x : b) free += x == 0;
            CHECK(free == 20);
        }
    }
}

TEST_CASE("visibility: all batching modes agree") {
    const Scene s = gap_scene();
    std::vector<SegmentQuery> q;
    std::vector<RayQuery> r;
    for (int k = 0; k < 1000; ++k) {
        const double a = std::fmod(k * 0.618034, 1.0), b = std::fmod(k * 0.754878, 1.0);
        q.push_back({Vec3(a, b, 0), Vec3(b, 1 - a, 1), 0, 1});
        r.push_back({Vec3(a, b, 0), Vec3(b - a, 1 - a - b, 1), 0});
    }
    std::vector<std::vector<std::uint8_t>> res;
    std::vector<std::vector<int>> hits;
    for (auto mode : {VisibilityOptions::Batching::single, VisibilityOptions::Batching::packet16,
                      VisibilityOptions::Batching::stream}) {
        VisibilityOptions opt;
        opt.batching = mode;
        auto v = make_visibility(s, opt);
        std::vector<std::uint8_t> b(q.size());
        v->occluded(q, b);
        res.push_back(b);
        std::vector<RayHit> h(r.size());
        v->first_hit(r, h);
        std::vector<int> ids;
        for (const auto& x : h) ids.push_back(x.patch);
        hits.push_back(ids);
    }
    CHECK(res[0] == res[1]);
    CHECK(res[0] == res[2]);
    CHECK(hits[0] == hits[2]);
    int nb = 0;
    for (auto x : res[0]) nb += x;
    CHECK(nb > 100);
    CHECK(nb < 990);
}

TEST_CASE("visibility: a scene without geometry is an error") {
    Scene s;
    CHECK_THROWS_AS(make_visibility(s), GeometryError);
}
