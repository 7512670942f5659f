#include "formfactor/core/error.h"
#include "formfactor/methods/method.h"
#include "mc_common.h"
#include "methods/analytic_method.h"

namespace formfactor {

std::vector<std::string> method_names() {
    return {"analytic", "mc-area", "mc-hemisphere", "mc-target"};
}

std::unique_ptr<Method> make_method(const std::string& name) {
    if (name == "analytic") return std::make_unique<AnalyticMethod>();
    if (name == "mc-area") return make_mc_area_method();
    if (name == "mc-hemisphere") return make_mc_hemisphere_method();
    if (name == "mc-target") return make_mc_target_method();
    throw OptionError("--method", "unknown method '" + name + "'");
}

std::string default_method(const Scene& scene) {
    // analytic is exact but handles unoccluded scenes only; mc-target is exact wherever nothing
    // blocks and estimates only the visible fraction elsewhere (docs/monte_carlo.md).
    try {
        AnalyticMethod().check(scene);
        return "analytic";
    } catch (const Error&) {
        return "mc-target";
    }
}

}  // namespace formfactor
