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
#include "formfactor/pipeline_solve.h"
#include "formfactor/solve/properties.h"
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

/// What the keywords of solve_radiosity() and solve_thermal() set.
struct SolveArgs {
    SolverOptions solver;
    /// Empty: the default for the kind of F (default_solver()).
    std::optional<SolverKind> kind;
    double ambient_temperature = 0.0;
};

// The keywords the two solves share, each written once.
const Keyword<SolveArgs> kSolveScene = {
    "scene", "Scene", nullptr, "the scene whose patches F couples.", nullptr, true};
const Keyword<SolveArgs> kSolveF = {
    "F",
    "Union[Result, HierarchicalOperator, scipy.sparse.spmatrix, _ArrayLike]",
    nullptr,
    "F[i, j] from patch i to patch j: a Result of this scene (used without a copy), an (N, N) "
    "array, a scipy.sparse matrix (N, N) (``Result.sparse()``, a Matrix Market or HDF5 file read "
    "with SciPy/h5py; solved by gauss-seidel, gmres or jacobi on its stored entries, never "
    "densified), or the scene's HierarchicalOperator (gmres or jacobi).",
    nullptr,
    true};
const Keyword<SolveArgs> kSolveResidual = {
    "residual", "float", "1e-08",
    "stop when the relative residual is below this (a finite number > 0).",
    [](const py::object& v, SolveArgs& o) {
        const double residual = arg<double>(v, "residual");
        if (!(residual > 0.0) || !std::isfinite(residual)) {
            throw OptionError("residual",
                              fmt::format("must be a finite number > 0, got {}", residual));
        }
        o.solver.residual = residual;
    }};
const Keyword<SolveArgs> kSolveMaxIterations = {
    "max_iterations", "int", "0",
    "sweeps (jacobi, gauss-seidel), shots (shooting) or products (gmres) at most; 0: automatic.",
    [](const py::object& v, SolveArgs& o) {
        const long long max_iterations = arg<long long>(v, "max_iterations");
        if (max_iterations < 0)
            throw OptionError("max_iterations", fmt::format("must be ≥ 0, got {}", max_iterations));
        o.solver.max_iterations = max_iterations;
    }};
const Keyword<SolveArgs> kSolveThreads = {
    "threads", "int", "0", "worker threads (0: all cores).",
    [](const py::object& v, SolveArgs& o) { o.solver.threads = arg<int>(v, "threads"); }};
const Keyword<SolveArgs> kSolveProgress = {"progress", "_Progress", "None", kProgressDoc, nullptr};

void apply_solver(const py::object& v, SolveArgs& o) {
    o.kind = parse_solver(arg<std::string>(v, "solver"));
}

/// The arguments of solve_radiosity(), in order.
const Keyword<SolveArgs> kSolveRadiosityKeywords[] = {
    kSolveScene,
    kSolveF,
    {"reflectance", "Optional[_ArrayLike]", "None",
     "ρ per patch: (N, 3), (N,) (grey) or a scalar; by default the scene's materials (MTL Kd).",
     nullptr, true},
    {"emission", "Optional[_ArrayLike]", "None",
     "E per patch, in the units of the radiosity: (N, 3), (N,) (grey) or a scalar; by default "
     "the scene's materials (MTL Ke).",
     nullptr, true},
    {"solver", "Optional[str]", "None",
     "gauss-seidel (the default for a matrix), jacobi, shooting (progressive refinement), direct "
     "(LU) or gmres (the default for an operator).",
     apply_solver},
    kSolveResidual,
    kSolveMaxIterations,
    kSolveThreads,
    kSolveProgress,
    {"comm", "Optional[Any]", "None",
     "an mpi4py communicator (``MPI.COMM_WORLD``) to solve over its ranks under mpirun. Every "
     "rank calls with the same arguments; only rank 0's F is read (the others may pass None). "
     "With ``gauss-seidel``, ``gmres`` or ``jacobi`` on a matrix, rank 0 sends each rank a block "
     "of rows of F and every rank iterates on its own rows: jacobi and gmres give the one "
     "process's result bit for bit, gauss-seidel one within ``residual`` of it. An operator "
     "built with ``comm=`` (Scene.hierarchical) must be given this communicator and is solved "
     "over its ranks (gmres or jacobi), bit for bit the one process's; other solvers and an "
     "operator built without ``comm=`` run on rank 0 alone. Rank 0 gets the result, the others "
     "None (docs/cluster.md).",
     nullptr},
};

