#include "formfactor/core/error.h"

#include <cstdio>
#include <cstdlib>

namespace formfactor {

void assertion_failed(const char* expr, const char* file, int line) {
    std::fprintf(stderr, "formfactor: internal error: assertion '%s' failed at %s:%d\n", expr, file,
                 line);
    std::abort();
}

}  // namespace formfactor
