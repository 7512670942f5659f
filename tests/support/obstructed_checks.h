#pragma once
// Shared pieces of the obstructed-analytic checks (test_differential.cpp,
// test_obstructed_inputs.cpp): running `analytic` and reading its reported error bound, an
// independent mc-target reference on some patches of a scene, and patch matching between two
// descriptions of one geometry.

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <limits>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <vector>

#include "formfactor/matrix/form_factors.h"
#include "formfactor/methods/method.h"
#include "formfactor/scene/scene.h"
#include "method_runner.h"
#include "random_geometry.h"
#include "scenes.h"

namespace formfactor::testing {

/// The analytic method's matrix and what it reports.
struct AnalyticRun {
    FormFactors ff;
    nlohmann::json details;
    double bound = 0;  ///< the reported error bound per entry
    double seconds = 0;
};

/// The error bound per entry that the analytic method reports: `error_bound_per_entry`, else
/// the obstructed pairs' `max_error_estimate`, else the tolerance.
inline double reported_bound(const nlohmann::json& d, double tolerance) {
    if (d.contains("error_bound_per_entry")) return d["error_bound_per_entry"].get<double>();
    if (d.contains("obstructions") && d["obstructions"].contains("max_error_estimate"))
        return std::max(tolerance, d["obstructions"]["max_error_estimate"].get<double>());
    return tolerance;
}

/// `analytic` with its default tolerances (1e-10 unobstructed, 1e-6 partly hidden), or with
/// `tolerance` for the partly hidden pairs when it is > 0.
inline AnalyticRun run_analytic(const Scene& s, int threads = 0, double tolerance = 0) {
    MethodOptions o;
    o.threads = threads;
    if (tolerance > 0) o.obstructed_tolerance = tolerance;
    AnalyticRun r;
    const auto t0 = std::chrono::steady_clock::now();
    r.ff = run_method(*make_method("analytic"), s, o, r.details);
    r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    r.bound = reported_bound(r.details, o.obstructed_tolerance);
    return r;
}

/// mc-target among some patches of a scene, the other patches and every obstruction kept as
/// obstruction-only surfaces (the same visibility: every surface blocks from both sides), with
/// its replicate standard errors. Entry (a, b) is from patches[a] to patches[b].
struct McReference {
    std::vector<std::size_t> patches;  ///< sorted, indices into the full scene's patches
    DenseMatrix F, se;
    std::uint64_t samples = 0;
    double dof = 0;  ///< degrees of freedom of se (replicates − 1)
    double seconds = 0;
};

/// mc-target on the polygons `all` where only `chosen` are patches.
inline McReference mc_reference(const std::vector<Polygon>& all,
                                const std::vector<Polygon>& obstructions,
                                std::vector<std::size_t> chosen, std::uint64_t samples,
                                std::uint64_t seed = 1) {
    std::sort(chosen.begin(), chosen.end());
    chosen.erase(std::unique(chosen.begin(), chosen.end()), chosen.end());
    std::vector<Polygon> patches, others = obstructions;
    std::vector<bool> in(all.size(), false);
    for (std::size_t k : chosen) in[k] = true;
    for (std::size_t k = 0; k < all.size(); ++k) (in[k] ? patches : others).push_back(all[k]);
    const Scene s = scene_of(patches, others);
    MethodOptions o;
    o.samples = samples;
    o.seed = seed;
    nlohmann::json d;
    const auto t0 = std::chrono::steady_clock::now();
    FormFactors ff = run_method(*make_method("mc-target"), s, o, d);
    McReference r;
    r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    r.patches = chosen;
    r.F = ff.F;
    r.se = *ff.standard_error;
    r.samples = samples;
    r.dof = std::max(1.0, d["replicates"].get<double>() - 1);
    return r;
}

/// mc_reference() for some patches of a loaded scene.
inline McReference mc_reference(const Scene& s, const std::vector<std::size_t>& chosen,
                                std::uint64_t samples, std::uint64_t seed = 1) {
    std::vector<Polygon> all, obstructions;
    for (const Patch& p : s.patches) all.push_back(p.polygon);
    for (const Surface& sf : s.surfaces)
        if (sf.obstruction) obstructions.push_back(sf.polygon);
    return mc_reference(all, obstructions, chosen, samples, seed);
}

/// perm[i] = the patch of `b` with the same centroid and normal as patch i of `a` (within
/// `tol`); throws when a patch has no match.
inline std::vector<std::size_t> match_patches(const Scene& a, const Scene& b, double tol = 1e-9) {
    std::vector<std::size_t> perm(a.patches.size());
    for (std::size_t i = 0; i < a.patches.size(); ++i) {
        std::size_t best = b.patches.size();
        double d_best = std::numeric_limits<double>::infinity();
        for (std::size_t j = 0; j < b.patches.size(); ++j) {
            const double d = (a.patches[i].centroid - b.patches[j].centroid).norm() +
                             (a.patches[i].normal - b.patches[j].normal).norm();
            if (d < d_best) d_best = d, best = j;
        }
        if (d_best > tol) throw std::runtime_error("patch without a match");
        perm[i] = best;
    }
    return perm;
}

}  // namespace formfactor::testing
