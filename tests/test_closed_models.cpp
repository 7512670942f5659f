// Closed models: recognition (formfactor/scene/closure.h) and watertight first hits
// (Visibility's re-cast, mc-hemisphere's escape count), in both of Embree's modes.
#include <doctest/doctest.h>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "formfactor/pipeline.h"
#include "formfactor/scene/closure.h"
#include "formfactor/visibility/visibility.h"
#include "support/cli_runner.h"
#include "support/closed_rooms.h"
#include "support/scenes.h"

using namespace formfactor;
using namespace formfactor::testing;

namespace {

std::string data(const std::string& name) { return std::string(FF_TEST_DATA_DIR) + "/" + name; }

// The L-shaped hall of tests/data/closed (40 × 20 × 10) in 2 × 2 squares: 600 patches.
Scene l_hall() {
    Scene s = load_scene(data("closed/l_hall.obj"));
    subdivide(s, SubdivisionOptions{1, 2.0});
    return s;
}

Scene sphere_in_room(int n) {
    std::vector<Polygon> faces = room_faces(Cells{3, 3, 3}, 1.0);
    for (const Polygon& p : sphere_faces(Vec3(1.5, 1.5, 1.5), 0.8, 8, 12)) faces.push_back(p);
    return scene_of(faces, {}, n);
}

struct Rooms {
    std::string name;
    Scene scene;
};

// The closed rooms of the tests at subdivision n.
std::vector<Rooms> rooms(int n) {
    return {{"box", scene_of(room_faces(box_room(), 1.0), {}, n)},
            {"L", scene_of(room_faces(l_room(), 1.0), {}, n)},
            {"U", scene_of(room_faces(u_room(), 1.0), {}, n)},
            {"box on the floor", scene_of(room_faces(box_on_floor_room(), 1.0), {}, n)},
            {"sphere in a room", sphere_in_room(n)}};
}

struct Escapes {
    std::uint64_t escapes = 0, recast = 0, rays = 0;
    double worst_row = 0.0;  // largest |row sum − 1|
    bool closed = false;
};

// mc-hemisphere on s with `rays` rays per patch: the rays that escaped (closed_model_escapes),
// those re-cast, and the worst row sum.
Escapes hemisphere(const Scene& s, std::uint64_t rays, bool robust, std::uint64_t seed = 1) {
    ComputeOptions o;
    o.method = MethodKind::mc_hemisphere;
    o.method_options.samples = rays;
    o.method_options.seed = seed;
    o.visibility.robust = robust;
    const ComputeResult r = compute_form_factors(s, o);
    Escapes e;
    const Fields& d = r.report.details;
    e.closed = d.contains("closed_model") && d.at("closed_model").boolean();
    if (e.closed) {
        e.escapes = d.at("closed_model_escapes").unsigned_integer();
        e.recast = d.at("recast_rays").unsigned_integer();
    }
    e.rays = *r.report.rays_cast;
    for (Eigen::Index i = 0; i < r.form_factors.F.rows(); ++i)
        e.worst_row = std::max(e.worst_row, std::abs(r.form_factors.F.row(i).sum() - 1.0));
    return e;
}

// Every room at subdivisions `ns`, `rays` per patch, both modes: no ray escapes and every row
// sums to 1 (to the rounding of a sum of counts / N).
void check_no_escapes(const std::vector<int>& ns, std::uint64_t rays) {
    for (int n : ns)
        for (const Rooms& room : rooms(n))
            for (bool robust : {false, true}) {
                CAPTURE(room.name);
                CAPTURE(n);
                CAPTURE(robust);
                REQUIRE(check_closure(room.scene).closed);
                const Escapes e = hemisphere(room.scene, rays, robust);
                MESSAGE(room.name << ", n = " << n << std::string(robust ? ", robust" : ", default")
                                  << ": " << e.rays << " rays, " << e.recast << " re-cast, "
                                  << e.escapes << " escaped");
                CHECK(e.closed);
                CHECK(e.escapes == 0);
                CHECK(e.worst_row <= 1e-12);
            }
}

}  // namespace

TEST_CASE("closed models: rooms, bodies inside them and the built-in cube are recognised") {
    for (int n : {1, 3})
        for (const Rooms& room : rooms(n)) {
            CAPTURE(room.name);
            const Closure c = check_closure(room.scene);
            CHECK(c.watertight);
            CHECK(c.closed);
            CHECK(c.open_edges == 0);
            CHECK(c.summary().rfind("yes", 0) == 0);
        }
    CHECK(check_closure(sphere_in_room(1)).shells == 2);
    Scene cube = load_scene("cube");
    subdivide(cube, SubdivisionOptions{3, 0.0});
    CHECK(check_closure(cube).closed);
    CHECK(check_closure(l_hall()).closed);
    CHECK(check_closure(load_scene("room-4")).closed);  // a floating box of patches inside
}

