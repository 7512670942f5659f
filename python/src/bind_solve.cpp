// Solvers with NumPy in and out: radiosity (RGB), thermal (grey bodies), repair, Hottel's total
// exchange factors.

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <optional>

#include "bindings.h"
#include "formfactor/core/error.h"
#include "formfactor/matrix/repair.h"
#include "formfactor/matrix/sparse.h"
#include "formfactor/output/report.h"
#include "formfactor/scene/closure.h"
#include "formfactor/solve/properties.h"
#include "formfactor/solve/radiosity.h"
#include "formfactor/solve/thermal.h"
#include "keywords.h"

namespace formfactor::python {

namespace {

/// F as the solvers take it: a Result's matrix (shared, whole), or an (N, N) array with the
/// scene's areas.
FormFactors form_factors_of(const PyScene& s, const py::object& F) {
    const std::size_t n = s.scene->patches.size();
    if (py::isinstance<PyResult>(F)) {
        const PyResult& r = F.cast<const PyResult&>();
        if (r.result.form_factors.is_block())
            throw OptionError("F", "the solvers need the whole matrix, not a block of rows");
        if (r.result.form_factors.size() != n)
            throw OptionError("F", "was computed for another scene (sizes differ)");
        return r.result.form_factors;
    }
    const auto a = as_doubles(F, "F", 2);
    if (static_cast<std::size_t>(a.shape(0)) != n || static_cast<std::size_t>(a.shape(1)) != n) {
        throw OptionError("F", fmt::format("must be {0}×{0} (the scene's patches), got {1}×{2}", n,
                                           a.shape(0), a.shape(1)));
    }
    FormFactors ff;
    ff.F = Eigen::Map<const DenseMatrix>(a.data(), static_cast<Eigen::Index>(n),
                                         static_cast<Eigen::Index>(n));
    if (!ff.F.allFinite()) throw OptionError("F", "has entries that are not finite");
    for (const Patch& p : s.scene->patches) ff.areas.push_back(p.area);
    return ff;
}

/// Per-patch doubles: a scalar for every patch or an (N,) array.
std::vector<double> per_patch(const py::object& v, const char* name, std::size_t n) {
    if (py::isinstance<py::float_>(v) || py::isinstance<py::int_>(v)) {
        return std::vector<double>(n, v.cast<double>());
    }
    const auto a = as_doubles(v, name, 1);
    if (static_cast<std::size_t>(a.shape(0)) != n) {
        throw OptionError(
            name, fmt::format("must have {} values (one per patch), got {}", n, a.shape(0)));
    }
    return std::vector<double>(a.data(), a.data() + n);
}

/// Per-patch colours: a scalar, an (N,) array (grey) or an (N, 3) array.
std::vector<Rgb> per_patch_rgb(const py::object& v, const char* name, std::size_t n) {
    if (py::isinstance<py::float_>(v) || py::isinstance<py::int_>(v)) {
        return std::vector<Rgb>(n, Rgb::Constant(v.cast<double>()));
    }
    const auto any = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(v);
    if (!any) throw OptionError(name, "must be an array of numbers");
    if (any.ndim() == 1) {
        const std::vector<double> g = per_patch(v, name, n);
        std::vector<Rgb> out;
        for (double x : g) out.push_back(Rgb::Constant(x));
        return out;
    }
    if (any.ndim() != 2 || static_cast<std::size_t>(any.shape(0)) != n || any.shape(1) != 3) {
        throw OptionError(name, fmt::format("must have shape ({}, 3) or ({},)", n, n));
    }
    std::vector<Rgb> out;
    for (std::size_t i = 0; i < n; ++i)
        out.emplace_back(any.data()[3 * i], any.data()[3 * i + 1], any.data()[3 * i + 2]);
    return out;
}

py::array_t<double> array_of(const std::vector<double>& v) {
    return py::array_t<double>(v.size(), v.data());
}

py::array_t<double> array_of(const std::vector<Rgb>& v) {
    py::array_t<double> out({v.size(), std::size_t(3)});
    for (std::size_t i = 0; i < v.size(); ++i)
        for (int c = 0; c < 3; ++c) out.mutable_at(static_cast<py::ssize_t>(i), c) = v[i][c];
    return out;
}

SolverOptions solver_options(const py::object& solver_arg, const py::object& residual_arg,
                             const py::object& max_iterations_arg, const py::object& threads_arg) {
    const std::string solver = arg<std::string>(solver_arg, "solver");
    const double residual = arg<double>(residual_arg, "residual");
    const long long max_iterations = arg<long long>(max_iterations_arg, "max_iterations");
    const int threads = arg<int>(threads_arg, "threads");
    SolverOptions o;
    o.solver = parse_solver(solver);
    o.residual = residual;
    o.max_iterations = max_iterations;
    o.threads = threads;
    if (!(residual > 0.0) || !std::isfinite(residual))
        throw OptionError("residual", fmt::format("must be a finite number > 0, got {}", residual));
    if (max_iterations < 0)
        throw OptionError("max_iterations", fmt::format("must be ≥ 0, got {}", max_iterations));
    return o;
}

py::dict stats_dict(const SolverStats& s) {
    py::dict d;
    d["solver"] = s.solver;
    d["iterations"] = s.iterations;
    d["residual"] = s.residual;
    d["tolerance"] = s.tolerance;
    d["converged"] = s.converged;
    d["seconds"] = s.seconds;
    d["warnings"] = s.warnings;
    return d;
}

/// A sparse F passed as ("csr", indptr, indices, data) (the Python layer's form of a
/// scipy.sparse matrix), with the scene's areas; nullopt for anything else.
std::optional<SparseFormFactors> sparse_of(const PyScene& s, const py::object& F) {
    if (!py::isinstance<py::tuple>(F)) return std::nullopt;
    const py::tuple t = F.cast<py::tuple>();
    if (t.size() != 4 || !py::isinstance<py::str>(t[0]) || t[0].cast<std::string>() != "csr")
        return std::nullopt;
    const std::size_t n = s.scene->patches.size();
    const auto indptr =
        t[1].cast<py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>>();
    const auto indices =
        t[2].cast<py::array_t<std::int32_t, py::array::c_style | py::array::forcecast>>();
    const auto data = t[3].cast<py::array_t<double, py::array::c_style | py::array::forcecast>>();
    if (static_cast<std::size_t>(indptr.size()) != n + 1)
        throw OptionError("F", fmt::format("must be {0}×{0} (the scene's patches), got {1} rows", n,
                                           indptr.size() - 1));
    SparseFormFactors sf;
    sf.n = n;
    sf.indptr.assign(indptr.data(), indptr.data() + indptr.size());
    sf.indices.assign(indices.data(), indices.data() + indices.size());
    sf.values.assign(data.data(), data.data() + data.size());
    for (const Patch& p : s.scene->patches) sf.areas.push_back(p.area);
    sf.dropped.assign(n, 0.0);
    sf.computed_row_sums.assign(n, 0.0);
    try {
        sf.check();
    } catch (const Error& e) {
        throw OptionError("F", e.what());
    }
    for (std::size_t i = 0; i < n; ++i) sf.computed_row_sums[i] = sf.row_sum(i);
    return sf;
}

/// Whether a solve over a communicator spreads F's rows over its ranks: the iterative solvers
/// (direct and shooting need the whole F, and run on rank 0 alone).
bool distributes(const SolverOptions& o) {
    return o.solver == SolverKind::jacobi || o.solver == SolverKind::gauss_seidel ||
           o.solver == SolverKind::gmres;
}

/// The hierarchical operator passed as F, or null; checked against the scene.
const HierarchicalFormFactors* operator_of(const PyScene& s, const py::object& F) {
    if (!py::isinstance<PyHierarchical>(F)) return nullptr;
    const PyHierarchical& h = F.cast<const PyHierarchical&>();
    if (h.op->size() != s.scene->patches.size())
        throw OptionError("F", "is the operator of another scene (sizes differ)");
    return h.op.get();
}

py::object radiosity(const PyScene& s, const py::object& F, const py::object& reflectance,
                     const py::object& emission, const py::object& solver,
                     const py::object& residual, const py::object& max_iterations,
                     const py::object& threads, const py::object& progress,
                     const py::object& comm_arg) {
    std::optional<distributed::Communicator> comm;
    open_communicator(comm_arg, comm);
    if (comm && distributed::rank() != 0) {
        serve_rank0();
        return py::none();
    }
    const HierarchicalFormFactors* op = operator_of(s, F);
    const std::optional<SparseFormFactors> sp = op ? std::nullopt : sparse_of(s, F);
    const FormFactors ff = op || sp ? FormFactors{} : form_factors_of(s, F);
    const std::size_t n = op ? op->size() : sp ? sp->n : ff.size();
    PatchProperties props = properties_from_scene(*s.scene);
    if (!reflectance.is_none()) props.reflectance = per_patch_rgb(reflectance, "reflectance", n);
    if (!emission.is_none()) props.emission = per_patch_rgb(emission, "emission", n);
    validate_properties(props);
    const SolverOptions o = solver_options(solver, residual, max_iterations, threads);
    const bool over_ranks = comm && !op && distributes(o);
    const RadiosityResult r = run_released(
        [&](CancellationFlag&, ProgressSink* sink) {
            SolverOptions run = o;
            run.progress = sink;
            if (over_ranks)
                return distributed::solve_radiosity(
                    sp ? distributed::distribute_rows(*sp) : distributed::distribute_rows(ff),
                    props, run);
            return op   ? solve_radiosity(*op, props, run)
                   : sp ? solve_radiosity(*sp, props, run)
                        : solve_radiosity(ff, props, run);
        },
        progress);
    py::dict d;
    d["radiosity"] = array_of(r.radiosity);
    d["stats"] = stats_dict(r.stats);
    py::dict b;
    b["emitted"] = array_of(std::vector<Rgb>{r.balance.emitted}).attr("reshape")(3);
    b["absorbed"] = array_of(std::vector<Rgb>{r.balance.absorbed}).attr("reshape")(3);
    b["escaped"] = array_of(std::vector<Rgb>{r.balance.escaped}).attr("reshape")(3);
    b["relative_defect"] = r.balance.relative_defect;
    d["balance"] = b;
    return d;
}

py::object thermal(const PyScene& s, const py::object& F, const py::object& emissivity,
                   const py::object& temperature, const py::object& net_flux,
                   const py::object& ambient, const py::object& solver, const py::object& residual,
                   const py::object& max_iterations, const py::object& threads,
                   const py::object& progress, const py::object& comm_arg) {
    std::optional<distributed::Communicator> comm;
    open_communicator(comm_arg, comm);
    if (comm && distributed::rank() != 0) {
        serve_rank0();
        return py::none();
    }
    const double ambient_temperature = arg<double>(ambient, "ambient_temperature");
    const HierarchicalFormFactors* op = operator_of(s, F);
    const std::optional<SparseFormFactors> sp = op ? std::nullopt : sparse_of(s, F);
    const FormFactors ff = op || sp ? FormFactors{} : form_factors_of(s, F);
    const std::size_t n = op ? op->size() : sp ? sp->n : ff.size();
    PatchProperties props = properties_from_scene(*s.scene);
    if (!emissivity.is_none()) props.emissivity = per_patch(emissivity, "emissivity", n);
    const double nan = std::numeric_limits<double>::quiet_NaN();
    const std::vector<double> T = temperature.is_none() ? std::vector<double>(n, nan)
                                                        : per_patch(temperature, "temperature", n);
    const std::vector<double> q =
        net_flux.is_none() ? std::vector<double>(n, nan) : per_patch(net_flux, "net_flux", n);
    for (std::size_t i = 0; i < n; ++i) {
        if (!std::isnan(T[i]) && !std::isnan(q[i])) {
            throw OptionError("net_flux", fmt::format("patch {} has both a temperature and a net "
                                                      "flux (give one; NaN for the other)",
                                                      i));
        }
        if (!std::isnan(T[i])) {
            props.temperature[i] = T[i];
            props.net_flux[i] = nan;
        } else if (!std::isnan(q[i])) {
            props.net_flux[i] = q[i];
            props.temperature[i] = nan;
        }
    }
    validate_properties(props);
    ThermalOptions o;
    o.solver = solver_options(solver, residual, max_iterations, threads);
    o.ambient_temperature = ambient_temperature;
    o.closed = check_closure(*s.scene).closed;
    if (!(ambient_temperature >= 0.0) || !std::isfinite(ambient_temperature)) {
        throw OptionError(
            "ambient_temperature",
            fmt::format("must be a finite number ≥ 0 (K), got {}", ambient_temperature));
    }
    const bool over_ranks = comm && !op && distributes(o.solver);
    const ThermalResult r = run_released(
        [&](CancellationFlag&, ProgressSink* sink) {
            ThermalOptions run = o;
            run.solver.progress = sink;
            if (over_ranks)
                return distributed::solve_thermal(
                    sp ? distributed::distribute_rows(*sp) : distributed::distribute_rows(ff),
                    props, run);
            return op   ? solve_thermal(*op, props, run)
                   : sp ? solve_thermal(*sp, props, run)
                        : solve_thermal(ff, props, run);
        },
        progress);
    py::dict d;
    d["area"] = array_of(r.area);
    d["emissivity"] = array_of(r.emissivity);
    d["temperature"] = array_of(r.temperature);
    py::array_t<bool> prescribed(static_cast<py::ssize_t>(n));
    for (std::size_t i = 0; i < n; ++i)
        prescribed.mutable_at(static_cast<py::ssize_t>(i)) = r.temperature_prescribed[i];
    d["temperature_prescribed"] = prescribed;
    d["radiosity"] = array_of(r.radiosity);
    d["net_flux"] = array_of(r.net_flux);
    d["net_power"] = array_of(r.net_power);
    d["total_net_power"] = r.total_net_power;
    d["escaped_power"] = r.escaped_power;
    d["relative_balance_defect"] = r.relative_balance_defect;
    d["ambient_temperature"] = r.ambient_temperature;
    d["stats"] = stats_dict(r.stats);
    d["warnings"] = r.warnings;
    return d;
}

}  // namespace

/// F x for x of shape (N,) or (N, k); `adjoint`: Fᵀ x, which reciprocity makes A ∘ F (x / A).
py::array_t<double> product(const PyHierarchical& h, const py::object& x, int threads,
                            bool adjoint) {
    const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(x);
    const auto n = static_cast<py::ssize_t>(h.op->size());
    if (!a || (a.ndim() != 1 && a.ndim() != 2) || a.shape(0) != n)
        throw OptionError("x", fmt::format("must have shape ({0},) or ({0}, k)", n));
    const Eigen::Index k = a.ndim() == 1 ? 1 : a.shape(1);
    const std::vector<double>& areas = h.op->areas();
    Eigen::MatrixXd X(n, k), Y;
    for (Eigen::Index i = 0; i < n; ++i)
        for (Eigen::Index c = 0; c < k; ++c)
            X(i, c) = adjoint ? a.data()[i * k + c] / areas[static_cast<std::size_t>(i)]
                              : a.data()[i * k + c];
    if (!X.allFinite()) throw OptionError("x", "has values that are not finite");
    {
        py::gil_scoped_release nogil;
        h.op->multiply(X, Y, threads);
    }
    py::array_t<double> out = a.ndim() == 1 ? py::array_t<double>(n)
                                            : py::array_t<double>({n, static_cast<py::ssize_t>(k)});
    double* o = out.mutable_data();
    for (Eigen::Index i = 0; i < n; ++i)
        for (Eigen::Index c = 0; c < k; ++c)
            o[i * k + c] = adjoint ? areas[static_cast<std::size_t>(i)] * Y(i, c) : Y(i, c);
    return out;
}

/// The keywords of Scene.hierarchical().
const Keyword<HierarchicalOptions> kHierarchicalKeywords[] = {
    {"tolerance", "float", "1e-06",
     "the relative error of each low-rank block (adaptive cross approximation).",
     [](const py::object& v, HierarchicalOptions& o) { o.tolerance = arg<double>(v, "tolerance"); },
     true},
    {"eta", "float", "1.5", "admissibility: how far apart two clusters must be to be compressed.",
     [](const py::object& v, HierarchicalOptions& o) { o.eta = arg<double>(v, "eta"); }},
    {"leaf_size", "int", "32", "patches per leaf cluster at most.",
     [](const py::object& v, HierarchicalOptions& o) {
         // A negative size as 0, which build_hierarchical() refuses with the valid range.
         o.leaf_size = static_cast<std::size_t>(std::max(0LL, arg<long long>(v, "leaf_size")));
     }},
    {"threads", "int", "0", "worker threads (0: all cores).",
     [](const py::object& v, HierarchicalOptions& o) { o.threads = arg<int>(v, "threads"); }},
    {"progress", "_Progress", "None",
     "None, True (a bar on stderr) or callable(phase, done, total, elapsed_seconds).", nullptr},
};

const Signature<HierarchicalOptions> kHierarchical{
    "hierarchical", "HierarchicalOperator",
    "The hierarchical (H-matrix) operator of this scene's form factors, for scenes without "
    "obstructions (closed rooms, furnaces, convex cavities): far cluster pairs as low-rank blocks, "
    "near ones exact, F never formed (docs/hierarchical.md). Pass it as F to solve_radiosity and "
    "solve_thermal (GMRES by default), apply it with ``op @ x``, or use "
    "``op.as_linear_operator()`` with SciPy. Raises Error for a scene with obstructions.",
    kHierarchicalKeywords};

py::dict hierarchical_stats(const HierarchicalStats& st) {
    py::dict d;
    d["patches"] = st.patches;
    d["tolerance"] = st.tolerance;
    d["eta"] = st.eta;
    d["leaf_size"] = st.leaf_size;
    d["clusters"] = st.clusters;
    d["leaves"] = st.leaves;
    d["zero_blocks"] = st.zero_blocks;
    d["dense_blocks"] = st.dense_blocks;
    d["low_rank_blocks"] = st.low_rank_blocks;
    d["low_rank_fallbacks"] = st.low_rank_fallbacks;
    d["dense_values"] = st.dense_values;
    d["low_rank_values"] = st.low_rank_values;
    d["mean_rank"] = st.mean_rank;
    d["max_rank"] = st.max_rank;
    d["entries_computed"] = st.entries_computed;
    d["bytes"] = st.bytes;
    d["seconds"] = st.seconds;
    return d;
}

void bind_hierarchical(py::module_& m) {
    py::class_<PyHierarchical>(m, "HierarchicalOperator", R"doc(
The hierarchical (H-matrix) form-factor operator of a scene without obstructions: F applied to
vectors without forming it (docs/hierarchical.md). ``op @ x`` or ``op.matvec(x)`` is F x for an
(N,) or (N, k) array; pass it as F to solve_radiosity / solve_thermal (gmres or jacobi);
``as_linear_operator()`` gives a scipy.sparse.linalg.LinearOperator.
)doc")
        .def_property_readonly(
            "shape",
            [](const PyHierarchical& h) { return py::make_tuple(h.op->size(), h.op->size()); })
        .def_property_readonly(
            "areas", [](const PyHierarchical& h) { return array_of(h.op->areas()); },
            "Patch areas (N,)")
        .def_property_readonly(
            "stats", [](const PyHierarchical& h) { return hierarchical_stats(h.op->stats()); },
            "What the build made: blocks by kind, ranks, entries computed, bytes, seconds")
        .def(
            "matvec",
            [](const PyHierarchical& h, const py::object& x, int threads) {
                return product(h, x, threads, false);
            },
            py::arg("x"), py::arg("threads") = 0, "F x for x of shape (N,) or (N, k)")
        .def(
            "__matmul__",
            [](const PyHierarchical& h, const py::object& x) { return product(h, x, 0, false); },
            "F @ x: F x for x of shape (N,) or (N, k)")
        .def(
            "as_linear_operator",
            [](const PyHierarchical& h) {
                const py::object linear_operator =
                    py::module_::import("scipy.sparse.linalg").attr("LinearOperator");
                const py::cpp_function matvec(
                    [h](const py::object& x) { return product(h, x, 0, false); });
                const py::cpp_function rmatvec(
                    [h](const py::object& y) { return product(h, y, 0, true); });
                const auto n = h.op->size();
                return linear_operator(
                    py::make_tuple(n, n), py::arg("matvec") = matvec, py::arg("rmatvec") = rmatvec,
                    py::arg("matmat") = matvec,
                    py::arg("dtype") = py::module_::import("builtins").attr("float"));
            },
            "A scipy.sparse.linalg.LinearOperator of F: matvec F x, rmatvec Fᵀ y = A ∘ F (y / A) "
            "(reciprocity, which the operator satisfies by construction).")
        .def(
            "row_sums",
            [](const PyHierarchical& h, int threads) {
                std::vector<double> r;
                {
                    py::gil_scoped_release nogil;
                    r = h.op->row_sums(threads);
                }
                return array_of(r);
            },
            py::arg("threads") = 0, "Σ_j F_ij per patch (N,)")
        .def(
            "per_surface",
            [](const PyHierarchical& h, int threads) {
                std::vector<int> group;
                for (const Patch& p : h.scene->patches) group.push_back(p.surface);
                const std::size_t g = h.scene->surfaces.size();
                DenseMatrix G;
                {
                    py::gil_scoped_release nogil;
                    G = h.op->per_group(group, g, threads);
                }
                py::array_t<double> out({g, g});
                std::copy(G.data(), G.data() + G.size(), out.mutable_data());
                return out;
            },
            py::arg("threads") = 0,
            "Per-surface factors (S, S) from S products (surfaces few): area-weighted rows")
        .def(
            "to_dense",
            [](const PyHierarchical& h, int threads) {
                DenseMatrix F;
                {
                    py::gil_scoped_release nogil;
                    F = h.op->to_dense(threads);
                }
                const std::size_t n = h.op->size();
                py::array_t<double> out({n, n});
                std::copy(F.data(), F.data() + F.size(), out.mutable_data());
                return out;
            },
            py::arg("threads") = 0, "The operator as an (N, N) array (N² doubles: small scenes)");
    auto scene = py::reinterpret_borrow<py::class_<PyScene>>(m.attr("Scene"));
    bind_with_keywords(
        scene, kHierarchical,
        [](const py::object& self, HierarchicalOptions& o, const std::vector<py::object>& values) {
            const PyScene& s = self.cast<const PyScene&>();
            auto op = run_released(
                [&](CancellationFlag&, ProgressSink* sink) {
                    HierarchicalOptions run = o;
                    run.progress = sink;
                    return std::make_shared<const HierarchicalFormFactors>(
                        build_hierarchical(*s.scene, run));
                },
                value_of(kHierarchical, values, "progress"));
            return PyHierarchical{s.scene, std::move(op)};
        });
}

void bind_solve(py::module_& m) {
    bind_hierarchical(m);
    m.def("radiosity", &radiosity, py::arg("scene"), py::arg("F"), py::arg("reflectance"),
          py::arg("emission"), py::arg("solver"), py::arg("residual"), py::arg("max_iterations"),
          py::arg("threads"), py::arg("progress"), py::arg("comm") = py::none());
    m.def("thermal", &thermal, py::arg("scene"), py::arg("F"), py::arg("emissivity"),
          py::arg("temperature"), py::arg("net_flux"), py::arg("ambient_temperature"),
          py::arg("solver"), py::arg("residual"), py::arg("max_iterations"), py::arg("threads"),
          py::arg("progress"), py::arg("comm") = py::none());
    m.def(
        "repair",
        [](const py::object& F, const py::object& areas, const py::object& mode,
           const py::object& enclosure, const py::object& force_closure) {
            const auto a = as_doubles(F, "F", 2);
            const auto n = static_cast<std::size_t>(a.shape(0));
            if (static_cast<std::size_t>(a.shape(1)) != n) throw OptionError("F", "must be square");
            const auto ar = as_doubles(areas, "areas", 1);
            if (static_cast<std::size_t>(ar.shape(0)) != n)
                throw OptionError("areas", fmt::format("must have {} values", n));
            auto* held = new DenseMatrix(Eigen::Map<const DenseMatrix>(
                a.data(), static_cast<Eigen::Index>(n), static_cast<Eigen::Index>(n)));
            py::capsule owner(held, [](void* p) { delete static_cast<DenseMatrix*>(p); });
            RepairOptions o;
            o.mode = parse_repair_mode(arg<std::string>(mode, "mode"));
            o.enclosure = arg<bool>(enclosure, "enclosure");
            o.force_closure = arg<bool>(force_closure, "force_closure");
            const std::vector<double> av(ar.data(), ar.data() + n);
            RepairReport report;
            {
                py::gil_scoped_release nogil;
                report = repair(*held, av, o);
            }
            py::array_t<double> out({n, n}, held->data(), owner);
            return py::make_tuple(out, json_text(to_json(report)));
        },
        py::arg("F"), py::arg("areas"), py::arg("mode"), py::arg("enclosure"),
        py::arg("force_closure"));
    m.def(
        "exchange_factors",
        [](const py::object& F, const py::object& emissivity) {
            const auto a = as_doubles(F, "F", 2);
            const auto n = static_cast<std::size_t>(a.shape(0));
            if (static_cast<std::size_t>(a.shape(1)) != n) throw OptionError("F", "must be square");
            const std::vector<double> eps = per_patch(emissivity, "emissivity", n);
            const DenseMatrix M = Eigen::Map<const DenseMatrix>(
                a.data(), static_cast<Eigen::Index>(n), static_cast<Eigen::Index>(n));
            DenseMatrix X;
            {
                py::gil_scoped_release nogil;
                X = total_exchange_factors(M, eps);
            }
            py::array_t<double> out({n, n});
            std::copy(X.data(), X.data() + X.size(), out.mutable_data());
            return out;
        },
        py::arg("F"), py::arg("emissivity"));
}

}  // namespace formfactor::python