const Signature<SolveArgs> kSolveRadiosity{
    "solve_radiosity", "RadiosityResult",
    "Solves the radiosity equation B = E + diag(ρ) F B for each of R, G, B. Returns a "
    "RadiosityResult.",
    kSolveRadiosityKeywords};

/// The arguments of solve_thermal(), in order.
const Keyword<SolveArgs> kSolveThermalKeywords[] = {
    kSolveScene,
    kSolveF,
    {"emissivity", "Optional[_ArrayLike]", "None",
     "ε per patch, (N,) or a scalar, in (0, 1]; by default the scene's materials.", nullptr, true},
    {"temperature", "Optional[_ArrayLike]", "None",
     "T per patch in K, (N,) or a scalar; NaN: not given for that patch. By default the scene's "
     "materials.",
     nullptr, true},
    {"net_flux", "Optional[_ArrayLike]", "None",
     "q per patch in W/m² leaving the patch, (N,) or a scalar; NaN: not given for that patch. A "
     "patch with neither a temperature nor a net flux is adiabatic (q = 0).",
     nullptr, true},
    {"ambient_temperature", "float", "0.0",
     "the black environment that the open part of each row sees, K (≥ 0).",
     [](const py::object& v, SolveArgs& o) {
         const double t = arg<double>(v, "ambient_temperature");
         if (!(t >= 0.0) || !std::isfinite(t)) {
             throw OptionError("ambient_temperature",
                               fmt::format("must be a finite number ≥ 0 (K), got {}", t));
         }
         o.ambient_temperature = t;
     }},
    {"solver", "Optional[str]", "None",
     "direct (the default for a matrix), gmres (the default for an operator or a sparse F), "
     "gauss-seidel, jacobi or shooting.",
     apply_solver},
    kSolveResidual,
    kSolveMaxIterations,
    kSolveThreads,
    kSolveProgress,
    {"comm", "Optional[Any]", "None",
     "an mpi4py communicator to solve over its ranks, as in solve_radiosity (pass "
     "``solver=\"gmres\"``: the default ``direct`` solve of a matrix runs on rank 0 alone).",
     nullptr},
};

const Signature<SolveArgs> kSolveThermal{
    "solve_thermal", "ThermalResult",
    "Radiative heat exchange between grey diffuse patches (net-radiation method): each patch has "
    "an emissivity ε and either a temperature T (K) or a net flux q (W/m², leaving the patch). "
    "Returns a ThermalResult (temperature, radiosity, net_flux, net_power, total_net_power, "
    "...).",
    kSolveThermalKeywords};

/// The arguments of repair(), in order.
const Keyword<RepairOptions> kRepairKeywords[] = {
    {"F", "_ArrayLike", nullptr, "(N, N) form factors, F[i, j] from patch i to patch j.", nullptr,
     true},
    {"areas", "_ArrayLike", nullptr, "(N,) patch areas.", nullptr, true},
    {"mode", "str", "'both'",
     "reciprocity (symmetrises A_i F_ij), closure (scales rows to sum to 1, keeping "
     "reciprocity) or both.",
     [](const py::object& v, RepairOptions& o) {
         o.mode = parse_repair_mode(arg<std::string>(v, "mode"));
     },
     true},
    {"enclosure", "bool", "False", "the patches close a volume: closure may close the rows.",
     [](const py::object& v, RepairOptions& o) { o.enclosure = arg<bool>(v, "enclosure"); }},
    {"force_closure", "bool", "False", "close the rows of a matrix that looks open.",
     [](const py::object& v, RepairOptions& o) {
         o.force_closure = arg<bool>(v, "force_closure");
     }},
};

const Signature<RepairOptions> kRepair{
    "repair", "Tuple[np.ndarray, dict[str, Any]]",
    "Repairs a form-factor matrix. F is not changed: returns (repaired copy, report dict).",
    kRepairKeywords};

/// The arguments of exchange_factors(), in order.
const Keyword<NoOptions> kExchangeFactorsKeywords[] = {
    {"F", "_ArrayLike", nullptr, "(N, N) form factors, F[i, j] from patch i to patch j.", nullptr,
     true},
    {"emissivity", "_ArrayLike", nullptr, "ε per patch, (N,) in (0, 1], or a scalar.", nullptr,
     true},
};