TEST_CASE("closed models: holes, T-junctions, flipped faces and exposed bodies are not closed") {
    // The hall's surfaces before subdivision: the floor's long edge meets two shorter ones.
    const Closure t = check_closure(load_scene(data("closed/l_hall.obj")));
    CHECK_FALSE(t.closed);
    CHECK(t.open_edges > 0);
    CHECK(t.summary().find("open edges") != std::string::npos);

    std::vector<Polygon> faces = room_faces(box_room(), 1.0);
    std::vector<Polygon> missing(faces.begin() + 1, faces.end());
    const Closure hole = check_closure(scene_of(missing, {}, 2));
    CHECK_FALSE(hole.closed);
    CHECK(hole.open_edges == 2 * 4);  // the missing face's border, in 2 × 2 patches

    std::vector<Polygon> flipped = faces;
    std::reverse(flipped[0].vertices.begin(), flipped[0].vertices.end());
    const Closure flip = check_closure(scene_of(flipped, {}, 1));
    CHECK_FALSE(flip.closed);
    CHECK(flip.misoriented_edges == 4);

    // A sphere alone, and one outside the room: watertight, but its fronts face open space.
    const Closure alone = check_closure(scene_of(sphere_faces(Vec3::Zero(), 1, 6, 8), {}, 1));
    CHECK(alone.watertight);
    CHECK_FALSE(alone.closed);
    CHECK(alone.exposed_bodies == 1);
    std::vector<Polygon> outside = room_faces(box_room(), 1.0);
    for (const Polygon& p : sphere_faces(Vec3(5, 1, 1), 0.5, 6, 8)) outside.push_back(p);
    const Closure out = check_closure(scene_of(outside, {}, 1));
    CHECK(out.watertight);
    CHECK(out.exposed_bodies == 1);
    CHECK(out.summary().find("outwards") != std::string::npos);

    CHECK_FALSE(check_closure(load_scene("cornell")).closed);
    CHECK_FALSE(check_closure(load_scene("plates")).closed);
}

TEST_CASE("closed models: vertices jittered by 1e-9 of the size are welded, gaps of 1e-6 are not") {
    for (bool shared : {true, false}) {
        CAPTURE(shared);
        const Scene s = scene_of(jittered(room_faces(l_room(), 1.0), 1e-9, shared, 7), {}, 2);
        CHECK(check_closure(s).closed);
    }
    const Scene gap = scene_of(jittered(room_faces(l_room(), 1.0), 1e-6, false, 7), {}, 1);
    CHECK_FALSE(check_closure(gap).closed);
}

TEST_CASE(
    "closed models: rays aimed at shared vertices and edges, from patch borders, hit a front") {
    // From every vertex and edge midpoint of every patch towards every vertex of the model: each
    // ray passes exactly through a vertex (or starts on a neighbour's edge). In the cube the
    // first hit must be a patch around the aimed vertex; in the hall at least a front face.
    Scene cube = load_scene("cube");
    subdivide(cube, SubdivisionOptions{4, 0.0});
    for (bool robust : {false, true})
        for (bool convex : {true, false}) {
            const Scene& s = convex ? cube : l_hall();
            CAPTURE(robust);
            CAPTURE(convex);
            VisibilityOptions vo;
            vo.robust = robust;
            const auto vis = make_visibility(s, vo);
            REQUIRE(vis->closed());
            const WeldedPatches w = weld_patches(s);
            std::vector<RayQuery> q;
            std::vector<Vec3> aim;
            for (std::size_t i = 0; i < s.patches.size(); i += convex ? 1 : 7) {
                const auto& v = s.patches[i].polygon.vertices;
                for (std::size_t k = 0; k < v.size(); ++k)
                    for (const Vec3& o : {v[k], Vec3(0.5 * (v[k] + v[(k + 1) % v.size()]))})
                        for (std::size_t t = 0; t < w.positions.size(); t += convex ? 1 : 5) {
                            const Vec3 d = w.positions[t] - o;
                            // No ray in the plane of a face (every face is axis-aligned here).
                            if ((d.array() == 0.0).any()) continue;
                            if (!(d.normalized().dot(s.patches[i].normal) > 1e-3)) continue;
                            q.push_back({o, d, static_cast<int>(i)});
                            aim.push_back(w.positions[t]);
                        }
            }
            std::vector<RayHit> h(q.size());
            vis->first_hit(q, h);
            std::size_t bad = 0, wrong = 0;
            for (std::size_t k = 0; k < q.size(); ++k) {
                if (!(h[k].patch >= 0 && h[k].front)) {
                    ++bad;
                    continue;
                }
                if (!convex) continue;
                // The aimed vertex lies on the patch hit (within rounding).
                const Patch& p = s.patches[static_cast<std::size_t>(h[k].patch)];
                const Polygon& g = p.polygon;
                const Vec3 lo = g.vertices[0].cwiseMin(g.vertices[2]),
                           hi = g.vertices[0].cwiseMax(g.vertices[2]);
                const bool on = (aim[k].array() >= lo.array() - 1e-9).all() &&
                                (aim[k].array() <= hi.array() + 1e-9).all();
                wrong += on ? 0 : 1;
            }
            MESSAGE((convex ? std::string("cube") : std::string("hall"))
                    << (robust ? std::string(", robust: ") : std::string(", default: ")) << q.size()
                    << " rays, " << vis->recast_rays() << " re-cast");
            CHECK(bad == 0);
            CHECK(wrong == 0);
        }
}

