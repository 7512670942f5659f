#include "formfactor/output/patch_table.h"

#include <fmt/format.h>

#include <ostream>

#include "core/text_numbers.h"
#include "formfactor/core/atomic_file.h"
#include "formfactor/core/error.h"

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

void write_table(std::ostream& out, const Scene& scene, const std::vector<double>* row_sums) {
    detail::TextBuffer buf;
    buf.append(row_sums ? "patch,surface,surface_name,area,cx,cy,cz,nx,ny,nz,row_sum,sky_factor\n"
                        : "patch,surface,surface_name,area,cx,cy,cz,nx,ny,nz\n");
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
        if (row_sums) {
            for (const double v : {(*row_sums)[i], 1.0 - (*row_sums)[i]}) {
                c = buf.room(detail::kMaxNumberChars + 1);
                *c++ = ',';
                buf.commit(detail::print_g17(c, v));
            }
        }
        buf.put('\n');
        if (buf.size() >= (std::size_t(1) << 20)) {
            out.write(buf.data(), static_cast<std::streamsize>(buf.size()));
            buf.clear();
        }
    }
    out.write(buf.data(), static_cast<std::streamsize>(buf.size()));
}

}  // namespace

void write_patch_table(std::ostream& out, const Scene& scene) { write_table(out, scene, nullptr); }

void write_patch_table(std::ostream& out, const Scene& scene, const std::vector<double>& row_sums) {
    if (row_sums.size() != scene.patches.size())
        throw Error(
            fmt::format("{} row sums for {} patches", row_sums.size(), scene.patches.size()));
    write_table(out, scene, &row_sums);
}

void write_pairs_csv(std::ostream& out, const std::vector<std::string>& names,
                     const DenseMatrix& F) {
    const std::size_t n = names.size();
    if (static_cast<std::size_t>(F.rows()) != n || static_cast<std::size_t>(F.cols()) != n)
        throw Error(fmt::format("{} names for a {}×{} matrix", n, F.rows(), F.cols()));
    detail::TextBuffer buf;
    buf.append("from,to,F\n");
    for (std::size_t i = 0; i < n; ++i) {
        for (std::size_t j = 0; j < n; ++j) {
            append_csv_field(buf, names[i]);
            buf.put(',');
            append_csv_field(buf, names[j]);
            char* c = buf.room(detail::kMaxNumberChars + 2);
            *c++ = ',';
            c = detail::print_g17(c, F(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)));
            *c++ = '\n';
            buf.commit(c);
            if (buf.size() >= (std::size_t(1) << 20)) {
                out.write(buf.data(), static_cast<std::streamsize>(buf.size()));
                buf.clear();
            }
        }
    }
    out.write(buf.data(), static_cast<std::streamsize>(buf.size()));
}

void write_patch_table(const std::string& path, const Scene& scene) {
    write_file_atomically(path, [&](std::ostream& out) { write_patch_table(out, scene); });
}

}  // namespace formfactor
