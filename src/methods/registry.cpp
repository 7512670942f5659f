#include "formfactor/core/error.h"
#include "formfactor/methods/method.h"
#include "methods/analytic_method.h"

namespace formfactor {

std::vector<std::string> method_names() { return {"analytic"}; }

std::unique_ptr<Method> make_method(const std::string& name) {
    if (name == "analytic") return std::make_unique<AnalyticMethod>();
    throw OptionError("--method", "unknown method '" + name + "'");
}

std::string default_method(const Scene&) { return "analytic"; }

}  // namespace formfactor
