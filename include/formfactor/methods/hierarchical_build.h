#pragma once
/// Building the hierarchical form-factor operator (matrix/hierarchical.h): the cluster tree, the
/// partition into zero, low-rank and dense blocks, and their entries by the analytic kernels.

#include <cstddef>

#include "formfactor/matrix/hierarchical.h"
#include "formfactor/scene/scene.h"

namespace formfactor {

class ProgressSink;

/// How the operator is built.
struct HierarchicalOptions {
    /// Error target: relative Frobenius error of each compressed block (the entries of the
    /// compressed blocks are computed to a tenth of it). Tighter targets cost more ranks.
    double tolerance = 1e-6;
    /// Admissibility: a cluster pair is compressed when 2·max(r_P, r_Q) ≤ eta · (|c_P − c_Q| −
    /// r_P − r_Q) (bounding spheres).
    double eta = 1.5;
    /// Patches per leaf cluster at most.
    std::size_t leaf_size = 32;
    /// Threads (0 = all cores).
    int threads = 0;
    /// Receives the progress of the build (blocks done), or none.
    ProgressSink* progress = nullptr;
};

/// True when build_hierarchical() accepts the scene's geometry: no surface can
/// block the view between two others (within 1e-6 of the scene's size; surfaces, or patches when
/// the scene has none). What `solve --storage auto` asks before it picks the operator.
bool hierarchical_accepts(const Scene& scene);

/// Builds the operator of the scene's patches. Throws OptionError for bad options, Error for a
/// scene with obstructions (see matrix/hierarchical.h), ResourceError when the estimated memory
/// does not fit.
HierarchicalFormFactors build_hierarchical(const Scene& scene, const HierarchicalOptions& options);

}  // namespace formfactor
