// Form factors: Scene.form_factors() → Result (the matrix as a NumPy view, standard errors,
// the report, sparse output), and point_factors().

#include <fmt/format.h>

#include <cmath>
#include <type_traits>

#include "bindings.h"
#include "formfactor/core/atomic_file.h"
#include "formfactor/core/error.h"
#include "formfactor/core/parallel.h"
#include "formfactor/distributed/distributed.h"
#include "formfactor/matrix/aggregate.h"
#include "formfactor/methods/point_factors.h"
#include "formfactor/output/page.h"
#include "formfactor/output/report.h"
#include "formfactor/scene/closure.h"

namespace formfactor::python {

namespace {

/// The keyword arguments of form_factors(), None where not given.
struct ComputeArgs {
    py::object method, tolerance, obstructed_tolerance, samples, seed, threads, sampler, resolution,
        points, rows, repair, ray_offset, comm;
    bool force_closure = false;
    bool robust_rays = false;
};

template <class T>
void set_if(const py::object& value, T& target, const char* name) {
    if (!value.is_none()) target = arg<T>(value, name);
}

/// A non-negative integer keyword: a negative Python int is an OptionError naming it.
std::uint64_t unsigned_arg(const py::object& value, const char* name) {
    const long long v = arg<long long>(value, name);
    if (v < 0) throw OptionError(name, fmt::format("must be ≥ 0, got {}", v));
    return static_cast<std::uint64_t>(v);
}

ComputeOptions options_of(const Scene& scene, const ComputeArgs& a) {
    ComputeOptions o;
    if (!a.method.is_none()) o.method = parse_method(arg<std::string>(a.method, "method"));
    MethodOptions& m = o.method_options;
    set_if(a.threads, m.threads, "threads");
    if (!a.tolerance.is_none()) {
        // As the CLI's --tolerance: a given tolerance sets the obstructed pairs' target too.
        m.tolerance = arg<double>(a.tolerance, "tolerance");
        m.obstructed_tolerance = m.tolerance;
    }
    set_if(a.obstructed_tolerance, m.obstructed_tolerance, "obstructed_tolerance");
    if (!a.samples.is_none()) m.samples = unsigned_arg(a.samples, "samples");
    if (!a.seed.is_none()) m.seed = unsigned_arg(a.seed, "seed");
    if (!a.sampler.is_none()) m.sampler = parse_sampler(arg<std::string>(a.sampler, "sampler"));
    set_if(a.resolution, m.resolution, "resolution");
    set_if(a.points, m.points, "points");
    if (!a.rows.is_none()) {
        if (!py::isinstance<py::tuple>(a.rows) || py::len(a.rows) != 2)
            throw OptionError("rows", "must be a pair (begin, end)");
        const auto t = a.rows.cast<py::tuple>();
        o.rows.begin = unsigned_arg(t[0], "rows");
        o.rows.end = t[1].is_none() ? RowRange::kEnd : unsigned_arg(t[1], "rows");
    }
    if (!a.repair.is_none())
        o.repair.mode = parse_repair_mode(arg<std::string>(a.repair, "repair"));
    o.repair.enclosure = known_enclosure(scene);
    o.repair.force_closure = a.force_closure;
    set_if(a.ray_offset, o.visibility.relative_epsilon, "ray_offset");
    o.visibility.robust = a.robust_rays;
    return o;
}

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
    if (ff.is_block()) {
        options["rows"] = {ff.first_row, ff.first_row + ff.size()};
        nlohmann::json report{{"formfactor_version", FF_VERSION},
                              {"timestamp", utc_timestamp()},
                              {"command", "python"},
                              {"scene", scene_summary_json(scene)},
                              {"N", ff.areas.size()},
                              {"rows", {ff.first_row, ff.first_row + ff.size()}},
                              {"method", to_string(method)},
                              {"options", options},
                              {"threads", r.threads},
                              {"details", to_json(r.report)},
                              {"diagnostics", {{"standard_error", standard_error_json(ff)}}}};
        nlohmann::json t = nlohmann::json::object();
        for (const auto& [step, sec] : r.timings.steps) t[step] = sec;
        t["total"] = total_seconds;
        report["timings"] = t;
        return json_text(report);
    }
    ReportContext ctx;
    ctx.command = "python";
    ctx.method = to_string(method);
    ctx.options = options;
    ctx.timings = r.timings;
    ctx.total_seconds = total_seconds;
    ctx.threads = r.threads;
    ctx.details = to_json(r.report);
    ctx.reciprocity = r.traits.reciprocity;
    nlohmann::json report = make_report(scene, ff, ctx);
    if (r.repair) report["repair"] = to_json(*r.repair);
    return json_text(report);
}

// Under a communicator (comm= the Fortran handle of an mpi4py communicator): every rank calls
// together; rank 0 computes over all of them and gets the result, the others serve it and get
// None. Without one, one process as always.
py::object compute(const PyScene& s, const ComputeArgs& args, const py::object& progress) {
    ComputeOptions o = options_of(*s.scene, args);
    if (!o.method) o.method = default_method(*s.scene);
    validate(o);
    std::optional<distributed::Communicator> comm;
    if (!args.comm.is_none()) {
        if (!args.rows.is_none())
            throw OptionError("rows", "a run over a communicator computes every row");
        comm.emplace(arg<std::int64_t>(args.comm, "comm"));
        if (distributed::rank() != 0) {
            run_released([](CancellationFlag&, ProgressSink*) { return distributed::serve(); },
                         py::none());
            return py::none();
        }
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
        .def_property_readonly("_report_json",
                               [](const PyResult& r) {
                                   if (!r.report_json)
                                       r.report_json = report_of(*r.scene, r.options, r.result,
                                                                 r.total_seconds);
                                   return *r.report_json;
                               })
        .def(
            "sparse",
            [](const PyResult& r, double threshold) {
                return csr(r.result.form_factors.F, threshold);
            },
            py::arg("threshold") = 0.0,
            "F as a scipy.sparse.csr_matrix holding the entries with |F_ij| > threshold.")
        .def(
            "per_surface",
            [](const PyResult& r) {
                if (r.result.form_factors.is_block())
                    throw OptionError("rows", "per-surface factors need the whole matrix");
                FormFactors agg = aggregate_per_surface(*r.scene, r.result.form_factors);
                const PatchGroups groups = surface_groups(*r.scene);
                return py::make_tuple(adopt(std::move(agg.F)), groups.names);
            },
            "(F_surfaces, names): the area-weighted per-surface matrix (View3D's Combine "
            "merges surfaces with cmb), rows = surfaces.")
        .def(
            "to_html",
            [](const PyResult& r, const std::string& path, const py::object& solution,
               const std::string& title, long long max_entries) {
                const std::string html = page_of(r, solution, title, max_entries);
                write_file_atomically(path, [&](std::ostream& out) { out << html; });
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
                       attribute_text(page_of(r, py::none(), "", 200'000)) + "\"></iframe>";
            },
            "The result page in a sandboxed iframe, for Jupyter (at most 200,000 entries of F).");

    py::class_<ComputeArgs>(m, "_ComputeArgs")
        .def(py::init<>())
        .def_readwrite("method", &ComputeArgs::method)
        .def_readwrite("tolerance", &ComputeArgs::tolerance)
        .def_readwrite("obstructed_tolerance", &ComputeArgs::obstructed_tolerance)
        .def_readwrite("samples", &ComputeArgs::samples)
        .def_readwrite("seed", &ComputeArgs::seed)
        .def_readwrite("threads", &ComputeArgs::threads)
        .def_readwrite("sampler", &ComputeArgs::sampler)
        .def_readwrite("resolution", &ComputeArgs::resolution)
        .def_readwrite("points", &ComputeArgs::points)
        .def_readwrite("rows", &ComputeArgs::rows)
        .def_readwrite("repair", &ComputeArgs::repair)
        .def_readwrite("ray_offset", &ComputeArgs::ray_offset)
        .def_readwrite("force_closure", &ComputeArgs::force_closure)
        .def_readwrite("robust_rays", &ComputeArgs::robust_rays)
        .def_readwrite("comm", &ComputeArgs::comm);

    m.def("compute", &compute, py::arg("scene"), py::arg("args"), py::arg("progress") = py::none());
    // Whether comm= can work: the library was built with MPI.
    m.attr("built_with_mpi") = distributed::built_with_mpi();

    m.def(
        "point_factors",
        [](const PyScene& s, const py::object& points, const py::object& normals, int threads,
           const py::object& progress) {
            const std::vector<Vec3> p = as_vec3s(points, "points");
            const std::vector<Vec3> n = as_vec3s(normals, "normals", p.size());
            if (n.size() != p.size()) {
                throw OptionError(
                    "normals",
                    fmt::format("must have {} rows (one per point), got {}", p.size(), n.size()));
            }
            for (std::size_t k = 0; k < n.size(); ++k)
                if (n[k].norm() == 0.0)
                    throw OptionError("normals", fmt::format("row {} is zero", k));
            DenseMatrix M = run_released(
                [&](CancellationFlag&, ProgressSink*) {
                    return point_form_factors(*s.scene, p, n, threads);
                },
                progress);
            return adopt(std::move(M));
        },
        py::arg("scene"), py::arg("points"), py::arg("normals"), py::arg("threads") = 0,
        py::arg("progress") = py::none());
}

}  // namespace formfactor::python
