// What one MPI rank sends another (src/distributed/wire.h): the scene, a method's report and
// rows of F arrive as they left, bit for bit. No MPI needed.

#include <doctest/doctest.h>

#include <cstring>
#include <limits>

#include "distributed/wire.h"
#include "formfactor/pipeline.h"

using namespace formfactor;
using namespace formfactor::distributed;

namespace {

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

bool same_polygon(const Polygon& a, const Polygon& b) {
    if (a.size() != b.size()) return false;
    for (std::size_t k = 0; k < a.size(); ++k)
        for (int c = 0; c < 3; ++c)
            if (!same_bits(a[k][c], b[k][c])) return false;
    return true;
}

Scene round_trip(const Scene& scene) {
    WireWriter w;
    put_scene(w, scene);
    WireReader r(w.bytes().data(), w.bytes().size());
    Scene back = get_scene(r);
    CHECK(r.at_end());
    return back;
}

}  // namespace

TEST_CASE("distributed wire: a subdivided VS3 scene arrives with every patch bit for bit") {
    SceneOptions so;
    so.source = std::string(FF_TEST_DATA_DIR) + "/room-4-obstruction.vs3";
    so.subdivision.n = 2;
    const Scene scene = prepare_scene(so);
    REQUIRE(scene.vs3_control.has_value());
    REQUIRE(scene.obstruction_count() > 0);
    const Scene back = round_trip(scene);
    CHECK(back.name == scene.name);
    CHECK(back.title == scene.title);
    CHECK(back.enclosure == scene.enclosure);
    CHECK(back.warnings == scene.warnings);
    REQUIRE(back.vs3_control.has_value());
    CHECK(back.vs3_control->maxU == scene.vs3_control->maxU);
    CHECK(same_bits(back.vs3_control->eps, scene.vs3_control->eps));
    REQUIRE(back.materials.size() == scene.materials.size());
    for (std::size_t m = 0; m < scene.materials.size(); ++m) {
        CHECK(back.materials[m].name == scene.materials[m].name);
        CHECK(same_bits(back.materials[m].emissivity, scene.materials[m].emissivity));
        CHECK(back.materials[m].reflectance == scene.materials[m].reflectance);
    }
    REQUIRE(back.surfaces.size() == scene.surfaces.size());
    for (std::size_t s = 0; s < scene.surfaces.size(); ++s) {
        CHECK(back.surfaces[s].name == scene.surfaces[s].name);
        CHECK(back.surfaces[s].obstruction == scene.surfaces[s].obstruction);
        CHECK(back.surfaces[s].base == scene.surfaces[s].base);
        CHECK(back.surfaces[s].combine == scene.surfaces[s].combine);
        CHECK(back.surfaces[s].where.line == scene.surfaces[s].where.line);
        CHECK(same_polygon(back.surfaces[s].polygon, scene.surfaces[s].polygon));
    }
    REQUIRE(back.patches.size() == scene.patches.size());
    for (std::size_t i = 0; i < scene.patches.size(); ++i) {
        CHECK(same_polygon(back.patches[i].polygon, scene.patches[i].polygon));
        CHECK(back.patches[i].surface == scene.patches[i].surface);
        CHECK(same_bits(back.patches[i].area, scene.patches[i].area));
        CHECK(back.patches[i].normal == scene.patches[i].normal);
        CHECK(back.patches[i].centroid == scene.patches[i].centroid);
    }
}

TEST_CASE("distributed wire: a scene's camera and unset temperatures survive") {
    Scene scene = load_scene("cornell");
    scene.camera = Camera{Vec3(1, 2, 3), Vec3(0, 0.5, 0), Vec3::UnitZ(), 33.0};
    scene.materials.front().temperature = std::numeric_limits<double>::quiet_NaN();
    const Scene back = round_trip(scene);
    REQUIRE(back.camera.has_value());
    CHECK(back.camera->eye == scene.camera->eye);
    CHECK(back.camera->up == scene.camera->up);
    CHECK(back.camera->fov_degrees == 33.0);
    CHECK(std::isnan(back.materials.front().temperature));
    CHECK(back.surfaces.size() == scene.surfaces.size());
}

TEST_CASE("distributed wire: a method report keeps its counts and nested details") {
    MethodReport report;
    report.method = MethodKind::mc_hemisphere;
    report.rays_cast = 123456789012ULL;
    report.pairs = PairClasses{10, 2, 7, 1};
    report.details = Fields::object();
    report.details["closed_model_escapes"] = std::uint64_t{5};
    report.details["note"] = "text";
    report.details["levels"] = std::vector<double>{1.5, -2.0};
    report.details["inner"] = Fields::object();
    report.details["inner"]["flag"] = true;
    report.details["inner"]["delta"] = -7;
    WireWriter w;
    put_report(w, report);
    WireReader r(w.bytes().data(), w.bytes().size());
    const MethodReport back = get_report(r);
    CHECK(r.at_end());
    CHECK(back.method == MethodKind::mc_hemisphere);
    CHECK(back.rays_cast == report.rays_cast);
    CHECK(!back.seconds.has_value());
    REQUIRE(back.pairs.has_value());
    CHECK(back.pairs->exact == 7);
    CHECK(back.details.at("closed_model_escapes").unsigned_integer() == 5);
    CHECK(back.details.at("note").text() == "text");
    CHECK(back.details.at("levels").reals() == std::vector<double>{1.5, -2.0});
    CHECK(back.details.at("inner").at("flag").boolean());
    CHECK(back.details.at("inner").at("delta").integer() == -7);
}

TEST_CASE("distributed wire: a dense block's non-zero entries keep NaN and drop only zeros") {
    FormFactors block;
    block.first_row = 4;
    block.F = DenseMatrix(2, 3);
    block.F << 0.0, 0.25, -0.0, std::numeric_limits<double>::quiet_NaN(), 0.0, -1e-300;
    block.standard_error = DenseMatrix::Constant(2, 3, 0.5);
    const SparseRows rows = nonzero_rows(block);
    WireWriter w;
    put_sparse_rows(w, rows);
    WireReader r(w.bytes().data(), w.bytes().size());
    const SparseRows back = get_sparse_rows(r);
    CHECK(r.at_end());
    CHECK(back.first_row == 4);
    REQUIRE(back.size() == 2);
    CHECK(back.indices[0] == std::vector<std::int32_t>{1});
    CHECK(back.values[0] == std::vector<double>{0.25});
    CHECK(back.indices[1] == std::vector<std::int32_t>{0, 2});
    CHECK(std::isnan(back.values[1][0]));
    CHECK(back.values[1][1] == -1e-300);
    CHECK(back.standard_error[1] == std::vector<double>{0.5, 0.5});
}

TEST_CASE("distributed wire: a message cut short is an error, not a read past its end") {
    WireWriter w;
    put_scene(w, load_scene("cornell"));
    WireReader r(w.bytes().data(), w.bytes().size() / 2);
    CHECK_THROWS_AS(get_scene(r), Error);
}
