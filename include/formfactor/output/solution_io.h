#pragma once
/// Per-patch solution tables (what `formfactor solve` writes and `formfactor render` reads) and
/// their JSON report sections.
///
/// Radiosity CSV: header `patch,radiosity_r,radiosity_g,radiosity_b`, one row per patch in
/// patch order (0-based), values `%.17g`.
/// Thermal CSV: header `patch,area,emissivity,temperature,radiosity,net_flux,net_power`
/// (m², –, K, W/m², W/m², W): net_flux and net_power are positive when the patch loses heat.

#include <iosfwd>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "formfactor/core/types.h"
#include "formfactor/solve/radiosity.h"
#include "formfactor/solve/thermal.h"

namespace formfactor {

/// Writes the radiosity table atomically. Throws InputError(path, 0, ...) on I/O failure.
void write_radiosity_csv(const std::string& path, const std::vector<Rgb>& radiosity);
/// Writes the thermal table atomically.
void write_thermal_csv(const std::string& path, const ThermalResult& result);
/// The same tables as text (for a caller that writes them itself, e.g. in a transaction).
std::string radiosity_csv_text(const std::vector<Rgb>& radiosity);
std::string thermal_csv_text(const ThermalResult& result);

/// A solution table read back: radiosity tables fill `radiosity`; thermal tables fill every
/// field (radiosity = J in all three channels).
struct SolutionTable {
    bool thermal = false;
    std::vector<Rgb> radiosity;
    std::vector<double> area, emissivity, temperature, net_flux, net_power;
    std::size_t size() const { return radiosity.size(); }
};

/// Reads a radiosity or thermal CSV (told apart by the header). Every patch 0..N−1 must appear
/// exactly once; `expected_patches` (when given) must equal N. Throws InputError("FILE",
/// LINE, ...) on a bad header, number, index, or count.
SolutionTable read_solution_csv(const std::string& path,
                                std::optional<std::size_t> expected_patches = std::nullopt);
/// The same, from a stream; `path` names it in error messages.
SolutionTable read_solution_csv(std::istream& in, const std::string& path,
                                std::optional<std::size_t> expected_patches = std::nullopt);

/// JSON sections of the run report.
nlohmann::json to_json(const SolverStats& stats);
nlohmann::json to_json(const RadiosityResult& result);
/// Includes the totals, the balance and the warnings (not the per-patch arrays).
nlohmann::json to_json(const ThermalResult& result);

}  // namespace formfactor
