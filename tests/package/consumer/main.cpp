// An application of the installed library (tests/package/run.cmake): the built-in unit cube,
// split 2×2 per face, its exact form factors through the pipeline, and closure: each row of a
// closed enclosure sums to 1. Exit code 0 when every row does, within 1e-9.

#include <formfactor/formfactor.h>

#include <algorithm>
#include <cstdio>

int main() {
    using namespace formfactor;
    Scene scene = load_scene("cube");
    subdivide(scene, SubdivisionOptions{2, 0.0});
    const ComputeResult r = compute_form_factors(scene);  // the default method: analytic
    const Diagnostics& d = *r.diagnostics;
    const double closure = std::max(1.0 - d.row_sum_min, d.row_sum_max - 1.0);
    std::printf("formfactor %s, %s: %zu patches, max |row sum - 1| = %.1e\n", FF_VERSION,
                to_string(r.report.method).c_str(), d.n, closure);
    return closure < 1e-9 ? 0 : 1;
}
