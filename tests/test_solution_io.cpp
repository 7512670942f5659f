#include <doctest/doctest.h>

#include <filesystem>
#include <fstream>

#include "formfactor/core/error.h"
#include "formfactor/output/solution_io.h"
#include "support/files.h"
#include "support/fixtures.h"

using namespace formfactor;
using namespace formfactor::testing;

namespace {

std::string temp_file(const std::string& name, const std::string& text = "") {
    const std::string p = (testing::scratch_dir() / name).string();
    if (!text.empty()) testing::write_text(p, text);
    return p;
}

std::string error_of(const std::string& name, const std::string& text,
                     std::optional<std::size_t> n = std::nullopt) {
    try {
        read_solution_csv(temp_file(name, text), n);
    } catch (const InputError& e) {
        return e.what();
    }
    return "no error";
}

}  // namespace

TEST_CASE("solution_io: radiosity and thermal tables round-trip bit for bit") {
    const std::vector<Rgb> b = {Rgb(0.1, 1.0 / 3.0, 2e-300), Rgb(1e10, 0.0, 7.25)};
    const std::string p = temp_file("r.csv");
    write_radiosity_csv(p, b);
    const SolutionTable t = read_solution_csv(p, 2);
    CHECK_FALSE(t.thermal);
    REQUIRE(t.size() == 2);
    CHECK(t.radiosity[0] == b[0]);
    CHECK(t.radiosity[1] == b[1]);
    std::ifstream in(p);
    std::string header;
    std::getline(in, header);
    CHECK(header == "patch,radiosity_r,radiosity_g,radiosity_b");

    ThermalResult r;
    r.area = {1.0, 2.0};
    r.emissivity = {0.5, 1.0};
    r.temperature = {300.0, std::nan("")};
    r.radiosity = {400.0, 500.0};
    r.net_flux = {-1.0 / 3.0, 2.0};
    r.net_power = {-1.0 / 3.0, 4.0};
    const std::string q = temp_file("t.csv");
    write_thermal_csv(q, r);
    const SolutionTable u = read_solution_csv(q);
    CHECK(u.thermal);
    CHECK(u.net_flux[0] == -1.0 / 3.0);
    CHECK(std::isnan(u.temperature[1]));
    CHECK(u.radiosity[1] == Rgb::Constant(500.0));
    CHECK(u.area[1] == 2.0);
}

TEST_CASE("solution_io: bad tables give FILE:LINE errors") {
    CHECK(error_of("a.csv", "patch,b\n0,1\n").find("a.csv:1: not a solution table") !=
          std::string::npos);
    CHECK(error_of("b.csv", "patch,radiosity_r,radiosity_g,radiosity_b\n0,1,2\n")
              .find("b.csv:2: 3 cells") != std::string::npos);
    CHECK(error_of("c.csv", "patch,radiosity_r,radiosity_g,radiosity_b\n0,1,x,3\n")
              .find("c.csv:2: radiosity_g: bad number 'x'") != std::string::npos);
    CHECK(error_of("d.csv", "patch,radiosity_r,radiosity_g,radiosity_b\n0,1,2,3\n0,1,2,3\n")
              .find("d.csv:3: patch 0 appears twice") != std::string::npos);
    CHECK(error_of("e.csv", "patch,radiosity_r,radiosity_g,radiosity_b\n0,1,2,3\n", 4)
              .find("1 patches in the table, the scene has 4") != std::string::npos);
    CHECK(error_of("f.csv", "patch,radiosity_r,radiosity_g,radiosity_b\n5,1,2,3\n")
              .find("f.csv:2: patch index 5 is not in 0..0") != std::string::npos);
}
