#pragma once
/// Form factors from differential elements (points with a normal: sensors, radiometers, the
/// points of a mean-radiant-temperature map) to every patch of a scene, exact with obstructions.

#include <vector>

#include "formfactor/core/progress.h"
#include "formfactor/core/types.h"
#include "formfactor/matrix/form_factors.h"
#include "formfactor/scene/scene.h"

namespace formfactor {

/// F_{dA_m → patch j} for M differential elements: row m of the returned M × N row-major matrix
/// is point m (position positions[m], front normal normals[m], normalised here), column j patch
/// j of scene.patches. Each entry is the exact factor to the part of patch j that the point sees
/// past every blocker (point_to_polygon_obstructed in formfactor/methods/obstructed.h): the other
/// surfaces of the scene (every patch blocks) and the obstruction-only surfaces; where nothing can
/// block, Lambert's formula (point_to_polygon). Blockers are first culled per entry by
/// conservative plane tests (in front of the element's plane, in front of the patch's plane,
/// inside the pyramid from the point over the patch's convex hull), so the cost per entry grows
/// with the blockers that can matter. Exact up to rounding (~1e-15 per entry unobstructed, the
/// clipping's rounding otherwise). Entries are computed in parallel (parallel_for over points and
/// patches, `threads` as in parallel_for); the result does not depend on the thread count.
/// Progress (one unit per entry) goes to `progress` when given.
/// Throws Error when the sizes differ or a position or normal is not finite or a normal is zero.
DenseMatrix point_form_factors(const Scene& scene, const std::vector<Vec3>& positions,
                               const std::vector<Vec3>& normals, int threads = 0,
                               ProgressSink* progress = nullptr);

}  // namespace formfactor
