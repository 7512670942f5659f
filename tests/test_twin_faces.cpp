// Twin faces: a thin plate modelled as two one-sided faces back to back (tests/data/
// twin_faces.obj: a unit floor and, 0.5 above it, fin_up facing up and fin_down facing the
// floor). A ray or a projected cell that meets the back of fin_up first belongs to fin_down
// (visibility.h, "Twin faces"); a back face with nothing coincident, and an obstruction from
// either side, still block. Every method on the file, and the visibility rule itself.
#include <doctest/doctest.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "formfactor/methods/hemicube.h"
#include "formfactor/methods/hemiplane.h"
#include "formfactor/methods/method.h"
#include "formfactor/scene/scene.h"
#include "formfactor/visibility/visibility.h"
#include "support/lambert.h"
#include "support/method_runner.h"
#include "support/scenes.h"

using formfactor::testing::run_method;

using namespace formfactor;

namespace {

// Howell C-11 with a = b = 1, c = 0.5 (X = Y = 2): floor → fin_down, and back (equal areas).
constexpr double kExact = 0.4152532835771468;
// Patches of twin_faces.obj.
constexpr int kFloor = 0, kFinUp = 1, kFinDown = 2;

Scene twin_scene() { return load_scene(std::string(FF_TEST_DATA_DIR) + "/twin_faces.obj"); }

const Polygon kFloorQuad =
    testing::quad(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0));
const Polygon kUpQuad =
    testing::quad(Vec3(0, 0, 0.5), Vec3(1, 0, 0.5), Vec3(1, 1, 0.5), Vec3(0, 1, 0.5));
const Polygon kDownQuad =
    testing::quad(Vec3(0, 0, 0.5), Vec3(0, 1, 0.5), Vec3(1, 1, 0.5), Vec3(1, 0, 0.5));

// The twins meshed differently, listed down face first: the floor (patch 0), fin_down split
// 3 × 3 (patches 1–9), fin_up split 2 × 2 (patches 10–13). Credit must go cell by cell or ray
// by ray to the fin_down piece actually reached, whatever the order the surfaces come in.
Scene mismatched_twins() {
    Scene s;
    s.name = "mismatched twins";
    s.materials.push_back({});
    auto add = [&](const Polygon& p, int n) {
        Surface surf;
        surf.polygon = p;
        s.surfaces.push_back(surf);
        for (const Polygon& c : testing::split_quad(p, n))
            s.patches.push_back(make_patch(c, static_cast<int>(s.surfaces.size()) - 1));
    };
    add(kFloorQuad, 1);
    add(kDownQuad, 3);
    add(kUpQuad, 2);
    return s;
}
constexpr int kDownFirst = 1, kDownEnd = 10, kUpEnd = 14;

FormFactors run(const std::string& method, const Scene& s, const MethodOptions& base,
                nlohmann::json* details = nullptr) {
    MethodOptions o = base;
    nlohmann::json d;
    FormFactors ff = run_method(*make_method(method), s, o, d);
    if (details) *details = d;
    return ff;
}

MethodOptions mc_options(std::uint64_t samples) {
    MethodOptions o;
    o.samples = samples;
    o.seed = 3;
    o.sampler =
        SamplerKind::sobol;  // 16 replicates: (F − exact)/SE ~ Student t(15), 5 SE (see test_mc)
    return o;
}

MethodOptions projection_options(int resolution, int points) {
    MethodOptions o;
    o.resolution = resolution;
    o.points = points;
    return o;
}

// The physics of the twin file whatever the method: fin_up faces into nothing (its row is 0),
// nothing reaches its back from the floor, nothing is its own neighbour, and no row exceeds 1.
void check_twin_physics(const DenseMatrix& F) {
    REQUIRE(F.rows() == 3);
    CHECK(F(kFloor, kFinUp) == 0.0);
    CHECK(F(kFinDown, kFinUp) == 0.0);
    CHECK(F.row(kFinUp).cwiseAbs().sum() == 0.0);
    CHECK(F(kFinDown, kFinDown) == 0.0);
    CHECK(F(kFloor, kFloor) == 0.0);
    for (Eigen::Index i = 0; i < 3; ++i) CHECK(F.row(i).sum() <= 1.0);
    CHECK(F.minCoeff() >= 0.0);
}

