// An application of the installed library (tests/package/run.cmake): the built-in unit cube,
// split 2×2 per face, its exact form factors, and closure: each row of a closed enclosure sums
// to 1. Exit code 0 when every row does, within 1e-9.

#include <formfactor/formfactor.h>

#include <algorithm>
#include <cstdio>

int main() {
    using namespace formfactor;
    Scene scene = load_scene("cube");
    subdivide(scene, SubdivisionOptions{2, 0.0});
    const auto method = make_method("analytic");
    method->check(scene);
    MethodOptions options;
    options.progress = false;
    nlohmann::json details;
    const FormFactors ff = method->compute(scene, options, details);
    const Diagnostics d = diagnose(ff);
    const double closure = std::max(1.0 - d.row_sum_min, d.row_sum_max - 1.0);
    std::printf("formfactor %s, %s: %zu patches, max |row sum - 1| = %.1e\n", FF_VERSION,
                method->name().c_str(), d.n, closure);
    return closure < 1e-9 ? 0 : 1;
}
