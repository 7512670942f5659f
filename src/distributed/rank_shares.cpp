// What the ranks did (formfactor/distributed/distributed.h), with or without MPI.

#include <algorithm>
#include <numeric>

#include "formfactor/distributed/distributed.h"

namespace formfactor::distributed {

double RankShares::imbalance() const {
    if (busy_seconds.empty()) return 0.0;
    const double mean = std::accumulate(busy_seconds.begin(), busy_seconds.end(), 0.0) /
                        double(busy_seconds.size());
    const double most = *std::max_element(busy_seconds.begin(), busy_seconds.end());
    return mean > 0.0 ? (most - mean) / mean : 0.0;
}

}  // namespace formfactor::distributed
