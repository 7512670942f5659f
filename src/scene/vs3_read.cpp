// View3D 3.2 input files (.vs3): the reader (the writer is vs3_write.cpp).
//
// The format, as View3D 3.2's reader (getdat.c: CountVS3D, GetCtrl, GetVS3D, GetVS3Da) reads
// it: one record per line, identified by its first character (any case); words separated by
// blanks, tabs or commas; `!` or `/` starts a comment (anywhere); `E...` (e.g. "End of data")
// or `*` ends the data. Records: T title, C control words `name = value`, F geometry format
// (3 = vertices and surfaces, 3a = BLAST-style surfaces by origin, azimuth and tilt), V vertex
// `V n x y z`, S surface `S n v1 v2 v3 v4 base cmb emit name` (v4 = 0 for a triangle), O
// obstruction `O n v1 v2 v3 v4` (View3D reads nothing more), M/N masking and null surfaces,
// X coordinate transformation (ignored by View3D 3.2). Numbers run 1, 2, 3, ... in order;
// obstruction surfaces are numbered after the radiating ones.

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "formfactor/core/error.h"
#include "formfactor/scene/scene.h"
#include "formfactor/scene/scene_io.h"
#include "scene/text.h"

namespace formfactor {

namespace {

using detail::exact;
using detail::short_number;
using detail::split;

// cos and sin of an angle in degrees, exact at multiples of 90°.
double cos_deg(double a) {
    const double r = std::fmod(std::fmod(a, 360.0) + 360.0, 360.0);
    if (r == 0.0) return 1.0;
    if (r == 90.0 || r == 270.0) return 0.0;
    if (r == 180.0) return -1.0;
    return std::cos(a * kPi / 180.0);
}
double sin_deg(double a) { return cos_deg(a - 90.0); }

std::string strip_comment(const std::string& line) {
    const std::size_t c = line.find_first_of("!/");
    return c == std::string::npos ? line : line.substr(0, c);
}

struct PendingSurface {
    char kind = 'S';  // 'S' or 'O'
    int line = 0;
    std::vector<int> vertex;  // 1-based vertex numbers (F 3)
    Polygon polygon;          // F 3a: computed directly
    int base = 0, cmb = 0;    // 1-based, 0 = none
    double emit = 0.9;
    std::string name;
};

class Vs3Reader {
  public:
    explicit Vs3Reader(std::string path) : path_(std::move(path)) {}

    Scene read() {
        lines_ = detail::read_lines(path_);
        scene_.name = path_;
        find_format();
        for (std::size_t i = 0; i < lines_.size(); ++i) {
            const std::vector<std::string> head = split(lines_[i], " \t,");
            if (head.empty()) continue;
            const int ln = static_cast<int>(i) + 1;
            const std::string& w = head[0];
            const char c = static_cast<char>(std::toupper(static_cast<unsigned char>(w[0])));
            if (c == '!' || c == '/') continue;
            if (c == 'E' || c == '*') break;
            if (c == 'T' && w.size() == 1) {
                const std::string& raw = lines_[i];
                scene_.title = detail::trim(raw.substr(raw.find_first_of("Tt") + 1));
                continue;
            }
            const std::vector<std::string> t = split(strip_comment(lines_[i]), " \t,");
            if (t.empty()) continue;
            if (w.size() != 1) fail(ln, "unknown record '" + w + "'");
            switch (c) {
                case 'C':
                    control(ln, t);
                    break;
                case 'F':
                    break;  // read by find_format()
                case 'V':
                    vertex(ln, t);
                    break;
                case 'S':
                case 'O':
                    if (format_3a_)
                        surface_3a(i, t);
                    else
                        surface_3(ln, t);
                    break;
                case 'M':
                    fail(ln,
                         "masking surfaces (M records) are not supported yet: formfactor cannot "
                         "yet make a surface block its own base");
                case 'N':
                    fail(ln,
                         "null surfaces (N records) are not supported yet: formfactor cannot yet "
                         "cut a surface out of its base");
                case 'X':
                    scene_.warnings.push_back(path_ + ":" + std::to_string(ln) +
                                              ": X (coordinate transformation) record ignored, as "
                                              "View3D 3.2 does");
                    break;
                default:
                    fail(ln, "unknown record '" + w + "'");
            }
        }
        build();
        return std::move(scene_);
    }

