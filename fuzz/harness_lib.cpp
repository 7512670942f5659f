// The fuzz harness compiled once for every fuzz_<name> target (fuzz_target.cpp).

#include <cstdlib>
#include <string_view>

#include "fuzz/harness.h"

namespace formfactor::fuzz {

bool run_named(std::string_view target, const std::uint8_t* data, std::size_t size) {
    for (const TargetName& t : kTargets)
        if (target == t.name) return run(t.target, data, size);
    std::abort();  // a target CMake built but the harness does not know
}

}  // namespace formfactor::fuzz
