#include <doctest/doctest.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "formfactor/core/error.h"
#include "formfactor/methods/hemicube.h"
#include "formfactor/methods/hemiplane.h"
#include "projection_test_scenes.h"

using namespace formfactor;
using namespace projection_test;

namespace {

// Reference values (Howell's catalog, copied from shared/reference/catalog.json).
constexpr double kB3_a1_b1_c1 = 0.13853160599489298;
constexpr double kB3_a10_b10_c1 = 0.24797140829531017;
constexpr double kB4_a1_b1_c1 = 0.05573419700255351;
constexpr double kC11_a1_b1_c1 = 0.19982489569838746;  // also the cube's opposite faces
constexpr double kC14_l1_w1_h1 = 0.20004377607540316;  // the cube's adjacent faces

FormFactors run(const Scene& s, int R, int K = 1, int threads = 0, std::uint64_t seed = 1) {
    MethodOptions o;
    o.resolution = R;
    o.points = K;
    o.threads = threads;
    o.seed = seed;
    o.progress = false;
    nlohmann::json details;
    return HemicubeMethod().compute(s, o, details);
}

}  // namespace

TEST_CASE("hemicube: point to rectangle against Howell B-3 and B-4") {
    const Scene b3 =
        make_scene({Polygon{{Vec3(0, 1, 1), Vec3(1, 1, 1), Vec3(1, 0, 1), Vec3(0, 0, 1)}}});
    const Scene b3w =
        make_scene({Polygon{{Vec3(0, 10, 1), Vec3(10, 10, 1), Vec3(10, 0, 1), Vec3(0, 0, 1)}}});
    const Scene b4 =
        make_scene({Polygon{{Vec3(0, 1, 0), Vec3(1, 1, 0), Vec3(1, 1, 1), Vec3(0, 1, 1)}}});
    for (int R : {64, 128, 256, 512, 1024}) {
        const double e1 = hemicube_point_row(b3, Vec3::Zero(), Vec3::UnitZ(), R)[0] - kB3_a1_b1_c1;
        const double e2 =
            hemicube_point_row(b3w, Vec3::Zero(), Vec3::UnitZ(), R)[0] - kB3_a10_b10_c1;
        const double e3 = hemicube_point_row(b4, Vec3::Zero(), Vec3::UnitZ(), R)[0] - kB4_a1_b1_c1;
        const double e4 =
            hemicube_point_row(b3, Vec3::Zero(), Vec3::UnitZ(), R, 0.3)[0] - kB3_a1_b1_c1;
        MESSAGE("R=" << R << " B3 " << e1 << " B3w " << e2 << " B4 " << e3 << " B3rot " << e4);
    }
}

TEST_CASE("hemicube: cube and plates") {
    const Scene pl = make_scene(plates());
    for (int R : {64, 128, 256, 512}) {
        const auto F = run(pl, R, 1).F;
        const auto F16 = run(pl, R, 16).F;
        MESSAGE("plates R=" << R << " K1 " << F(0, 1) - kC11_a1_b1_c1 << " K16 "
                            << F16(0, 1) - kC11_a1_b1_c1);
    }
    for (int n : {1, 4}) {
        const Scene cube = make_scene(cube_faces(), n);
        for (int R : {64, 256, 512}) {
            const auto F = run(cube, R, n == 1 ? 16 : 1).F;
            auto sf = [&](int a, int b) { return surface_factor(cube, F, a, b); };
            double maxrow = 0;
            for (Eigen::Index i = 0; i < F.rows(); ++i)
                maxrow = std::max(maxrow, std::abs(F.row(i).sum() - 1));
            MESSAGE("cube n=" << n << " R=" << R << " opp " << sf(0, 1) - kC11_a1_b1_c1 << " adj "
                              << sf(0, 2) - kC14_l1_w1_h1 << " rowsum " << maxrow);
        }
    }
}
