#pragma once
/// VTK XML unstructured grids (`.vtu`, "VTKFile type=UnstructuredGrid" version 1.0, ASCII
/// arrays) of the patches, written directly, with per-patch cell data, so that ParaView or VisIt
/// shows a result at once. Each patch is one cell (VTK_TRIANGLE, VTK_QUAD for a convex quad,
/// VTK_POLYGON otherwise) with its own points, in the patch's vertex order (CCW seen from the
/// front, so VTK's cell normal is the patch's front). Every file carries the cell arrays
/// `patch` and `surface` (0-based indices) besides the fields given. Values `%.17g`.

#include <iosfwd>
#include <optional>
#include <string>
#include <vector>

#include "formfactor/matrix/form_factors.h"
#include "formfactor/scene/scene.h"
#include "formfactor/solve/radiosity.h"
#include "formfactor/solve/thermal.h"

namespace formfactor {

/// One per-patch array of cell data: `components` values per patch, patch after patch.
struct VtuField {
    std::string name;
    int components = 1;
    std::vector<double> values;
};

/// The fields of a form-factor matrix: `area`, `row_sum` (Σ_j F_ij), `sky_factor`
/// (1 − Σ_j F_ij: what leaves the patch to no patch), from the areas and row sums given.
std::vector<VtuField> row_sum_fields(const std::vector<double>& areas,
                                     const std::vector<double>& row_sums);

/// row_sum_fields() of a dense F, plus, when F has standard errors, `row_sum_standard_error`
/// (sqrt Σ_j σ_ij², as for independent entries), and, when `row` is given, `F_from_<row>`: the
/// row F_row,j (what patch `row` sends to each patch j) and, with standard errors,
/// `F_from_<row>_standard_error`. Throws OptionError("row", ...) when `row` is not a patch.
std::vector<VtuField> form_factor_fields(const FormFactors& ff,
                                         std::optional<std::size_t> row = std::nullopt);

/// Appends the radiosity solution: `radiosity` (3 components, RGB).
void append_solution_fields(std::vector<VtuField>& fields, const RadiosityResult& result);
/// Appends the thermal solution: `emissivity`, `temperature` (K), `radiosity` (W/m²),
/// `net_flux` (W/m², positive = the patch loses heat) and `net_power` (W).
void append_solution_fields(std::vector<VtuField>& fields, const ThermalResult& result);

/// Writes the patches of `scene` with `fields` as a VTU file to the stream. Throws Error when a
/// field's size is not components × patches or its name is empty or not plain (letters, digits,
/// `_`, `-`, `.`).
void write_vtu(std::ostream& out, const Scene& scene, const std::vector<VtuField>& fields);
/// The same into `path`, atomically.
void write_vtu(const std::string& path, const Scene& scene, const std::vector<VtuField>& fields);

}  // namespace formfactor
