// The memory estimate of dense runs and the refusal before anything big is allocated (a run
// too large for the machine is refused with a message, never ends in std::bad_alloc).

#include <doctest/doctest.h>

#include <string>

#include "formfactor/core/error.h"
#include "formfactor/matrix/memory.h"
#include "formfactor/scene/scene.h"

using namespace formfactor;

namespace {

std::string resource_error(const DenseRunNeeds& needs, double available) {
    try {
        check_memory(needs, available, "do something else");
    } catch (const ResourceError& e) {
        return e.what();
    }
    return "";
}

}  // namespace

TEST_CASE("memory: the estimate counts F, standard errors, the repair copy and extra matrices") {
    DenseRunNeeds needs;
    needs.patches = 135000;
    const double f = 135000.0 * 135000.0 * 8.0;
    CHECK(estimate_dense_memory(needs).total() == doctest::Approx(f + 135000 * kBytesPerPatch));
    needs.standard_errors = true;
    needs.repair = true;
    needs.extra_matrices = {"direct solve: system matrix", "direct solve: LU factors"};
    CHECK(estimate_dense_memory(needs).total() == doctest::Approx(5 * f + 135000 * kBytesPerPatch));
    // Points: no square matrix, an M × N output.
    DenseRunNeeds pts;
    pts.patches = 1000;
    pts.matrix = false;
    pts.output_rows = 50;
    CHECK(estimate_dense_memory(pts).total() ==
          doctest::Approx(50.0 * 1000 * 8 + 1000 * kBytesPerPatch));
}

TEST_CASE("memory: a run larger than the machine is refused with what it needs and what fits") {
    DenseRunNeeds needs;
    needs.patches = 135000;  // cube --subdivide 150
    needs.standard_errors = true;
    const std::string m = resource_error(needs, 21e9);
    CHECK(m.find("not enough memory: 135,000 patches need about 293 GB") == 0);
    CHECK(m.find("F (135,000² doubles) 146 GB") != std::string::npos);
    CHECK(m.find("standard errors (135,000² doubles) 146 GB") != std::string::npos);
    CHECK(m.find("21 GB available") != std::string::npos);
    CHECK(m.find("do something else") != std::string::npos);
    // The largest N that fits: 2 · 8 N² + 8192 N ≤ 21e9 → N ≈ 36,000.
    const std::size_t fit = max_dense_patches(needs, 21e9);
    CHECK(fit > 35000);
    CHECK(fit < 37000);
    CHECK(m.find("at most about " + std::to_string(fit / 1000) + ",") != std::string::npos);
    needs.patches = fit;
    CHECK(resource_error(needs, 21e9).empty());
    needs.patches = fit + 1;
    CHECK_FALSE(resource_error(needs, 21e9).empty());
    // Unknown availability: no check.
    needs.patches = 10000000;
    CHECK(resource_error(needs, 0.0).empty());
}

TEST_CASE("memory: the machine's available memory is known and positive") {
    const double a = available_memory();
    CHECK(a > 1e6);
    CHECK(a < 1e16);
    CHECK(format_bytes(1.5e9) == "1.5 GB");
    CHECK(format_bytes(730e6) == "730 MB");
    CHECK(format_bytes(12) == "12 bytes");
}

TEST_CASE("memory: the patch count of a subdivision is known before subdividing") {
    Scene s = load_scene("cube");
    SubdivisionOptions o;
    o.n = 150;
    CHECK(subdivision_patch_count(s, o) == 6.0 * 150 * 150);
    o.n = 100000;  // 6e10 patches: counted, never built
    CHECK(subdivision_patch_count(s, o) == 6e10);
    o.n = 3;
    subdivide(s, o);
    CHECK(s.patches.size() == 54u);
    CHECK_THROWS_AS(subdivision_patch_count(s, SubdivisionOptions{0, 0.0}), OptionError);
}
