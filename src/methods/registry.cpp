#include "formfactor/core/error.h"
#include "formfactor/methods/method.h"

namespace formfactor {

std::vector<std::string> method_names() { return {}; }

std::unique_ptr<Method> make_method(const std::string& name) {
    throw OptionError("--method", "unknown method '" + name + "'");
}

std::string default_method(const Scene&) { return "analytic"; }

}  // namespace formfactor
