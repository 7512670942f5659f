#pragma once
/// Whether a scene may hide part of one surface from another.

#include "formfactor/scene/scene.h"

namespace formfactor {

/// True when some surface of the scene may block the view between two others: an
/// obstruction-only surface, or a surface with vertices of other surfaces on both sides of its
/// plane, farther from it than relative_tolerance × the diagonal of the scene's bounding box. A
/// conservative test on the surfaces (on the patches when the scene has no surfaces): false
/// means that no segment between two surfaces is blocked (a convex room, parallel plates).
bool may_obstruct(const Scene& scene, double relative_tolerance = 1e-9);

}  // namespace formfactor