  private:
    [[noreturn]] void fail(int line, const std::string& msg) const {
        throw InputError(path_, line, msg);
    }
    void warn(int line, const std::string& msg) {
        scene_.warnings.push_back(path_ + ":" + std::to_string(line) + ": " + msg);
    }

    double number(int line, const std::string& w, const char* record) const {
        double x = 0.0;
        if (!detail::parse_double(w, x))
            fail(line, "malformed number '" + w + "' in " + record + " record");
        if (!std::isfinite(x))
            fail(line, "number '" + w + "' in " + record + " record is not finite");
        return x;
    }
    int integer(int line, const std::string& w, const char* record) const {
        int x = 0;
        if (!detail::parse_int(w, x))
            fail(line,
                 "malformed number '" + w + "' in " + record + " record (an integer is needed)");
        return x;
    }

    // F records are read first: View3D's CountVS3D pass does the same, so F may come anywhere.
    void find_format() {
        int f_line = 0;
        std::string f_value;
        for (std::size_t i = 0; i < lines_.size(); ++i) {
            const std::vector<std::string> t = split(strip_comment(lines_[i]), " \t,");
            if (t.empty()) continue;
            const char c = static_cast<char>(std::toupper(static_cast<unsigned char>(t[0][0])));
            if (c == 'E' || c == '*') break;
            if (c != 'F' || t[0].size() != 1) continue;
            const int ln = static_cast<int>(i) + 1;
            if (t.size() < 2) fail(ln, "F record needs the geometry format (3 or 3a)");
            std::string v = t[1];
            std::transform(v.begin(), v.end(), v.begin(),
                           [](unsigned char ch) { return static_cast<char>(std::tolower(ch)); });
            if (v != "3" && v != "3a")
                fail(ln, "geometry format 'F " + t[1] +
                             "' is not supported (View3D 3.2 reads 3 and 3a)");
            if (f_line && v != f_value)
                fail(ln, "F " + t[1] + " contradicts F " + f_value + " at line " +
                             std::to_string(f_line));
            f_line = ln;
            f_value = v;
        }
        format_3a_ = f_value == "3a";
    }

    void control(int ln, const std::vector<std::string>& t) {
        Vs3Control c = scene_.vs3_control.value_or(Vs3Control{});
        // Words are `name = value`, separated by blanks, commas or '='.
        std::vector<std::string> w;
        for (std::size_t k = 1; k < t.size(); ++k)
            for (const std::string& p : split(t[k], "=")) w.push_back(p);
        std::vector<std::string> ignored;
        for (std::size_t k = 0; k < w.size(); k += 2) {
            std::string key = w[k];
            std::transform(key.begin(), key.end(), key.begin(),
                           [](unsigned char ch) { return static_cast<char>(std::tolower(ch)); });
            if (k + 1 >= w.size()) fail(ln, "control word '" + w[k] + "' has no value");
            const std::string& v = w[k + 1];
            if (key == "eps") {
                c.eps = number(ln, v, "C");
                if (!(c.eps > 0.0)) fail(ln, "eps must be positive (got " + v + ")");
            } else if (key == "maxu") {
                c.maxU = integer(ln, v, "C");
                ignored.push_back(w[k]);
            } else if (key == "maxo") {
                c.maxO = integer(ln, v, "C");
                ignored.push_back(w[k]);
            } else if (key == "mino") {
                c.minO = integer(ln, v, "C");
                ignored.push_back(w[k]);
            } else if (key == "row") {
                c.row = integer(ln, v, "C");
                ignored.push_back(w[k]);
            } else if (key == "col") {
                c.col = integer(ln, v, "C");
                ignored.push_back(w[k]);
            } else if (key == "out") {
                c.out = integer(ln, v, "C");
                ignored.push_back(w[k]);
            } else if (key == "list") {
                c.list = integer(ln, v, "C");
                ignored.push_back(w[k]);
            } else if (key == "prjd" || key == "maxv") {
                integer(ln, v, "C");
                ignored.push_back(w[k]);
            } else if (key == "encl") {
                c.encl = integer(ln, v, "C");
                scene_.enclosure = c.encl != 0;
            } else if (key == "emit") {
                c.emit = integer(ln, v, "C");
            } else {
                warn(ln, "unknown control word '" + w[k] + "' ignored");
            }
        }
        if (!ignored.empty()) {
            std::string list;
            for (const std::string& s : ignored) list += (list.empty() ? "" : ", ") + s;
            warn(ln, "control " + list + (ignored.size() == 1 ? " has" : " have") +
                         " no meaning in formfactor (View3D's integration and output controls): "
                         "kept but ignored");
        }
        scene_.vs3_control = c;
    }

