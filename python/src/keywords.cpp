// The parsing, signatures and registry behind keywords.h.

#include "keywords.h"

#include <fmt/format.h>

namespace formfactor::python {

namespace {

/// What _signatures() returns: one dict per function bound with keywords.
py::list& signatures() {
    // Never destroyed: a static py::object would be released after the interpreter is gone.
    static py::list* list = new py::list();
    return *list;
}

}  // namespace

std::string parameter_text(const std::vector<std::string>& names,
                           const std::vector<std::string>& defaults,
                           const std::vector<bool>& positional, bool self) {
    // A plain `self` (not `$self`): pybind11's functions hold a capsule as __self__, which would
    // make inspect drop a `$self` as already bound.
    std::vector<std::string> params;
    if (self) params.emplace_back("self");
    bool star = false;
    for (std::size_t k = 0; k < names.size(); ++k) {
        if (!positional[k] && !star) {
            params.emplace_back("*");
            star = true;
        }
        params.push_back(defaults[k].empty() ? names[k] : names[k] + "=" + defaults[k]);
    }
    std::string text;
    for (const auto& param : params) text += (text.empty() ? "" : ", ") + param;
    return text;
}

std::vector<py::object> given_values(const char* function, const std::vector<std::string>& names,
                                     const std::vector<std::string>& defaults,
                                     std::size_t positional, const py::args& args,
                                     const py::kwargs& kwargs) {
    if (args.size() > positional) {
        throw py::type_error(fmt::format("{}() takes at most {} positional argument{} ({} given)",
                                         function, positional, positional == 1 ? "" : "s",
                                         args.size()));
    }
    std::vector<py::object> values(names.size());
    for (std::size_t k = 0; k < args.size(); ++k) values[k] = args[k];
    for (const auto& [key, value] : kwargs) {
        const std::string name = py::str(key).cast<std::string>();
        std::size_t k = 0;
        while (k < names.size() && names[k] != name) ++k;
        if (k == names.size()) {
            throw py::type_error(
                fmt::format("{}() got an unexpected keyword argument '{}'", function, name));
        }
        if (values[k]) {
            throw py::type_error(
                fmt::format("{}() got multiple values for argument '{}'", function, name));
        }
        values[k] = py::reinterpret_borrow<py::object>(value);
    }
    const py::object literal = py::module_::import("ast").attr("literal_eval");
    for (std::size_t k = 0; k < names.size(); ++k) {
        if (values[k]) continue;
        if (defaults[k].empty()) {
            throw py::type_error(
                fmt::format("{}() missing required argument: '{}'", function, names[k]));
        }
        values[k] = literal(defaults[k]);
    }
    return values;
}

void record_signature(const std::string& owner, const std::string& name, const std::string& returns,
                      const std::vector<std::string>& names, const std::vector<std::string>& types,
                      const std::vector<std::string>& defaults,
                      const std::vector<bool>& positional) {
    py::list keywords;
    for (std::size_t k = 0; k < names.size(); ++k) {
        py::dict d;
        d["name"] = names[k];
        d["type"] = types[k];
        d["default"] = defaults[k];
        d["positional"] = static_cast<bool>(positional[k]);
        keywords.append(d);
    }
    py::dict sig;
    sig["owner"] = owner;
    sig["name"] = name;
    sig["returns"] = returns;
    sig["keywords"] = keywords;
    signatures().append(sig);
}

void bind_signatures(py::module_& m) {
    m.def(
        "_signatures", [] { return py::list(signatures()); },
        "The functions bound with keyword tables, for python/generate_stub.py: owner, name, "
        "returns, keywords (name, type, default, positional).");
}

}  // namespace formfactor::python
