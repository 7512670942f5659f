#include "formfactor/core/error.h"
#include "formfactor/methods/hemicube.h"
#include "formfactor/methods/hemiplane.h"
#include "formfactor/methods/method.h"
#include "mc_common.h"
#include "methods/analytic_method.h"

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

std::string default_method(const Scene& scene) {
    // analytic is exact for unoccluded scenes. With occlusion it is exact-grade too (to
    // MethodOptions::obstructed_tolerance, docs/analytic.md), but its cost then grows with the
    // partly hidden pairs; mc-target stays the default there (a per-pair estimate whose cost is
    // predictable), --method analytic asks for the exact-grade result.
    return AnalyticMethod::may_obstruct(scene) ? "mc-target" : "analytic";
}

}  // namespace formfactor