    void vertex(int ln, const std::vector<std::string>& t) {
        if (format_3a_)
            fail(ln, "V records are not used with F 3a (surfaces carry their geometry)");
        if (t.size() < 5)
            fail(ln, "V record has " + std::to_string(t.size() - 1) +
                         " fields (4 needed: number, x, y, z)");
        const int n = integer(ln, t[1], "V");
        const int expected = static_cast<int>(vertices_.size()) + 1;
        if (n >= 1 && n < expected)
            fail(ln, "vertex " + t[1] + " defined twice (first at line " +
                         std::to_string(vertex_lines_[static_cast<std::size_t>(n - 1)]) + ")");
        if (n != expected)
            fail(ln, "vertex " + t[1] + " out of sequence (expected " + std::to_string(expected) +
                         ": View3D numbers vertices 1, 2, 3, ... in order)");
        Vec3 v;
        for (int k = 0; k < 3; ++k) v[k] = number(ln, t[static_cast<std::size_t>(2 + k)], "V");
        if (t.size() > 5) warn(ln, "extra fields after the V record ignored");
        vertices_.push_back(v);
        vertex_lines_.push_back(ln);
    }

    void surface_number(int ln, const std::string& w, char kind) {
        const int n = integer(ln, w, kind == 'O' ? "O" : "S");
        const int expected = static_cast<int>(pending_.size()) + 1;
        if (n >= 1 && n < expected)
            fail(ln, "surface " + w + " defined twice (first at line " +
                         std::to_string(pending_[static_cast<std::size_t>(n - 1)].line) + ")");
        if (n != expected)
            fail(ln, "surface " + w + " out of sequence (expected " + std::to_string(expected) +
                         ": View3D numbers surfaces 1, 2, 3, ... in order)");
    }

    // base, cmb, emit, name of an S record, from t[first].
    void surface_data(int ln, const std::vector<std::string>& t, std::size_t first,
                      PendingSurface& s) {
        s.base = integer(ln, t[first], "S");
        s.cmb = integer(ln, t[first + 1], "S");
        s.emit = number(ln, t[first + 2], "S");
        s.name = t[first + 3];
        if (s.emit < 0.0 || s.emit > 1.0)
            fail(ln, "emissivity " + t[first + 2] + " of surface " +
                         std::to_string(pending_.size() + 1) + " is outside [0, 1]");
        if (t.size() > first + 4) warn(ln, "extra fields after the surface name ignored");
    }

