// View3D 3.2 input files (.vs3): the writer, save_vs3(). The format is described at the top of
// vs3_read.cpp.

#include <array>
#include <cctype>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "formfactor/core/atomic_file.h"
#include "formfactor/core/error.h"
#include "formfactor/scene/scene.h"
#include "formfactor/scene/scene_io.h"
#include "scene/text.h"

namespace formfactor {

namespace {

using detail::exact;

// A surface name as one VS3 word: blanks and the comment and separator characters replaced.
std::string vs3_name(const std::string& name, std::size_t number) {
    std::string s;
    for (char c : name)
        s += (std::isspace(static_cast<unsigned char>(c)) || c == '!' || c == '/' || c == ',') ? '_'
                                                                                               : c;
    if (s.empty()) {
        s = "s";
        s += std::to_string(number);
    }
    return s;
}

}  // namespace

void save_vs3(const Scene& scene, const std::string& path) {
    // Pieces: each surface as one polygon, or as triangles when View3D cannot take it whole.
    struct Piece {
        std::size_t surface;
        Polygon polygon;
    };
    std::vector<std::size_t> order;  // radiating surfaces first, then obstructions
    for (std::size_t s = 0; s < scene.surfaces.size(); ++s)
        if (!scene.surfaces[s].obstruction) order.push_back(s);
    for (std::size_t s = 0; s < scene.surfaces.size(); ++s)
        if (scene.surfaces[s].obstruction) order.push_back(s);
    std::vector<Piece> pieces;
    std::vector<int> first_piece(scene.surfaces.size(), -1);
    std::vector<bool> is_base(scene.surfaces.size(), false);
    std::vector<std::size_t> subsurfaces(scene.surfaces.size(), 0);
    for (const Surface& s : scene.surfaces)
        if (s.base >= 0) {
            is_base[static_cast<std::size_t>(s.base)] = true;
            ++subsurfaces[static_cast<std::size_t>(s.base)];
        }
    // VS3 expresses holes only as subsurfaces (which the reader turns back into holes).
    for (std::size_t s = 0; s < scene.surfaces.size(); ++s) {
        const Surface& x = scene.surfaces[s];
        if (!x.holes.empty() && (x.obstruction || x.holes.size() != subsurfaces[s]))
            throw GeometryError("cannot write surface '" + x.name + "' to VS3: it has " +
                                std::to_string(x.holes.size()) +
                                " hole(s) that are not its subsurfaces");
    }
    for (std::size_t s : order) {
        const Polygon& p = scene.surfaces[s].polygon;
        first_piece[s] = static_cast<int>(pieces.size());
        if (p.size() == 3 || (p.size() == 4 && convexity(p) == Convexity::strictly_convex)) {
            pieces.push_back({s, p});
            continue;
        }
        if (is_base[s])
            throw GeometryError("cannot write surface '" + scene.surfaces[s].name +
                                "' to VS3: it has " + std::to_string(p.size()) +
                                " vertices (or is a non-convex quad) and is the base of a "
                                "subsurface");
        const double d = diameter(p);
        for (const auto& t : triangulate(p)) {
            Polygon tri;
            for (int k : t) tri.vertices.push_back(p[static_cast<std::size_t>(k)]);
            if (area(tri) > 1e-14 * d * d) pieces.push_back({s, std::move(tri)});
        }
    }
    // Distinct vertices, numbered in order of first use.
    std::map<std::array<double, 3>, int> index;
    std::vector<Vec3> verts;
    std::vector<std::vector<int>> refs;
    for (const Piece& pc : pieces) {
        std::vector<int> r;
        for (const Vec3& v : pc.polygon.vertices) {
            const std::array<double, 3> key{v.x(), v.y(), v.z()};
            auto [it, inserted] = index.emplace(key, static_cast<int>(verts.size()) + 1);
            if (inserted) verts.push_back(v);
            r.push_back(it->second);
        }
        refs.push_back(std::move(r));
    }

    std::ostringstream out;
    std::string title = scene.title.empty() ? scene.name : scene.title;
    for (char& c : title)
        if (c == '\n' || c == '\r') c = ' ';
    out << "T " << title << "\n";
    Vs3Control c = scene.vs3_control.value_or(Vs3Control{});
    if (!scene.vs3_control) c.encl = scene.enclosure ? 1 : 0;
    out << "C encl=" << c.encl << " emit=" << c.emit << " eps=" << exact(c.eps)
        << " maxU=" << c.maxU << " maxO=" << c.maxO << " minO=" << c.minO << " row=" << c.row
        << " col=" << c.col << " out=" << c.out << " list=" << c.list << "\n";
    out << "F 3\n";
    out << "! written by formfactor: " << scene.surfaces.size() << " surfaces\n";
    out << "!  #  x  y  z\n";
    for (std::size_t k = 0; k < verts.size(); ++k)
        out << "V " << k + 1 << " " << exact(verts[k].x()) << " " << exact(verts[k].y()) << " "
            << exact(verts[k].z()) << "\n";
    out << "!  #  v1 v2 v3 v4 base cmb emit name\n";
    for (std::size_t k = 0; k < pieces.size(); ++k) {
        const Surface& s = scene.surfaces[pieces[k].surface];
        const std::vector<int>& r = refs[k];
        out << (s.obstruction ? "O " : "S ") << k + 1 << " " << r[0] << " " << r[1] << " " << r[2]
            << " " << (r.size() == 4 ? r[3] : 0) << " ";
        int base = 0, cmb = 0;
        if (s.base >= 0) base = first_piece[static_cast<std::size_t>(s.base)] + 1;
        const int own_first = first_piece[pieces[k].surface];
        if (s.combine >= 0)
            cmb = first_piece[static_cast<std::size_t>(s.combine)] + 1;
        else if (static_cast<int>(k) != own_first && !s.obstruction)
            cmb = own_first + 1;
        const double emit =
            s.material >= 0 && static_cast<std::size_t>(s.material) < scene.materials.size()
                ? scene.materials[static_cast<std::size_t>(s.material)].emissivity
                : 0.9;
        out << base << " " << cmb << " " << exact(emit) << " " << vs3_name(s.name, k + 1) << "\n";
    }
    out << "End of data\n";
    const std::string text = out.str();
    write_file_atomically(path, [&](std::ostream& file) { file << text; });
}

}  // namespace formfactor
