#pragma once
// Private helper of the samplers: picking a cell of a discrete distribution.

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

}  // namespace formfactor::detail
