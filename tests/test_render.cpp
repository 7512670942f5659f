#include <doctest/doctest.h>
#include <stb/stb_image.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "formfactor/core/error.h"
#include "formfactor/methods/method.h"
#include "formfactor/output/render.h"
#include "formfactor/solve/radiosity.h"
#include "output/render_internal.h"
#include "support/files.h"
#include "support/fixtures.h"
#include "support/method_runner.h"

using namespace formfactor;
using namespace formfactor::testing;

namespace {

std::string temp_path(const std::string& name) { return (testing::scratch_dir() / name).string(); }

struct Png {
    int w = 0, h = 0;
    std::vector<unsigned char> rgb;
    const unsigned char* at(int x, int y) const {
        return rgb.data() + 3 * (static_cast<std::size_t>(y) * std::size_t(w) + std::size_t(x));
    }
};

Png read_png(const std::string& path) {
    Png p;
    int n = 0;
    unsigned char* data = stbi_load(path.c_str(), &p.w, &p.h, &n, 3);
    REQUIRE(data != nullptr);
    p.rgb.assign(data, data + 3 * std::size_t(p.w) * std::size_t(p.h));
    stbi_image_free(data);
    return p;
}

}  // namespace

TEST_CASE("render: an open box, read back: size, red left wall, green right wall") {
    std::vector<Rgb> radiance;
    const Scene s = open_box_scene(4, radiance);
    RenderOptions o;
    o.width = 160;
    o.height = 120;
    RenderInfo info;
    const Image img = render_radiosity(s, radiance, o, &info);
    CHECK(info.triangles == 5 * 16 * 2);
    CHECK(info.exposure > 0.0);
    const std::string path = temp_path("box.png");
    std::filesystem::remove(path);
    write_png(path, img);
    const Png png = read_png(path);
    CHECK(png.w == 160);
    CHECK(png.h == 120);
    // 4:3 image, 40° vertical field: the opening (distance 1.5) spans ±69 % of the half-width
    // and the back wall (distance 2.5) ±41 %, so the left wall covers 15–30 % of the width and
    // the right wall, mirrored, 70–85 %; the back wall is in the middle.
    for (int y : {40, 60, 80}) {
        const unsigned char* l = png.at(36, y);
        const unsigned char* r = png.at(124, y);
        CHECK(l[0] > 2 * l[1]);
        CHECK(l[0] > 2 * l[2]);
        CHECK(r[1] > 2 * r[0]);
        CHECK(r[1] > 2 * r[2]);
        const unsigned char* b = png.at(80, y);
        CHECK(std::abs(int(b[0]) - int(b[1])) < 3);
        CHECK(b[0] > 100);
    }
    // The corners of the image see out through the opening: background.
    CHECK(png.at(0, 0)[0] == 0);
    // Flat shading and a manual exposure give the same wall colours (constant per wall).
    o.flat = true;
    o.exposure = 1.0;
    const Image flat = render_radiosity(s, radiance, o);
    CHECK(int(flat.pixel(36, 60)[0]) == int(detail::linear_to_srgb8(0.6)));
}

TEST_CASE("render: Gouraud smoothing shares vertices within a plane, never across a corner") {
    std::vector<Rgb> radiance;
    const Scene s = open_box_scene(4, radiance);
    // A gradient on the back wall, to see the averaging.
    for (std::size_t i = 64; i < 80; ++i) radiance[i] = Rgb::Constant(double(i - 64));
    const detail::ShadedMesh smooth = detail::shaded_mesh(s, radiance, false);
    const detail::ShadedMesh flat = detail::shaded_mesh(s, radiance, true);
    CHECK(smooth.positions.size() == 5 * 25);  // 5×5 grid per wall, corners not shared
    CHECK(flat.positions.size() == 5 * 16 * 4);
    CHECK(smooth.triangles.size() == 5 * 16 * 2);
    // Left-wall vertices stay pure red (no white from the floor or the back wall).
    for (std::size_t t = 0; t < smooth.triangles.size(); ++t)
        if (smooth.triangle_patch[t] < 16)
            for (int v : smooth.triangles[t]) CHECK(smooth.values[std::size_t(v)] == radiance[0]);
    // The back wall's centre vertex (2, 2) averages patches 5, 6, 9, 10 of that wall.
    bool found = false;
    for (std::size_t v = 0; v < smooth.positions.size(); ++v)
        if ((smooth.positions[v] - Vec3(0.5, 0.5, 0.0)).norm() < 1e-12) {
            CHECK(smooth.values[v][0] == doctest::Approx((5 + 6 + 9 + 10) / 4.0));
            found = true;
        }
    CHECK(found);
}

TEST_CASE("render: false colour with a colour bar") {
    std::vector<Rgb> radiance;
    const Scene s = open_box_scene(2, radiance);
    FalseColourField f;
    for (std::size_t i = 0; i < s.patches.size(); ++i) f.values.push_back(300.0 + double(i));
    f.label = "temperature";
    f.unit = "K";
    RenderOptions o;
    o.width = 320;
    o.height = 240;
    RenderInfo info;
    const Image img = render_false_colour(s, f, o, &info);
    CHECK(info.value_min == 300.0);
    CHECK(info.value_max == 319.0);
    const std::string path = temp_path("false.png");
    write_png(path, img);
    const Png png = read_png(path);
    CHECK(png.w == 320);
    // Find the bar: the column in the right panel whose top is bright yellow (inferno's top)
    // and bottom near black.
    bool bar = false;
    for (int x = 200; x < 320 && !bar; ++x) {
        const unsigned char* top = png.at(x, 40);
        const unsigned char* bottom = png.at(x, 225);
        if (top[0] > 200 && top[1] > 200 && top[2] < 180 && bottom[0] < 40 && bottom[1] < 40)
            bar = true;
    }
    CHECK(bar);
    // Some text pixels (the labels are light grey 235).
    int text = 0;
    for (int y = 0; y < 240; ++y)
        for (int x = 200; x < 320; ++x)
            if (png.at(x, y)[0] == 235 && png.at(x, y)[1] == 235) ++text;
    CHECK(text > 50);
    CHECK(colormap_inferno(0.0).maxCoeff() < 0.05);
    CHECK(colormap_inferno(1.0)[0] > 0.95);
}

