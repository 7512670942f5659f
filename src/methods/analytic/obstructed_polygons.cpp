// The public functions of formfactor/methods/obstructed.h: F from a point or a polygon to a
// polygon past blockers, by the point kernel (point_hidden()) and the adaptive integration of the
// hidden part over the sender (hidden_integral.cpp) on a BlockerSet of the given blockers. See
// docs/analytic.md, "Obstructed scenes".

#include <algorithm>
#include <numeric>
#include <vector>

#include "formfactor/kernels/analytic.h"
#include "formfactor/methods/obstructed.h"
#include "methods/analytic/obstructed_internal.h"

namespace formfactor {

namespace {

detail::BlockerSet make_blockers(const std::vector<Polygon>& blockers) {
    detail::BlockerSet set;
    for (std::size_t k = 0; k < blockers.size(); ++k) set.add(blockers[k], static_cast<int>(k));
    set.build();
    return set;
}

double pair_eps(const Polygon& a, const Polygon& b, const std::vector<Polygon>& blockers) {
    Bounds3 box;
    for (const Vec3& v : a.vertices) box.extend(v);
    for (const Vec3& v : b.vertices) box.extend(v);
    for (const Polygon& p : blockers)
        for (const Vec3& v : p.vertices) box.extend(v);
    return 1e-11 * box.diagonal().norm();
}

}  // namespace

double point_to_polygon_obstructed(const Vec3& x, const Vec3& n, const Polygon& receiver,
                                   const std::vector<Polygon>& blockers) {
    const detail::BlockerSet set = make_blockers(blockers);
    std::vector<int> all(set.size());
    std::iota(all.begin(), all.end(), 0);
    const double eps = pair_eps(receiver, receiver, blockers);
    double total = 0.0;
    for (const Polygon& r : detail::BlockerSet::convex_parts(receiver)) {
        double unobs = 0.0;
        const double hidden = detail::point_hidden(x, n, r, set, all.data(),
                                                   static_cast<int>(all.size()), eps, &unobs);
        total += std::max(0.0, unobs - hidden);
    }
    return total;
}

ObstructedFormFactor polygon_to_polygon_obstructed(const Polygon& a, const Polygon& b,
                                                   const std::vector<Polygon>& blockers,
                                                   double tolerance) {
    ObstructedFormFactor out;
    out.unobstructed = polygon_to_polygon(a, b);
    out.value = out.unobstructed;
    if (!(out.unobstructed > 0.0) || blockers.empty()) return out;
    const detail::BlockerSet set = make_blockers(blockers);
    const double eps = pair_eps(a, b, blockers);
    std::vector<int> all(set.size());
    std::iota(all.begin(), all.end(), 0);
    double hidden = 0.0;
    for (const Polygon& r : detail::BlockerSet::convex_parts(b)) {
        const detail::HiddenIntegral h = detail::hidden_integral(
            a, r, set, all.data(), static_cast<int>(all.size()), tolerance, eps);
        hidden += h.hidden;
        out.error_estimate += h.error;
        out.max_level = std::max(out.max_level, h.max_level);
        out.cells += h.cells;
    }
    out.value = std::clamp(out.unobstructed - hidden, 0.0, out.unobstructed);
    return out;
}

}  // namespace formfactor
