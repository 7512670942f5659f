// The parsing, signatures and registry behind keywords.h.

#include "keywords.h"

#include <fmt/format.h>

#include <algorithm>

namespace formfactor::python {

namespace {

/// What _signatures() returns: one dict per function bound with keywords.
py::list& signatures() {
    // Never destroyed: a static py::object would be released after the interpreter is gone.
    static py::list* list = new py::list();
    return *list;
}

/// Levenshtein's edit distance between a and b (insertions, deletions, substitutions).
std::size_t edit_distance(std::string_view a, std::string_view b) {
    std::vector<std::size_t> row(b.size() + 1);
    for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
    for (std::size_t i = 1; i <= a.size(); ++i) {
        std::size_t diagonal = row[0];
        row[0] = i;
        for (std::size_t j = 1; j <= b.size(); ++j) {
            const std::size_t above = row[j];
            row[j] =
                std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
            diagonal = above;
        }
    }
    return row[b.size()];
}

}  // namespace

const PyScene& scene_arg(const py::object& value, const char* name) {
    if (!py::isinstance<PyScene>(value))
        throw OptionError(name,
                          "must be a formfactor.Scene, got " + py::repr(value).cast<std::string>());
    return value.cast<const PyScene&>();
}

std::string path_arg(const py::object& value, const char* name) {
    if (!py::isinstance<py::str>(value) && !py::hasattr(value, "__fspath__"))
        throw OptionError(
            name, "must be a str or an os.PathLike, got " + py::repr(value).cast<std::string>());
    return arg<std::string>(py::module_::import("os").attr("fspath")(value), name);
}

std::string unknown_keyword_message(const char* function, const std::string& name,
                                    const std::vector<std::string>& names) {
    std::string message =
        fmt::format("{}() got an unexpected keyword argument '{}'", function, name);
    // The nearest keyword when a typing slip away (a third of its letters at most), else them
    // all: a misspelt keyword should say what was meant.
    const std::string* nearest = nullptr;
    std::size_t best = std::string::npos;
    for (const auto& candidate : names) {
        const std::size_t d = edit_distance(name, candidate);
        if (d < best) {
            best = d;
            nearest = &candidate;
        }
    }
    if (nearest && best <= std::max<std::size_t>(2, nearest->size() / 3))
        return message + fmt::format("; did you mean '{}'?", *nearest);
    std::string all;
    for (const auto& candidate : names) all += (all.empty() ? "" : ", ") + candidate;
    return message + fmt::format(" (it takes {})", all.empty() ? "none" : all);
}

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
            throw py::type_error(unknown_keyword_message(function, name, names));
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