    void surface_3(int ln, const std::vector<std::string>& t) {
        const char kind = static_cast<char>(std::toupper(static_cast<unsigned char>(t[0][0])));
        PendingSurface s;
        s.kind = kind;
        s.line = ln;
        if (kind == 'S' && t.size() < 10)
            fail(ln, "S record has " + std::to_string(t.size() - 1) +
                         " fields (9 needed: number, v1, v2, v3, v4, base, cmb, emit, name)");
        if (kind == 'O' && t.size() < 6)
            fail(ln, "O record has " + std::to_string(t.size() - 1) +
                         " fields (5 needed: number, v1, v2, v3, v4)");
        surface_number(ln, t[1], kind);
        const char* rec = kind == 'O' ? "O" : "S";
        for (int k = 0; k < 4; ++k) {
            const int v = integer(ln, t[static_cast<std::size_t>(2 + k)], rec);
            if (k == 3 && v == 0) break;  // a triangle
            if (v <= 0)
                fail(ln, "surface " + t[1] + ": vertex number " +
                             t[static_cast<std::size_t>(2 + k)] +
                             " is invalid (vertices are numbered from 1" +
                             (k == 3 ? std::string("; 0 marks a triangle") : std::string()) + ")");
            s.vertex.push_back(v);
        }
        if (kind == 'S') {
            surface_data(ln, t, 6, s);
        } else {
            // View3D reads nothing after the vertices of an O record; accept the S columns.
            if (t.size() >= 8 && (integer(ln, t[6], "O") != 0 || integer(ln, t[7], "O") != 0))
                fail(ln, "obstruction surface " + t[1] + " cannot have a base or cmb surface");
            s.name = t.size() >= 10 ? t[9] : "obstruction-" + t[1];
        }
        pending_.push_back(std::move(s));
    }

    // F 3a: `S n shape base cmb emit name` (or `O n shape`), then on the next lines: origin
    // x y z, azimuth, tilt, then width height (R) or 3 (T) / 4 (Q) pairs of plane coordinates.
    void surface_3a(std::size_t& i, const std::vector<std::string>& t) {
        const int ln = static_cast<int>(i) + 1;
        const char kind = static_cast<char>(std::toupper(static_cast<unsigned char>(t[0][0])));
        PendingSurface s;
        s.kind = kind;
        s.line = ln;
        if (kind == 'S' && t.size() < 7)
            fail(ln, "S record has " + std::to_string(t.size() - 1) +
                         " fields (6 needed with F 3a: number, shape, base, cmb, emit, name)");
        if (kind == 'O' && t.size() < 3)
            fail(ln, "O record has " + std::to_string(t.size() - 1) +
                         " fields (2 needed with F 3a: number, shape)");
        surface_number(ln, t[1], kind);
        const char shape = static_cast<char>(std::toupper(static_cast<unsigned char>(t[2][0])));
        if (t[2].size() != 1 || (shape != 'R' && shape != 'T' && shape != 'Q'))
            fail(ln, "invalid shape '" + t[2] + "' of surface " + t[1] +
                         " (R rectangle, T triangle or Q quadrilateral)");
        if (kind == 'S')
            surface_data(ln, t, 3, s);
        else
            s.name = t.size() >= 7 ? t[6] : "obstruction-" + t[1];

        const std::size_t needed = shape == 'R' ? 7 : shape == 'T' ? 11 : 13;
        std::vector<double> x;
        while (x.size() < needed) {
            ++i;
            if (i >= lines_.size())
                fail(ln, "surface " + t[1] + " (" + std::string(1, shape) + ") needs " +
                             std::to_string(needed) + " numbers on the following lines; found " +
                             std::to_string(x.size()) + " before the end of the file");
            const std::vector<std::string> g = split(strip_comment(lines_[i]), " \t,");
            const int gl = static_cast<int>(i) + 1;
            for (std::size_t k = 0; k < g.size() && x.size() < needed; ++k) {
                double v = 0.0;
                if (!detail::parse_double(g[k], v)) {
                    if (k == 0 && std::isalpha(static_cast<unsigned char>(g[k][0])))
                        fail(gl, "surface " + t[1] + " (" + std::string(1, shape) + ") needs " +
                                     std::to_string(needed) + " numbers after line " +
                                     std::to_string(ln) + "; found " + std::to_string(x.size()));
                    fail(gl, "malformed number '" + g[k] + "' in the geometry of surface " + t[1]);
                }
                if (!std::isfinite(v))
                    fail(gl, "number '" + g[k] + "' in the geometry of surface " + t[1] +
                                 " is not finite");
                x.push_back(v);
            }
        }
        // The plane's frame, exactly as View3D's GetVS3Da: ca = −cos(azimuth), sa = sin(azimuth),
        // local (u, w) ↦ origin + u (ca, sa, 0) + w (−cos(tilt)·sa, cos(tilt)·ca, sin(tilt)).
        const Vec3 o(x[0], x[1], x[2]);
        const double ca = -cos_deg(x[3]), sa = sin_deg(x[3]);
        const double ct = cos_deg(x[4]), st = sin_deg(x[4]);
        std::vector<Vec2> uv;
        if (shape == 'R') {
            const double w = x[5], h = x[6];
            uv = {Vec2(0, h), Vec2(0, 0), Vec2(w, 0), Vec2(w, h)};
        } else {
            for (std::size_t k = 5; k + 1 < needed; k += 2) uv.emplace_back(x[k], x[k + 1]);
        }
        for (const Vec2& p : uv)
            s.polygon.vertices.push_back(
                o + Vec3(p.x() * ca - p.y() * ct * sa, p.x() * sa + p.y() * ct * ca, p.y() * st));
        pending_.push_back(std::move(s));
    }