// Monte Carlo: floor ↔ fin_down within 5 standard errors (a bias as small as the historical
// 0.32 vs 0.415 is hundreds of SE away), the twin physics exact.
void check_mc(const std::string& method, std::uint64_t samples) {
    CAPTURE(method);
    const FormFactors ff = run(method, twin_scene(), mc_options(samples));
    REQUIRE(ff.standard_error);
    const DenseMatrix& se = *ff.standard_error;
    check_twin_physics(ff.F);
    for (const auto& pair : {std::pair{kFloor, kFinDown}, std::pair{kFinDown, kFloor}}) {
        const auto i = pair.first, j = pair.second;  // no structured binding: clang 14 cannot
        CAPTURE(i);                                  // capture one in CAPTURE's lambda
        CAPTURE(j);
        const double f = ff.F(i, j), e = se(i, j);
        CAPTURE(f);
        CAPTURE(e);
        CHECK(e < 0.01);
        CHECK(std::abs(f - kExact) <= 5.0 * e + 1e-12);  // mc-target: exact, SE 0
    }
}

// Floor → the fin_down pieces of mismatched_twins(): their sum against C-11 within k SE of the
// sum (entries' SEs added in quadrature: conservative for a row's negatively correlated hit
// counts), every fin_up piece exactly 0.
void check_mc_mismatched(const std::string& method, std::uint64_t samples) {
    CAPTURE(method);
    const Scene s = mismatched_twins();
    const FormFactors ff = run(method, s, mc_options(samples));
    double sum = 0, var = 0;
    for (int j = kDownFirst; j < kDownEnd; ++j) {
        sum += ff.F(0, j);
        var += (*ff.standard_error)(0, j) * (*ff.standard_error)(0, j);
    }
    CAPTURE(sum);
    CAPTURE(std::sqrt(var));
    CHECK(std::abs(sum - kExact) <= 5.0 * std::sqrt(var) + 1e-12);
    for (int j = kDownEnd; j < kUpEnd; ++j) CHECK(ff.F(0, j) == 0.0);
}

// Projection methods: floor → the fin_down pieces of mismatched_twins() (fin_down first, so a
// draw-order tie would go the wrong way), and the fin_up pieces exactly 0.
void check_projection_mismatched(const std::string& method, const MethodOptions& o, double tol) {
    CAPTURE(method);
    const Scene s = mismatched_twins();
    const DenseMatrix F = run(method, s, o).F;
    double sum = 0;
    for (int j = kDownFirst; j < kDownEnd; ++j) sum += F(0, j);
    CAPTURE(sum);
    CHECK(std::abs(sum - kExact) < tol);
    for (int j = kDownEnd; j < kUpEnd; ++j) CHECK(F(0, j) == 0.0);
}

RayHit first_hit(const Visibility& v, const RayQuery& q) {
    RayHit h;
    v.first_hit(std::span<const RayQuery>(&q, 1), std::span<RayHit>(&h, 1));
    return h;
}

bool blocked(const Visibility& v, const SegmentQuery& q) {
    std::uint8_t b = 7;
    v.occluded(std::span<const SegmentQuery>(&q, 1), std::span<std::uint8_t>(&b, 1));
    return b != 0;
}

