#include "formfactor/output/patch_table.h"

#include <ostream>

#include "core/text_numbers.h"
#include "formfactor/core/atomic_file.h"

namespace formfactor {

namespace {

// s as a CSV field: quoted (quotes doubled) when it holds a comma, a quote or a line break.
void append_csv_field(detail::TextBuffer& buf, const std::string& s) {
    if (s.find_first_of(",\"\n\r") == std::string::npos) {
        buf.append(s);
        return;
    }
    buf.put('"');
    for (char c : s) {
        if (c == '"') buf.put('"');
        buf.put(c);
    }
    buf.put('"');
}

}  // namespace

void write_patch_table(std::ostream& out, const Scene& scene) {
    detail::TextBuffer buf;
    buf.append("patch,surface,surface_name,area,cx,cy,cz,nx,ny,nz\n");
    for (std::size_t i = 0; i < scene.patches.size(); ++i) {
        const Patch& p = scene.patches[i];
        const bool known =
            p.surface >= 0 && static_cast<std::size_t>(p.surface) < scene.surfaces.size();
        char* c = buf.room(48);
        c = detail::print_integer(c, static_cast<long long>(i));
        *c++ = ',';
        c = detail::print_integer(c, p.surface);
        *c++ = ',';
        buf.commit(c);
        if (known) append_csv_field(buf, scene.surfaces[static_cast<std::size_t>(p.surface)].name);
        for (const double v : {p.area, p.centroid.x(), p.centroid.y(), p.centroid.z(), p.normal.x(),
                               p.normal.y(), p.normal.z()}) {
            c = buf.room(detail::kMaxNumberChars + 1);
            *c++ = ',';
            buf.commit(detail::print_g17(c, v));
        }
        buf.put('\n');
        if (buf.size() >= (std::size_t(1) << 20)) {
            out.write(buf.data(), static_cast<std::streamsize>(buf.size()));
            buf.clear();
        }
    }
    out.write(buf.data(), static_cast<std::streamsize>(buf.size()));
}

void write_patch_table(const std::string& path, const Scene& scene) {
    write_file_atomically(path, [&](std::ostream& out) { write_patch_table(out, scene); });
}

}  // namespace formfactor