    void build() {
        const int ns = static_cast<int>(pending_.size());
        for (int k = 0; k < ns; ++k) {
            PendingSurface& p = pending_[static_cast<std::size_t>(k)];
            Surface s;
            s.name = p.name;
            s.obstruction = p.kind == 'O';
            s.where = {path_, p.line};
            if (!format_3a_) {
                for (int v : p.vertex) {
                    if (v > static_cast<int>(vertices_.size()))
                        fail(p.line, "surface " + std::to_string(k + 1) + ": vertex " +
                                         std::to_string(v) + " does not exist (the file defines " +
                                         std::to_string(vertices_.size()) + " vertices)");
                    s.polygon.vertices.push_back(vertices_[static_cast<std::size_t>(v - 1)]);
                }
            } else {
                s.polygon = p.polygon;
            }
            validate_polygon(s.polygon, s.where, "surface " + std::to_string(k + 1));
            Material m;
            m.name = p.name;
            if (!s.obstruction) {
                m.emissivity = p.emit;
                m.reflectance = Rgb::Constant(1.0 - p.emit);
            }
            scene_.materials.push_back(m);
            s.material = k;
            scene_.surfaces.push_back(std::move(s));
        }
        for (int k = 0; k < ns; ++k) {
            const PendingSurface& p = pending_[static_cast<std::size_t>(k)];
            Surface& s = scene_.surfaces[static_cast<std::size_t>(k)];
            const std::string me = "surface " + std::to_string(k + 1);
            if (p.base != 0) {
                const int b = p.base;
                if (b < 0 || b > ns)
                    fail(p.line, me + ": base surface " + std::to_string(b) +
                                     " does not exist (the file has " + std::to_string(ns) +
                                     " surfaces)");
                if (b == k + 1) fail(p.line, me + " cannot be its own base");
                const Surface& base = scene_.surfaces[static_cast<std::size_t>(b - 1)];
                if (!base.obstruction && b > k + 1)
                    fail(p.line, me + ": base surface " + std::to_string(b) +
                                     " must come before its subsurface");
                check_subsurface(p.line, me, s.polygon, b, base.polygon);
                s.base = b - 1;
            }
            if (p.cmb != 0) {
                const int c = p.cmb;
                if (c < 0 || c > ns)
                    fail(p.line, me + ": combine surface " + std::to_string(c) +
                                     " does not exist (the file has " + std::to_string(ns) +
                                     " surfaces)");
                if (c >= k + 1)
                    fail(p.line, me + ": must combine with a previous surface (cmb " +
                                     std::to_string(c) + ")");
                const PendingSurface& target = pending_[static_cast<std::size_t>(c - 1)];
                if (target.kind == 'O')
                    fail(p.line,
                         me + ": cannot combine with obstruction surface " + std::to_string(c));
                if (target.cmb != 0)
                    fail(p.line, me + ": may not chain combined surfaces (surface " +
                                     std::to_string(c) + " is itself combined with " +
                                     std::to_string(target.cmb) + ")");
                s.combine = c - 1;
            }
        }
        // Subsurfaces become holes of their (radiating) base: the base then stands for base
        // minus its subsurfaces, as after View3D's Separate step. Siblings must not overlap.
        for (int k = 0; k < ns; ++k) {
            const Surface& s = scene_.surfaces[static_cast<std::size_t>(k)];
            if (s.base < 0) continue;
            Surface& base = scene_.surfaces[static_cast<std::size_t>(s.base)];
            if (base.obstruction) continue;
            for (int j = 0; j < k; ++j) {
                const Surface& t = scene_.surfaces[static_cast<std::size_t>(j)];
                if (t.base != s.base) continue;
                const double o = overlap_area(s.polygon, t.polygon);
                const double a = std::min(area(s.polygon), area(t.polygon));
                if (o > 1e-9 * a)
                    fail(s.where.line,
                         "surface " + std::to_string(k + 1) + " overlaps surface " +
                             std::to_string(j + 1) + " (both subsurfaces of surface " +
                             std::to_string(s.base + 1) + "; overlap area " + short_number(o) +
                             "): subsurfaces of one base must not "
                             "overlap");
            }
            base.holes.push_back(s.polygon);
        }
    }

