// The extension module formfactor._core: exceptions, shared conversions, and the module itself.
// The public package is python/formfactor/__init__.py, which re-exports what is bound here.

#include <fmt/format.h>

#include <cmath>

#include "bindings.h"
#include "formfactor/core/error.h"

namespace formfactor::python {

namespace {

/// The Python keyword argument of a library option field ("method_options.samples" →
/// "samples", "visibility.relative_epsilon" → "ray_offset").
std::string keyword_of(const std::string& field) {
    std::string k = field;
    for (const char* prefix : {"method_options.", "visibility.", "repair.", "options."}) {
        const std::string p = prefix;
        if (k.rfind(p, 0) == 0) k = k.substr(p.size());
    }
    if (k == "relative_epsilon") return "ray_offset";
    if (k == "mode") return "repair";
    if (!k.empty() && k[0] == '-') {
        // A CLI-style flag from a shared helper ("--max-edge"): the keyword spelling.
        k.erase(0, k.find_first_not_of('-'));
        for (char& c : k)
            if (c == '-') c = '_';
    }
    return k;
}

/// Raises errors_module.<name>(*args) as the current Python exception.
void raise(const char* name, const py::tuple& args) {
    const py::object cls = py::module_::import("formfactor._errors").attr(name);
    const py::object instance = cls(*args);
    PyErr_SetObject(cls.ptr(), instance.ptr());
}

}  // namespace

py::array_t<double, py::array::c_style | py::array::forcecast> as_doubles(py::handle obj,
                                                                          const char* name,
                                                                          int ndim) {
    if (obj.is_none()) throw OptionError(name, "must be an array, got None");
    py::array_t<double, py::array::c_style | py::array::forcecast> a;
    try {
        a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(obj);
    } catch (const py::error_already_set&) {
        a = {};
    }
    if (!a) throw OptionError(name, "must be an array of numbers");
    if (a.ndim() != ndim) {
        throw OptionError(name, fmt::format("must have {} dimension{}, got {}", ndim,
                                            ndim == 1 ? "" : "s", a.ndim()));
    }
    return a;
}

std::vector<Vec3> as_vec3s(py::handle obj, const char* name, std::size_t n) {
    py::array_t<double, py::array::c_style | py::array::forcecast> a;
    {
        auto any = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(obj);
        if (!any) throw OptionError(name, "must be an array of numbers");
        a = any;
    }
    std::vector<Vec3> out;
    if (a.ndim() == 1 && a.shape(0) == 3 && n > 0) {
        const double* d = a.data();
        out.assign(n, Vec3(d[0], d[1], d[2]));
    } else {
        if (a.ndim() != 2 || a.shape(1) != 3) {
            throw OptionError(name, "must have shape (M, 3)" +
                                        std::string(n > 0 ? " or (3,)" : "") + ", got " +
                                        py::str(py::tuple(obj.attr("shape"))).cast<std::string>());
        }
        const double* d = a.data();
        out.reserve(static_cast<std::size_t>(a.shape(0)));
        for (py::ssize_t k = 0; k < a.shape(0); ++k)
            out.emplace_back(d[3 * k], d[3 * k + 1], d[3 * k + 2]);
    }
    for (std::size_t k = 0; k < out.size(); ++k) {
        if (!out[k].allFinite()) {
            throw OptionError(name, fmt::format("row {} is not finite", k));
        }
    }
    return out;
}

py::object progress_callback(const py::object& progress) {
    if (progress.is_none()) return py::none();
    if (py::isinstance<py::bool_>(progress)) {
        if (!progress.cast<bool>()) return py::none();
        return py::module_::import("formfactor._progress").attr("TextProgress")();
    }
    if (!PyCallable_Check(progress.ptr())) {
        throw OptionError("progress",
                          "must be None, True or a callable progress(phase, done, total, "
                          "elapsed_seconds)");
    }
    return progress;
}

void CallbackProgress::update(const std::string& label, std::size_t done, std::size_t total,
                              double elapsed_seconds) {
    std::lock_guard lock(mutex_);
    if (!pending_.empty() && pending_.back().label == label) {
        pending_.back() = {label, done, total, elapsed_seconds};
    } else {
        pending_.push_back({label, done, total, elapsed_seconds});
    }
}

void CallbackProgress::finish(const std::string&) {
    // Nothing to add: the library's last update of a phase that ran to its end has done == total.
}

void CallbackProgress::deliver(const py::object& callback) {
    std::vector<Update> updates;
    {
        std::lock_guard lock(mutex_);
        updates.swap(pending_);
    }
    for (const Update& u : updates) callback(u.label, u.done, u.total, u.elapsed);
}

void bind_errors(py::module_&) {
    // The exception classes are Python classes (formfactor/_errors.py: Error, InputError (also a
    // ValueError, with .file and .line), OptionError (also a ValueError, with .option),
    // GeometryError, ResourceError (also a MemoryError), Cancelled); library errors become them.
    py::register_exception_translator([](std::exception_ptr p) {
        if (!p) return;
        try {
            std::rethrow_exception(p);
        } catch (const InputError& e) {
            raise("InputError", py::make_tuple(e.what(), e.file(),
                                               e.line() > 0 ? py::object(py::int_(e.line()))
                                                            : py::object(py::none())));
        } catch (const OptionError& e) {
            const std::string k = keyword_of(e.field());
            raise("OptionError", py::make_tuple(k + ": " + e.message(), k));
        } catch (const GeometryError& e) {
            raise("GeometryError", py::make_tuple(e.what()));
        } catch (const ResourceError& e) {
            raise("ResourceError", py::make_tuple(e.what()));
        } catch (const Cancelled& e) {
            raise("Cancelled", py::make_tuple(e.what()));
        } catch (const Error& e) {
            raise("Error", py::make_tuple(e.what()));
        }
    });
}

}  // namespace formfactor::python

PYBIND11_MODULE(_core, m) {
    namespace ffp = formfactor::python;
    m.doc() = "The compiled core of the formfactor package (use `import formfactor`).";
    m.attr("__version__") = FF_VERSION;
    ffp::bind_errors(m);
    ffp::bind_scene(m);
    ffp::bind_compute(m);
    ffp::bind_solve(m);
    ffp::bind_render(m);
    ffp::bind_signatures(m);
    // The classes are formfactor's (their repr, pickling and the stub say formfactor.Scene).
    for (const char* name : {"Scene", "Result", "HierarchicalOperator"})
        m.attr(name).attr("__module__") = "formfactor";
}
