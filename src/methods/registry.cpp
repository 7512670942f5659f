// The list of methods, by kind and name, and the default choice.

#include "formfactor/core/error.h"
#include "formfactor/methods/hemicube.h"
#include "formfactor/methods/hemiplane.h"
#include "formfactor/methods/method.h"
#include "methods/analytic/analytic_method.h"
#include "methods/monte_carlo/mc_common.h"

namespace formfactor {

MethodKind parse_method(const std::string& name) {
    return enum_from_name(kMethodNames, name, "method", "method");
}

std::string to_string(MethodKind kind) { return enum_to_name(kMethodNames, kind); }

std::vector<std::string> method_names() {
    std::vector<std::string> out;
    for (const auto& e : kMethodNames) out.emplace_back(e.name);
    return out;
}

std::unique_ptr<Method> make_method(MethodKind kind) {
    switch (kind) {
        case MethodKind::analytic:
            return std::make_unique<AnalyticMethod>();
        case MethodKind::hemicube:
            return std::make_unique<HemicubeMethod>();
        case MethodKind::hemiplane:
            return std::make_unique<HemiplaneMethod>();
        case MethodKind::mc_area:
            return make_mc_area_method();
        case MethodKind::mc_hemisphere:
            return make_mc_hemisphere_method();
        case MethodKind::mc_target:
            return make_mc_target_method();
    }
    throw Error("unknown method kind");
}

std::unique_ptr<Method> make_method(const std::string& name) {
    return make_method(parse_method(name));
}

MethodKind default_method(const Scene&) {
    // The most accurate method that handles the scene: analytic is exact for unoccluded pairs
    // and exact-grade (MethodOptions::obstructed_tolerance, 1e-6 by default) for partly hidden
    // ones (docs/analytic.md). Its cost grows with the partly hidden pairs.
    return MethodKind::analytic;
}

}  // namespace formfactor
