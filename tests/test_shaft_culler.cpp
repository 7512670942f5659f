#include <doctest/doctest.h>

#include <algorithm>
#include <vector>

#include "formfactor/core/random.h"
#include "formfactor/geometry/sampling.h"
#include "formfactor/kernels/analytic.h"
#include "formfactor/visibility/visibility.h"
#include "support/scenes.h"
#include "visibility/shaft_culler.h"

using namespace formfactor;
using testing::quad;
using testing::scene_of;

namespace {

// Every pair the culler clears must have no blocked ray among `rays` segments between uniform
// points of the two patches, each end in front of the other patch by more than 1e-3 in cosine
// (grazing segments weigh ~nothing in F, and the single-precision ray tracer may graze an
// adjacent face within its epsilon); returns the fraction of the pairs with F > 0 cleared.
double check_against_rays(const Scene& s, int rays) {
    const ShaftCuller culler(s);
    const auto vis = make_visibility(s);
    std::vector<PolygonSampler> samplers;
    for (const Patch& p : s.patches) samplers.emplace_back(p.polygon);
    const int n = static_cast<int>(s.patches.size());
    int pairs = 0, cleared = 0, wrong = 0;
    std::vector<SegmentQuery> q;
    std::vector<std::uint8_t> blocked;
    for (int i = 0; i < n; ++i) {
        for (int j = i + 1; j < n; ++j) {
            const Patch &pi = s.patches[static_cast<std::size_t>(i)],
                        &pj = s.patches[static_cast<std::size_t>(j)];
            if (!(polygon_to_polygon(pi.polygon, pj.polygon) > 0)) continue;
            ++pairs;
            if (!culler.unoccluded(i, j)) continue;
            ++cleared;
            CHECK(culler.unoccluded(j, i));
            q.clear();
            const PointSet4 set(SamplerKind::random, stream_key(5, i, j), 0);
            for (std::uint32_t k = 0; q.size() < static_cast<std::size_t>(rays) && k < 100000;
                 ++k) {
                // Points off the patches' rims by 1e-3 of their parameter range: a ray end on
                // an edge shared with a perpendicular neighbour can touch it in single precision.
                auto in = [](double t) { return 1e-3 + (1 - 2e-3) * t; };
                const auto u = set(k);
                const Vec3 x = samplers[static_cast<std::size_t>(i)](in(u[0]), in(u[1]));
                const Vec3 y = samplers[static_cast<std::size_t>(j)](in(u[2]), in(u[3]));
                const double len = (y - x).norm();
                if (pi.normal.dot(y - x) <= 1e-3 * len || pj.normal.dot(x - y) <= 1e-3 * len)
                    continue;
                q.push_back({x, y, i, j});
            }
            blocked.assign(q.size(), 0);
            vis->occluded(q, blocked);
            if (std::count(blocked.begin(), blocked.end(), 1) > 0) {
                ++wrong;
                MESSAGE("cleared pair " << i << " " << j << " has blocked rays");
            }
        }
    }
    CHECK(wrong == 0);
    return pairs > 0 ? static_cast<double>(cleared) / pairs : 0.0;
}

}  // namespace

TEST_CASE("shaft culler: a blocker in the shaft, beside it, or touching it") {
    const Polygon floor = quad(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0));
    const Polygon ceiling = quad(Vec3(0, 1, 1), Vec3(1, 1, 1), Vec3(1, 0, 1), Vec3(0, 0, 1));
    const Polygon inside =
        quad(Vec3(0.4, 0.4, 0.5), Vec3(0.6, 0.4, 0.5), Vec3(0.6, 0.6, 0.5), Vec3(0.4, 0.6, 0.5));
    const Polygon corner =  // cuts only a corner of the shaft
        quad(Vec3(0.9, 0.9, 0.5), Vec3(1.5, 0.9, 0.5), Vec3(1.5, 1.5, 0.5), Vec3(0.9, 1.5, 0.5));
    const Polygon beside =
        quad(Vec3(1.1, 0, 0.5), Vec3(2, 0, 0.5), Vec3(2, 1, 0.5), Vec3(1.1, 1, 0.5));
    const Polygon wall =  // the plane x = 1, touching the shaft along a face
        quad(Vec3(1, 0, 0), Vec3(1, 0, 1), Vec3(1, 1, 1), Vec3(1, 1, 0));
    const Polygon below =
        quad(Vec3(-1, -1, -0.5), Vec3(2, -1, -0.5), Vec3(2, 2, -0.5), Vec3(-1, 2, -0.5));
    CHECK(ShaftCuller(scene_of({floor, ceiling})).unoccluded(0, 1));
    CHECK(!ShaftCuller(scene_of({floor, ceiling}, {inside})).unoccluded(0, 1));
    CHECK(!ShaftCuller(scene_of({floor, ceiling}, {corner})).unoccluded(0, 1));
    CHECK(ShaftCuller(scene_of({floor, ceiling}, {beside})).unoccluded(0, 1));
    CHECK(ShaftCuller(scene_of({floor, ceiling}, {wall})).unoccluded(0, 1));
    CHECK(ShaftCuller(scene_of({floor, ceiling}, {below})).unoccluded(0, 1));
    // A tilted blocker whose vertices all lie outside the shaft's box but which crosses it.
    const Polygon diagonal =
        quad(Vec3(-1, 0.5, -1), Vec3(2, 0.5, 2), Vec3(2, 0.6, 2.05), Vec3(-1, 0.6, -0.95));
    CHECK(!ShaftCuller(scene_of({floor, ceiling}, {diagonal})).unoccluded(0, 1));
    // Whole polygons (surfaces).
    CHECK(ShaftCuller(scene_of({floor, ceiling}, {beside})).unoccluded(floor, ceiling));
    CHECK(!ShaftCuller(scene_of({floor, ceiling}, {inside})).unoccluded(floor, ceiling));
}

TEST_CASE("shaft culler: convex rooms are clear, and every cleared pair is clear for rays") {
    // The unit cube, inward, 3×3 per face: nothing can block (every pair with F > 0 cleared,
    // edge- and corner-sharing neighbours included).
    Scene cube = load_scene("cube");
    subdivide(cube, SubdivisionOptions{3, 0.0});
    CHECK(check_against_rays(cube, 16) == 1.0);
    // The Cornell box with its two blocks, 3×3 per surface: a cleared pair must let every ray
    // through; most pairs are clear.
    Scene cornell = load_scene("cornell");
    subdivide(cornell, SubdivisionOptions{3, 0.0});
    const double cleared = check_against_rays(cornell, 256);
    MESSAGE("Cornell 3x3: " << cleared << " of the visible pairs cleared");
    CHECK(cleared > 0.5);
    // The room with a floating box (as radiating surfaces), 4×4 per wall.
    const double room = check_against_rays(load_scene("room-4"), 256);
    MESSAGE("room-4: " << room << " of the visible pairs cleared");
    CHECK(room > 0.3);
}

TEST_CASE("shaft culler: a scene without polygons blocks nothing") {
    const Scene empty;
    const ShaftCuller culler(empty);
    Polygon a, b;
    a.vertices = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0)};
    b.vertices = {Vec3(0, 0, 1), Vec3(0, 1, 1), Vec3(1, 1, 1), Vec3(1, 0, 1)};
    CHECK(culler.unoccluded(a, b));
}