TEST_CASE("closed models: no mc-hemisphere ray escapes the rooms (2000 rays per patch)") {
    check_no_escapes({1, 2}, 2000);
}

TEST_CASE("closed models: no mc-hemisphere ray escapes the rooms (10^5 rays per patch)" *
          doctest::test_suite("slow")) {
    check_no_escapes({1, 3}, 100000);
}

TEST_CASE("closed models: no ray escapes the 600-patch L-shaped hall at 10^5 rays per patch" *
          doctest::test_suite("slow")) {
    // Before the watertight re-cast (seed 1): 9 rows short by one ray each in the default mode,
    // 2 in the robust mode.
    const Scene s = l_hall();
    for (bool robust : {false, true}) {
        CAPTURE(robust);
        const Escapes e = hemisphere(s, 100000, robust);
        MESSAGE(std::string(robust ? "robust: " : "default: ")
                << e.rays << " rays, " << e.recast << " re-cast, " << e.escapes << " escaped");
        CHECK(e.escapes == 0);
        CHECK(e.worst_row <= 1e-12);
    }
}

TEST_CASE("closed models: no ray escapes rooms with jittered vertices (10^6 rays per patch)" *
          doctest::test_suite("slow")) {
    for (bool shared : {true, false})
        for (const Cells& cells : {l_room(), box_on_floor_room()}) {
            CAPTURE(shared);
            const Scene s = scene_of(jittered(room_faces(cells, 1.0), 1e-9, shared, 3), {}, 2);
            REQUIRE(check_closure(s).closed);
            const Escapes e = hemisphere(s, 1000000, false);
            MESSAGE(s.patches.size() << " patches: " << e.rays << " rays, " << e.recast
                                     << " re-cast, " << e.escapes << " escaped");
            CHECK(e.escapes == 0);
            CHECK(e.worst_row <= 1e-12);
        }
}

TEST_CASE("closed models: jittered rooms lose no mc-hemisphere ray (2000 rays per patch)") {
    for (bool shared : {true, false})
        for (bool robust : {false, true}) {
            CAPTURE(shared);
            CAPTURE(robust);
            const Scene s = scene_of(jittered(room_faces(u_room(), 1.0), 1e-9, shared, 5), {}, 2);
            const Escapes e = hemisphere(s, 2000, robust);
            CHECK(e.closed);
            CHECK(e.escapes == 0);
            CHECK(e.worst_row <= 1e-12);
        }
}

TEST_CASE("closed models: an open scene's report has no closed-model fields") {
    const Escapes e = hemisphere(load_scene("cornell"), 200, false);
    CHECK_FALSE(e.closed);
}

TEST_CASE("closed models: info and the JSON report say whether the model is closed") {
    testing::Cli cli;
    const testing::CliResult closed = cli.run("info cube --subdivide 2");
    REQUIRE(closed.code == 0);
    CHECK(closed.out.find("closed       yes") != std::string::npos);
    const testing::CliResult open =
        cli.run("info " + testing::shell_quote(data("closed/l_hall.obj")));
    REQUIRE(open.code == 0);
    CHECK(open.out.find("closed       no (12 open edges") != std::string::npos);
    const testing::CliResult run = cli.run(
        "compute cube --subdivide 2 --method mc-hemisphere --samples 500 -o F.csv --report r.json");
    REQUIRE(run.code == 0);
    std::ifstream in(cli.file("r.json"));
    const nlohmann::json j = nlohmann::json::parse(in);
    CHECK(j["scene"]["closed"] == true);
    CHECK(j["details"]["closed_model"] == true);
    CHECK(j["details"]["closed_model_escapes"] == 0);
    CHECK(run.err.find("escaped") == std::string::npos);
}