TEST_CASE("render: PLY and glTF exports with vertex colours") {
    std::vector<Rgb> radiance;
    const Scene s = open_box_scene(2, radiance);
    const std::string ply = temp_path("box.ply");
    ExportOptions eo;
    eo.binary = false;
    write_mesh(ply, s, radiance, eo);
    std::ifstream in(ply);
    std::string line;
    std::getline(in, line);
    CHECK(line == "ply");
    bool vertices = false, faces = false;
    while (std::getline(in, line) && line != "end_header") {
        if (line == "element vertex 45") vertices = true;  // 9 per wall
        if (line == "element face 40") faces = true;
    }
    CHECK(vertices);
    CHECK(faces);

    const std::string gltf = temp_path("box.gltf");
    write_mesh(gltf, s, radiance);
    std::ifstream gin(gltf);
    const nlohmann::json j = nlohmann::json::parse(gin);
    CHECK(j["asset"]["version"] == "2.0");
    CHECK(j["accessors"][0]["count"] == 45);
    CHECK(j["accessors"][2]["count"] == 120);
    const std::string uri = j["buffers"][0]["uri"];
    const std::size_t b64 = uri.size() - uri.find(',') - 1;
    CHECK(b64 == (std::size_t(j["buffers"][0]["byteLength"]) + 2) / 3 * 4);
    const std::size_t bytes = j["buffers"][0]["byteLength"];
    CHECK(bytes == 45 * 12 * 2 + 120 * 4);

    const std::string glb = temp_path("box.glb");
    write_mesh(glb, s, radiance);
    CHECK(std::filesystem::file_size(glb) > bytes);
    CHECK_THROWS_AS(write_mesh(temp_path("box.stl"), s, radiance), OptionError);
}

TEST_CASE("render: bad sizes, cameras and value counts are errors") {
    std::vector<Rgb> radiance;
    const Scene s = open_box_scene(1, radiance);
    RenderOptions o;
    o.width = 0;
    CHECK_THROWS_AS(render_radiosity(s, radiance, o), OptionError);
    o.width = 10;
    Camera c;
    c.eye = c.target = Vec3::Zero();
    o.camera = c;
    CHECK_THROWS_AS(render_radiosity(s, radiance, o), OptionError);
    o.camera.reset();
    radiance.pop_back();
    CHECK_THROWS_AS(render_radiosity(s, radiance, o), Error);
    // Auto camera: sees the whole box (every patch drawn) when the scene has no camera.
    std::vector<Rgb> r2;
    Scene t = open_box_scene(1, r2);
    t.camera.reset();
    RenderInfo info;
    o.width = 64;
    o.height = 64;
    o.back_faces = true;
    render_radiosity(t, r2, o, &info);
    CHECK(info.triangles == 10);
    CHECK_THROWS_AS(write_png("/nonexistent-dir/x.png", render_radiosity(t, r2, o)), InputError);
}

TEST_CASE("render: the empty Cornell box solved and seen through its published camera") {
    Scene s = load_scene("cornell-empty");
    subdivide(s, SubdivisionOptions{4, 0.0});
    MethodOptions mo;
    nlohmann::json details;
    const FormFactors ff = run_method(*make_method("analytic"), s, mo, details);
    const RadiosityResult r = solve_radiosity(ff, properties_from_scene(s));
    RenderOptions o;
    o.width = 120;
    o.height = 90;
    for (std::size_t i = 0; i < s.patches.size(); ++i)
        o.emitters.push_back(
            s.materials[std::size_t(s.surfaces[std::size_t(s.patches[i].surface)].material)]
                .emission.maxCoeff() > 0.0);
    const std::string path = temp_path("cornell.png");
    write_png(path, render_radiosity(s, r.radiosity, o));
    const Png png = read_png(path);
    CHECK(png.w == 120);
    CHECK(png.h == 90);
    // The camera looks along +z with +y up: the red wall (x ≈ 556) is on the left, the green
    // one (x = 0) on the right; colour bleeding keeps them clearly red and green.
    for (int y : {30, 45, 60}) {
        const unsigned char* l = png.at(18, y);
        const unsigned char* rr = png.at(101, y);
        CHECK(l[0] > l[1] + 60);
        CHECK(l[0] > l[2] + 60);
        CHECK(rr[1] > rr[0] + 20);
        CHECK(rr[1] > rr[2] + 40);
    }
    // Colour bleeding: the white back wall near the red wall is redder than near the green one.
    const unsigned char* bl = png.at(34, 45);
    const unsigned char* br = png.at(86, 45);
    CHECK(int(bl[0]) - int(bl[1]) > int(br[0]) - int(br[1]));
}
