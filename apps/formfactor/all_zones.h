#pragma once
// --all-zones (compute, solve, view): every zone of an EnergyPlus model, each its own
// enclosure, each zone's files named after the zone and written together after the last zone.

#include <map>
#include <string>
#include <vector>

#include "common.h"
#include "formfactor/core/atomic_file.h"

namespace formfactor::cli {

/// A zone's name as part of a file name: letters, digits, '-' and '_' kept (and the bytes of
/// UTF-8 letters), anything else ('/', ':', spaces, '.') an '_', so that no name reaches another
/// folder.
std::string file_name_part(const std::string& zone);

/// One zone's file of --all-zones: `{zone}` in `path` replaced by the zone's name, else the name
/// inserted before the extension (F.npy -> F_SPACE1-1.npy).
std::string zone_file(const std::string& path, const std::string& zone);

/// The zones of the EnergyPlus model that --all-zones goes through. Throws OptionError when the
/// scene is not an EnergyPlus model or --zone is given; `does` says what the command does with
/// them ("computes", "solves").
std::vector<std::string> all_zones(const SceneArgs& scene, const std::string& does);

/// The files of every zone, so that two zones never write one file.
class ZoneOutputs {
  public:
    /// Makes `path` (when not empty) the zone's file (zone_file()); throws OptionError when
    /// another zone already writes it.
    void claim(std::string& path, const std::string& zone);

  private:
    std::map<std::string, std::string> zone_of_file_;
};

/// Every output of one run is staged in `tx`; it is committed here, or handed to `outer` when
/// the run is one zone of --all-zones (the zones' files are then written together or not at
/// all).
void finish(OutputTransaction& tx, OutputTransaction* outer);

/// The last line of a run: what it wrote, or (one zone of --all-zones) what it will write.
void print_wrote(const std::string& files, const OutputTransaction* outer);

}  // namespace formfactor::cli
