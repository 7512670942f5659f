#pragma once
/// What the binding files of the Python module share (python/src/*.cpp): the scene and result
/// holders, NumPy conversions, and run_released(), which runs a computation with the GIL released
/// and turns Ctrl-C into a cancellation.

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <chrono>
#include <functional>
#include <future>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <type_traits>
#include <vector>

#include "formfactor/core/cancel.h"
#include "formfactor/core/error.h"
#include "formfactor/core/progress.h"
#include "formfactor/core/types.h"
#include "formfactor/distributed/distributed.h"
#include "formfactor/matrix/hierarchical.h"
#include "formfactor/pipeline.h"
#include "formfactor/scene/scene.h"

namespace formfactor::python {

namespace py = pybind11;

/// A scene as Python holds it: immutable once made (patch arrays are views into it).
struct PyScene {
    std::shared_ptr<const Scene> scene;
};

/// A computed matrix and everything said about it.
struct PyResult {
    std::shared_ptr<const Scene> scene;
    ComputeResult result;
    ComputeOptions options;      ///< as resolved (method set); progress and cancel cleared
    double total_seconds = 0.0;  ///< wall time of the call
    /// The report, as the CLI writes it (json_text), made when first asked for: the
    /// diagnostics it recomputes cost O(N²), which a caller that never reads it should not pay.
    mutable std::optional<std::string> report_json;
};

/// The hierarchical operator of a scene (formfactor/matrix/hierarchical.h): whole in this
/// process, or spread over the ranks of an mpi4py communicator (Scene.hierarchical(comm=...)).
struct PyHierarchical {
    std::shared_ptr<const Scene> scene;
    /// The whole operator; null when it is spread over ranks.
    std::shared_ptr<const HierarchicalFormFactors> op;
    /// Spread over the ranks of `comm`: the operator as rank 0 knows it (on the other ranks its
    /// size, areas, row sums and id, as rank 0 sent them); its blocks stay on their ranks until
    /// the next build over ranks in this process. Null when whole.
    std::shared_ptr<const distributed::DistributedHierarchical> spread;
    /// The mpi4py communicator of a spread operator (None when whole), and the whole
    /// operator's stats as rank 0 made them (a dict).
    py::object comm = py::none();
    py::object spread_stats = py::none();