    void check_subsurface(int line, const std::string& me, const Polygon& sub, int b,
                          const Polygon& base) {
        // View3D's TestSubSrf: in the base's plane (1e-5 of the subsurface's radius), facing
        // the same way, inside the base.
        const Plane pl = plane_of(base);
        const double tol = 0.5e-5 * diameter(sub);
        double worst = 0.0;
        for (const Vec3& v : sub.vertices) worst = std::max(worst, std::abs(pl.signed_distance(v)));
        const std::string bs = "base surface " + std::to_string(b);
        if (worst > tol)
            fail(line, me + " is not in the plane of its " + bs + " (distance " +
                           short_number(worst) + ")");
        if (normal(sub).dot(pl.n) < 0.999)
            fail(line, me + " should face the same direction as its " + bs);
        const PlaneFrame f = frame_of(base);
        std::vector<Vec2> q;
        for (const Vec3& v : base.vertices) q.push_back(f.to_local(v));
        const double eps = 1e-9 * diameter(base);
        for (const Vec3& v : sub.vertices) {
            const Vec2 x = f.to_local(v);
            // Inside or on the boundary: winding number, with points near an edge counted in.
            bool on_edge = false;
            int winding = 0;
            for (std::size_t k = 0; k < q.size(); ++k) {
                const Vec2& a = q[k];
                const Vec2& c = q[(k + 1) % q.size()];
                const Vec2 e = c - a;
                const double len = e.norm();
                const double tpar = len > 0 ? (x - a).dot(e) / (len * len) : 0.0;
                const double cr = e.x() * (x - a).y() - e.y() * (x - a).x();
                if (tpar >= -eps / std::max(len, 1e-300) &&
                    tpar <= 1 + eps / std::max(len, 1e-300) && std::abs(cr) <= eps * len)
                    on_edge = true;
                if (a.y() <= x.y()) {
                    if (c.y() > x.y() && cr > 0) ++winding;
                } else if (c.y() <= x.y() && cr < 0) {
                    --winding;
                }
            }
            if (!on_edge && winding == 0) fail(line, me + " is not entirely within its " + bs);
        }
        // The corners can all be inside a non-convex base while an edge leaves it.
        double outside = 0.0;
        for (const Polygon& piece : subtract_holes(sub, {base})) outside += area(piece);
        if (outside > 1e-9 * area(sub))
            fail(line, me + " is not entirely within its " + bs + " (area " +
                           short_number(outside) + " outside)");
    }

    std::string path_;
    std::vector<std::string> lines_;
    Scene scene_;
    bool format_3a_ = false;
    std::vector<Vec3> vertices_;
    std::vector<int> vertex_lines_;
    std::vector<PendingSurface> pending_;
};

}  // namespace

Scene load_vs3(const std::string& path) {
    Scene scene = Vs3Reader(path).read();
    detail::require_surfaces(scene, path, "no surfaces (S records)",
                             "S records have rows, O records only block");
    subdivide(scene, SubdivisionOptions{});
    return scene;
}

}  // namespace formfactor
