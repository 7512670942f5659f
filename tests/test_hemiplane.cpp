#include <doctest/doctest.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "formfactor/core/error.h"
#include "formfactor/methods/hemiplane.h"
#include "projection_test_scenes.h"

using namespace formfactor;
using namespace projection_test;

TEST_CASE("hemiplane: explore") {
    const Scene b3 = make_scene({Polygon{{Vec3(0, 1, 1), Vec3(1, 1, 1), Vec3(1, 0, 1), Vec3(0, 0, 1)}}});
    const Scene b4 = make_scene({Polygon{{Vec3(0, 1, 0), Vec3(1, 1, 0), Vec3(1, 1, 1), Vec3(0, 1, 1)}}});
    for (int R : {64, 128, 256, 512, 1024}) {
        auto r1 = hemiplane_point_row(b3, Vec3::Zero(), Vec3::UnitZ(), R, 0.3);
        auto r2 = hemiplane_point_row(b4, Vec3::Zero(), Vec3::UnitZ(), R, 0.3);
        MESSAGE("R=" << R << " B3 " << r1.F[0] - 0.13853160599489298 << " amb " << r1.ambiguous << " B4 " << r2.F[0] - 0.05573419700255351 << " amb " << r2.ambiguous << " negl " << r2.neglected);
    }
    const Scene pl = make_scene(plates());
    const Scene cube = make_scene(cube_faces(), 4);
    for (int R : {64, 256, 1024}) {
        MethodOptions o; o.resolution = R; o.points = 16; o.progress = false;
        nlohmann::json d;
        auto F = HemiplaneMethod().compute(pl, o, d).F;
        MESSAGE("plates R=" << R << " err " << F(0, 1) - 0.19982489569838746 << " " << d.dump());
        o.points = 1;
        auto G = HemiplaneMethod().compute(cube, o, d).F;
        MESSAGE("cube R=" << R << " opp " << surface_factor(cube, G, 0, 1) - 0.19982489569838746 << " adj " << surface_factor(cube, G, 0, 2) - 0.20004377607540316 << " row0 " << G.row(0).sum() << " " << d.dump());
    }
}
