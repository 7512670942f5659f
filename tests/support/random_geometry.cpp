// Random obstructed scenes and their forms (see random_geometry.h).

#include "random_geometry.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <tuple>

#include "formfactor/core/random.h"
#include "formfactor/scene/scene_io.h"
#include "scenes.h"

namespace formfactor::testing {

namespace {

// A portable random stream (std:: distributions differ between standard libraries).
class Rng {
  public:
    explicit Rng(std::uint64_t seed) : state_(splitmix64(seed ^ 0x5eedf00dULL)) {}
    double uniform() { return to_unit(splitmix64(state_++)); }
    double uniform(double a, double b) { return a + (b - a) * uniform(); }
    int integer(int n) { return std::min(n - 1, static_cast<int>(uniform() * n)); }
    bool chance(double p) { return uniform() < p; }
    template <class T>
    const T& pick(const std::vector<T>& v) {
        return v[static_cast<std::size_t>(integer(static_cast<int>(v.size())))];
    }
    Mat3 rotation() {
        // A uniform random rotation from a uniform unit quaternion (rejection in the 4-ball).
        Eigen::Vector4d q;
        do {
            q = Eigen::Vector4d(uniform(-1, 1), uniform(-1, 1), uniform(-1, 1), uniform(-1, 1));
        } while (q.squaredNorm() > 1 || q.squaredNorm() < 1e-6);
        q.normalize();
        return Eigen::Quaterniond(q[0], q[1], q[2], q[3]).toRotationMatrix();
    }
    Mat3 small_rotation(double angle) {
        Vec3 axis(uniform(-1, 1), uniform(-1, 1), uniform(-1, 1));
        if (axis.norm() < 1e-3) axis = Vec3::UnitZ();
        return Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
    }

