#include "formfactor/output/patch_table.h"

#include <fmt/format.h>

#include <ostream>

#include "formfactor/output/atomic_file.h"

namespace formfactor {

namespace {

std::string csv_field(const std::string& s) {
    if (s.find_first_of(",\"\n\r") == std::string::npos) return s;
    std::string q = "\"";
    for (char c : s) {
        if (c == '"') q += '"';
        q += c;
    }
    return q + "\"";
}

}  // namespace

void write_patch_table(std::ostream& out, const Scene& scene) {
    out << "patch,surface,surface_name,area,cx,cy,cz,nx,ny,nz\n";
    fmt::memory_buffer buf;
    for (std::size_t i = 0; i < scene.patches.size(); ++i) {
        const Patch& p = scene.patches[i];
        const bool known =
            p.surface >= 0 && static_cast<std::size_t>(p.surface) < scene.surfaces.size();
        const std::string name =
            known ? scene.surfaces[static_cast<std::size_t>(p.surface)].name : "";
        buf.clear();
        fmt::format_to(std::back_inserter(buf),
                       "{},{},{},{:.17g},{:.17g},{:.17g},{:.17g},{:.17g},{:.17g},{:.17g}\n", i,
                       p.surface, csv_field(name), p.area, p.centroid.x(), p.centroid.y(),
                       p.centroid.z(), p.normal.x(), p.normal.y(), p.normal.z());
        out.write(buf.data(), static_cast<std::streamsize>(buf.size()));
    }
}

void write_patch_table(const std::string& path, const Scene& scene) {
    write_file_atomically(path, [&](std::ostream& out) { write_patch_table(out, scene); });
}

}  // namespace formfactor
