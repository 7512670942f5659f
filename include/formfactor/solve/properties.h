#pragma once
/// Per-patch surface properties for the solvers: RGB reflectance and emission (radiosity),
/// emissivity, temperature or prescribed net flux (thermal). They start from the scene's
/// materials (MTL Kd → reflectance, Ke → emission) and can be overridden per patch or per
/// surface from a CSV file (`--properties P.csv`).

#include <iosfwd>
#include <string>
#include <vector>

#include "formfactor/core/types.h"
#include "formfactor/scene/scene.h"

namespace formfactor {

/// One entry per patch (scene.patches order). Temperature and net flux are NaN when not given;
/// a patch has at most one of them (setting one clears the other).
struct PatchProperties {
    std::vector<Rgb> reflectance;     ///< ρ per channel, in [0, 1)
    std::vector<Rgb> emission;        ///< E per channel (radiant exitance, e.g. W/m²), ≥ 0
    std::vector<double> emissivity;   ///< grey ε in (0, 1]
    std::vector<double> temperature;  ///< K, ≥ 0, NaN when not prescribed
    std::vector<double> net_flux;     ///< W/m², leaving the patch, NaN when not prescribed

    std::size_t size() const { return reflectance.size(); }
};

/// The properties that the scene's materials give each patch (patch → surface → material).
/// Throws GeometryError when a patch names a missing surface or material.
PatchProperties properties_from_scene(const Scene& scene);

/// Reads a properties CSV and applies it to `props` (which has one entry per scene patch).
///
/// Format: a header row, then one row per patch or per surface. The header has exactly one of
/// `patch` (0-based patch index) or `surface` (a surface name, applied to every patch of every
/// surface with that name) and any of reflectance_r, reflectance_g, reflectance_b, emission_r,
/// emission_g, emission_b, emissivity, temperature, net_flux. A missing column or an empty
/// cell keeps the current value. Lines that are empty or start with `#` are skipped.
///
/// Throws InputError("FILE", LINE, ...) for: an unreadable file, an unknown or repeated column,
/// a bad number, a wrong cell count, an unknown surface name, a patch index out of range,
/// ε outside (0, 1], T < 0, reflectance outside [0, 1), negative emission, or a row giving both
/// temperature and net_flux.
void apply_properties_csv(const std::string& path, const Scene& scene, PatchProperties& props);
/// The same, from a stream; `path` names it in error messages.
void apply_properties_csv(std::istream& in, const std::string& path, const Scene& scene,
                          PatchProperties& props);

/// Checks every value's range (as above); throws GeometryError naming the patch otherwise.
void validate_properties(const PatchProperties& props);

}  // namespace formfactor
