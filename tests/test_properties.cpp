#include <doctest/doctest.h>

#include <filesystem>
#include <fstream>

#include "formfactor/core/error.h"
#include "formfactor/solve/properties.h"
#include "support/files.h"
#include "support/fixtures.h"

using namespace formfactor;
using namespace formfactor::testing;

namespace {

// Writes `text` to a file in this process's scratch folder and returns its path.
std::string write_temp(const std::string& name, const std::string& text) {
    return testing::write_file(name, text);
}

std::string error_of(const std::string& name, const std::string& text) {
    const Scene s = unit_cube();
    PatchProperties p = properties_from_scene(s);
    const std::string path = write_temp(name, text);
    try {
        apply_properties_csv(path, s, p);
    } catch (const InputError& e) {
        return e.what();
    }
    return "no error";
}

}  // namespace

TEST_CASE("properties: from the scene's materials, then overridden per patch and per surface") {
    Scene s = unit_cube();
    s.materials[1].reflectance = Rgb(0.1, 0.2, 0.3);
    s.materials[4].emission = Rgb(5, 6, 7);
    s.materials[2].temperature = 400.0;
    PatchProperties p = properties_from_scene(s);
    REQUIRE(p.size() == 6);
    CHECK(p.reflectance[1] == Rgb(0.1, 0.2, 0.3));
    CHECK(p.emission[4] == Rgb(5, 6, 7));
    CHECK(p.temperature[2] == 400.0);
    CHECK(std::isnan(p.temperature[0]));
    CHECK(std::isnan(p.net_flux[0]));

    const std::string a = write_temp("by_patch.csv",
                                     "# comment\n"
                                     "patch,reflectance_g,emissivity,temperature\n"
                                     "0,0.75,0.5,300\n"
                                     "\n"
                                     "5,,1,\n");
    apply_properties_csv(a, s, p);
    CHECK(p.reflectance[0] == Rgb(0.5, 0.75, 0.5));
    CHECK(p.emissivity[0] == 0.5);
    CHECK(p.temperature[0] == 300.0);
    CHECK(p.emissivity[5] == 1.0);
    CHECK(std::isnan(p.temperature[5]));  // empty cell keeps the value
    CHECK(p.reflectance[5] == Rgb(0.5, 0.5, 0.5));

    const std::string b = write_temp("by_surface.csv",
                                     "surface,net_flux,emission_r\n"
                                     "y0,-25.5,1e3\n"
                                     "\"x0\",12,\n");
    apply_properties_csv(b, s, p);
    CHECK(p.net_flux[2] == -25.5);
    CHECK(std::isnan(p.temperature[2]));  // a flux replaces the material's temperature
    CHECK(p.emission[2][0] == 1000.0);
    CHECK(p.net_flux[0] == 12.0);
    CHECK(std::isnan(p.temperature[0]));
    validate_properties(p);
}

TEST_CASE("properties: bad CSV input gives FILE:LINE errors") {
    CHECK(error_of("e1.csv", "patch,colour\n0,1\n").find("e1.csv:1: unknown column 'colour'") !=
          std::string::npos);
    CHECK(error_of("e2.csv", "patch,emissivity\n0,0.5\n1,abc\n")
              .find("e2.csv:3: emissivity: bad number 'abc'") != std::string::npos);
    CHECK(error_of("e3.csv", "surface,temperature\nfloor,300\n")
              .find("e3.csv:2: unknown surface 'floor'") != std::string::npos);
    CHECK(error_of("e4.csv", "patch,temperature\n6,300\n")
              .find("e4.csv:2: patch index 6 out of range") != std::string::npos);
    CHECK(error_of("e5.csv", "patch,emissivity\n0,0\n")
              .find("e5.csv:2: emissivity = 0 must be in (0, 1]") != std::string::npos);
    CHECK(error_of("e6.csv", "patch,emissivity\n0,1.5\n").find("e6.csv:2:") != std::string::npos);
    CHECK(error_of("e7.csv", "patch,temperature\n0,-1\n")
              .find("e7.csv:2: temperature = -1 must be") != std::string::npos);
    CHECK(error_of("e8.csv", "patch,reflectance_r\n0,1\n")
              .find("e8.csv:2: reflectance_r = 1 must be in [0, 1)") != std::string::npos);
    CHECK(
        error_of("e9.csv", "patch,temperature,net_flux\n0,300,5\n").find("e9.csv:2: give either") !=
        std::string::npos);
    CHECK(error_of("e10.csv", "patch,temperature\n0,300,5\n").find("e10.csv:2: 3 cells") !=
          std::string::npos);
    CHECK(error_of("e11.csv", "temperature\n300\n")
              .find("e11.csv:1: the header needs exactly one key") != std::string::npos);
    CHECK(
        error_of("e12.csv", "patch,temperature\n1.5,300\n").find("e12.csv:2: patch index '1.5'") !=
        std::string::npos);
    CHECK(error_of("e13.csv", "patch,emissivity,emissivity\n")
              .find("e13.csv:1: column 'emissivity' appears twice") != std::string::npos);
    CHECK(error_of("e14.csv", "").find("e14.csv: empty") != std::string::npos);
    CHECK(error_of("e15.csv", "patch,emission_b\n0,-2\n")
              .find("e15.csv:2: emission_b = -2 must be") != std::string::npos);
    const Scene s = unit_cube();
    PatchProperties p = properties_from_scene(s);
    CHECK_THROWS_WITH_AS(apply_properties_csv("/nonexistent/p.csv", s, p),
                         doctest::Contains("/nonexistent/p.csv: cannot open"), InputError);
}