const Signature<NoOptions> kExchangeFactors{
    "exchange_factors", "np.ndarray",
    "Hottel's total exchange factors 𝓕 = diag(ε) F (I − diag(1−ε) F)⁻¹ diag(ε): 𝓕[i, j] is the "
    "fraction of the power a black body at i's temperature would emit over A_i that j absorbs "
    "after any number of diffuse reflections (Σ_j 𝓕_ij = ε_i in a closed enclosure). O(N³).",
    kExchangeFactorsKeywords};

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

/// A scipy.sparse matrix (any format) as the solvers take it: its CSR entries, duplicates
/// summed, with the scene's areas; nullopt for anything else.
std::optional<SparseFormFactors> sparse_of(const PyScene& s, const py::object& F) {
    const std::string module = py::str(py::type::of(F).attr("__module__")).cast<std::string>();
    if (module.rfind("scipy.sparse", 0) != 0) return std::nullopt;
    const py::module_ scipy_sparse = py::module_::import("scipy.sparse");
    if (!scipy_sparse.attr("issparse")(F).cast<bool>()) return std::nullopt;
    const auto shape = F.attr("shape").cast<std::pair<long long, long long>>();
    if (shape.first != shape.second) {
        throw OptionError(
            "F", fmt::format("a sparse F must be square, got {}x{}", shape.first, shape.second));
    }
    const py::object c = scipy_sparse.attr("csr_matrix")(
        F, py::arg("dtype") = py::float_().get_type(), py::arg("copy") = true);
    c.attr("sum_duplicates")();
    c.attr("sort_indices")();
    const std::size_t n = s.scene->patches.size();
    const auto indptr =
        py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>::ensure(
            c.attr("indptr"));
    const auto indices =
        py::array_t<std::int32_t, py::array::c_style | py::array::forcecast>::ensure(
            c.attr("indices"));
    const auto data =
        py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(c.attr("data"));
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
const PyHierarchical* operator_of(const PyScene& s, const py::object& F) {
    if (!py::isinstance<PyHierarchical>(F)) return nullptr;
    const PyHierarchical& h = F.cast<const PyHierarchical&>();
    if (h.size() != s.scene->patches.size())
        throw OptionError("F", "is the operator of another scene (sizes differ)");
    return &h;
}

/// An operator spread over the ranks of a communicator is solved over those ranks: comm= must
/// be that communicator. Checked on every rank before any message, so every rank raises alike.
void check_operator_comm(const py::object& F, const py::object& comm) {
    if (!py::isinstance<PyHierarchical>(F)) return;
    const PyHierarchical& h = F.cast<const PyHierarchical&>();
    if (!h.spread) return;
    if (comm.is_none())
        throw OptionError(
            "comm",
            "F is an operator built over a communicator (Scene.hierarchical(comm=...)): "
            "pass that communicator as comm=");
    if (py::hasattr(comm, "py2f") && !comm.attr("py2f")().equal(h.comm.attr("py2f")()))
        throw OptionError("comm", "is not the communicator F was built over");
}

/// What solve_radiosity() and solve_thermal() begin with: the communicator opened for the call
/// and F as the solvers take it, exactly one of the hierarchical operator, a sparse F (any
/// scipy.sparse matrix) or a dense one (a Result or an array), checked against the scene. On a
/// rank other than 0 the constructor serves rank 0's solve and holds no F (on_rank0() false:
/// the call returns None).
class SolveInput {
  public:
    SolveInput(const py::object& scene_arg_value, const py::object& F,
               const py::object& comm_arg_value)
        : scene(scene_arg(scene_arg_value)) {
        check_operator_comm(F, comm_arg_value);
        open_communicator(comm_arg_value, comm_);
        if (comm_ && distributed::rank() != 0) {
            serve_rank0();
            return;
        }
        rank0_ = true;
        if (const PyHierarchical* h = operator_of(scene, F)) {
            op_ = h->op.get();
            spread_ = h->spread.get();
        }
        sparse_ = op_ || spread_ ? std::nullopt : sparse_of(scene, F);
        if (!op_ && !spread_ && !sparse_) dense_ = form_factors_of(scene, F);
        n = op_ ? op_->size() : spread_ ? spread_->n : sparse_ ? sparse_->n : dense_.size();
    }
    SolveInput(const SolveInput&) = delete;
    SolveInput& operator=(const SolveInput&) = delete;

    /// False on a rank other than 0 (it has served rank 0's solve).
    bool on_rank0() const { return rank0_; }

    /// How the F given is held.
    Storage storage() const {
        return op_ || spread_ ? Storage::hierarchical : sparse_ ? Storage::sparse : Storage::dense;
    }

    /// The pipeline's solve of `o` on the F given, or with F's rows spread over the
    /// communicator's ranks when there is one and the solver iterates on a matrix
    /// (distributes()), or over the ranks that hold an operator spread over them.
    SolveResult solve(const PatchProperties& props, const SolveOptions& o) const {
        const Scene& s = *scene.scene;
        if (spread_) return distributed::solve(s, *spread_, props, o);
        if (comm_ && !op_ && distributes(o.solver))
            return distributed::solve(s,
                                      sparse_ ? distributed::distribute_rows(*sparse_)
                                              : distributed::distribute_rows(dense_),
                                      props, o);
        return op_       ? formfactor::solve(s, *op_, props, o)
               : sparse_ ? formfactor::solve(s, *sparse_, props, o)
                         : formfactor::solve(s, dense_, props, o);
    }

    /// The solver asked for, else the pipeline's default for F as given and the problem.
    SolverKind solver(const SolveArgs& a, bool thermal) const {
        return a.kind.value_or(default_solver(storage(), thermal));
    }

    const PyScene& scene;
    std::size_t n = 0;  ///< patches: F is n × n

  private:
    std::optional<distributed::Communicator> comm_;
    bool rank0_ = false;
    const HierarchicalFormFactors* op_ = nullptr;
    const distributed::DistributedHierarchical* spread_ = nullptr;
    std::optional<SparseFormFactors> sparse_;
    FormFactors dense_;
};

/// The pipeline's solve of the radiosity or (thermal) the thermal problem on the F of `in`, the
/// GIL released, progress to `progress`.
SolveResult solved(const SolveInput& in, const PatchProperties& props, const SolveArgs& a,
                   bool thermal, const py::object& progress) {
    SolveOptions o;
    o.thermal = thermal;
    o.solver = a.solver;
    o.solver.solver = in.solver(a, thermal);
    o.ambient_temperature = a.ambient_temperature;
    return run_released(
        [&](CancellationFlag&, ProgressSink* sink) {
            SolveOptions run = o;
            run.solver.progress = sink;
            return in.solve(props, run);
        },
        progress);
}

py::object radiosity(const SolveArgs& a, const std::vector<py::object>& values) {
    const auto value = [&](const char* name) { return value_of(kSolveRadiosity, values, name); };
    const SolveInput in(value("scene"), value("F"), value("comm"));
    if (!in.on_rank0()) return py::none();
    const PyScene& s = in.scene;
    const std::size_t n = in.n;
    PatchProperties props = properties_from_scene(*s.scene);
    if (!value("reflectance").is_none())
        props.reflectance = per_patch_rgb(value("reflectance"), "reflectance", n);
    if (!value("emission").is_none())
        props.emission = per_patch_rgb(value("emission"), "emission", n);
    validate_properties(props);
    const RadiosityResult r = *solved(in, props, a, false, value("progress")).radiosity;
    py::dict b;
    b["emitted"] = array_of(std::vector<Rgb>{r.balance.emitted}).attr("reshape")(3);
    b["absorbed"] = array_of(std::vector<Rgb>{r.balance.absorbed}).attr("reshape")(3);
    b["escaped"] = array_of(std::vector<Rgb>{r.balance.escaped}).attr("reshape")(3);
    b["relative_defect"] = r.balance.relative_defect;
    return py::module_::import("formfactor")
        .attr("RadiosityResult")(py::arg("radiosity") = array_of(r.radiosity),
                                 py::arg("stats") = stats_dict(r.stats), py::arg("balance") = b);
}

py::object thermal(const SolveArgs& a, const std::vector<py::object>& values) {
    const auto value = [&](const char* name) { return value_of(kSolveThermal, values, name); };
    const SolveInput in(value("scene"), value("F"), value("comm"));
    if (!in.on_rank0()) return py::none();
    const PyScene& s = in.scene;
    const std::size_t n = in.n;
    PatchProperties props = properties_from_scene(*s.scene);
    if (!value("emissivity").is_none())
        props.emissivity = per_patch(value("emissivity"), "emissivity", n);
    const double nan = std::numeric_limits<double>::quiet_NaN();
    const auto given = [&](const char* name) {
        return value(name).is_none() ? std::vector<double>(n, nan)
                                     : per_patch(value(name), name, n);
    };
    const std::vector<double> T = given("temperature");
    const std::vector<double> q = given("net_flux");
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
    const ThermalResult r = *solved(in, props, a, true, value("progress")).thermal;
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
    return py::module_::import("formfactor").attr("ThermalResult")(**d);
}

/// A square F as a float64 array, or an OptionError.
py::array_t<double, py::array::c_style | py::array::forcecast> square(const py::object& F) {
    auto a = as_doubles(F, "F", 2);
    if (a.shape(0) != a.shape(1)) throw OptionError("F", "must be square");
    return a;
}

py::object repair_call(const RepairOptions& o, const std::vector<py::object>& values) {
    const auto a = square(value_of(kRepair, values, "F"));
    const auto n = static_cast<std::size_t>(a.shape(0));
    const auto ar = as_doubles(value_of(kRepair, values, "areas"), "areas", 1);
    if (static_cast<std::size_t>(ar.shape(0)) != n)
        throw OptionError("areas", fmt::format("must have {} values", n));
    auto* held = new DenseMatrix(Eigen::Map<const DenseMatrix>(
        a.data(), static_cast<Eigen::Index>(n), static_cast<Eigen::Index>(n)));
    py::capsule owner(held, [](void* p) { delete static_cast<DenseMatrix*>(p); });
    const std::vector<double> av(ar.data(), ar.data() + n);
    RepairReport report;
    {
        py::gil_scoped_release nogil;
        report = repair(*held, av, o);
    }
    py::array_t<double> out({n, n}, held->data(), owner);
    return py::make_tuple(out,
                          py::module_::import("json").attr("loads")(json_text(to_json(report))));
}

py::array_t<double> exchange_factors_call(const NoOptions&, const std::vector<py::object>& values) {
    const auto a = square(value_of(kExchangeFactors, values, "F"));
    const auto n = static_cast<std::size_t>(a.shape(0));
    const std::vector<double> eps =
        per_patch(value_of(kExchangeFactors, values, "emissivity"), "emissivity", n);
    for (double e : eps)
        if (!(e > 0.0 && e <= 1.0))
            throw OptionError("emissivity",
                              fmt::format("every value must be in (0, 1], got {}", e));
    const DenseMatrix M = Eigen::Map<const DenseMatrix>(a.data(), static_cast<Eigen::Index>(n),
                                                        static_cast<Eigen::Index>(n));
    DenseMatrix X;
    {
        py::gil_scoped_release nogil;
        X = total_exchange_factors(M, eps);
    }
    py::array_t<double> out({n, n});
    std::copy(X.data(), X.data() + X.size(), out.mutable_data());
    return out;
}

}  // namespace

