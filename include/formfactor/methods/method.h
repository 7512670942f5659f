#pragma once
/// One interface for every estimator of F (DESIGN.md, "The methods"): a method computes a block
/// of rows of the matrix (all of them by default, in parallel) for a scene, given a context.
/// Virtual calls are per run, never per ray or pair. Callers normally go through the pipeline
/// (formfactor/pipeline.h), which builds the context.

#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "formfactor/core/enum_names.h"
#include "formfactor/core/fields.h"
#include "formfactor/core/random.h"
#include "formfactor/matrix/form_factors.h"
#include "formfactor/matrix/sparse.h"
#include "formfactor/scene/scene.h"

namespace formfactor {

class ProgressSink;
class Visibility;
class PartlyHiddenPairs;

/// The estimators of F.
enum class MethodKind {
    analytic,       ///< exact contour integrals, far-field Gauss rules, shadows clipped out
    hemicube,       ///< Cohen & Greenberg's hemicube (item buffer)
    hemiplane,      ///< Sillion's single-plane projection
    mc_area,        ///< Monte Carlo, area sampling of both patches
    mc_hemisphere,  ///< Monte Carlo, cosine-weighted rays from each patch
    mc_target,      ///< Monte Carlo on the target: exact unoccluded factor × visible fraction
};

/// The names of the methods (the CLI's --method, the Python module's method=).
inline constexpr EnumEntry<MethodKind> kMethodNames[] = {
    {MethodKind::analytic, "analytic"},           {MethodKind::hemicube, "hemicube"},
    {MethodKind::hemiplane, "hemiplane"},         {MethodKind::mc_area, "mc-area"},
    {MethodKind::mc_hemisphere, "mc-hemisphere"}, {MethodKind::mc_target, "mc-target"},
};

/// The method called `name`; throws OptionError("method", ...) for an unknown name.
MethodKind parse_method(const std::string& name);
/// The name of `kind`.
std::string to_string(MethodKind kind);

/// Options shared by the methods; each method documents which it reads.
struct MethodOptions {
    int threads = 0;           ///< 0 = all cores
    double tolerance = 1e-10;  ///< absolute error target per entry (analytic)
    /// analytic: absolute error target per entry of the partly hidden pairs of an obstructed
    /// scene (their adaptive integration; fully visible pairs keep `tolerance`, fully hidden
    /// ones are exactly 0). A user-given tolerance sets both.
    double obstructed_tolerance = 1e-6;
    std::uint64_t samples = 0;  ///< Monte Carlo: samples per row or pair (0 = method default)
    std::uint64_t seed = 1;     ///< random streams are seeded from (seed, i, j)
    int resolution = 256;       ///< hemicube / hemiplane cells per side
    int points = 1;             ///< hemicube / hemiplane: points per patch
    /// Monte Carlo: the point set (core/random.h). Standard errors: i.i.d. formulas for random,
    /// else the spread of 16 independent randomisations (replicates) of the point set.
    SamplerKind sampler = SamplerKind::sobol;
};

/// Everything a method is given: the scene (patches final), options, what was built for it.
struct MethodContext {
    const Scene& scene;
    MethodOptions options;
    /// The ray tracer of the scene, built once by the caller for the methods that cast rays
    /// (Method::needs_visibility()); a method builds its own when this is null.
    const Visibility* visibility = nullptr;
    /// Where progress goes; null (the default): nowhere.
    ProgressSink* progress = nullptr;
    /// The rows to compute (clamped to the patch count).
    RowRange rows;
    /// Where a method that emits sparse rows (Method::emits_sparse_rows()) puts them instead of
    /// a dense block: it resets it to ctx.rows and leaves form_factors.F empty (0 × N, areas
    /// and first_row set). Null (the default), or a method that does not emit sparse rows:
    /// the dense rows × N block as always.
    SparseRows* sparse_rows = nullptr;
    /// analytic, in a scene that may obstruct: the classification of the scene and every
    /// partly hidden pair's value, computed beforehand (formfactor/methods/partly_hidden.h;
    /// an MPI run integrates each pair once over the ranks), for this scene, with values set
    /// and made sparse exactly when sparse_rows is set. Null (the default): computed here.
    const PartlyHiddenPairs* partly_hidden = nullptr;
    /// A block of rows (rows not every row), by the analytic method in a scene that obstructs
    /// nothing or with partly_hidden given: the entries F_ij with j > i are the whole
    /// matrix's, those below the diagonal are not computed (0, or a pair's value) for the
    /// caller to fill from the rows of the other blocks: by reciprocity (F_ij = A_j F_ji / A_i
    /// as detail::reciprocal_entry() gives it), then PartlyHiddenPairs::write_lower_values():
    /// bit for bit the whole matrix, and the blocks of a matrix cost what the whole matrix
    /// does. Every other method, and analytic without partly_hidden where the scene may
    /// obstruct, ignore it (whole rows). An MPI run of dense rows sets it.
    bool upper_triangle_only = false;
};

/// How the method classified patch pairs (methods that classify them: analytic, mc-target).
struct PairClasses {
    std::size_t pairs = 0;      ///< unordered pairs considered
    std::size_t zero = 0;       ///< facing away or behind: exactly 0
    std::size_t exact = 0;      ///< closed form (contour integral)
    std::size_t far_field = 0;  ///< Gauss rule with an a-priori bound
};

/// What a method says about its run. Only output/ turns it into JSON (to_fields(), then
/// to_json(const Fields&) of output/report.h).
struct MethodReport {
    MethodKind method = MethodKind::analytic;
    /// An upper bound of |F_ij − exact| for every entry (exact-grade methods), when the method
    /// has one.
    std::optional<double> error_bound_per_entry;
    std::optional<PairClasses> pairs;
    std::optional<std::uint64_t> rays_cast;  ///< rays (or segments) traced
    std::optional<double> seconds;           ///< the method's own wall time, when it reports it
    /// Everything else, method-specific (keys documented with each method).
    Fields details;
};

/// The report as one Fields tree (what output/report.h turns into the run report's "details"):
/// its details, with the typed members under their keys (error_bound_per_entry; pairs,
/// pairs_zero, pairs_exact, pairs_far_field; rays_cast; seconds).
Fields to_fields(const MethodReport& report);

/// F for the context's rows, and the method's report.
struct MethodResult {
    FormFactors form_factors;
    MethodReport report;
};

/// An estimator of the form-factor matrix.
class Method {
  public:
    virtual ~Method() = default;
    virtual MethodKind kind() const = 0;
    /// The name used by the CLI's --method.
    std::string name() const { return to_string(kind()); }
    /// Throws Error when the method cannot handle the scene (say why).
    virtual void check(const Scene& scene) const = 0;
    /// True when the method casts rays: the caller then builds a Visibility for the context.
    virtual bool needs_visibility() const { return false; }
    /// True when compute() can emit its rows into MethodContext::sparse_rows, touching only the
    /// entries a row reaches (no rows × N block).
    virtual bool emits_sparse_rows() const { return false; }
    /// The same for this scene (a method may emit sparse rows only for some scenes).
    virtual bool emits_sparse_rows(const Scene& scene) const {
        (void)scene;
        return emits_sparse_rows();
    }
    /// True when sparse rows are best asked for in one call for every row (the method's set-up
    /// spans the whole scene: a sparse run then asks for one block).
    virtual bool sparse_rows_at_once() const { return false; }
    /// Computes rows ctx.rows of F for ctx.scene.patches (form_factors.first_row = the range's
    /// begin). Any split of the rows gives the same values, bit for bit, as one run.
    virtual MethodResult compute(const MethodContext& ctx) const = 0;
};

/// The method of kind `kind`.
std::unique_ptr<Method> make_method(MethodKind kind);
/// make_method(parse_method(name)).
std::unique_ptr<Method> make_method(const std::string& name);
/// Names of every method.
std::vector<std::string> method_names();
/// The most accurate method that can handle the scene.
MethodKind default_method(const Scene& scene);

}  // namespace formfactor
