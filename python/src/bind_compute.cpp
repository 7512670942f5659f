// Form factors: Scene.form_factors() → Result (the matrix as a NumPy view, standard errors,
// the report, sparse output), and point_factors().

#include <fmt/format.h>

#include <cmath>
#include <exception>
#include <type_traits>

#include "bindings.h"
#include "formfactor/core/atomic_file.h"
#include "formfactor/core/error.h"
#include "formfactor/core/parallel.h"
#include "formfactor/distributed/distributed.h"
#include "formfactor/output/page.h"
#include "formfactor/output/report.h"
#include "formfactor/pipeline_solve.h"
#include "formfactor/scene/closure.h"
#include "keywords.h"

namespace formfactor::python {

void open_communicator(const py::object& comm, std::optional<distributed::Communicator>& scope) {
    if (comm.is_none()) return;
    if (!py::hasattr(comm, "py2f"))
        throw OptionError(
            "comm", "must be an mpi4py communicator, got " + py::repr(comm).cast<std::string>());
    scope.emplace(arg<std::int64_t>(comm.attr("py2f")(), "comm"));
}

void serve_rank0() {
    run_released([](CancellationFlag&, ProgressSink*) { return distributed::serve(); }, py::none());
}

py::object on_every_rank(const py::object& comm, const std::function<py::object()>& work) {
    py::object value = py::none();
    std::exception_ptr failure;
    std::string message;
    bool rank0 = false;
    {
        std::optional<distributed::Communicator> scope;
        open_communicator(comm, scope);
        rank0 = distributed::rank() == 0;
        try {
            if (rank0)
                value = work();
            else
                serve_rank0();
        } catch (const std::exception& e) {
            failure = std::current_exception();
            message = e.what();
        }
    }
    // The scope has ended (no rank serves any more): rank 0's outcome to every rank.
    const py::object sent = comm.attr("bcast")(
        rank0 ? py::object(py::make_tuple(failure != nullptr, message, value)) : py::none(),
        py::arg("root") = 0);
    // Rank 0's failure as it was; a rank's own (an interruption while it served) likewise.
    if (failure) std::rethrow_exception(failure);
    const auto outcome = sent.cast<py::tuple>();
    if (outcome[0].cast<bool>()) throw Error(outcome[1].cast<std::string>());
    return outcome[2];
}

namespace {

/// A non-negative integer keyword: a negative Python int is an OptionError naming it.
std::uint64_t unsigned_arg(const py::object& value, const char* name) {
    const long long v = arg<long long>(value, name);
    if (v < 0) throw OptionError(name, fmt::format("must be ≥ 0, got {}", v));
    return static_cast<std::uint64_t>(v);
}

/// The keywords of Scene.form_factors(), in the order they are applied (tolerance before
/// obstructed_tolerance, which it also sets).
const Keyword<ComputeOptions> kComputeKeywords[] = {
    {"method", "Optional[str]", "None",
     "analytic (exact contour integrals, shadows clipped out; the default for every scene), "
     "hemicube, hemiplane, mc-area, mc-hemisphere or mc-target (Monte Carlo, with per-entry "
     "standard errors); methods() lists them.",
     [](const py::object& v, ComputeOptions& o) {
         o.method = parse_method(arg<std::string>(v, "method"));
     },
     true},
    {"tolerance", "Optional[float]", "None",
     "absolute error target per entry (analytic; default 1e-10, and 1e-6 for the partly hidden "
     "pairs of an obstructed scene, which a given tolerance also sets).",
     [](const py::object& v, ComputeOptions& o) {
         // As the CLI's --tolerance: a given tolerance sets the obstructed pairs' target too.
         o.method_options.tolerance = arg<double>(v, "tolerance");
         o.method_options.obstructed_tolerance = o.method_options.tolerance;
     }},
    {"obstructed_tolerance", "Optional[float]", "None",
     "the target of the partly hidden pairs alone (analytic, obstructed scenes).",
     [](const py::object& v, ComputeOptions& o) {
         o.method_options.obstructed_tolerance = arg<double>(v, "obstructed_tolerance");
     }},
    {"samples", "Optional[int]", "None", "samples (Monte Carlo).",
     [](const py::object& v, ComputeOptions& o) {
         o.method_options.samples = unsigned_arg(v, "samples");
     }},
    {"seed", "Optional[int]", "None",
     "the random seed (Monte Carlo; results do not depend on the thread count).",
     [](const py::object& v, ComputeOptions& o) {
         o.method_options.seed = unsigned_arg(v, "seed");
     }},
    {"threads", "Optional[int]", "None", "worker threads (0 or None: all cores).",
     [](const py::object& v, ComputeOptions& o) {
         o.method_options.threads = arg<int>(v, "threads");
     }},
    {"sampler", "Optional[str]", "None", "sobol, halton, stratified or random (Monte Carlo).",
     [](const py::object& v, ComputeOptions& o) {
         o.method_options.sampler = parse_sampler(arg<std::string>(v, "sampler"));
     }},
    {"resolution", "Optional[int]", "None", "cells per side (hemicube, hemiplane).",
     [](const py::object& v, ComputeOptions& o) {
         o.method_options.resolution = arg<int>(v, "resolution");
     }},
    {"points", "Optional[int]", "None", "points per patch (hemicube, hemiplane).",
     [](const py::object& v, ComputeOptions& o) {
         o.method_options.points = arg<int>(v, "points");
     }},
    {"rows", "Optional[Tuple[int, Optional[int]]]", "None",
     "(begin, end): compute only those rows, bit-identical to the same rows of the whole "
     "matrix (end None: N).",
     [](const py::object& v, ComputeOptions& o) {
         if (!(py::isinstance<py::tuple>(v) || py::isinstance<py::list>(v)) || py::len(v) != 2)
             throw OptionError("rows", "must be a pair (begin, end)");
         const auto t = py::tuple(v);
         o.rows.begin = unsigned_arg(t[0], "rows");
         o.rows.end = t[1].is_none() ? RowRange::kEnd : unsigned_arg(t[1], "rows");
     }},
    {"repair", "Optional[str]", "None",
     "reciprocity, closure or both (closure only for closed scenes unless force_closure).",
     [](const py::object& v, ComputeOptions& o) {
         o.repair.mode = parse_repair_mode(arg<std::string>(v, "repair"));
     }},
    {"force_closure", "bool", "False", "close the rows of a scene not known to be closed.",
     [](const py::object& v, ComputeOptions& o) {
         o.repair.force_closure = arg<bool>(v, "force_closure");
     }},
    {"ray_offset", "Optional[float]", "None",
     "the ray tracer's end offset, relative to the scene's size.",
     [](const py::object& v, ComputeOptions& o) {
         o.visibility.relative_epsilon = arg<double>(v, "ray_offset");
     }},
    {"robust_rays", "bool", "False", "Embree's robust mode.",
     [](const py::object& v, ComputeOptions& o) {
         o.visibility.robust = arg<bool>(v, "robust_rays");
     }},
    {"progress", "_Progress", "None", kProgressDoc, nullptr},
    {"comm", "Optional[Any]", "None",
     "an mpi4py communicator (MPI.COMM_WORLD) to compute over its ranks under mpirun: every "
     "rank calls with the same arguments; rank 0 gets the Result, bit for bit the one process's, "
     "the others compute rows for it and get None (docs/cluster.md). Not with rows=.",
     nullptr},
};

/// The arguments of point_factors(), in order (points before normals, which are checked
/// against them).
const Keyword<PointOptions> kPointFactorsKeywords[] = {
    {"scene", "Scene", nullptr, "the scene whose patches receive.", nullptr, true},
    {"points", "_ArrayLike", nullptr,
     "(M, 3) positions of the differential elements (sensors, radiometers, the points of a "
     "mean-radiant-temperature map).",
     [](const py::object& v, PointOptions& o) { o.positions = as_vec3s(v, "points"); }, true},
    {"normals", "_ArrayLike", nullptr,
     "(M, 3) front normals (any length; normalised), or one (3,) normal for every point.",
     [](const py::object& v, PointOptions& o) {
         o.normals = as_vec3s(v, "normals", o.positions.size());
         if (o.normals.size() != o.positions.size()) {
             throw OptionError("normals", fmt::format("must have {} rows (one per point), got {}",
                                                      o.positions.size(), o.normals.size()));
         }
         for (std::size_t k = 0; k < o.normals.size(); ++k)
             if (o.normals[k].norm() == 0.0)
                 throw OptionError("normals", fmt::format("row {} is zero", k));
     },
     true},
    {"threads", "int", "0", "worker threads (0: all cores).",
     [](const py::object& v, PointOptions& o) { o.threads = arg<int>(v, "threads"); }},
    {"progress", "_Progress", "None", kProgressDoc, nullptr},
};

const Signature<PointOptions> kPointFactors{
    "point_factors", "np.ndarray",
    "Form factors from M differential elements to every patch: an (M, N) array whose row m is "
    "point m.\n\nExact with obstructions: each entry is the factor to the part of patch j the "
    "point sees past every other surface.",
    kPointFactorsKeywords};

const Signature<ComputeOptions> kFormFactors{
    "form_factors", "Result",
    "Computes the form factors of this scene's patches: returns a Result whose ``matrix[i, j]`` "
    "is F_ij, from patch i (row) to patch j (column).\n\nThe GIL is released while it computes; "
    "Ctrl-C raises KeyboardInterrupt promptly.",
    kComputeKeywords};

/// The run report, with the keys of the CLI's `compute --report` (output/report.h).
std::string report_of(const Scene& scene, const ComputeOptions& o, const ComputeResult& r,
                      double total_seconds) {
    const MethodKind method = *o.method;
    const MethodOptions& m = o.method_options;
    nlohmann::json options{
        {"scene", scene.name},
        {"method", to_string(method)},
        {"threads", m.threads},
        {"tolerance", m.tolerance},
        {"obstructed_tolerance", m.obstructed_tolerance},
        {"samples", m.samples},
        {"seed", m.seed},
        {"sampler", sampler_name(m.sampler)},
        {"resolution", m.resolution},
        {"points", m.points},
        {"repair", to_string(o.repair.mode)},
        {"ray_offset", o.visibility.relative_epsilon},
        {"robust_rays", o.visibility.robust},
    };
    const FormFactors& ff = r.form_factors;
    ReportContext ctx;
    ctx.command = "python";
    ctx.method = to_string(method);
    ctx.options = std::move(options);
    ctx.timings = r.timings;
    ctx.total_seconds = total_seconds;
    ctx.threads = r.threads;
    ctx.details = to_json(to_fields(r.report));
    ctx.reciprocity = r.traits.reciprocity;
    if (ff.is_block()) ctx.options["rows"] = {ff.first_row, ff.first_row + ff.size()};
    if (r.repair) ctx.repair = to_json(*r.repair);
    return json_text(make_report(scene, ff, std::move(ctx)));
}

// Under a communicator (comm= an mpi4py communicator): every rank calls together; rank 0
// computes over all of them and gets the result, the others serve it and get None. Without
// one, one process as always.
py::object compute(const PyScene& s, ComputeOptions o, const py::object& progress,
                   const py::object& comm_arg, bool rows_given) {
    o.repair.enclosure = known_enclosure(*s.scene);
    if (!o.method) o.method = default_method(*s.scene);
    validate(o);
    if (!comm_arg.is_none() && rows_given)
        throw OptionError("rows", "a run over a communicator computes every row");
    std::optional<distributed::Communicator> comm;
    open_communicator(comm_arg, comm);
    if (comm && distributed::rank() != 0) {
        serve_rank0();
        return py::none();
    }
    PyResult out;
    out.scene = s.scene;
    const auto start = std::chrono::steady_clock::now();
    out.result = run_released(
        [&](CancellationFlag& flag, ProgressSink* sink) {
            ComputeOptions run = o;
            run.cancel = &flag;
            run.progress = sink;
            // Over the communicator's ranks when there is one (the pipeline's call otherwise).
            return comm ? distributed::compute_form_factors(*s.scene, run)
                        : compute_form_factors(*s.scene, run);
        },
        progress);
    out.total_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    out.options = o;
    return py::cast(std::move(out));
}

/// A NumPy array that takes over `M` (no copy): the matrix lives in a capsule the array owns.
py::array_t<double> adopt(DenseMatrix&& M) {
    auto* held = new DenseMatrix(std::move(M));
    py::capsule owner(held, [](void* p) { delete static_cast<DenseMatrix*>(p); });
    return py::array_t<double>(
        {static_cast<std::size_t>(held->rows()), static_cast<std::size_t>(held->cols())},
        held->data(), owner);
}

/// A read-only view of a row-major matrix owned by `self`.
py::array_t<double> matrix_view(const DenseMatrix& M, const py::object& self) {
    const auto cols = static_cast<std::size_t>(M.cols());
    auto a = py::array_t<double>({static_cast<std::size_t>(M.rows()), cols},
                                 {cols * sizeof(double), sizeof(double)}, M.data(), self);
    py::detail::array_proxy(a.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
    return a;
}

py::object csr(const DenseMatrix& F, double threshold) {
    if (!(threshold >= 0.0) || !std::isfinite(threshold)) {
        throw OptionError("threshold",
                          fmt::format("must be a finite number ≥ 0, got {}", threshold));
    }
    const auto rows = static_cast<std::size_t>(F.rows());
    const auto cols = static_cast<std::size_t>(F.cols());
    std::vector<std::int64_t> indptr(rows + 1, 0);
    std::vector<std::int32_t> indices;
    std::vector<double> data;
    for (std::size_t i = 0; i < rows; ++i) {
        const double* row = F.data() + i * cols;
        for (std::size_t j = 0; j < cols; ++j) {
            if (std::abs(row[j]) > threshold) {
                indices.push_back(static_cast<std::int32_t>(j));
                data.push_back(row[j]);
            }
        }
        indptr[i + 1] = static_cast<std::int64_t>(data.size());
    }
    const py::module_ sparse = py::module_::import("scipy.sparse");
    return sparse.attr("csr_matrix")(
        py::make_tuple(py::array_t<double>(data.size(), data.data()),
                       py::array_t<std::int32_t>(indices.size(), indices.data()),
                       py::array_t<std::int64_t>(indptr.size(), indptr.data())),
        py::arg("shape") = py::make_tuple(rows, cols));
}

/// The result page of `r`: its scene, F and report, and `solution` when given — a
/// RadiosityResult or an (N, 3) array (radiosity, true colour) or a ThermalResult
/// (temperature, net flux, radiosity J).
std::string page_of(const PyResult& r, const py::object& solution, const std::string& title,
                    long long max_entries) {
    if (r.result.form_factors.is_block())
        throw OptionError("rows", "the result page needs the whole matrix, not a row block");
    if (max_entries < 1) throw OptionError("max_entries", "must be ≥ 1");
    const std::size_t n = r.scene->patches.size();
    PageContent content;
    content.title = title;
    content.form_factors = &r.result.form_factors;
    if (!r.report_json) r.report_json = report_of(*r.scene, r.options, r.result, r.total_seconds);
    content.report = nlohmann::json::parse(*r.report_json);
    const auto column = [&](const char* attr) {
        const auto a = as_doubles(solution.attr(attr), attr, 1);
        if (static_cast<std::size_t>(a.shape(0)) != n)
            throw OptionError("solution",
                              fmt::format("{} has {} values, not {}", attr, a.shape(0), n));
        return std::vector<double>(a.data(), a.data() + n);
    };
    if (!solution.is_none() && py::hasattr(solution, "temperature")) {
        content.temperature = column("temperature");
        content.net_flux = column("net_flux");
        content.thermal_radiosity = column("radiosity");
    } else if (!solution.is_none()) {
        const py::object values =
            py::hasattr(solution, "radiosity") ? solution.attr("radiosity") : solution;
        const auto a = as_doubles(values, "solution", 2);
        if (static_cast<std::size_t>(a.shape(0)) != n || a.shape(1) != 3)
            throw OptionError("solution", fmt::format("radiosity must have shape ({}, 3)", n));
        for (std::size_t i = 0; i < n; ++i)
            content.radiosity.emplace_back(a.data()[3 * i], a.data()[3 * i + 1],
                                           a.data()[3 * i + 2]);
        for (std::size_t i = 0; i < n; ++i)
            content.emitters.push_back(r.scene->material_of(i).emission.maxCoeff() > 0.0);
    }
    PageOptions po;
    po.max_entries = static_cast<std::size_t>(max_entries);
    py::gil_scoped_release nogil;
    return page_html(*r.scene, content, po);
}

/// HTML-escaped for a double-quoted attribute.
std::string attribute_text(const std::string& s) {
    std::string out;
    out.reserve(s.size() + s.size() / 16);
    for (char c : s) {
        switch (c) {
            case '&':
                out += "&amp;";
                break;
            case '"':
                out += "&quot;";
                break;
            case '<':
                out += "&lt;";
                break;
            case '>':
                out += "&gt;";
                break;
            default:
                out += c;
        }
    }
    return out;
}

}  // namespace

void bind_compute(py::module_& m) {
    py::class_<PyResult>(m, "Result", R"doc(
Form factors computed for a scene: ``matrix[i, j]`` is F_ij, the fraction of the power leaving
patch i (diffusely) that arrives at patch j — from i (row) to j (column). (pyViewFactor puts the
receiver first; formfactor never does.)

``matrix`` is a read-only view of the computed matrix (no copy; ``.copy()`` to change it).
For a row block (``rows=(b, e)``) it holds rows b..e-1 and every column.
)doc")
        .def_property_readonly(
            "matrix",
            [](const py::object& self) {
                return matrix_view(self.cast<const PyResult&>().result.form_factors.F, self);
            },
            "F (N×N float64, or the rows asked for): F[i, j] from patch i to patch j. "
            "A read-only view, no copy.")
        .def_property_readonly(
            "standard_error",
            [](const py::object& self) -> py::object {
                const auto& ff = self.cast<const PyResult&>().result.form_factors;
                if (!ff.standard_error) return py::none();
                return matrix_view(*ff.standard_error, self);
            },
            "Per-entry standard errors (Monte-Carlo methods; same shape as matrix), else None.")
        .def_property_readonly(
            "error_bound",
            [](const PyResult& r) -> py::object {
                const auto& b = r.result.report.error_bound_per_entry;
                return b ? py::object(py::float_(*b)) : py::none();
            },
            "An upper bound of |F_ij − exact| for every entry (analytic), else None.")
        .def_property_readonly(
            "areas",
            [](const py::object& self) {
                const auto& a = self.cast<const PyResult&>().result.form_factors.areas;
                return readonly_view<double>(a.data(), a.size(), sizeof(double), self);
            },
            "(N,) patch areas (A_i F_ij = A_j F_ji).")
        .def_property_readonly(
            "rows",
            [](const PyResult& r) {
                const auto& ff = r.result.form_factors;
                return py::make_tuple(ff.first_row, ff.first_row + ff.size());
            },
            "(begin, end): the rows held.")
        .def_property_readonly("method",
                               [](const PyResult& r) { return to_string(r.result.report.method); })
        .def_property_readonly("threads", [](const PyResult& r) { return r.result.threads; })
        .def_property_readonly(
            "report",
            [](const PyResult& r) {
                if (!r.report_json)
                    r.report_json = report_of(*r.scene, r.options, r.result, r.total_seconds);
                return py::module_::import("json").attr("loads")(*r.report_json);
            },
            "The run report as a dict: the same keys as the CLI's ``compute --report`` JSON "
            "(scene, N, method, options, threads, timings, diagnostics with row sums and "
            "reciprocity, details of the method, repair).")
        .def("__repr__",
             [](const PyResult& r) {
                 const FormFactors& ff = r.result.form_factors;
                 const auto& bound = r.result.report.error_bound_per_entry;
                 return fmt::format("<formfactor.Result {}: rows {}..{} of {}, {}>",
                                    to_string(r.result.report.method), ff.first_row,
                                    ff.first_row + ff.size(), ff.areas.size(),
                                    bound               ? fmt::format("error bound {:.2g}", *bound)
                                    : ff.standard_error ? std::string("standard errors")
                                                        : std::string("approximate"));
             })
        .def(
            "sparse",
            [](const PyResult& r, const py::object& threshold) {
                return csr(r.result.form_factors.F, arg<double>(threshold, "threshold"));
            },
            py::arg("threshold") = 0.0,
            "F as a scipy.sparse.csr_matrix holding the entries with |F_ij| > threshold.")
        .def(
            "per_surface",
            [](const PyResult& r) {
                if (r.result.form_factors.is_block())
                    throw OptionError("rows", "per-surface factors need the whole matrix");
                SurfaceFormFactors<FormFactors> surfaces =
                    per_surface(*r.scene, r.result.form_factors);
                DenseMatrix G = surfaces.aggregated ? std::move(surfaces.aggregated->F)
                                                    : r.result.form_factors.F;
                return py::make_tuple(adopt(std::move(G)), surfaces.groups.names);
            },
            "(F_surfaces, names): the area-weighted per-surface matrix (View3D's Combine "
            "merges surfaces with cmb), rows = surfaces.")
        .def(
            "to_html",
            [](const PyResult& r, const py::object& path, const py::object& solution,
               const py::object& title, const py::object& max_entries) {
                const std::string file = path_arg(path, "path");
                const std::string html = page_of(r, solution, arg<std::string>(title, "title"),
                                                 arg<long long>(max_entries, "max_entries"));
                write_file_atomically(file, [&](std::ostream& out) { out << html; });
            },
            py::arg("path"), py::arg("solution") = py::none(), py::arg("title") = "",
            py::arg("max_entries") = static_cast<long long>(PageOptions{}.max_entries),
            "Writes the result page to `path`: one self-contained HTML file (no network) with the "
            "scene in 3D, coloured by row sum, sky factor, standard error, or `solution` (a "
            "RadiosityResult, an (N, 3) radiosity array, or a ThermalResult); a click on a patch "
            "shows its row of F. At most `max_entries` entries of F are stored (the page states "
            "the threshold and each row's dropped mass). See docs/page.md.")
        .def(
            "_repr_html_",
            [](const PyResult& r) {
                // A notebook shows the page in a sandboxed frame (scripts only, its own CSP).
                return "<iframe sandbox=\"allow-scripts\" "
                       "style=\"width:100%;height:640px;border:0\" "
                       "title=\"formfactor result\" srcdoc=\"" +
                       attribute_text(page_of(r, py::none(), "",
                                              static_cast<long long>(kInlinePageMaxEntries))) +
                       "\"></iframe>";
            },
            fmt::format("The result page in a sandboxed iframe, for Jupyter: at most {} entries "
                        "of F (the page is kept in the notebook; to_html keeps {} by default).",
                        kInlinePageMaxEntries, kPageMaxEntries)
                .c_str());

    auto scene = py::reinterpret_borrow<py::class_<PyScene>>(m.attr("Scene"));
    bind_with_keywords(
        scene, kFormFactors,
        [](const py::object& self, ComputeOptions& o, const std::vector<py::object>& values) {
            return compute(self.cast<const PyScene&>(), o,
                           value_of(kFormFactors, values, "progress"),
                           value_of(kFormFactors, values, "comm"),
                           !value_of(kFormFactors, values, "rows").is_none());
        });

    m.def("method_names", &method_names,
          "The names of the methods Scene.form_factors(method=...) accepts, as the library lists "
          "them.");
    // Whether comm= can work: the library was built with MPI.
    m.attr("built_with_mpi") = distributed::built_with_mpi();

    bind_function_with_keywords(
        m, kPointFactors, [](PointOptions& o, const std::vector<py::object>& values) {
            const PyScene& s = scene_arg(value_of(kPointFactors, values, "scene"));
            for (const char* name : {"points", "normals"})
                if (value_of(kPointFactors, values, name).is_none())
                    throw OptionError(name, "must be an array of 3-vectors, got None");
            PointResult r = run_released(
                [&](CancellationFlag& flag, ProgressSink* sink) {
                    PointOptions run = o;
                    run.cancel = &flag;
                    run.progress = sink;
                    return compute_point_form_factors(*s.scene, run);
                },
                value_of(kPointFactors, values, "progress"));
            return adopt(std::move(r.F));
        });
}

}  // namespace formfactor::python