/// `make(product)` on rank 0 of an operator spread over the ranks of its communicator, with
/// `product` F X over the ranks, the GIL released; its result on every rank (on_every_rank()).
Eigen::MatrixXd on_ranks(
    const PyHierarchical& h, int threads,
    const std::function<Eigen::MatrixXd(const HierarchicalFormFactors::Product&)>& make) {
    const py::object got = on_every_rank(h.comm, [&]() -> py::object {
        const Eigen::MatrixXd M = run_released([&](CancellationFlag&, ProgressSink*) {
            return make([&](const Eigen::MatrixXd& X, Eigen::MatrixXd& Y) {
                distributed::multiply(*h.spread, X, Y, threads);
            });
        });
        // Column-major: (columns, rows) in C order.
        py::array_t<double> out({M.cols(), M.rows()});
        std::copy(M.data(), M.data() + M.size(), out.mutable_data());
        return out;
    });
    const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(got);
    FF_ASSERT(a && a.ndim() == 2);
    return Eigen::Map<const Eigen::MatrixXd>(a.data(), a.shape(1), a.shape(0));
}

/// F x for x of shape (N,) or (N, k); `adjoint`: Fᵀ x, which reciprocity makes A ∘ F (x / A).
/// An operator spread over ranks: every rank calls with the same x (rank 0's is used) and gets
/// the product.
py::array_t<double> product(const PyHierarchical& h, const py::object& x, int threads,
                            bool adjoint) {
    const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(x);
    const auto n = static_cast<py::ssize_t>(h.size());
    if (!a || (a.ndim() != 1 && a.ndim() != 2) || a.shape(0) != n)
        throw OptionError("x", fmt::format("must have shape ({0},) or ({0}, k)", n));
    const Eigen::Index k = a.ndim() == 1 ? 1 : a.shape(1);
    const std::vector<double>& areas = h.areas();
    Eigen::MatrixXd X(n, k), Y;
    for (Eigen::Index i = 0; i < n; ++i)
        for (Eigen::Index c = 0; c < k; ++c)
            X(i, c) = adjoint ? a.data()[i * k + c] / areas[static_cast<std::size_t>(i)]
                              : a.data()[i * k + c];
    if (!X.allFinite()) throw OptionError("x", "has values that are not finite");
    if (h.spread) {
        Y = on_ranks(h, threads, [&](const HierarchicalFormFactors::Product& p) {
            Eigen::MatrixXd out;
            p(X, out);
            return out;
        });
    } else {
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
    {"progress", "_Progress", "None", kProgressDoc, nullptr},
    {"comm", "Optional[Any]", "None",
     "an mpi4py communicator (``MPI.COMM_WORLD``) to build the operator over its ranks under "
     "mpirun: every rank calls with the same arguments and gets the operator, whose blocks stay "
     "spread over the ranks (each rank computes a share and holds a run of them). Its products "
     "(``op @ x``, ``matvec``, the products of ``as_linear_operator()``, ``per_surface``, "
     "``to_dense``) are then calls that every rank makes together with the same arguments (rank "
     "0's x is used), and every rank gets the result, bit for bit the one process's. Solve it "
     "with ``solve_radiosity(scene, op, comm=comm)`` or ``solve_thermal`` (the same "
     "communicator; rank 0 gets the result, the others None). A process holds one operator over "
     "ranks at a time: a later build replaces it (docs/cluster.md).",
     nullptr},
};

const Signature<HierarchicalOptions> kHierarchical{
    "hierarchical", "HierarchicalOperator",
    "The hierarchical (H-matrix) operator of this scene's form factors, for scenes without "
    "obstructions (closed rooms, furnaces, convex cavities): far cluster pairs as low-rank blocks, "
    "near ones exact, F never formed (docs/hierarchical.md). Pass it as F to solve_radiosity and "
    "solve_thermal (GMRES by default), apply it with ``op @ x``, or use "
    "``op.as_linear_operator()`` with SciPy. Raises Error for a scene with obstructions. With "
    "``comm=`` the build and every product run over the communicator's ranks.",
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

/// Scene.hierarchical(comm=...): the operator built over the ranks of `comm`, on every rank.
/// Rank 0 builds (the others serve it) and sends every rank what the operator is to Python:
/// its size, areas, row sums, stats and id.
PyHierarchical spread_operator(const PyScene& s, const HierarchicalOptions& o,
                               const py::object& progress, const py::object& comm) {
    // Bad options: the OptionError of one process, on every rank before any message.
    check_hierarchical_options(o);
    const py::object sent = on_every_rank(comm, [&]() -> py::object {
        const distributed::DistributedHierarchical H = run_released(
            [&](CancellationFlag&, ProgressSink* sink) {
                HierarchicalOptions run = o;
                run.progress = sink;
                return distributed::build_hierarchical(*s.scene, run);
            },
            progress);
        // And what the ranks did, under the names of the CLI report's details.mpi.
        py::dict st = hierarchical_stats(H.stats);
        st["ranks"] = comm.attr("Get_size")();
        st["blocks_computed_per_rank"] = H.blocks_built;
        st["busy_seconds_per_rank"] = H.build_seconds;
        st["blocks_held_per_rank"] = H.blocks_held;
        st["chunks_held_per_rank"] = H.chunks_held;
        st["moved_bytes"] = H.moved_bytes;
        return py::make_tuple(H.n, H.id, array_of(H.areas), array_of(H.row_sums), st);
    });
    const auto t = sent.cast<py::tuple>();
    auto H = std::make_shared<distributed::DistributedHierarchical>();
    H->n = t[0].cast<std::size_t>();
    H->id = t[1].cast<std::uint64_t>();
    H->areas = t[2].cast<std::vector<double>>();
    H->row_sums = t[3].cast<std::vector<double>>();
    if (H->n != s.scene->patches.size())
        throw Error("Scene.hierarchical: rank 0's scene has another number of patches");
    PyHierarchical out{s.scene, nullptr, std::move(H)};
    out.comm = comm;
    out.spread_stats = t[4];
    return out;
}

void bind_hierarchical(py::module_& m) {
    py::class_<PyHierarchical>(m, "HierarchicalOperator", R"doc(
The hierarchical (H-matrix) form-factor operator of a scene without obstructions: F applied to
vectors without forming it (docs/hierarchical.md). ``op @ x`` or ``op.matvec(x)`` is F x for an
(N,) or (N, k) array; pass it as F to solve_radiosity / solve_thermal (gmres or jacobi);
``as_linear_operator()`` gives a scipy.sparse.linalg.LinearOperator.
)doc")
        .def_property_readonly(
            "shape", [](const PyHierarchical& h) { return py::make_tuple(h.size(), h.size()); })
        .def_property_readonly(
            "areas", [](const PyHierarchical& h) { return array_of(h.areas()); },
            "Patch areas (N,)")
        .def_property_readonly(
            "stats",
            [](const PyHierarchical& h) -> py::dict {
                if (h.spread) return py::dict(h.spread_stats.attr("copy")());
                return hierarchical_stats(h.op->stats());
            },
            "What the build made: blocks by kind, ranks, entries computed, bytes, seconds (built "
            "over ranks: the whole operator's, and what each rank computed and holds)")
        .def_property_readonly(
            "comm", [](const PyHierarchical& h) { return h.comm; },
            "The mpi4py communicator the operator is spread over (None: whole in this process)")
        .def(
            "matvec",
            [](const PyHierarchical& h, const py::object& x, const py::object& threads) {
                return product(h, x, arg<int>(threads, "threads"), false);
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
                const auto n = h.size();
                return linear_operator(
                    py::make_tuple(n, n), py::arg("matvec") = matvec, py::arg("rmatvec") = rmatvec,
                    py::arg("matmat") = matvec,
                    py::arg("dtype") = py::module_::import("builtins").attr("float"));
            },
            "A scipy.sparse.linalg.LinearOperator of F: matvec F x, rmatvec Fᵀ y = A ∘ F (y / A) "
            "(reciprocity, which the operator satisfies by construction).")
        .def(
            "row_sums",
            [](const PyHierarchical& h, const py::object& threads_arg) {
                const int threads = arg<int>(threads_arg, "threads");
                // Over ranks: made by the build (a product with ones over the ranks).
                if (h.spread) return array_of(h.spread->row_sums);
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
            [](const PyHierarchical& h, const py::object& threads_arg) {
                const int threads = arg<int>(threads_arg, "threads");
                std::vector<int> group;
                for (const Patch& p : h.scene->patches) group.push_back(p.surface);
                const std::size_t g = h.scene->surfaces.size();
                DenseMatrix G;
                if (h.spread) {
                    G = on_ranks(h, threads, [&](const HierarchicalFormFactors::Product& p) {
                        return Eigen::MatrixXd(
                            HierarchicalFormFactors::per_group(h.spread->areas, group, g, p));
                    });
                } else {
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
            [](const PyHierarchical& h, const py::object& threads_arg) {
                const int threads = arg<int>(threads_arg, "threads");
                DenseMatrix F;
                if (h.spread) {
                    F = on_ranks(h, threads, [&](const HierarchicalFormFactors::Product& p) {
                        return Eigen::MatrixXd(HierarchicalFormFactors::to_dense(h.size(), p));
                    });
                } else {
                    py::gil_scoped_release nogil;
                    F = h.op->to_dense(threads);
                }
                const std::size_t n = h.size();
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
            const py::object progress = value_of(kHierarchical, values, "progress");
            const py::object comm = value_of(kHierarchical, values, "comm");
            if (comm.is_none()) {
                auto op = run_released(
                    [&](CancellationFlag&, ProgressSink* sink) {
                        HierarchicalOptions run = o;
                        run.progress = sink;
                        return std::make_shared<const HierarchicalFormFactors>(
                            compute_hierarchical_operator(*s.scene, run));
                    },
                    progress);
                return PyHierarchical{s.scene, std::move(op), nullptr};
            }
            return spread_operator(s, o, progress, comm);
        });
}

void bind_solve(py::module_& m) {
    bind_hierarchical(m);
    bind_function_with_keywords(m, kSolveRadiosity, radiosity);
    bind_function_with_keywords(m, kSolveThermal, thermal);
    bind_function_with_keywords(m, kRepair, repair_call);
    bind_function_with_keywords(m, kExchangeFactors, exchange_factors_call);
}

}  // namespace formfactor::python
