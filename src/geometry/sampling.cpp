// Uniform points on a polygon (PolygonSampler). The projected-solid-angle sampler is
// projected_sampling.cpp.

#include "formfactor/geometry/sampling.h"

#include <algorithm>
#include <array>

#include "formfactor/core/error.h"
#include "geometry/cdf.h"

namespace formfactor {

using detail::find_cell;

PolygonSampler::PolygonSampler(const Polygon& p) {
    FF_ASSERT(p.size() >= 3);
    const double scale = diameter(p);
    if (p.size() == 4 && (p[0] + p[2] - p[1] - p[3]).norm() <= 1e-12 * scale) {
        parallelogram_ = true;
        origin_ = p[0];
        e1_ = p[1] - p[0];
        e2_ = p[3] - p[0];
        return;
    }
    std::vector<std::array<int, 3>> tris;
    if (p.size() == 3)
        tris.push_back({0, 1, 2});
    else
        tris = triangulate(p);
    double total = 0.0;
    for (const auto& t : tris) {
        const std::array<Vec3, 3> tri{p[static_cast<std::size_t>(t[0])],
                                      p[static_cast<std::size_t>(t[1])],
                                      p[static_cast<std::size_t>(t[2])]};
        total += 0.5 * (tri[1] - tri[0]).cross(tri[2] - tri[0]).norm();
        triangles_.push_back(tri);
        cdf_.push_back(total);
    }
    FF_ASSERT(total > 0);
    for (double& c : cdf_) c /= total;
    cdf_.back() = 1.0;
}

Vec3 PolygonSampler::operator()(double u, double v) const {
    if (parallelogram_) return origin_ + u * e1_ + v * e2_;
    std::size_t k = 0;
    if (triangles_.size() > 1) {
        k = find_cell(cdf_, u);
        const double lo = k == 0 ? 0.0 : cdf_[k - 1];
        u = std::clamp((u - lo) / (cdf_[k] - lo), 0.0, 1.0);
    }
    // Heitz 2019: low-distortion square → triangle.
    double b0 = u, b1 = v;
    detail::square_to_triangle(b0, b1);
    const auto& t = triangles_[k];
    return b0 * t[0] + b1 * t[1] + (1.0 - b0 - b1) * t[2];
}

}  // namespace formfactor
