#pragma once
// Runs one method directly, without the pipeline: every row, no progress, the
// report's "details" as JSON (to_json of the typed report, the same keys the run report holds).

#include <nlohmann/json.hpp>

#include "formfactor/methods/method.h"
#include "formfactor/output/report.h"

namespace formfactor::testing {

inline FormFactors run_method(const Method& method, const Scene& scene,
                              const MethodOptions& options, nlohmann::json& details) {
    MethodResult r = method.compute(MethodContext{scene, options, nullptr, nullptr, {}});
    details = to_json(to_fields(r.report));
    return std::move(r.form_factors);
}

inline FormFactors run_method(const Method& method, const Scene& scene,
                              const MethodOptions& options) {
    return std::move(
        method.compute(MethodContext{scene, options, nullptr, nullptr, {}}).form_factors);
}

/// The analytic method held to 1e-13 per entry: exact enough that row sums and reciprocity
/// keep that accuracy through a per-surface aggregation.
inline FormFactors tight_analytic(const Scene& scene) {
    const auto method = make_method("analytic");
    method->check(scene);
    MethodOptions o;
    o.tolerance = 1e-13;
    return run_method(*method, scene, o);
}

}  // namespace formfactor::testing
