#pragma once
/// Keyword arguments defined once (as TensorStore's python/tensorstore/keyword_arguments.h):
/// each is one table entry — name, type, default, doc and what it sets — from which come the
/// binding's argument parsing, the function's signature (its __text_signature__, read by
/// inspect, help() and stubtest), its docstring, and the lines of the type stub
/// (python/generate_stub.py writes them from formfactor._core._signatures()).

#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "bindings.h"

namespace formfactor::python {

/// The doc of every progress= keyword.
inline constexpr const char* kProgressDoc =
    "None, True (a bar on stderr) or callable(phase, done, total, elapsed_seconds).";

/// The options of a function whose every argument is read in its call (value_of()).
struct NoOptions {};

/// `value` as the Scene it must be, or an OptionError naming the keyword `name`.
const PyScene& scene_arg(const py::object& value, const char* name = "scene");

/// `value` as a file path (a str or an os.PathLike), or an OptionError naming `name`.
std::string path_arg(const py::object& value, const char* name = "path");

/// One keyword argument of a function bound with bind_with_keywords().
template <class Options>
struct Keyword {
    const char* name;
    /// Its annotation in the stub, e.g. "Optional[float]".
    const char* type;
    /// Its default as a Python literal ("None", "False", "1.5"); null: required (a module
    /// function's leading arguments: the scene, the path).
    const char* default_value;
    const char* doc;
    /// Sets the options from a given value (checked with arg<T>); not called for None where the
    /// default is None (apply_keywords()). Null: the function reads the value itself (progress=).
    void (*apply)(const py::object& value, Options& options);
    /// May also be given by position (it then comes before the `*` of the signature).
    bool positional = false;
};

/// A function's keywords with its name, return annotation and docstring summary.
template <class Options>
struct Signature {
    const char* name;
    /// The return annotation in the stub.
    const char* returns;
    /// The docstring's text before the list of keywords.
    const char* summary;
    std::span<const Keyword<Options>> keywords;
};

/// The parameters of `keywords` as a signature's text: `self, method=None, *, tolerance=None`
/// (without `self, ` for a module function). An empty default is a required parameter.
std::string parameter_text(const std::vector<std::string>& names,
                           const std::vector<std::string>& defaults,
                           const std::vector<bool>& positional, bool self = true);

/// The TypeError message of a keyword `name` that `function` does not take: Python's own
/// words, then the nearest of `names` when it is a slip away ("did you mean 'residual'?"), else
/// the list of them.
std::string unknown_keyword_message(const char* function, const std::string& name,
                                    const std::vector<std::string>& names);

/// The values given to `function(self, *args, **kwargs)`, one per keyword in table order (the
/// default where not given), or a TypeError worded as Python's own for a positional argument
/// too many, an unknown keyword (unknown_keyword_message()), a keyword given twice or a required
/// one missing.
std::vector<py::object> given_values(const char* function, const std::vector<std::string>& names,
                                     const std::vector<std::string>& defaults,
                                     std::size_t positional, const py::args& args,
                                     const py::kwargs& kwargs);

/// Records a signature for formfactor._core._signatures() (what the stub generator reads):
/// `owner` is the class name ("Scene") or "module" for a module function.
void record_signature(const std::string& owner, const std::string& name, const std::string& returns,
                      const std::vector<std::string>& names, const std::vector<std::string>& types,
                      const std::vector<std::string>& defaults,
                      const std::vector<bool>& positional);

/// The docstring of a method with these keywords: the text signature ("name(self, ...)\n--\n\n",
/// which CPython turns into __text_signature__), the summary, then one line per keyword.
template <class Options>
std::string docstring(const Signature<Options>& sig, std::vector<std::string>* names = nullptr,
                      std::vector<std::string>* defaults = nullptr,
                      std::vector<bool>* positional = nullptr, bool self = true) {
    std::vector<std::string> n, d;
    std::vector<bool> p;
    for (const auto& k : sig.keywords) {
        n.emplace_back(k.name);
        d.emplace_back(k.default_value ? k.default_value : "");
        p.push_back(k.positional);
    }
    std::string doc = std::string(sig.name) + "(" + parameter_text(n, d, p, self) + ")\n--\n\n" +
                      sig.summary + "\n\nArguments:\n";
    for (const auto& k : sig.keywords)
        doc += "\n" + std::string(k.name) + " (" + k.type +
               (k.default_value ? std::string(", default ") + k.default_value : "") +
               "): " + k.doc + "\n";
    if (names) *names = n;
    if (defaults) *defaults = d;
    if (positional) *positional = p;
    return doc;
}

/// The value of keyword `name` among `values` (in table order, as given_values() returns them).
template <class Options>
const py::object& value_of(const Signature<Options>& sig, const std::vector<py::object>& values,
                           std::string_view name) {
    for (std::size_t k = 0; k < sig.keywords.size(); ++k)
        if (name == sig.keywords[k].name) return values[k];
    throw std::logic_error("no keyword " + std::string(name) + " in " + sig.name);
}

/// Applies each of `values` (in table order) to `o` by its keyword's `apply`: a None where the
/// default is None (or for a required argument, which the call checks) leaves the option as it
/// is; any other None (for a flag, a number or a string with a default) goes to `apply`, which
/// refuses it as the wrong type.
template <class Options>
void apply_keywords(const Signature<Options>& sig, const std::vector<py::object>& values,
                    Options& o) {
    for (std::size_t k = 0; k < values.size(); ++k) {
        const Keyword<Options>& key = sig.keywords[k];
        const bool not_given =
            values[k].is_none() &&
            (!key.default_value || std::string_view(key.default_value) == "None");
        if (key.apply && !not_given) key.apply(values[k], o);
    }
}

/// Binds `sig` as a method of `cls`: `call(self, options, values)` runs it with `options`
/// (default-constructed, then each given keyword applied in table order) and `values`, the
/// values of every keyword by table order (for those without `apply`).
template <class Class, class Options, class Call>
void bind_with_keywords(Class& cls, const Signature<Options>& sig, Call call) {
    std::vector<std::string> names, defaults;
    std::vector<bool> positional;
    const std::string doc = docstring(sig, &names, &defaults, &positional);
    std::vector<std::string> types;
    for (const auto& k : sig.keywords) types.emplace_back(k.type);
    record_signature(py::str(cls.attr("__name__")).cast<std::string>(), sig.name, sig.returns,
                     names, types, defaults, positional);
    std::size_t n_positional = 0;
    for (bool b : positional) n_positional += b ? 1 : 0;
    // pybind11's own signature line would hide the one in the docstring.
    py::options options;
    options.disable_function_signatures();
    cls.def(
        sig.name,
        [sig, names, defaults, n_positional, call](const py::object& self, const py::args& args,
                                                   const py::kwargs& kwargs) {
            const std::vector<py::object> values =
                given_values(sig.name, names, defaults, n_positional, args, kwargs);
            Options o{};
            apply_keywords(sig, values, o);
            return call(self, o, values);
        },
        doc.c_str());
}

/// Binds `sig` as a function of module `m`: `call(options, values)`, as bind_with_keywords()
/// without `self`.
template <class Options, class Call>
void bind_function_with_keywords(py::module_& m, const Signature<Options>& sig, Call call) {
    std::vector<std::string> names, defaults;
    std::vector<bool> positional;
    const std::string doc = docstring(sig, &names, &defaults, &positional, false);
    std::vector<std::string> types;
    for (const auto& k : sig.keywords) types.emplace_back(k.type);
    record_signature("module", sig.name, sig.returns, names, types, defaults, positional);
    std::size_t n_positional = 0;
    for (bool b : positional) n_positional += b ? 1 : 0;
    py::options options;
    options.disable_function_signatures();
    m.def(
        sig.name,
        [sig, names, defaults, n_positional, call](const py::args& args, const py::kwargs& kwargs) {
            const std::vector<py::object> values =
                given_values(sig.name, names, defaults, n_positional, args, kwargs);
            Options o{};
            apply_keywords(sig, values, o);
            return call(o, values);
        },
        doc.c_str());
}

}  // namespace formfactor::python
