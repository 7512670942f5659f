#pragma once
/// One interface for every estimator of F (DESIGN.md, "The methods"): a method fills the whole
/// matrix (rows in parallel) for a scene. Virtual calls are per run, never per ray or pair.

#include <cstdint>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "formfactor/matrix/form_factors.h"
#include "formfactor/scene/scene.h"

namespace formfactor {

class Progress;

/// Options shared by the methods; each method documents which it reads.
struct MethodOptions {
    int threads = 0;           ///< 0 = all cores
    double tolerance = 1e-10;  ///< absolute error target per entry (analytic)
    /// analytic: absolute error target per entry of the partly hidden pairs of an obstructed
    /// scene (their adaptive integration; fully visible pairs keep `tolerance`, fully hidden
    /// ones are exactly 0). A user-given --tolerance sets both.
    double obstructed_tolerance = 1e-6;
    std::uint64_t samples = 0;  ///< Monte Carlo: samples per row or pair (0 = method default)
    std::uint64_t seed = 1;     ///< random streams are seeded from (seed, i, j)
    int resolution = 256;       ///< hemicube / hemiplane cells per side
    int points = 1;             ///< hemicube / hemiplane: points per patch
    bool progress = true;       ///< show a progress bar on a terminal
    /// Monte Carlo: the point set, "sobol" (Owen-scrambled, default) | "halton" | "stratified"
    /// | "random" (core/random.h). Standard errors: i.i.d. formulas for "random", else the spread
    /// of 16 independent randomisations (replicates) of the point set.
    std::string sampler = "sobol";
};

/// An estimator of the form-factor matrix.
class Method {
  public:
    virtual ~Method() = default;
    /// The name used by --method.
    virtual std::string name() const = 0;
    /// Throws Error when the method cannot handle the scene (say why).
    virtual void check(const Scene& scene) const = 0;
    /// Computes F for scene.patches. `details` receives method-specific report fields.
    virtual FormFactors compute(const Scene& scene, const MethodOptions& options,
                                nlohmann::json& details) const = 0;
};

/// The method called `name`; throws OptionError("--method", ...) for an unknown name.
std::unique_ptr<Method> make_method(const std::string& name);
/// Names of every method.
std::vector<std::string> method_names();
/// The most accurate method that can handle the scene.
std::string default_method(const Scene& scene);
/// True when some surface of the scene may block the view between two others (a conservative
/// test: obstruction-only surfaces, or a surface with other surfaces on both sides of its plane).
bool may_obstruct(const Scene& scene);

}  // namespace formfactor