// Rays from a grid of floor points in a fan of directions that all cross z = 0.5 inside the
// unit square, in every batching mode: how many first hits went to each patch / outcome.
struct HitTally {
    int front = 0, back = 0, obstruction = 0, miss = 0;
    std::vector<int> by_patch;
};
HitTally tally_up_rays(const Scene& s, VisibilityOptions::Batching batching, int from_patch) {
    VisibilityOptions vo;
    vo.batching = batching;
    auto v = make_visibility(s, vo);
    std::vector<RayQuery> q;
    for (int a = 0; a < 9; ++a)
        for (int b = 0; b < 9; ++b)
            for (int k = 0; k < 12; ++k) {
                const Vec3 x(0.1 + 0.1 * a, 0.1 + 0.1 * b, 0.0);
                // Targets on the plate, inside it by at least 0.01.
                const Vec3 t(0.01 + 0.98 * ((a * 7 + k * 5) % 12) / 11.0,
                             0.01 + 0.98 * ((b * 5 + k * 7) % 12) / 11.0, 0.5);
                q.push_back({x, t - x, from_patch});
            }
    std::vector<RayHit> h(q.size());
    v->first_hit(q, h);
    HitTally t;
    t.by_patch.assign(s.patches.size(), 0);
    for (std::size_t k = 0; k < h.size(); ++k) {
        const RayHit& r = h[k];
        if (r.patch == RayHit::kMiss) {
            ++t.miss;
        } else if (r.patch == RayHit::kObstructionHit) {
            ++t.obstruction;
        } else {
            (r.front ? t.front : t.back)++;
            ++t.by_patch[static_cast<std::size_t>(r.patch)];
            // The distance is the plate's (all hits here are within 1e-4 of z = 0.5).
            CHECK(std::abs(r.distance * q[k].direction.normalized().z() - 0.5) < 2e-4);
        }
    }
    return t;
}

constexpr VisibilityOptions::Batching kBatchings[] = {VisibilityOptions::Batching::single,
                                                      VisibilityOptions::Batching::packet16,
                                                      VisibilityOptions::Batching::stream};

}  // namespace

TEST_CASE("twin faces: a first hit on the back of a twin goes to the front face behind it") {
    const Scene file = twin_scene();
    REQUIRE(file.patches.size() == 3u);
    const Scene reordered =
        testing::scene_of({kFloorQuad, kDownQuad, kUpQuad});  // fin_down before fin_up
    for (auto batching : kBatchings) {
        CAPTURE(static_cast<int>(batching));
        const HitTally a = tally_up_rays(file, batching, kFloor);
        CHECK(a.front == 972);
        CHECK(a.by_patch[kFinDown] == 972);
        CHECK(a.back + a.obstruction + a.miss == 0);
        const HitTally b = tally_up_rays(reordered, batching, 0);
        CHECK(b.front == 972);
        CHECK(b.by_patch[1] == 972);  // fin_down
    }
    // Shadow rays to a point of either twin are not blocked by the other (their ends are moved
    // off the plane towards the floor).
    auto v = make_visibility(file);
    for (int to : {kFinDown, kFinUp}) {
        CHECK_FALSE(blocked(*v, {Vec3(0.2, 0.3, 0), Vec3(0.7, 0.6, 0.5), kFloor, to}));
        CHECK_FALSE(blocked(*v, {Vec3(0.7, 0.6, 0.5), Vec3(0.2, 0.3, 0), to, kFloor}));
    }
    // From fin_down down to the floor, and from fin_up up into nothing.
    const RayHit down = first_hit(*v, {Vec3(0.5, 0.5, 0.5), Vec3(0.1, 0.2, -1), kFinDown});
    CHECK(down.patch == kFloor);
    CHECK(down.front);
    CHECK(first_hit(*v, {Vec3(0.5, 0.5, 0.5), Vec3(0.1, 0.2, 1), kFinUp}).patch == RayHit::kMiss);
}

