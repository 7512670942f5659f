#pragma once
// Lambert's point-to-polygon formula written out again for the projection-method tests
// (hemicube, hemiplane), independent of the kernels module.

#include <cmath>

#include "formfactor/core/types.h"
#include "formfactor/geometry/polygon.h"

namespace formfactor::testing {

/// Exact F from a differential element at x (unit normal n) to a convex polygon wholly in front
/// of it and unoccluded: Lambert's contour formula, F = 1/(2π) |Σ γ_k n·(R_k × R_k+1)/|R_k ×
/// R_k+1||.
inline double lambert(const Vec3& x, const Vec3& n, const Polygon& poly) {
    double sum = 0.0;
    for (std::size_t k = 0; k < poly.size(); ++k) {
        const Vec3 a = poly[k] - x;
        const Vec3 b = poly[(k + 1) % poly.size()] - x;
        const Vec3 c = a.cross(b);
        const double len = c.norm();
        if (len == 0.0) continue;
        const double gamma = std::atan2(len, a.dot(b));
        sum += gamma * n.dot(c) / len;
    }
    return std::abs(sum) / (2.0 * kPi);
}

}  // namespace formfactor::testing
