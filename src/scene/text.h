#pragma once
// Private helpers of the scene loaders and writers (reading text: core/text.h; writing files:
// formfactor/core/atomic_file.h).

#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#include "core/text.h"
#include "formfactor/core/error.h"
#include "formfactor/scene/scene.h"

namespace formfactor::detail {

/// Formats a double with 17 significant digits (exact round trip), shortest when possible.
inline std::string exact(double x) {
    char buf[64];
    auto [p, ec] = std::to_chars(buf, buf + sizeof buf, x);
    return ec == std::errc() ? std::string(buf, p) : std::string("nan");
}

/// Throws InputError(path, 0, ...) when the scene read from `path` has no surface with a row
/// (no faces at all, or only obstruction-only ones): there is nothing to compute. `none`: what
/// the format lacks ("no faces (f records)"); `hint`: which of its surfaces have rows.
inline void require_surfaces(const Scene& scene, const std::string& path, const std::string& none,
                             const std::string& hint) {
    std::size_t obstructions = 0;
    for (const Surface& s : scene.surfaces) obstructions += s.obstruction ? 1 : 0;
    if (scene.surfaces.size() > obstructions) return;
    if (scene.surfaces.empty())
        throw InputError(path, 0, "the scene is empty: " + none + ", nothing to compute");
    throw InputError(path, 0,
                     "all " + std::to_string(obstructions) +
                         " surfaces are obstructions: there are no surfaces to compute form "
                         "factors between (" +
                         hint + ")");
}

/// A short form of a number for messages ("2.1e-03").
inline std::string short_number(double x) {
    std::ostringstream s;
    s.precision(2);
    s << x;
    return s.str();
}

}  // namespace formfactor::detail
