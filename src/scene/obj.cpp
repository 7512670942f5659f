// Wavefront OBJ + MTL: reader (tinyobjloader, after a validating pre-scan of our own) and
// writer.
//
// tinyobjloader accepts faces that index missing vertices and reads malformed numbers as 0, and
// it does not say where a face came from; so the OBJ and MTL text is first scanned here for
// FILE:LINE messages and for each face's line and group, then handed to tinyobjloader, and the
// two readings are cross-checked.

#ifndef TINYOBJLOADER_USE_DOUBLE
#define TINYOBJLOADER_USE_DOUBLE
#endif
#include <tiny_obj_loader.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <map>
#include <set>
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
using detail::split;

bool starts_with_obstruction(const std::string& name) {
    for (const std::string& w : split(name)) {
        std::string l = w.substr(0, 11);
        std::transform(l.begin(), l.end(), l.begin(),
                       [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
        if (l == "obstruction") return true;
    }
    return false;
}

// What the MTL scan found for one material (values tinyobjloader reads differently or not at
// all: `Kd r` alone means grey, `emissivity` and `temperature` are ours).
struct MtlValues {
    std::optional<Rgb> kd, ke;
    std::optional<double> emissivity, temperature;
};

struct FaceInfo {
    int line = 0;
    std::string key;  // group, else object, else "face"
    bool obstruction = false;
    std::vector<int> v;  // 0-based vertex indices
    // tinyobjloader counts a face's vertices in an unsigned char: a face with more than
    // kTinyObjMaxFaceVertices vertices is handed to it as its first three (this line), and its
    // polygon is built from `v`.
    std::string stand_in;
};

// Most vertices per face that tinyobjloader can count (mesh_t::num_face_vertices is unsigned
// char); longer faces bypass it (FaceInfo::stand_in), so no limit reaches the user.
constexpr std::size_t kTinyObjMaxFaceVertices = 255;

class ObjReader {
  public:
    explicit ObjReader(std::string path) : path_(std::move(path)) {}

    Scene read() {
        const std::vector<std::string> lines = detail::read_lines(path_);
        scene_.name = path_;
        scan(lines);

        std::string text;
        {
            std::size_t next_face = 0;
            for (std::size_t i = 0; i < lines.size(); ++i) {
                while (next_face < faces_.size() &&
                       faces_[next_face].line < static_cast<int>(i) + 1)
                    ++next_face;
                const bool stand_in = next_face < faces_.size() &&
                                      faces_[next_face].line == static_cast<int>(i) + 1 &&
                                      !faces_[next_face].stand_in.empty();
                (text += stand_in ? faces_[next_face].stand_in : lines[i]) += '\n';
            }
        }
        std::istringstream in(text);
        Reader mtl(*this);
        tinyobj::attrib_t attrib;
        std::vector<tinyobj::shape_t> shapes;
        std::vector<tinyobj::material_t> materials;
        std::string warn, err;
        if (!tinyobj::LoadObj(&attrib, &shapes, &materials, &warn, &err, &in, &mtl, false))
            throw InputError(path_, 0, "cannot read OBJ: " + detail::trim(err));

        // Materials: the MTL's, then "default" for faces without one (when needed).
        for (const tinyobj::material_t& tm : materials) {
            Material m;
            m.name = tm.name;
            m.reflectance = Rgb(tm.diffuse[0], tm.diffuse[1], tm.diffuse[2]);
            m.emission = Rgb(tm.emission[0], tm.emission[1], tm.emission[2]);
            auto it = mtl_values_.find(tm.name);
            if (it != mtl_values_.end()) {
                if (it->second.kd) m.reflectance = *it->second.kd;
                if (it->second.ke) m.emission = *it->second.ke;
                if (it->second.emissivity) m.emissivity = *it->second.emissivity;
                if (it->second.temperature) m.temperature = *it->second.temperature;
            }
            scene_.materials.push_back(m);
        }
        int default_material = -1;

        std::size_t f = 0;
        std::map<std::string, int> per_key;
        for (const FaceInfo& fi : faces_) ++per_key[fi.key];
        std::map<std::string, int> seen;
        for (const tinyobj::shape_t& sh : shapes) {
            std::size_t offset = 0;
            for (std::size_t k = 0; k < sh.mesh.num_face_vertices.size(); ++k) {
                const std::size_t nv = sh.mesh.num_face_vertices[k];
                if (f >= faces_.size())
                    throw InputError(path_, 0, "tinyobjloader read more faces than the file has");
                const FaceInfo& fi = faces_[f];
                const bool stand_in = !fi.stand_in.empty();
                if (nv != (stand_in ? 3 : fi.v.size()))
                    throw InputError(path_, fi.line, "tinyobjloader read this face differently");
                for (std::size_t j = 0; j < nv; ++j)
                    if (sh.mesh.indices[offset + j].vertex_index != fi.v[j])
                        throw InputError(path_, fi.line,
                                         "tinyobjloader read this face differently");
                Surface s;
                s.polygon.vertices.reserve(fi.v.size());
                // The coordinates as the scan parsed them (correctly rounded): tinyobjloader's
                // own number parser is not (it read "0.3" as 0.30000000000000004), so the same
                // geometry from an OBJ file and from any other form differed in the last bit.
                for (const int vi : fi.v) {
                    if (vi < 0 || static_cast<std::size_t>(vi) >= vertices_.size())
                        throw InputError(path_, fi.line,
                                         "tinyobjloader read this face differently");
                    s.polygon.vertices.push_back(vertices_[static_cast<std::size_t>(vi)]);
                }
                offset += nv;
                const int count = ++seen[fi.key];
                s.name = per_key[fi.key] == 1 ? fi.key : fi.key + "." + std::to_string(count);
                s.obstruction = fi.obstruction;
                s.where = {path_, fi.line};
                const int mid = sh.mesh.material_ids[k];
                if (mid >= 0 && static_cast<std::size_t>(mid) < scene_.materials.size()) {
                    s.material = mid;
                } else {
                    if (default_material < 0) {
                        Material d;
                        d.name = "default";
                        scene_.materials.push_back(d);
                        default_material = static_cast<int>(scene_.materials.size()) - 1;
                    }
                    s.material = default_material;
                }
                validate_polygon(s.polygon, s.where, "face");
                scene_.surfaces.push_back(std::move(s));
                ++f;
            }
        }
        if (f != faces_.size())
            throw InputError(path_, 0,
                             "tinyobjloader read " + std::to_string(f) + " faces, the file has " +
                                 std::to_string(faces_.size()));
        if (attrib.vertices.size() != 3 * vertex_count_)
            throw InputError(path_, 0, "tinyobjloader read a different number of vertices");
        for (std::string& w : notes_) scene_.warnings.push_back(std::move(w));
        return std::move(scene_);
    }

  private:
    // Opens the MTL libraries the OBJ names, relative to the OBJ's folder, after the scan.
    class Reader : public tinyobj::MaterialReader {
      public:
        explicit Reader(ObjReader& r) : r_(r) {}
        bool operator()(const std::string& id, std::vector<tinyobj::material_t>* materials,
                        std::map<std::string, int>* map, std::string* warn,
                        std::string* err) override {
            auto it = r_.mtl_text_.find(id);
            if (it == r_.mtl_text_.end()) return false;
            std::istringstream in(it->second);
            tinyobj::LoadMtl(map, materials, &in, warn, err);
            return true;
        }

      private:
        ObjReader& r_;
    };

    [[noreturn]] void fail(const std::string& file, int line, const std::string& msg) const {
        throw InputError(file, line, msg);
    }
    void note(const std::string& file, int line, const std::string& msg) {
        notes_.push_back(file + ":" + std::to_string(line) + ": " + msg);
    }

    int index(int line, const std::string& w, std::size_t defined_so_far, const char* what) {
        int i = 0;
        if (!detail::parse_int(w, i))
            fail(path_, line, "malformed " + std::string(what) + " index '" + w + "' in f record");
        if (i == 0)
            fail(path_, line, std::string(what) + " index 0 is invalid (OBJ indices start at 1)");
        if (i < 0) {
            const long r = static_cast<long>(defined_so_far) + i;
            if (r < 0)
                fail(path_, line,
                     "relative " + std::string(what) + " index " + w +
                         " points before the first one (" + std::to_string(defined_so_far) +
                         " defined so far)");
            return static_cast<int>(r);
        }
        return i - 1;
    }

    void scan(const std::vector<std::string>& lines) {
        std::string group, object;
        std::set<std::string> warned;
        std::size_t nvt = 0, nvn = 0;
        std::vector<std::pair<int, int>> forward;  // (line, index) to check at the end
        for (std::size_t i = 0; i < lines.size(); ++i) {
            const int ln = static_cast<int>(i) + 1;
            std::string l = lines[i];
            const std::size_t hash = l.find('#');
            if (hash != std::string::npos) l.resize(hash);
            const std::vector<std::string> t = split(l, " \t\r\f\v");
            if (t.empty()) continue;
            const std::string& k = t[0];
            if (k == "v") {
                if (t.size() < 4)
                    fail(path_, ln,
                         "v record has " + std::to_string(t.size() - 1) +
                             " numbers (x, y, z needed)");
                Vec3 p = Vec3::Zero();
                for (std::size_t j = 1; j < t.size(); ++j) {
                    double x = 0.0;
                    if (!detail::parse_double(t[j], x))
                        fail(path_, ln, "malformed number '" + t[j] + "' in v record");
                    if (j <= 3 && !std::isfinite(x))
                        fail(path_, ln, "vertex coordinate '" + t[j] + "' is not finite");
                    if (j <= 3) p[static_cast<Eigen::Index>(j - 1)] = x;
                }
                vertices_.push_back(p);
                ++vertex_count_;
            } else if (k == "vt") {
                ++nvt;
            } else if (k == "vn") {
                ++nvn;
            } else if (k == "f") {
                if (t.size() < 4)
                    fail(path_, ln,
                         "face has " + std::to_string(t.size() - 1) +
                             " vertices (at least 3 needed)");
                FaceInfo fi;
                if (t.size() - 1 > kTinyObjMaxFaceVertices)
                    fi.stand_in = t[0] + " " + t[1] + " " + t[2] + " " + t[3];
                fi.line = ln;
                fi.key = !group.empty() ? group : !object.empty() ? object : "face";
                fi.obstruction = starts_with_obstruction(group) || starts_with_obstruction(object);
                for (std::size_t j = 1; j < t.size(); ++j) {
                    const std::vector<std::string> parts = [&] {
                        std::vector<std::string> p;
                        std::size_t a = 0;
                        while (true) {
                            const std::size_t b = t[j].find('/', a);
                            p.push_back(t[j].substr(a, b == std::string::npos ? b : b - a));
                            if (b == std::string::npos) break;
                            a = b + 1;
                        }
                        return p;
                    }();
                    if (parts.size() > 3) fail(path_, ln, "malformed face vertex '" + t[j] + "'");
                    const int v = index(ln, parts[0], vertex_count_, "vertex");
                    if (parts.size() > 1 && !parts[1].empty()) index(ln, parts[1], nvt, "texture");
                    if (parts.size() > 2 && !parts[2].empty()) index(ln, parts[2], nvn, "normal");
                    forward.emplace_back(ln, v);
                    fi.v.push_back(v);
                }
                faces_.push_back(std::move(fi));
            } else if (k == "g") {
                group = detail::trim(l.substr(l.find('g') + 1));
            } else if (k == "o") {
                object = detail::trim(l.substr(l.find('o') + 1));
                group.clear();
            } else if (k == "mtllib") {
                for (std::size_t j = 1; j < t.size(); ++j) scan_mtl(ln, t[j]);
            } else if (k == "usemtl") {
                const std::string name = t.size() > 1 ? t[1] : "";
                if (!name.empty() && !mtl_values_.count(name) && !missing_mtl_)
                    note(path_, ln,
                         "material '" + name +
                             "' is not defined in any material library: the "
                             "default material is used");
            } else if (k == "l" || k == "p") {
                if (warned.insert(k).second)
                    note(path_, ln,
                         std::string(k == "l" ? "lines (l records)" : "points (p records)") +
                             " ignored: only faces are surfaces");
            } else if (k == "curv" || k == "curv2" || k == "surf" || k == "cstype" || k == "vp") {
                if (warned.insert("freeform").second)
                    note(path_, ln,
                         "free-form geometry (" + k +
                             ") ignored: only polygonal "
                             "faces are surfaces");
            } else if (k == "s" || k == "mg" || k == "usemap" || k == "maplib" || k == "lod" ||
                       k == "bevel" || k == "c_interp" || k == "d_interp" || k == "shadow_obj" ||
                       k == "trace_obj" || k == "deg" || k == "bmat" || k == "step" ||
                       k == "parm" || k == "trim" || k == "hole" || k == "scrv" || k == "sp" ||
                       k == "end" || k == "con") {
                // no bearing on the surfaces
            } else if (warned.insert("?" + k).second) {
                note(path_, ln, "unknown OBJ record '" + k + "' ignored");
            }
        }
        for (const auto& [ln, v] : forward)
            if (v >= static_cast<int>(vertex_count_))
                fail(path_, ln,
                     "face vertex index " + std::to_string(v + 1) + " out of range (the file has " +
                         std::to_string(vertex_count_) + " vertices)");
    }

    void scan_mtl(int obj_line, const std::string& name) {
        if (mtl_text_.count(name)) return;
        const std::filesystem::path p = std::filesystem::path(path_).parent_path() / name;
        const std::string file = p.string();
        std::vector<std::string> lines;
        try {
            lines = detail::read_lines(file);
        } catch (const InputError&) {
            missing_mtl_ = true;
            note(path_, obj_line,
                 "cannot open material library '" + file + "': surfaces get the default material");
            return;
        }
        std::string text;
        std::string current;
        for (std::size_t i = 0; i < lines.size(); ++i) {
            const int ln = static_cast<int>(i) + 1;
            (text += lines[i]) += '\n';
            std::string l = lines[i];
            const std::size_t hash = l.find('#');
            if (hash != std::string::npos) l.resize(hash);
            const std::vector<std::string> t = split(l, " \t\r\f\v");
            if (t.empty()) continue;
            const std::string& k = t[0];
            auto numbers = [&](std::size_t lo, std::size_t hi) {
                if (t.size() - 1 < lo || t.size() - 1 > hi)
                    fail(file, ln,
                         k + " needs " +
                             (lo == hi ? std::to_string(lo)
                                       : std::to_string(lo) + " to " + std::to_string(hi)) +
                             " numbers (got " + std::to_string(t.size() - 1) + ")");
                std::vector<double> x;
                for (std::size_t j = 1; j < t.size(); ++j) {
                    double v = 0.0;
                    if (!detail::parse_double(t[j], v))
                        fail(file, ln, "malformed number '" + t[j] + "' in " + k + " record");
                    if (!std::isfinite(v))
                        fail(file, ln, "number '" + t[j] + "' in " + k + " record is not finite");
                    x.push_back(v);
                }
                return x;
            };
            auto rgb = [&]() {
                if (t.size() > 1 && (t[1] == "spectral" || t[1] == "xyz"))
                    fail(file, ln, k + " " + t[1] + " is not supported (give r g b)");
                const std::vector<double> x = numbers(1, 3);
                if (x.size() == 2) fail(file, ln, k + " needs 1 or 3 numbers (got 2)");
                return x.size() == 1 ? Rgb::Constant(x[0]) : Rgb(x[0], x[1], x[2]);
            };
            if (k == "newmtl") {
                current = t.size() > 1 ? t[1] : "";
                mtl_values_[current];
            } else if (k == "Kd") {
                const Rgb c = rgb();
                if ((c.array() < 0.0).any() || (c.array() > 1.0).any())
                    fail(file, ln, "reflectance Kd must be within [0, 1]");
                mtl_values_[current].kd = c;
            } else if (k == "Ke") {
                const Rgb c = rgb();
                if ((c.array() < 0.0).any()) fail(file, ln, "emission Ke must not be negative");
                mtl_values_[current].ke = c;
            } else if (k == "emissivity") {
                const double e = numbers(1, 1)[0];
                if (e < 0.0 || e > 1.0) fail(file, ln, "emissivity must be within [0, 1]");
                mtl_values_[current].emissivity = e;
            } else if (k == "temperature") {
                const double T = numbers(1, 1)[0];
                if (!(T > 0.0)) fail(file, ln, "temperature must be positive (kelvin)");
                mtl_values_[current].temperature = T;
            }
        }
        mtl_text_[name] = std::move(text);
    }

    std::string path_;
    Scene scene_;
    std::vector<FaceInfo> faces_;
    std::size_t vertex_count_ = 0;
    std::vector<Vec3> vertices_;  ///< x, y, z of every `v` record, in file order
    std::map<std::string, std::string> mtl_text_;
    std::map<std::string, MtlValues> mtl_values_;
    bool missing_mtl_ = false;
    std::vector<std::string> notes_;
};

std::string obj_name(const std::string& name, std::size_t k) {
    std::string s;
    for (char c : name) s += std::isspace(static_cast<unsigned char>(c)) || c == '#' ? '_' : c;
    if (s.empty()) s = "surface" + std::to_string(k + 1);
    return s;
}

}  // namespace

Scene load_obj(const std::string& path) {
    Scene scene = ObjReader(path).read();
    detail::require_surfaces(scene, path, "no faces (f records)",
                             "faces outside groups and objects named obstruction* have rows");
    subdivide(scene, SubdivisionOptions{});
    return scene;
}

void save_obj(const Scene& scene, const std::string& path) {
    const std::filesystem::path p(path);
    const std::string mtl_file = p.stem().string() + ".mtl";
    const std::string mtl_path = (p.parent_path() / mtl_file).string();

    // Material names: unique, no blanks.
    std::vector<std::string> mat_names;
    std::set<std::string> used;
    for (std::size_t k = 0; k < scene.materials.size(); ++k) {
        std::string n = obj_name(scene.materials[k].name, k);
        while (used.count(n)) n += "_" + std::to_string(k);
        used.insert(n);
        mat_names.push_back(n);
    }
    std::ostringstream mtl;
    mtl << "# written by formfactor\n";
    for (std::size_t k = 0; k < scene.materials.size(); ++k) {
        const Material& m = scene.materials[k];
        mtl << "newmtl " << mat_names[k] << "\n";
        mtl << "Kd " << exact(m.reflectance.x()) << " " << exact(m.reflectance.y()) << " "
            << exact(m.reflectance.z()) << "\n";
        mtl << "Ke " << exact(m.emission.x()) << " " << exact(m.emission.y()) << " "
            << exact(m.emission.z()) << "\n";
        mtl << "emissivity " << exact(m.emissivity) << "\n";
        if (std::isfinite(m.temperature)) mtl << "temperature " << exact(m.temperature) << "\n";
        mtl << "\n";
    }

    std::ostringstream obj;
    obj << "# written by formfactor: " << scene.surfaces.size() << " surfaces\n";
    if (!scene.title.empty()) {
        std::string t = scene.title;
        for (char& c : t)
            if (c == '\n' || c == '\r') c = ' ';
        obj << "# " << t << "\n";
    }
    if (!scene.materials.empty()) obj << "mtllib " << mtl_file << "\n";
    // OBJ has no holes: a surface with holes is written as its convex pieces (polygon minus
    // holes), faces of its group (read back as surfaces NAME.1, NAME.2, ...).
    std::vector<std::vector<Polygon>> faces;
    for (const Surface& s : scene.surfaces)
        faces.push_back(s.holes.empty() ? std::vector<Polygon>{s.polygon}
                                        : subtract_holes(s.polygon, s.holes));
    for (const auto& f : faces)
        for (const Polygon& poly : f)
            for (const Vec3& v : poly.vertices)
                obj << "v " << exact(v.x()) << " " << exact(v.y()) << " " << exact(v.z()) << "\n";
    // Group names: unique per surface, so that each reads back as one surface of that name.
    std::set<std::string> groups;
    std::size_t next = 1;
    for (std::size_t k = 0; k < scene.surfaces.size(); ++k) {
        const Surface& s = scene.surfaces[k];
        std::string g = obj_name(s.name, k);
        if (s.obstruction && !starts_with_obstruction(g)) g = "obstruction_" + g;
        if (!s.obstruction && starts_with_obstruction(g)) g = "surface_" + g;
        while (groups.count(g)) g += "_" + std::to_string(k + 1);
        groups.insert(g);
        obj << "g " << g << "\n";
        if (s.material >= 0 && static_cast<std::size_t>(s.material) < mat_names.size())
            obj << "usemtl " << mat_names[static_cast<std::size_t>(s.material)] << "\n";
        for (const Polygon& f : faces[k]) {
            obj << "f";
            for (std::size_t j = 0; j < f.size(); ++j) obj << " " << next++;
            obj << "\n";
        }
    }
    // Both files or neither.
    OutputTransaction tx;
    if (!scene.materials.empty()) tx.stage(mtl_path, [&](std::ostream& out) { out << mtl.str(); });
    tx.stage(path, [&](std::ostream& out) { out << obj.str(); });
    tx.commit();
}

}  // namespace formfactor
