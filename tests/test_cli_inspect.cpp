#include <doctest/doctest.h>
#include <stb/stb_image.h>

#include <filesystem>

#include "support/cli_runner.h"

using formfactor::testing::Cli;

TEST_CASE("cli inspect: the hemicube cross of a cube face, as a PNG") {
    Cli cli;
    const auto r = cli.run("inspect cube --patch 4 --resolution 64 -o view.png");
    CHECK(r.code == 0);
    CHECK(r.err.empty());
    CHECK(r.out.find("wrote") != std::string::npos);
    CHECK(r.out.find("patch 5") != std::string::npos);  // the ceiling is what it sees most
    int w = 0, h = 0, n = 0;
    unsigned char* data = stbi_load(cli.file("view.png").c_str(), &w, &h, &n, 3);
    REQUIRE(data != nullptr);
    CHECK(w == 512);  // 2R cells, scaled up to at least 512 pixels
    CHECK(h == 512);
    stbi_image_free(data);
    CHECK(cli.dir().entries() == 1);  // no temporary left behind
}

TEST_CASE("cli inspect: hemiplane, a given point, weights and the delta map") {
    Cli cli;
    CHECK(cli.run("inspect plates --patch 0 --method hemiplane --resolution 64 --point 0.2 0.3 0 "
                  "--weights -o a.png")
              .code == 0);
    const auto r = cli.run("inspect cornell --subdivide 2 --patch 3 --delta-map -o b.png");
    CHECK(r.code == 0);
    CHECK(std::filesystem::exists(cli.file("a.png")));
    CHECK(std::filesystem::exists(cli.file("b.png")));
}

TEST_CASE("cli inspect: bad options give one error line, exit code 2, and no file") {
    Cli cli;
    for (const char* args : {
             "inspect cube --patch 99 -o v.png",                   // no such patch
             "inspect cube --patch 0 --method analytic -o v.png",  // not a projection
             "inspect cube --patch 0 --resolution 63 -o v.png",    // odd resolution
             "inspect cube --patch 0 --method hemiplane --resolution 96 -o v.png",
             "inspect cube --patch 0 --weights --delta-map -o v.png",
             "inspect cube --patch 0 -o v.txt",  // not a PNG
         }) {
        CAPTURE(args);
        const auto r = cli.run(args);
        CHECK(r.code == 2);
        CHECK(r.one_error_line());
    }
    CHECK(cli.dir().entries() == 0);
    const auto missing = cli.run("inspect cube --patch 0 -o no/such/dir/v.png");
    CHECK(missing.code == 1);
    CHECK(missing.one_error_line());
}
