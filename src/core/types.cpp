#include "formfactor/core/types.h"

#include <algorithm>
#include <string>

#include "formfactor/core/error.h"

namespace formfactor {

RowRange RowRange::clamped(std::size_t n) const {
    RowRange r{begin, std::min(end, n)};
    if (r.begin > r.end)
        throw OptionError("rows", "the row range [" + std::to_string(begin) + ", " +
                                      (end == kEnd ? std::string("end") : std::to_string(end)) +
                                      ") is outside the " + std::to_string(n) + " patches");
    return r;
}

}  // namespace formfactor
