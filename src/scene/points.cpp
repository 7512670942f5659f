#include "formfactor/scene/points.h"

#include <filesystem>
#include <fstream>
#include <istream>

#include "formfactor/core/error.h"
#include "scene/text.h"

namespace formfactor {

namespace {

// The fields of a line: comma-separated when it has a comma (each field trimmed, empty fields
// kept so that "1,,2" is an error), else separated by spaces and tabs.
std::vector<std::string> fields_of(const std::string& line) {
    if (line.find(',') == std::string::npos) return detail::split(line, " \t");
    return detail::split_fields(line);
}

const char* const kNames[6] = {"x", "y", "z", "nx", "ny", "nz"};

}  // namespace

PointElements parse_points_csv(std::istream& in, const std::string& name) {
    PointElements out;
    std::string line;
    int ln = 0;
    bool content_seen = false;
    while (std::getline(in, line)) {
        ++ln;
        if (!line.empty() && line.back() == '\r') line.pop_back();
        const std::size_t hash = line.find('#');
        if (hash != std::string::npos) line.resize(hash);
        if (detail::trim(line).empty()) continue;
        const std::vector<std::string> f = fields_of(line);
        double probe = 0.0;
        const bool header = !content_seen && !f.empty() && !detail::parse_double(f[0], probe);
        content_seen = true;
        if (f.size() != 6)
            throw InputError(name, ln,
                             std::string(header ? "header" : "line") + " has " +
                                 std::to_string(f.size()) + " fields (x,y,z,nx,ny,nz expected: 6)");
        if (header) continue;
        double v[6];
        for (int k = 0; k < 6; ++k) {
            if (f[static_cast<std::size_t>(k)].empty())
                throw InputError(name, ln, std::string("empty field ") + kNames[k]);
            if (!detail::parse_double(f[static_cast<std::size_t>(k)], v[k]))
                throw InputError(name, ln,
                                 "malformed number '" + f[static_cast<std::size_t>(k)] + "' (" +
                                     kNames[k] + ")");
            if (!std::isfinite(v[k]))
                throw InputError(name, ln,
                                 std::string(kNames[k]) + " = '" + f[static_cast<std::size_t>(k)] +
                                     "' is not finite");
        }
        // Scaled by its largest component first, so that tiny or huge components normalise
        // without underflow or overflow.
        const Vec3 n(v[3], v[4], v[5]);
        const double big = n.cwiseAbs().maxCoeff();
        if (!(big > 0.0))
            throw InputError(name, ln, "the normal (nx, ny, nz) must not be the zero vector");
        out.positions.emplace_back(v[0], v[1], v[2]);
        out.normals.push_back((n / big).normalized());
        out.lines.push_back(ln);
    }
    if (in.bad()) throw InputError(name, 0, "cannot read file");
    if (out.positions.empty())
        throw InputError(name, 0, "no points (one line x,y,z,nx,ny,nz per point)");
    return out;
}

PointElements read_points_csv(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in || std::filesystem::is_directory(path)) throw InputError(path, 0, "cannot open file");
    return parse_points_csv(in, path);
}

}  // namespace formfactor