TEST_CASE("twin faces: a back face with nothing coincident, and an obstruction, still block") {
    const Polygon ceiling =
        testing::quad(Vec3(0, 0, 1), Vec3(0, 1, 1), Vec3(1, 1, 1), Vec3(1, 0, 1));  // faces down
    // fin_up alone between the floor and a ceiling: a genuine back face.
    const Scene lone = testing::scene_of({kFloorQuad, kUpQuad, ceiling});
    // An obstruction plate there instead: blocks from both sides.
    const Scene plate = testing::scene_of({kFloorQuad, ceiling}, {kUpQuad});
    // fin_up a little below fin_down (an inverted thin plate). The offset is 1e-5 of the
    // diagonal (1.7e-5 here): 1e-4 below, fin_up's back is a genuine blocker; 5e-6 below, the two
    // are twins.
    auto up_at = [](double z) {
        return testing::quad(Vec3(0, 0, z), Vec3(1, 0, z), Vec3(1, 1, z), Vec3(0, 1, z));
    };
    const Scene apart = testing::scene_of({kFloorQuad, up_at(0.5 - 1e-4), kDownQuad, ceiling});
    const Scene close = testing::scene_of({kFloorQuad, up_at(0.5 - 5e-6), kDownQuad, ceiling});
    for (auto batching : kBatchings) {
        CAPTURE(static_cast<int>(batching));
        const HitTally a = tally_up_rays(lone, batching, 0);
        CHECK(a.back == 972);
        CHECK(a.by_patch[1] == 972);
        const HitTally b = tally_up_rays(plate, batching, 0);
        CHECK(b.obstruction == 972);
        const HitTally c = tally_up_rays(apart, batching, 0);
        CHECK(c.back == 972);
        CHECK(c.by_patch[1] == 972);
        const HitTally d = tally_up_rays(close, batching, 0);
        CHECK(d.front == 972);
        CHECK(d.by_patch[2] == 972);
    }
    auto v = make_visibility(lone);
    CHECK(blocked(*v, {Vec3(0.2, 0.3, 0), Vec3(0.6, 0.7, 1), 0, 2}));
    auto w = make_visibility(plate);
    CHECK(blocked(*w, {Vec3(0.2, 0.3, 0), Vec3(0.6, 0.7, 1), 0, 1}));
    CHECK(blocked(*w, {Vec3(0.6, 0.7, 1), Vec3(0.2, 0.3, 0), 1, 0}));
    CHECK(first_hit(*w, {Vec3(0.5, 0.5, 1), Vec3(0.1, 0, -1), 1}).patch == RayHit::kObstructionHit);
    // The methods agree: nothing reaches the ceiling through either.
    MethodOptions o = mc_options(4096);
    for (const std::string m : {"mc-hemisphere", "mc-area", "mc-target"}) {
        CAPTURE(m);
        CHECK(run(m, lone, o).F(0, 2) == 0.0);
        CHECK(run(m, plate, o).F(0, 1) == 0.0);
        CHECK(run(m, plate, o).F(1, 0) == 0.0);
    }
    for (const std::string m : {"hemicube", "hemiplane"}) {
        CAPTURE(m);
        const MethodOptions p = projection_options(128, 4);
        CHECK(run(m, lone, p).F(0, 2) == 0.0);
        CHECK(run(m, lone, p).F(0, 1) == 0.0);
        CHECK(run(m, plate, p).F(0, 1) == 0.0);
        CHECK(run(m, plate, p).F(1, 0) == 0.0);
    }
}

TEST_CASE("twin faces: a patch lying on an obstruction is seen, the obstruction blocks the rest") {
    // fin_down on an obstruction plate of the same size: the floor sees fin_down (exact C-11),
    // and nothing beyond (a ceiling above the plate gets 0).
    const Polygon ceiling =
        testing::quad(Vec3(0, 0, 1), Vec3(0, 1, 1), Vec3(1, 1, 1), Vec3(1, 0, 1));
    const Scene s = testing::scene_of({kFloorQuad, kDownQuad, ceiling}, {kUpQuad});
    for (auto batching : kBatchings) {
        const HitTally a = tally_up_rays(s, batching, 0);
        CHECK(a.by_patch[1] == 972);
    }
    const FormFactors mc = run("mc-hemisphere", s, mc_options(1 << 16));
    CHECK(std::abs(mc.F(0, 1) - kExact) <= 5.0 * (*mc.standard_error)(0, 1));
    CHECK(mc.F(0, 2) == 0.0);
    const DenseMatrix hc = run("hemicube", s, projection_options(256, 16)).F;
    CHECK(std::abs(hc(0, 1) - kExact) < 2e-4);
    CHECK(hc(0, 2) == 0.0);
}

