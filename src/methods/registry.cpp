#include "formfactor/core/error.h"
#include "formfactor/methods/hemicube.h"
#include "formfactor/methods/hemiplane.h"
#include "formfactor/methods/method.h"
#include "methods/monte_carlo/mc_common.h"
#include "methods/analytic/analytic_method.h"

namespace formfactor {

std::vector<std::string> method_names() {
    return {"analytic", "hemicube", "hemiplane", "mc-area", "mc-hemisphere", "mc-target"};
}

std::unique_ptr<Method> make_method(const std::string& name) {
    if (name == "analytic") return std::make_unique<AnalyticMethod>();
    if (name == "hemicube") return std::make_unique<HemicubeMethod>();
    if (name == "hemiplane") return std::make_unique<HemiplaneMethod>();
    if (name == "mc-area") return make_mc_area_method();
    if (name == "mc-hemisphere") return make_mc_hemisphere_method();
    if (name == "mc-target") return make_mc_target_method();
    throw OptionError("--method", "unknown method '" + name + "'");
}

std::string default_method(const Scene&) {
    // The most accurate method that handles the scene: analytic is exact for unoccluded pairs
    // and exact-grade (MethodOptions::obstructed_tolerance, 1e-6 by default) for partly hidden
    // ones (docs/analytic.md). Its cost grows with the partly hidden pairs; `run` picks
    // mc-hemisphere for speed on its fine Cornell subdivision and says so.
    return "analytic";
}

bool may_obstruct(const Scene& scene) { return AnalyticMethod::may_obstruct(scene); }

}  // namespace formfactor
