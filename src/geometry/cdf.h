#pragma once
// Private helpers of the samplers: picking a cell of a discrete distribution, and mapping the
// unit square onto a triangle.

#include <algorithm>
#include <cstddef>
#include <vector>

namespace formfactor::detail {

// Index of the cell whose cumulative range holds s (cdf ascending, last = total).
inline std::size_t find_cell(const std::vector<double>& cdf, double s) {
    if (cdf.size() <= 8) {
        std::size_t k = 0;
        while (k + 1 < cdf.size() && s >= cdf[k]) ++k;
        return k;
    }
    auto it = std::upper_bound(cdf.begin(), cdf.end(), s);
    return std::min<std::size_t>(static_cast<std::size_t>(it - cdf.begin()), cdf.size() - 1);
}

/// Heitz 2019, "A Low-Distortion Map Between Triangle and Square": (b0, b1) from the unit square
/// become barycentric weights of the first two corners of a triangle (the third 1 − b0 − b1).
inline void square_to_triangle(double& b0, double& b1) {
    if (b1 > b0) {
        b0 *= 0.5;
        b1 -= b0;
    } else {
        b1 *= 0.5;
        b0 -= b1;
    }
}

}  // namespace formfactor::detail
