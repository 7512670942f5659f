#pragma once
/// EnergyPlus's `ZoneProperty:UserViewFactors:BySurfaceName`: a zone's view factors by surface
/// name, so that an EnergyPlus run uses them instead of its own approximation. Written as IDF
/// text (`.idf`) or as epJSON (`.epJSON`); either is pasted or merged into the model (or
/// included with `##include` in IDF).
///
/// IDF: the object, the zone name, then one `From Surface, To Surface, View Factor` triple per
/// ordered pair (i, j), row-major, every pair (zeros too), values `%.17g`.
/// epJSON: {"ZoneProperty:UserViewFactors:BySurfaceName": {"<zone> view factors": {
/// "zone_or_zonelist_or_space_or_spacelist_name": zone, "view_factors": [{"from_surface",
/// "to_surface", "view_factor"}, ...]}}} in the same order (field names of EnergyPlus's schema).

#include <iosfwd>
#include <string>
#include <vector>

#include "formfactor/matrix/form_factors.h"

namespace formfactor {

/// The two syntaxes.
enum class EnergyPlusSyntax { Idf, EpJson };

/// The syntax for `path`'s extension (`.idf`, `.epjson`, any case), or none.
bool energyplus_syntax_for(const std::string& path, EnergyPlusSyntax& syntax);

/// Writes the object for `zone` with the surfaces `names` (rows and columns of F, from row i to
/// column j). Throws Error when names and F disagree in size, a name is empty, or (IDF) a name
/// holds a character IDF cannot carry (`,` `;` `!` or a line break).
void write_energyplus_view_factors(std::ostream& out, EnergyPlusSyntax syntax,
                                   const std::string& zone, const std::vector<std::string>& names,
                                   const DenseMatrix& F);

/// The same into `path` (syntax by extension), atomically.
void write_energyplus_view_factors(const std::string& path, const std::string& zone,
                                   const std::vector<std::string>& names, const DenseMatrix& F);

/// One zone's view factors (rows and columns named by its surfaces).
struct ZoneViewFactors {
    std::string zone;
    std::vector<std::string> names;
    DenseMatrix F;
};

/// One object per zone, in order, in one file (IDF: the objects one after the other; epJSON:
/// the members of one ZoneProperty:UserViewFactors:BySurfaceName object). Throws as above, and
/// Error when a zone appears twice.
void write_energyplus_view_factors(std::ostream& out, EnergyPlusSyntax syntax,
                                   const std::vector<ZoneViewFactors>& zones);

}  // namespace formfactor