TEST_CASE("twin faces: mc-hemisphere") {
    check_mc("mc-hemisphere", 1 << 16);
    check_mc_mismatched("mc-hemisphere", 1 << 16);
}

TEST_CASE("twin faces: mc-area") {
    check_mc("mc-area", 1 << 14);
    check_mc_mismatched("mc-area", 1 << 12);
}

TEST_CASE("twin faces: mc-target") {
    check_mc("mc-target", 1 << 10);
    check_mc_mismatched("mc-target", 1 << 10);
}

TEST_CASE("twin faces: hemicube") {
    // 16 Gauss points per patch (point-to-area error ~1e-6) at R = 256: aliasing along the
    // plate's outline, a few 1e-5 (hemicube tests: the plates within 1e-4).
    nlohmann::json d;
    const DenseMatrix F = run("hemicube", twin_scene(), projection_options(256, 16)).F;
    check_twin_physics(F);
    CHECK(std::abs(F(kFloor, kFinDown) - kExact) < 2e-4);
    CHECK(std::abs(F(kFinDown, kFloor) - kExact) < 2e-4);
    check_projection_mismatched("hemicube", projection_options(256, 16), 2e-4);
    // The centre cell of the floor's hemicube is fin_down's, not the back face's.
    const ProjectionView v =
        hemicube_view(twin_scene(), Vec3(0.5, 0.5, 0), Vec3::UnitZ(), 128, 0.0, kFloor);
    CHECK(v.item(128, 128) == kFinDown);  // the middle of the top face
}

TEST_CASE("twin faces: hemiplane") {
    // R = 512, 16 points: the discretisation error is bounded by the ambiguous fraction.
    nlohmann::json d;
    const DenseMatrix F = run("hemiplane", twin_scene(), projection_options(512, 16), &d).F;
    check_twin_physics(F);
    const double amb = d["ambiguous_max"].get<double>();
    CAPTURE(amb);
    CHECK(std::abs(F(kFloor, kFinDown) - kExact) <= amb);
    CHECK(std::abs(F(kFloor, kFinDown) - kExact) < 1e-3);
    CHECK(std::abs(F(kFinDown, kFloor) - kExact) < 1e-3);
    check_projection_mismatched("hemiplane", projection_options(512, 16), 1e-3);
    const ProjectionView v =
        hemiplane_view(twin_scene(), Vec3(0.5, 0.5, 0), Vec3::UnitZ(), 64, 0.0, kFloor);
    CHECK(v.item(32, 32) == kFinDown);
}

TEST_CASE("twin faces: analytic") {
    MethodOptions o;
    const DenseMatrix F = run("analytic", twin_scene(), o).F;
    check_twin_physics(F);
    CHECK(std::abs(F(kFloor, kFinDown) - kExact) < 1e-9);
    CHECK(std::abs(F(kFinDown, kFloor) - kExact) < 1e-9);
    // The twins meshed differently: each entry within the obstructed tolerance (1e-6).
    const Scene s = mismatched_twins();
    const DenseMatrix G = run("analytic", s, o).F;
    double sum = 0;
    for (int j = kDownFirst; j < kDownEnd; ++j) sum += G(0, j);
    CHECK(std::abs(sum - kExact) < 9e-6);
    for (int j = kDownEnd; j < kUpEnd; ++j) CHECK(G(0, j) == 0.0);
}