  private:
    std::uint64_t state_;
};

// A planar face given as a grid: P(a, b) = o + (a e1 + b e2)/m for a quad (front e1 × e2),
// or a triangle (v0, v1, v2) split into m² triangles as subdivide() does.
struct Face {
    std::vector<Vec3> corners;  // 3 or 4, counter-clockwise seen from the front
};

// The m×m (quads) or m² (triangles) patches of a face in subdivide()'s order, with jitter: the
// face moved rigidly by ~j (a rotation about its centre and a shift) and every grid vertex
// moved within the face's plane by up to j. Every patch stays planar; neighbouring faces no
// longer meet exactly (gaps and overlaps of ~j), as in models written by other programs.
std::vector<Polygon> split_face(const Face& f, int m, double j, Rng& rng) {
    const bool quad = f.corners.size() == 4;
    // Grid vertices.
    std::vector<Vec3> grid;
    auto at = [&](int a, int b) -> Vec3& {
        return grid[static_cast<std::size_t>(b * (m + 1) + a)];
    };
    grid.resize(static_cast<std::size_t>((m + 1) * (m + 1)));
    for (int b = 0; b <= m; ++b)
        for (int a = 0; a <= m; ++a) {
            const double u = double(a) / m, v = double(b) / m;
            if (quad) {
                // Bilinear, as subdivide(); exact for the parallelograms drawn here.
                at(a, b) = (1 - u) * (1 - v) * f.corners[0] + u * (1 - v) * f.corners[1] +
                           u * v * f.corners[2] + (1 - u) * v * f.corners[3];
            } else {
                at(a, b) = f.corners[0] + u * (f.corners[1] - f.corners[0]) +
                           v * (f.corners[2] - f.corners[0]);
            }
        }
    if (j > 0) {
        Vec3 c = Vec3::Zero();
        for (const Vec3& p : f.corners) c += p / static_cast<double>(f.corners.size());
        const Mat3 R = rng.small_rotation(rng.uniform(0, j));
        const Vec3 shift(rng.uniform(-j, j), rng.uniform(-j, j), rng.uniform(-j, j));
        Vec3 e1 = (f.corners[1] - f.corners[0]).normalized();
        Vec3 n = (f.corners[1] - f.corners[0]).cross(f.corners[2] - f.corners[0]).normalized();
        e1 = R * e1;
        n = R * n;
        const Vec3 e2 = n.cross(e1);
        for (Vec3& p : grid)
            p = c + R * (p - c) + shift + rng.uniform(-j, j) * e1 + rng.uniform(-j, j) * e2;
    }
    std::vector<Polygon> out;
    if (quad) {
        for (int b = 0; b < m; ++b)
            for (int a = 0; a < m; ++a)
                out.push_back(Polygon{{at(a, b), at(a + 1, b), at(a + 1, b + 1), at(a, b + 1)}});
    } else {
        for (int b = 0; b < m; ++b)
            for (int a = 0; a + b < m; ++a) {
                out.push_back(Polygon{{at(a, b), at(a + 1, b), at(a, b + 1)}});
                if (a < m - 1 - b)
                    out.push_back(Polygon{{at(a + 1, b), at(a + 1, b + 1), at(a, b + 1)}});
            }
    }
    return out;
}

Face face_of(const Polygon& p) { return Face{p.vertices}; }

// The room's faces as room_scene(): x=0, x=1, y=0, y=1, z=0, z=1, facing inward.
std::vector<Face> room_faces() {
    using V = Vec3;
    const std::array<std::array<V, 3>, 6> f = {{{V(0, 0, 0), V(0, 1, 0), V(0, 0, 1)},
                                                {V(1, 0, 0), V(0, 0, 1), V(0, 1, 0)},
                                                {V(0, 0, 0), V(0, 0, 1), V(1, 0, 0)},
                                                {V(0, 1, 0), V(1, 0, 0), V(0, 0, 1)},
                                                {V(0, 0, 0), V(1, 0, 0), V(0, 1, 0)},
                                                {V(0, 0, 1), V(0, 1, 0), V(1, 0, 0)}}};
    std::vector<Face> out;
    for (const auto& [o, e1, e2] : f) out.push_back(Face{{o, o + e1, o + e1 + e2, o + e2}});
    return out;
}

// Bounding sphere of a set of polygons.
std::pair<Vec3, double> sphere_of(const std::vector<Polygon>& faces) {
    Bounds3 b;
    for (const Polygon& p : faces)
        for (const Vec3& v : p.vertices) b.extend(v);
    const Vec3 c = 0.5 * (b.lo + b.hi);
    double r = 0;
    for (const Polygon& p : faces)
        for (const Vec3& v : p.vertices) r = std::max(r, (v - c).norm());
    return {c, r};
}

bool inside_room(const std::vector<Polygon>& faces, double margin) {
    for (const Polygon& p : faces)
        for (const Vec3& v : p.vertices)
            if ((v.array() < margin).any() || (v.array() > 1 - margin).any()) return false;
    return true;
}

// A blocker drawn at random: its whole faces and whether it is a closed solid on its own.
struct Drawn {
    std::string kind;
    std::vector<Polygon> faces;
    bool solid = true;  // closed, touching nothing
};

Drawn draw_blocker(Rng& rng) {
    const int kind = rng.integer(8);
    Drawn d;
    for (int attempt = 0; attempt < 100; ++attempt) {
        const Vec3 c(rng.uniform(0.3, 0.7), rng.uniform(0.3, 0.7), rng.uniform(0.3, 0.7));
        const Vec3 h(rng.uniform(0.06, 0.2), rng.uniform(0.06, 0.2), rng.uniform(0.06, 0.2));
        d.faces.clear();
        d.solid = true;
        switch (kind) {
            case 0:
                d.kind = "box";
                d.faces = box_faces(c, h, Mat3::Identity());
                break;
            case 1:
                d.kind = "tilted box";
                d.faces = box_faces(c, h, rng.rotation());
                break;
            case 2: {
                // Resting on a wall: one face in the wall's plane (kept, facing into the wall,
                // or left out: an open box against the wall).
                const int axis = rng.integer(3);
                const bool high = rng.chance(0.5);
                Vec3 cc = c;
                cc[axis] = high ? 1 - h[axis] : h[axis];
                d.faces = box_faces(cc, h, Mat3::Identity());
                const bool keep = rng.chance(0.5);
                d.kind = std::string("box on a wall") + (keep ? "" : ", open");
                if (!keep) d.faces.erase(d.faces.begin() + (2 * axis + (high ? 0 : 1)));
                d.solid = false;
                return d;  // touches the wall by construction
            }
            case 3: {
                // Two boxes sharing part of a face plane.
                const int axis = rng.integer(3);
                Vec3 h2(rng.uniform(0.05, 0.15), rng.uniform(0.05, 0.15), rng.uniform(0.05, 0.15));
                Vec3 c2 = c;
                c2[axis] = c[axis] + h[axis] + h2[axis];
                for (int k = 0; k < 3; ++k)
                    if (k != axis) c2[k] += rng.uniform(-0.5, 0.5) * h[k];
                d.kind = "touching boxes";
                d.faces = box_faces(c, h, Mat3::Identity());
                for (Polygon& p : box_faces(c2, h2, Mat3::Identity())) d.faces.push_back(p);
                d.solid = false;
                break;
            }
            case 4: {
                d.kind = "overlapping boxes";
                d.faces = box_faces(c, h, Mat3::Identity());
                const Vec3 c2 = c + Vec3(rng.uniform(-1, 1) * h[0], rng.uniform(-1, 1) * h[1],
                                         rng.uniform(-1, 1) * h[2]);
                const Vec3 h2(rng.uniform(0.05, 0.15), rng.uniform(0.05, 0.15),
                              rng.uniform(0.05, 0.15));
                for (Polygon& p : box_faces(c2, h2, rng.rotation())) d.faces.push_back(p);
                d.solid = false;
                break;
            }
            case 5: {
                const double t = rng.chance(0.5) ? 1e-3 : 2e-4;
                d.kind = "thin plate " + std::to_string(t).substr(0, 6);
                d.faces = box_faces(c, Vec3(h[0] + 0.05, h[1] + 0.05, t / 2), rng.rotation());
                break;
            }
            case 6: {
                d.kind = "single quad";
                const Mat3 R = rng.rotation();
                const Vec3 a = R.col(0) * (h[0] + 0.05), b = R.col(1) * (h[1] + 0.05);
                d.faces = {Polygon{{c - a - b, c + a - b, c + a + b, c - a + b}}};
                d.solid = false;
                break;
            }
            default:
                d.kind = "icosahedron";
                d.faces = icosahedron_faces(c, rng.uniform(0.08, 0.2), rng.rotation());
                break;
        }
        if (inside_room(d.faces, 0.02)) return d;
    }
    // Fall back to a small box in the middle.
    d.kind = "box";
    d.solid = true;
    d.faces = box_faces(Vec3::Constant(0.5), Vec3::Constant(0.1), Mat3::Identity());
    return d;
}

std::string fmt(double x) {
    std::ostringstream s;
    s.precision(17);
    s << x;
    return s.str();
}

// Foreign text styles.
struct Style {
    bool share_vertices;  // one V/v per distinct point (else each polygon its own)
    bool rotate;          // polygon k starts at its vertex k mod size (always: the order other
                          // programs write is theirs, and it must not matter)
    bool negative;        // OBJ: relative (negative) indices
    bool object;          // OBJ: `o obstruction` instead of `g obstruction`
    bool per_blocker;     // OBJ: one obstruction group per polygon group
    bool tabs;            // VS3: tabs and commas between fields
    explicit Style(std::uint64_t s)
        : share_vertices(s & 1),
          rotate(true),
          negative((s & 4) && !(s & 1)),
          object(s & 8),
          per_blocker(s & 16),
          tabs(s & 32) {}
};

// The polygon starting at vertex `shift` (same cycle, same orientation).
Polygon rotated(const Polygon& p, std::size_t shift) {
    Polygon q;
    for (std::size_t k = 0; k < p.size(); ++k) q.vertices.push_back(p[(k + shift) % p.size()]);
    return q;
}

// Vertex numbering of a text file: shared (map of exact coordinates) or one per use.
class VertexPool {
  public:
    explicit VertexPool(bool share) : share_(share) {}
    int add(const Vec3& v) {
        if (share_) {
            const auto key = std::make_tuple(v.x(), v.y(), v.z());
            auto it = index_.find(key);
            if (it != index_.end()) return it->second;
            index_[key] = static_cast<int>(points_.size()) + 1;
        }
        points_.push_back(v);
        return static_cast<int>(points_.size());
    }
    const std::vector<Vec3>& points() const { return points_; }