    std::size_t size() const { return op ? op->size() : spread->n; }
    const std::vector<double>& areas() const { return op ? op->areas() : spread->areas; }
};

/// Every rank of the mpi4py communicator `comm` calls together: rank 0 runs `work` while the
/// other ranks serve it (serve_rank0()), then rank 0's outcome goes to every rank. Its value (a
/// picklable Python object) is returned on every rank; its error is raised on rank 0 as it was
/// and on the others as an Error with its message. `comm` that is not a communicator: the
/// OptionError of open_communicator() on every rank, before any message.
py::object on_every_rank(const py::object& comm, const std::function<py::object()>& work);

/// `value` as a T, or an OptionError naming the keyword (a string for samples=, say, must not
/// surface as pybind11's "Unable to cast"). Every keyword of the module is checked here, so that
/// a wrong type is one error type whichever function it is given to.
template <class T>
T arg(const py::object& value, const char* name) {
    // An int is accepted for a float; a float is not taken for an int, nor a bool for a number.
    // NumPy's scalars are numbers too (numbers.Integral, numbers.Real).
    const auto is = [&](const char* abc) {
        return py::isinstance(value, py::module_::import("numbers").attr(abc));
    };
    if constexpr (std::is_same_v<T, bool>) {
        // NumPy's bool too (a flag read from an array); an int is not taken for a flag.
        if (py::isinstance<py::bool_>(value) ||
            py::str(py::type::of(value).attr("__name__")).cast<std::string>() == "bool_")
            return value.cast<bool>();
        throw OptionError(name,
                          "must be True or False, got " + py::repr(value).cast<std::string>());
    } else if constexpr (std::is_same_v<T, double>) {
        if ((py::isinstance<py::float_>(value) || py::isinstance<py::int_>(value) || is("Real")) &&
            !py::isinstance<py::bool_>(value))
            return py::float_(value).cast<double>();
        throw OptionError(name, "must be a number, got " + py::repr(value).cast<std::string>());
    } else if constexpr (std::is_integral_v<T>) {
        if ((py::isinstance<py::int_>(value) || is("Integral")) &&
            !py::isinstance<py::bool_>(value)) {
            try {
                return py::int_(value).cast<T>();
            } catch (const py::cast_error&) {
                throw OptionError(name, "is out of range: " + py::repr(value).cast<std::string>());
            }
        }
        throw OptionError(name, "must be an integer, got " + py::repr(value).cast<std::string>());
    } else {
        if (py::isinstance<py::str>(value)) return value.cast<std::string>();
        throw OptionError(name, "must be a string, got " + py::repr(value).cast<std::string>());
    }
}

/// A read-only NumPy view of `count` values of type T starting at `data`, `stride` bytes apart
/// (`shape2` > 0: a 2-D view of shape (count, shape2), inner stride sizeof(T)), kept alive by
/// `owner`.
template <class T>
py::array_t<T> readonly_view(const T* data, std::size_t count, std::size_t stride, py::handle owner,
                             std::size_t shape2 = 0) {
    py::array_t<T> a = shape2 == 0
                           ? py::array_t<T>({count}, {stride}, data, owner)
                           : py::array_t<T>({count, shape2}, {stride, sizeof(T)}, data, owner);
    py::detail::array_proxy(a.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
    return a;
}

/// A C-contiguous float64 copy (or the array itself when it is one already) of `obj`, checked
/// to have `ndim` dimensions; `name` is the keyword argument for error messages.
py::array_t<double, py::array::c_style | py::array::forcecast> as_doubles(py::handle obj,
                                                                          const char* name,
                                                                          int ndim);

/// An (n, 3) array of points or vectors (a (3,) array is repeated n times when n > 0).
std::vector<Vec3> as_vec3s(py::handle obj, const char* name, std::size_t n = 0);

/// Progress forwarded to a Python callable callback(phase, done, total, elapsed_seconds) from the
/// thread that waits for the computation (which holds the GIL when it calls), never from the
/// workers.
class CallbackProgress final : public ProgressSink {
  public:
    void update(const std::string& label, std::size_t done, std::size_t total,
                double elapsed_seconds) override;
    void finish(const std::string& label) override;
    /// Calls the callback with what changed since the last call (GIL held).
    void deliver(const py::object& callback);

  private:
    struct Update {
        std::string label;
        std::size_t done = 0, total = 0;
        double elapsed = 0.0;
    };
    std::mutex mutex_;
    std::vector<Update> pending_;
};

/// What a progress= argument asks for: None (None or False), a bar on stderr (True: a
/// formfactor.TextProgress), or the callable itself; anything else is an OptionError.
py::object progress_callback(const py::object& progress);

/// Runs `work(flag)` on a worker thread with the GIL released; the calling thread waits,
/// taking the GIL every 20 ms to check for signals (Ctrl-C: the flag is requested, the worker
/// stops at its next poll, and KeyboardInterrupt is raised) and to deliver progress to
/// `callback` (a progress= argument, see progress_callback()). Errors of `work` propagate
/// (translated to Python by the module's exception translator).
template <class Work>
auto run_released(Work&& work, const py::object& callback = py::none())
    -> decltype(work(std::declval<CancellationFlag&>(), static_cast<ProgressSink*>(nullptr))) {
    using R =
        decltype(work(std::declval<CancellationFlag&>(), static_cast<ProgressSink*>(nullptr)));
    const py::object deliver_to = progress_callback(callback);
    CancellationFlag flag;
    CallbackProgress progress;
    ProgressSink* sink = deliver_to.is_none() ? nullptr : &progress;
    std::packaged_task<R()> task([&]() -> R {
        CancellationScope scope(flag);
        return work(flag, sink);
    });
    std::future<R> done = task.get_future();
    bool interrupted = false;
    {
        py::gil_scoped_release nogil;
        std::thread worker(std::move(task));
        while (done.wait_for(std::chrono::milliseconds(20)) != std::future_status::ready) {
            py::gil_scoped_acquire gil;
            if (PyErr_CheckSignals() != 0) {
                // The KeyboardInterrupt stays pending on this thread until we raise it below.
                flag.request();
                interrupted = true;
                break;
            }
            if (sink) {
                try {
                    progress.deliver(deliver_to);
                } catch (py::error_already_set& e) {
                    // The callback raised: stop the computation and raise that.
                    e.restore();
                    flag.request();
                    interrupted = true;
                    break;
                }
            }
        }
        worker.join();
    }
    if (interrupted) throw py::error_already_set();
    if (sink) progress.deliver(deliver_to);
    return done.get();
}

/// comm= of a call that may run over the ranks of an mpi4py communicator: opens `scope` on it
/// (formfactor/distributed/distributed.h) unless `comm` is None; OptionError("comm") for
/// anything that is not an mpi4py communicator.
void open_communicator(const py::object& comm, std::optional<distributed::Communicator>& scope);

/// A call over a communicator on a rank other than 0: serves rank 0's computations with the GIL
/// released until rank 0's scope ends.
void serve_rank0();

void bind_errors(py::module_& m);
void bind_scene(py::module_& m);
void bind_compute(py::module_& m);
void bind_solve(py::module_& m);
void bind_render(py::module_& m);
void bind_signatures(py::module_& m);

}  // namespace formfactor::python
