#include "formfactor/core/error.h"
#include "formfactor/methods/method.h"
#include "mc_common.h"

namespace formfactor {

std::vector<std::string> method_names() { return {"mc-area", "mc-hemisphere"}; }

std::unique_ptr<Method> make_method(const std::string& name) {
    if (name == "mc-area") return make_mc_area_method();
    if (name == "mc-hemisphere") return make_mc_hemisphere_method();
    throw OptionError("--method", "unknown method '" + name + "'");
}

std::string default_method(const Scene&) { return "analytic"; }

}  // namespace formfactor