  private:
    bool share_;
    std::map<std::tuple<double, double, double>, int> index_;
    std::vector<Vec3> points_;
};

}  // namespace

std::vector<Polygon> box_faces(const Vec3& c, const Vec3& h, const Mat3& R) {
    std::vector<Polygon> out;
    for (int a = 0; a < 3; ++a) {
        const int b = (a + 1) % 3, d = (a + 2) % 3;
        const Vec3 ea = h[a] * R.col(a), eb = h[b] * R.col(b), ed = h[d] * R.col(d);
        // Face +a: front ea (eb × ed ∥ ea); face −a reversed.
        for (int s : {1, -1}) {
            const Vec3 o = c + s * ea;
            Polygon p{{o - eb - ed, o + eb - ed, o + eb + ed, o - eb + ed}};
            if (s < 0) std::reverse(p.vertices.begin(), p.vertices.end());
            out.push_back(p);
        }
    }
    return out;
}

std::vector<Polygon> icosahedron_faces(const Vec3& c, double r, const Mat3& R) {
    const double phi = (1 + std::sqrt(5.0)) / 2;
    std::vector<Vec3> v;
    for (int s1 : {-1, 1})
        for (int s2 : {-1, 1}) {
            v.emplace_back(0, s1, s2 * phi);
            v.emplace_back(s1, s2 * phi, 0);
            v.emplace_back(s2 * phi, 0, s1);
        }
    const double scale = r / std::sqrt(1 + phi * phi);
    std::vector<Polygon> out;
    for (std::size_t i = 0; i < v.size(); ++i)
        for (std::size_t j = i + 1; j < v.size(); ++j)
            for (std::size_t k = j + 1; k < v.size(); ++k) {
                auto edge = [&](std::size_t a, std::size_t b) {
                    return std::abs((v[a] - v[b]).norm() - 2.0) < 1e-9;
                };
                if (!edge(i, j) || !edge(j, k) || !edge(i, k)) continue;
                Polygon p{{c + scale * (R * v[i]), c + scale * (R * v[j]), c + scale * (R * v[k])}};
                if (normal(p).dot(centroid(p) - c) < 0) std::swap(p.vertices[1], p.vertices[2]);
                out.push_back(p);
            }
    return out;
}

Geometry room_with_blockers(int n, const std::vector<std::vector<Polygon>>& blocker_faces, int m,
                            bool closed, const std::string& label, bool split_obstructions) {
    Geometry g;
    g.n = n;
    g.label = label;
    g.closed = closed;
    g.style = 1;  // shared vertices, rotated first vertices
    Rng rng(0);
    for (const Face& f : room_faces())
        for (Polygon& p : split_face(f, n, 0, rng)) g.room.push_back(p);
    for (const auto& faces : blocker_faces)
        for (const Polygon& p : faces) {
            const std::vector<Polygon> pieces = split_face(face_of(p), m, 0, rng);
            g.blockers.insert(g.blockers.end(), pieces.begin(), pieces.end());
            if (split_obstructions)
                g.obstructions.insert(g.obstructions.end(), pieces.begin(), pieces.end());
            else
                g.obstructions.push_back(p);
        }
    return g;
}

Geometry random_geometry(std::uint64_t seed, const GeneratorOptions& options) {
    Rng rng(seed);
    Geometry g;
    g.n = rng.pick(options.room_n);
    g.style = splitmix64(seed + 17);
    if (rng.chance(options.jitter_probability))
        g.jitter = std::exp(rng.uniform(std::log(1e-6), std::log(3e-5)));
    const int count = 1 + rng.integer(std::max(1, options.max_blockers));
    std::vector<Drawn> drawn;
    for (int attempt = 0; attempt < 50 && static_cast<int>(drawn.size()) < count; ++attempt) {
        Drawn d = draw_blocker(rng);
        // Blockers apart from each other (their bounding spheres 0.02 apart).
        const auto [c, r] = sphere_of(d.faces);
        bool apart = true;
        for (const Drawn& e : drawn) {
            const auto [c2, r2] = sphere_of(e.faces);
            apart = apart && (c - c2).norm() > r + r2 + 0.02;
        }
        if (apart) drawn.push_back(std::move(d));
    }
    const int m = rng.pick(options.blocker_split);
    const bool whole_obstructions = g.jitter == 0 && rng.chance(0.5);
    std::ostringstream label;
    label << "seed " << seed << ": room n=" << g.n << ", m=" << m;
    if (g.jitter > 0) label << ", jitter " << g.jitter;
    g.closed = true;
    for (const Face& f : room_faces())
        for (Polygon& p : split_face(f, g.n, g.jitter, rng)) g.room.push_back(p);
    for (const Drawn& d : drawn) {
        label << ", " << d.kind;
        g.closed = g.closed && d.solid;
        for (const Polygon& p : d.faces) {
            const std::vector<Polygon> pieces = split_face(face_of(p), m, g.jitter, rng);
            for (const Polygon& q : pieces) g.blockers.push_back(q);
            if (whole_obstructions)
                g.obstructions.push_back(p);
            else
                for (const Polygon& q : pieces) g.obstructions.push_back(q);
        }
    }
    if (whole_obstructions) label << ", whole obstructions";
    g.label = label.str();
    return g;
}

std::vector<Form> all_forms() {
    return {Form::kScene,         Form::kSceneObstruction,
            Form::kObj,           Form::kObjObstruction,
            Form::kVs3,           Form::kVs3Obstruction,
            Form::kSavedObj,      Form::kSavedObjObstruction,
            Form::kSavedVs3,      Form::kSavedVs3Obstruction,
            Form::kScenePermuted, Form::kSceneObstructionPermuted};
}

std::string form_name(Form f) {
    switch (f) {
        case Form::kScene:
            return "scene";
        case Form::kSceneObstruction:
            return "scene-O";
        case Form::kObj:
            return "obj";
        case Form::kObjObstruction:
            return "obj-O";
        case Form::kVs3:
            return "vs3-S";
        case Form::kVs3Obstruction:
            return "vs3-O";
        case Form::kSavedObj:
            return "save_obj";
        case Form::kSavedObjObstruction:
            return "save_obj-O";
        case Form::kSavedVs3:
            return "save_vs3-S";
        case Form::kSavedVs3Obstruction:
            return "save_vs3-O";
        case Form::kScenePermuted:
            return "scene-perm";
        case Form::kSceneObstructionPermuted:
            return "scene-O-perm";
    }
    return "?";
}

bool blockers_radiate(Form f) {
    return f == Form::kScene || f == Form::kObj || f == Form::kVs3 || f == Form::kSavedObj ||
           f == Form::kSavedVs3 || f == Form::kScenePermuted;
}

namespace {

// A shuffle of 0..n-1 from a seed (Fisher–Yates).
std::vector<std::size_t> shuffled(std::size_t n, std::uint64_t seed) {
    std::vector<std::size_t> v(n);
    for (std::size_t k = 0; k < n; ++k) v[k] = k;
    for (std::size_t k = n; k > 1; --k) std::swap(v[k - 1], v[splitmix64(seed + k) % k]);
    return v;
}

bool permuted(Form f) { return f == Form::kScenePermuted || f == Form::kSceneObstructionPermuted; }

}  // namespace

std::vector<std::size_t> patch_order(const Geometry& g, Form f) {
    const std::size_t n = g.room.size() + (blockers_radiate(f) ? g.blockers.size() : 0);
    if (permuted(f)) return shuffled(n, g.style ^ 0x9e3779b97f4a7c15ULL);
    std::vector<std::size_t> v(n);
    for (std::size_t k = 0; k < n; ++k) v[k] = k;
    return v;
}

Scene make_scene(const Geometry& g, bool radiate) {
    std::vector<Polygon> patches = g.room;
    if (radiate) patches.insert(patches.end(), g.blockers.begin(), g.blockers.end());
    Scene s = scene_of(patches, radiate ? std::vector<Polygon>{} : g.obstructions);
    s.name = g.label;
    s.enclosure = g.closed && radiate;
    return s;
}

std::string obj_text(const Geometry& g, bool radiate) {
    const Style st(g.style);
    std::ostringstream out;
    out << "# formfactor differential harness: " << g.label << "\n";
    VertexPool pool(st.share_vertices);
    // Faces: (group, polygon), in patch order.
    std::vector<std::pair<std::string, Polygon>> faces;
    for (std::size_t k = 0; k < g.room.size(); ++k) faces.emplace_back("room", g.room[k]);
    const std::vector<Polygon>& blockers = radiate ? g.blockers : g.obstructions;
    for (std::size_t k = 0; k < blockers.size(); ++k) {
        std::string group = radiate ? "blocker" : "obstruction";
        if (!radiate && st.per_blocker) group = "obstruction_" + std::to_string(k / 6 + 1);
        faces.emplace_back(group, blockers[k]);
    }
    std::vector<std::vector<int>> index(faces.size());
    for (std::size_t f = 0; f < faces.size(); ++f) {
        const Polygon p =
            st.rotate ? rotated(faces[f].second, f % faces[f].second.size()) : faces[f].second;
        for (const Vec3& v : p.vertices) index[f].push_back(pool.add(v));
    }
    if (st.share_vertices || !st.negative)
        for (const Vec3& v : pool.points())
            out << "v " << fmt(v.x()) << " " << fmt(v.y()) << " " << fmt(v.z()) << "\n";
    std::string current;
    for (std::size_t f = 0; f < faces.size(); ++f) {
        if (faces[f].first != current) {
            current = faces[f].first;
            const bool obj = st.object && current.rfind("obstruction", 0) == 0;
            out << (obj ? "o " : "g ") << current << "\n";
        }
        if (!st.share_vertices && st.negative) {
            for (int i : index[f]) {
                const Vec3& v = pool.points()[static_cast<std::size_t>(i - 1)];
                out << "v " << fmt(v.x()) << " " << fmt(v.y()) << " " << fmt(v.z()) << "\n";
            }
            out << "f";
            for (std::size_t k = 0; k < index[f].size(); ++k)
                out << " " << -static_cast<long>(index[f].size() - k);
            out << "\n";
        } else {
            out << "f";
            for (int i : index[f]) out << " " << i;
            out << "\n";
        }
    }
    return out.str();
}

std::string vs3_text(const Geometry& g, bool radiate) {
    const Style st(g.style);
    const std::string sep = st.tabs ? "\t" : " ";
    VertexPool pool(st.share_vertices);
    struct Rec {
        char kind;
        std::vector<int> v;
        std::string name;
    };
    std::vector<Rec> recs;
    auto add = [&](char kind, const Polygon& p0, const std::string& name) {
        const Polygon p = st.rotate ? rotated(p0, recs.size() % p0.size()) : p0;
        Rec r{kind, {}, name};
        for (const Vec3& v : p.vertices) r.v.push_back(pool.add(v));
        recs.push_back(std::move(r));
    };
    for (std::size_t k = 0; k < g.room.size(); ++k)
        add('S', g.room[k], "room_" + std::to_string(k + 1));
    if (radiate)
        for (std::size_t k = 0; k < g.blockers.size(); ++k)
            add('S', g.blockers[k], "blocker_" + std::to_string(k + 1));
    else
        for (std::size_t k = 0; k < g.obstructions.size(); ++k) add('O', g.obstructions[k], "");
    std::ostringstream out;
    out << "! formfactor differential harness: " << g.label << "\n";
    out << "T harness geometry\n";
    out << "C encl=" << (g.closed && radiate ? 1 : 0) << " list=0 eps=1e-4 out=0\n";
    out << "F 3\n";
    const auto& pts = pool.points();
    for (std::size_t k = 0; k < pts.size(); ++k)
        out << "V" << sep << k + 1 << sep << fmt(pts[k].x()) << sep << fmt(pts[k].y()) << sep
            << fmt(pts[k].z()) << "\n";
    for (std::size_t k = 0; k < recs.size(); ++k) {
        const Rec& r = recs[k];
        out << r.kind << sep << k + 1;
        for (int i : r.v) out << sep << i;
        if (r.v.size() == 3) out << sep << 0;
        if (r.kind == 'S') out << sep << "0" << sep << "0" << sep << "0.9" << sep << r.name;
        out << "\n";
    }
    out << "End of data\n";
    return out.str();
}

Scene load_form(const Geometry& g, Form f, const std::string& dir) {
    const bool radiate = blockers_radiate(f);
    auto write = [&](const std::string& name, const std::string& text) {
        const std::string path = (std::filesystem::path(dir) / name).string();
        std::ofstream(path, std::ios::binary) << text;
        return path;
    };
    const std::string tag = form_name(f);
    switch (f) {
        case Form::kScene:
        case Form::kSceneObstruction:
            return make_scene(g, radiate);
        case Form::kScenePermuted:
        case Form::kSceneObstructionPermuted: {
            std::vector<Polygon> canonical = g.room, patches, others;
            if (radiate) canonical.insert(canonical.end(), g.blockers.begin(), g.blockers.end());
            for (std::size_t k : patch_order(g, f)) patches.push_back(canonical[k]);
            if (!radiate)
                for (std::size_t k : shuffled(g.obstructions.size(), g.style + 5))
                    others.push_back(g.obstructions[k]);
            Scene s = scene_of(patches, others);
            s.enclosure = g.closed && radiate;
            return s;
        }
        case Form::kObj:
        case Form::kObjObstruction:
            return load_scene(write(tag + ".obj", obj_text(g, radiate)));
        case Form::kVs3:
        case Form::kVs3Obstruction:
            return load_scene(write(tag + ".vs3", vs3_text(g, radiate)));
        case Form::kSavedObj:
        case Form::kSavedObjObstruction: {
            const std::string path = (std::filesystem::path(dir) / (tag + ".obj")).string();
            save_obj(make_scene(g, radiate), path);
            return load_scene(path);
        }
        case Form::kSavedVs3:
        case Form::kSavedVs3Obstruction: {
            const std::string path = (std::filesystem::path(dir) / (tag + ".vs3")).string();
            save_vs3(make_scene(g, radiate), path);
            return load_scene(path);
        }
    }
    return make_scene(g, radiate);
}

}  // namespace formfactor::testing
