#include <doctest/doctest.h>
#include <stb/stb_image.h>

#include <filesystem>
#include <set>

#include "formfactor/core/atomic_file.h"
#include "formfactor/core/error.h"
#include "formfactor/methods/hemicube.h"
#include "formfactor/methods/hemiplane.h"
#include "formfactor/output/view_image.h"
#include "formfactor/scene/scene.h"
#include "support/files.h"

using namespace formfactor;

namespace {

std::filesystem::path temp_dir() { return testing::scratch_dir(); }

}  // namespace

TEST_CASE("view image: item colours are stable, distinct and mark the special items") {
    CHECK(item_colour(7) == item_colour(7));
    std::set<std::array<std::uint8_t, 3>> seen;
    for (int i = 0; i < 64; ++i) seen.insert(item_colour(i));
    CHECK(seen.size() == 64u);
    CHECK(item_colour(kViewNothing) == std::array<std::uint8_t, 3>{0, 0, 0});
    CHECK(item_colour(kViewBackFace) == std::array<std::uint8_t, 3>{64, 64, 64});
    CHECK(item_colour(kViewUnused) == std::array<std::uint8_t, 3>{255, 255, 255});
    CHECK(seen.count(item_colour(kViewNothing)) == 0);  // no patch is black
}

TEST_CASE("view image: the hemicube cross of the cube's floor centre, written as PNG") {
    const Scene cube = load_scene("cube");
    const ProjectionView v = hemicube_view(cube, Vec3(0.5, 0.5, 0), Vec3::UnitZ(), 64, 0.0, 4);
    const Image img = render_view(v, false, 2);
    REQUIRE(img.width == 256);
    REQUIRE(img.height == 256);
    const auto path = temp_dir() / "cross.png";
    std::filesystem::remove(path);
    write_png(path.string(), img);
    CHECK(std::filesystem::exists(path));
    CHECK_FALSE(std::filesystem::exists(temporary_path_for(path.string())));
    int w = 0, h = 0, n = 0;
    unsigned char* data = stbi_load(path.string().c_str(), &w, &h, &n, 3);
    REQUIRE(data != nullptr);
    CHECK(w == 256);
    CHECK(h == 256);
    auto pixel = [&](int x, int y) {
        const unsigned char* p = data + (static_cast<std::size_t>(y) * w + x) * 3;
        return std::array<std::uint8_t, 3>{p[0], p[1], p[2]};
    };
    CHECK(pixel(128, 128) == item_colour(5));        // the ceiling in the middle
    CHECK(pixel(0, 0) == item_colour(kViewUnused));  // a corner of the cross
    stbi_image_free(data);
    // Weighted by the delta form factor: the centre keeps its colour (the largest cell), the
    // horizon goes dark.
    const Image wimg = render_view(v, true, 1);
    const auto centre = item_colour(5);
    CHECK(std::abs(int(wimg.rgb[(64 * 128 + 64) * 3]) - int(centre[0])) <= 1);
    const std::size_t horizon = (64 * 128 + 127) * 3;  // right arm, outer edge
    CHECK(wimg.rgb[horizon] + wimg.rgb[horizon + 1] + wimg.rgb[horizon + 2] < 30);
    std::filesystem::remove(path);
}

TEST_CASE("view image: the delta map and the hemiplane square") {
    const Scene pl = load_scene("plates");
    const ProjectionView v = hemiplane_view(pl, Vec3(0.5, 0.5, 0), Vec3::UnitZ(), 64, 0.0, 0);
    const Image map = render_delta_map(v);
    REQUIRE(map.width == 64);
    // Brightest (yellow) in the middle, darkest at the corners.
    const std::uint8_t* mid = map.rgb.data() + (32 * 64 + 32) * 3;
    const std::uint8_t* corner = map.rgb.data();
    CHECK(mid[0] + mid[1] > corner[0] + corner[1] + 200);
    const Image items = render_view(v);
    const std::uint8_t* c = items.rgb.data() + (32 * 64 + 32) * 3;
    CHECK(std::array<std::uint8_t, 3>{c[0], c[1], c[2]} == item_colour(1));
}

TEST_CASE("view image: an unwritable path throws and leaves nothing") {
    const Image img{2, 2, std::vector<std::uint8_t>(12, 100)};
    const auto bad = temp_dir() / "no_such_dir" / "x.png";
    CHECK_THROWS_AS(write_png(bad.string(), img), Error);
    CHECK_FALSE(std::filesystem::exists(temporary_path_for(bad.string())));
    CHECK_THROWS_AS(write_png((temp_dir() / "y.png").string(), Image{}), Error);
    CHECK_THROWS_AS(render_view(ProjectionView{}), Error);
}
