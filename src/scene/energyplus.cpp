// EnergyPlus models (.idf, .epJSON) as scenes, one zone each (formfactor/scene/energyplus.h).
// Both syntaxes are first turned into the same list of objects (class, name, fields with their
// lines), then one model builder reads the geometry from it. (Past 600 lines: the builder reads
// every field through both syntaxes side by side, so that IDF and epJSON cannot drift apart.)

#include "formfactor/scene/energyplus.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <numbers>
#include <optional>
#include <sstream>

#include "core/text.h"
#include "formfactor/core/error.h"
#include "scene/energyplus_objects.h"
#include "scene/text.h"

namespace formfactor {

namespace {

using detail::EnergyPlusObject;
using detail::IdfField;
using Json = detail::EnergyPlusJson;

std::string lower(std::string s) {
    std::transform(s.begin(), s.end(), s.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return s;
}

bool is_epjson(const std::string& path) {
    const std::string p = lower(path);
    return p.size() >= 7 && p.compare(p.size() - 7, 7, ".epjson") == 0;
}

// ---- the model ------------------------------------------------------------------------------

struct ZoneInfo {
    std::string name;
    double north = 0.0, x = 0.0, y = 0.0, z = 0.0;
};

// A simplified object's rectangle as given: azimuth and tilt in degrees (subsurfaces take their
// base surface's), the starting (lower left) corner, the two sides in metres.
struct Rect {
    double azimuth = 0.0, tilt = 0.0, x = 0.0, y = 0.0, z = 0.0, length = 0.0, height = 0.0;
};

struct SurfaceInfo {
    std::string name, zone, base;  // base: fenestration only
    std::vector<Vec3> vertices;
    std::string type_as_written;
    int line = 0;
    double multiplier = 1.0;
    bool fenestration = false;
    std::optional<Rect> rect;  // a simplified object: vertices made from it in build()
    bool placed = false;       // vertices are world coordinates, counter-clockwise from outside
    // A base surface's Outside Boundary Condition Object (interzone objects, and detailed surfaces
    // whose condition is Zone or Surface); when it names a zone, EnergyPlus makes the facing
    // surface in that zone. `outside_is_zone`: the condition is Zone, so it must name one.
    std::string outside;
    bool outside_is_zone = false;
    int outside_line = 0;
    std::string generated_from;  // a surface EnergyPlus generates: the surface it faces
};

const char* const kDetailedSurfaces[] = {"buildingsurface:detailed", "wall:detailed",
                                         "roofceiling:detailed", "floor:detailed"};
// The simplified (rectangular) geometry objects, as the Input-Output Reference lists their fields:
// base surfaces (name, construction, zone, [space], [outside boundary condition object], azimuth,
// tilt, starting x, y, z, length, height or width) and subsurfaces (name, construction, base
// surface, [shading control name before 9.0], [frame and divider], [outside boundary condition
// object], multiplier, starting x, starting z, length, height).
struct RectClass {
    const char* type;    // lower case
    bool sub;            // on a base surface (Window, Door, ...) rather than in a zone
    bool interzone;      // has an Outside Boundary Condition Object field
    bool frame;          // Window, GlazedDoor: Frame and Divider (and Shading Control before 9.0)
    double tilt;         // the default tilt of a base surface, degrees
    const char* second;  // the second side: "height" or "width" (epJSON key)
};
const RectClass kRectClasses[] = {
    {"wall:exterior", false, false, false, 90.0, "height"},
    {"wall:adiabatic", false, false, false, 90.0, "height"},
    {"wall:underground", false, false, false, 90.0, "height"},
    {"wall:interzone", false, true, false, 90.0, "height"},
    {"roof", false, false, false, 0.0, "width"},
    {"ceiling:adiabatic", false, false, false, 0.0, "width"},
    {"ceiling:interzone", false, true, false, 0.0, "width"},
    {"floor:groundcontact", false, false, false, 180.0, "width"},
    {"floor:adiabatic", false, false, false, 180.0, "width"},
    {"floor:interzone", false, true, false, 180.0, "width"},
    {"window", true, false, true, 0.0, "height"},
    {"door", true, false, false, 0.0, "height"},
    {"glazeddoor", true, false, true, 0.0, "height"},
    {"window:interzone", true, true, false, 0.0, "height"},
    {"door:interzone", true, true, false, 0.0, "height"},
    {"glazeddoor:interzone", true, true, false, 0.0, "height"},
};

const char* const kBoundaryConditions[] = {"adiabatic",
                                           "surface",
                                           "zone",
                                           "outdoors",
                                           "foundation",
                                           "ground",
                                           "groundfcfactormethod",
                                           "othersidecoefficients",
                                           "othersideconditionsmodel",
                                           "groundslabpreprocessoraverage",
                                           "groundslabpreprocessorcore",
                                           "groundslabpreprocessorperimeter",
                                           "groundbasementpreprocessoraveragewall",
                                           "groundbasementpreprocessoraveragefloor",
                                           "groundbasementpreprocessorupperwall",
                                           "groundbasementpreprocessorlowerwall"};

bool is_boundary_condition(const std::string& v) {
    const std::string l = lower(v);
    return std::any_of(std::begin(kBoundaryConditions), std::end(kBoundaryConditions),
                       [&](const char* b) { return l == b; });
}

class ModelBuilder {
  public:
    explicit ModelBuilder(std::string path) : path_(std::move(path)) {}

    void read(const std::vector<EnergyPlusObject>& objects) {
        for (const EnergyPlusObject& o : objects) {
            if (o.type == "version") read_version(o);
        }
        for (const EnergyPlusObject& o : objects) {
            if (o.type == "globalgeometryrules")
                read_rules(o);
            else if (o.type == "building")
                read_building(o);
            else if (o.type == "zone")
                read_zone(o);
            else if (o.type == "fenestrationsurface:detailed")
                read_fenestration(o);
            else if (std::any_of(std::begin(kDetailedSurfaces), std::end(kDetailedSurfaces),
                                 [&](const char* t) { return o.type == t; }))
                read_surface(o);
            else
                for (const RectClass& c : kRectClasses)
                    if (o.type == c.type) read_rectangle(o, c);
        }
    }

    std::vector<std::string> zone_names() const {
        std::vector<std::string> names;
        for (const ZoneInfo& z : zones_) names.push_back(z.name);
        return names;
    }

    Scene build(const std::string& wanted) const {
        if (zones_.empty()) throw InputError(path_, 0, "no Zone objects (nothing to enclose)");
        const ZoneInfo* zone = nullptr;
        if (wanted.empty()) {
            if (zones_.size() > 1)
                throw InputError(path_, 0,
                                 fmt::format("the model has {} zones; choose one with `zone` "
                                             "NAME: {}",
                                             zones_.size(), join(zone_names())));
            zone = &zones_.front();
        } else {
            for (const ZoneInfo& z : zones_)
                if (lower(z.name) == lower(wanted)) zone = &z;
            if (!zone)
                throw InputError(path_, 0,
                                 fmt::format("zone '{}' is not in the model (zones: {})", wanted,
                                             join(zone_names())));
        }
        const std::string zkey = lower(zone->name);
        const std::vector<SurfaceInfo> all = with_rectangles(zkey);
        std::map<std::string, const SurfaceInfo*> by_name;  // lower-case name → surface
        std::map<std::string, std::vector<const SurfaceInfo*>> fenestration_of;  // by base
        for (const SurfaceInfo& s : all) {
            by_name[lower(s.name)] = &s;
            if (s.fenestration) fenestration_of[lower(s.base)].push_back(&s);
        }
        Scene scene;
        scene.name = path_;
        scene.title = zone->name;
        scene.enclosure = true;
        scene.materials.push_back(Material{});
        std::map<std::string, int> index;  // lower-case surface name → scene surface
        // Base surfaces in file order, each followed by its fenestration surfaces (in file
        // order): the same order from IDF and epJSON (whose objects are grouped by class) when
        // the model uses one class of base surfaces.
        std::vector<const SurfaceInfo*> order;
        for (const SurfaceInfo& s : all) {
            if (s.fenestration) continue;
            order.push_back(&s);
            auto f = fenestration_of.find(lower(s.name));
            if (f != fenestration_of.end())
                order.insert(order.end(), f->second.begin(), f->second.end());
        }
        for (const SurfaceInfo& s : all)
            if (s.fenestration &&
                (!by_name.count(lower(s.base)) || by_name.at(lower(s.base))->fenestration))
                order.push_back(&s);  // refused below, with its line
        for (const SurfaceInfo* sp : order) {
            const SurfaceInfo& s = *sp;
            const SurfaceInfo* owner = &s;
            if (s.fenestration) {
                auto b = by_name.find(lower(s.base));
                if (b == by_name.end())
                    throw InputError(
                        path_, s.line,
                        where(s) + ": its base surface '" + s.base + "' does not exist");
                if (b->second->fenestration)
                    throw InputError(path_, s.line,
                                     where(s) + ": its base surface '" + s.base +
                                         "' is itself a fenestration surface");
                owner = b->second;
            }
            if (lower(owner->zone) != zkey) continue;
            if (index.count(lower(s.name)))
                throw InputError(path_, s.line,
                                 where(s) + ": a surface of that name already exists");
            const ZoneInfo* z = find_zone(owner->zone);
            if (!z)
                throw InputError(path_, owner->line,
                                 where(*owner) + ": its zone '" + owner->zone + "' does not exist");
            Surface out;
            out.name = s.name;
            out.material = 0;
            out.where = {path_, s.line};
            for (const Vec3& v : s.vertices)
                out.polygon.vertices.push_back(s.placed ? v : place(v, *z));
            // EnergyPlus lists vertices counter-clockwise seen from outside (unless the rules say
            // clockwise; rectangles are made that way): reversed, they run counter-clockwise
            // seen from inside the zone.
            if (s.placed || !clockwise_)
                std::reverse(out.polygon.vertices.begin(), out.polygon.vertices.end());
            validate_polygon(out.polygon, out.where, where(s));
            index[lower(s.name)] = static_cast<int>(scene.surfaces.size());
            scene.surfaces.push_back(std::move(out));
        }
        if (scene.surfaces.empty())
            throw InputError(path_, 0, "zone '" + zone->name + "' has no surfaces");
        // A generated surface where the zone already has one: the zone would count that area
        // twice (the model names the zone where it means the facing surface).
        for (const SurfaceInfo* sp : order) {
            if (sp->generated_from.empty() || sp->fenestration) continue;
            const Surface& g = scene.surfaces[static_cast<std::size_t>(index.at(lower(sp->name)))];
            const Plane pl = plane_of(g.polygon);
            for (const SurfaceInfo* op : order) {
                auto o = index.find(lower(op->name));
                if (op->fenestration || op == sp || o == index.end()) continue;
                const Surface& other = scene.surfaces[static_cast<std::size_t>(o->second)];
                double off = 0.0;
                for (const Vec3& v : other.polygon.vertices)
                    off = std::max(off, std::abs(pl.signed_distance(v)));
                if (off > 1e-6 * diameter(g.polygon) ||
                    std::abs(normal(other.polygon).dot(pl.n)) < 0.999)
                    continue;
                if (overlap_area(g.polygon, other.polygon) > 1e-9 * area(g.polygon))
                    throw InputError(
                        path_, sp->outside_line,
                        fmt::format("{} '{}' names zone '{}' as its outside, where EnergyPlus "
                                    "generates '{}'; but that zone's surface '{}' already covers "
                                    "it (name the surface, not the zone, as the Outside Boundary "
                                    "Condition Object)",
                                    sp->type_as_written, sp->generated_from, zone->name, sp->name,
                                    other.name));
            }
        }
        // Fenestration: holes of its base, checked to lie in it.
        for (const SurfaceInfo* sp : order) {
            const SurfaceInfo& s = *sp;
            if (!s.fenestration) continue;
            auto me = index.find(lower(s.name));
            if (me == index.end()) continue;
            const int b = index.at(lower(s.base));
            Surface& sub = scene.surfaces[static_cast<std::size_t>(me->second)];
            Surface& base = scene.surfaces[static_cast<std::size_t>(b)];
            sub.base = b;
            check_in_base(s, sub.polygon, base);
            for (const Polygon& h : base.holes) {
                const double o = overlap_area(sub.polygon, h);
                if (o > 1e-9 * std::min(area(sub.polygon), area(h)))
                    throw InputError(
                        path_, s.line,
                        where(s) + " overlaps another subsurface of '" + base.name + "'");
            }
            base.holes.push_back(sub.polygon);
            if (s.multiplier != 1.0)
                scene.warnings.push_back(fmt::format(
                    "{} has Multiplier {}: its geometry counts once here (EnergyPlus multiplies "
                    "its area)",
                    where(s), detail::short_number(s.multiplier)));
        }
        if (!have_rules_)
            scene.warnings.push_back(
                "no GlobalGeometryRules: EnergyPlus's defaults taken (UpperLeftCorner, "
                "Counterclockwise, Relative)");
        return scene;
    }

  private:
    static std::string join(const std::vector<std::string>& v) {
        std::string s;
        for (const std::string& x : v) s += (s.empty() ? "" : ", ") + x;
        return s;
    }

    static std::string where(const SurfaceInfo& s) {
        return s.type_as_written + " '" + s.name + "'";
    }

    const ZoneInfo* find_zone(const std::string& name) const {
        for (const ZoneInfo& z : zones_)
            if (lower(z.name) == lower(name)) return &z;
        return nullptr;
    }

    // The surfaces with the rectangles of simplified objects made into vertices (world
    // coordinates, counter-clockwise seen from outside, upper left corner first), as EnergyPlus
    // makes them: a base surface's azimuth turns with the building's and the zone's north under
    // relative coordinates (`Coordinate System`), its starting corner is moved into the zone by
    // `Rectangular Surface Coordinate System`; a subsurface starts at its base surface's lower
    // left corner moved by its X along the base's length and its Z up the base, and takes the
    // base's azimuth and tilt. Then the surfaces EnergyPlus generates in zone `zkey` (lower case)
    // for base surfaces of other zones whose outside boundary condition object names it.
    // Also refuses a base surface whose zone, or the zone its condition names, does not exist.
    // Subsurfaces are made for the bases seen from zone `zkey` only, whose errors build() reports.
    std::vector<SurfaceInfo> with_rectangles(const std::string& zkey) const {
        std::vector<SurfaceInfo> all = surfaces_;
        std::map<std::string, std::size_t> index;  // lower-case name → first surface of that name
        for (std::size_t k = 0; k < all.size(); ++k) index.emplace(lower(all[k].name), k);
        // Whether zone `zkey` sees a base surface: its own, or one that names it outside.
        auto seen = [&](const SurfaceInfo& base) {
            return lower(base.zone) == zkey ||
                   (!base.outside.empty() && lower(base.outside) == zkey &&
                    find_zone(base.outside));
        };
        for (SurfaceInfo& s : all) {
            if (s.fenestration) continue;
            const ZoneInfo* z = find_zone(s.zone);
            if (!z)
                throw InputError(path_, s.line,
                                 where(s) + ": its zone '" + s.zone + "' does not exist");
            if (s.outside_is_zone && !find_zone(s.outside))
                throw InputError(path_, s.outside_line,
                                 where(s) + ": Outside Boundary Condition Object '" + s.outside +
                                     "' is not a zone of the model (the condition is Zone)");
            if (!s.rect) continue;
            Rect& r = *s.rect;
            if (relative_) r.azimuth += building_north_ + z->north;
            const Vec3 corner(r.x, r.y, r.z);
            s.vertices = rectangle(rect_relative_ ? to_world(corner, *z) : corner, r.azimuth,
                                   r.tilt, r.length, r.height);
            s.placed = true;
        }
        for (SurfaceInfo& s : all) {
            if (!s.fenestration || !s.rect) continue;
            auto b = index.find(lower(s.base));
            // A missing base, or one that is a subsurface, is refused by build() with its line.
            if (b == index.end() || all[b->second].fenestration) continue;
            const SurfaceInfo& base = all[b->second];
            if (!seen(base)) continue;
            double azimuth = 0.0, tilt = 0.0;
            Vec3 corner;
            if (base.rect) {
                azimuth = base.rect->azimuth;
                tilt = base.rect->tilt;
                corner = base.vertices[1];
            } else {
                // A detailed base: EnergyPlus's vertex 2 and the azimuth and tilt of its outward
                // normal (SurfaceGeometry's MakeRelativeRectangularVertices).
                const std::vector<Vec3> v = outward_world(base, *find_zone(base.zone));
                if (v.size() < 3) continue;  // build() refuses the base
                azimuth_and_tilt(v, azimuth, tilt);
                corner = v[1];
            }
            corner +=
                s.rect->x * length_direction(azimuth) + s.rect->z * up_direction(azimuth, tilt);
            s.vertices = rectangle(corner, azimuth, tilt, s.rect->length, s.rect->height);
            s.placed = true;
        }
        // The facing surfaces EnergyPlus generates: "iz-" and the name, the vertices reversed, in
        // the zone named; each subsurface of the base likewise, a subsurface of the new base.
        std::vector<SurfaceInfo> generated;
        for (const SurfaceInfo& s : all) {
            if (s.fenestration || s.outside.empty() || lower(s.zone) == zkey) continue;
            const ZoneInfo* there = find_zone(s.outside);
            if (!there || lower(there->name) != zkey) continue;
            const ZoneInfo& here = *find_zone(s.zone);
            SurfaceInfo g = s;
            g.name = "iz-" + s.name;
            g.zone = there->name;
            g.vertices = outward_world(s, here);
            std::reverse(g.vertices.begin(), g.vertices.end());
            g.placed = true;
            g.rect.reset();
            g.outside.clear();
            g.outside_is_zone = false;
            g.generated_from = s.name;
            generated.push_back(std::move(g));
            for (const SurfaceInfo& f : all) {
                if (!f.fenestration || lower(f.base) != lower(s.name)) continue;
                SurfaceInfo h = f;
                h.name = "iz-" + f.name;
                h.base = "iz-" + s.name;
                h.vertices = outward_world(f, here);
                std::reverse(h.vertices.begin(), h.vertices.end());
                h.placed = true;
                h.rect.reset();
                generated.push_back(std::move(h));
            }
        }
        all.insert(all.end(), generated.begin(), generated.end());
        return all;
    }

    // A surface's vertices in world coordinates, counter-clockwise seen from outside, in the
    // order EnergyPlus keeps them as entered counter-clockwise; clockwise entry is turned round
    // from the first vertex on (1, n, n−1, ..., 2), so that a wall entered clockwise from its
    // upper left corner has its lower left corner second, as it has counter-clockwise. `z` is
    // the zone its coordinates are relative to.
    std::vector<Vec3> outward_world(const SurfaceInfo& s, const ZoneInfo& z) const {
        if (s.placed) return s.vertices;
        std::vector<Vec3> v;
        for (const Vec3& p : s.vertices) v.push_back(place(p, z));
        if (clockwise_ && v.size() > 2) std::reverse(v.begin() + 1, v.end());
        return v;
    }

    // EnergyPlus's azimuth and tilt of a surface (Vectors' DetermineAzimuthAndTilt), in degrees,
    // from its vertices counter-clockwise seen from outside: the azimuth of the outward normal
    // clockwise from north, or for a horizontal surface that of its edge from vertex 2 to 3.
    static void azimuth_and_tilt(const std::vector<Vec3>& v, double& azimuth, double& tilt) {
        Polygon p;
        p.vertices = v;
        const Vec3 n = normal(p);
        const Vec3 x = (v[2] - v[1]).normalized();
        const double deg = 180.0 / std::numbers::pi;
        const double angle =
            std::abs(n.z()) < 1.0 - 1.12e-16 ? std::atan2(n.x(), -n.y()) : std::atan2(x.y(), x.x());
        tilt = std::acos(std::clamp(n.z(), -1.0, 1.0)) * deg;
        azimuth = std::fmod(450.0 - angle * deg, 360.0) + 90.0;
        if (azimuth < 0.0) azimuth += 360.0;
        azimuth = std::fmod(azimuth, 360.0);
    }

    // EnergyPlus's rectangle axes: along the length (to the right seen from outside) and up the
    // surface, for an azimuth (clockwise from north, of the outward normal) and a tilt from
    // horizontal, in degrees.
    static Vec3 length_direction(double azimuth) {
        const double a = azimuth * std::numbers::pi / 180.0;
        return Vec3(-std::cos(a), std::sin(a), 0.0);
    }
    static Vec3 up_direction(double azimuth, double tilt) {
        const double a = azimuth * std::numbers::pi / 180.0, t = tilt * std::numbers::pi / 180.0;
        return Vec3(-std::cos(t) * std::sin(a), -std::cos(t) * std::cos(a), std::sin(t));
    }

    // Upper left, lower left (the starting corner), lower right, upper right.
    static std::vector<Vec3> rectangle(const Vec3& corner, double azimuth, double tilt,
                                       double length, double height) {
        const Vec3 u = length * length_direction(azimuth), w = height * up_direction(azimuth, tilt);
        return {corner + w, corner, corner + u, corner + u + w};
    }

    Vec3 place(const Vec3& v, const ZoneInfo& z) const { return relative_ ? to_world(v, z) : v; }

    Vec3 to_world(const Vec3& v, const ZoneInfo& z) const {
        // EnergyPlus (SurfaceGeometry): rotate by the zone's relative north, move to its origin,
        // rotate by the building's north axis. Angles are clockwise from north, in degrees.
        const double deg = std::numbers::pi / 180.0;
        const double cz = std::cos(-z.north * deg), sz = std::sin(-z.north * deg);
        const double cb = std::cos(-building_north_ * deg), sb = std::sin(-building_north_ * deg);
        const double xb = v.x() * cz - v.y() * sz + z.x;
        const double yb = v.x() * sz + v.y() * cz + z.y;
        return Vec3(xb * cb - yb * sb, xb * sb + yb * cb, v.z() + z.z);
    }

    void check_in_base(const SurfaceInfo& s, const Polygon& sub, const Surface& base) const {
        const Plane pl = plane_of(base.polygon);
        double worst = 0.0;
        for (const Vec3& v : sub.vertices) worst = std::max(worst, std::abs(pl.signed_distance(v)));
        if (worst > 1e-5 * diameter(sub))
            throw InputError(path_, s.line,
                             where(s) + " is not in the plane of its base surface '" + base.name +
                                 "' (distance " + detail::short_number(worst) + ")");
        if (normal(sub).dot(pl.n) < 0.999)
            throw InputError(path_, s.line,
                             where(s) + " does not face the same way as its base surface '" +
                                 base.name + "' (its vertices run the other way)");
        double outside = 0.0;
        for (const Polygon& piece : subtract_holes(sub, {base.polygon})) outside += area(piece);
        if (outside > 1e-9 * area(sub))
            throw InputError(path_, s.line,
                             where(s) + " is not within its base surface '" + base.name +
                                 "' (area " + detail::short_number(outside) + " outside)");
    }

    // ---- field access, for both syntaxes ----

    // An IDF field by position (empty when absent), or an epJSON member by key.
    std::string text_field(const EnergyPlusObject& o, std::size_t idf_index,
                           const char* key) const {
        if (o.json) {
            auto it = o.json->find(key);
            if (it == o.json->end() || it->is_null()) return {};
            if (it->is_string()) return it->get<std::string>();
            if (it->is_number()) return it->dump();
            throw InputError(path_, 0,
                             fmt::format("{} '{}': {} is neither text nor a number",
                                         o.type_as_written, o.name, key));
        }
        return idf_index < o.fields.size() ? o.fields[idf_index].value : std::string();
    }

    int line_of(const EnergyPlusObject& o, std::size_t idf_index) const {
        if (o.json) return 0;
        return idf_index < o.fields.size() ? o.fields[idf_index].line : o.line;
    }

    double number(const EnergyPlusObject& o, std::size_t idf_index, const char* key,
                  const char* what, double fallback) const {
        if (o.json) {
            auto it = o.json->find(key);
            if (it == o.json->end() || it->is_null()) return fallback;
            if (it->is_number()) {
                const double v = it->get<double>();
                if (std::isfinite(v)) return v;
            }
            if (it->is_string() && it->get<std::string>().empty()) return fallback;
            throw InputError(path_, 0,
                             fmt::format("{} '{}': {} '{}' is not a finite number",
                                         o.type_as_written, o.name, what, it->dump()));
        }
        const std::string v = text_field(o, idf_index, key);
        if (v.empty()) return fallback;
        double x = 0.0;
        if (!detail::parse_double(v, x) || !std::isfinite(x))
            throw InputError(path_, line_of(o, idf_index),
                             fmt::format("{} '{}': {} '{}' is not a finite number",
                                         o.type_as_written, o.name, what, v));
        return x;
    }

    std::string choice(const EnergyPlusObject& o, std::size_t idf_index, const char* key,
                       const char* what, std::initializer_list<const char*> keys,
                       const char* fallback) const {
        std::string v = text_field(o, idf_index, key);
        if (v.empty()) return fallback;
        for (const char* k : keys)
            if (lower(v) == lower(k)) return lower(k);
        std::string list;
        for (const char* k : keys) list += (list.empty() ? "" : ", ") + std::string(k);
        throw InputError(
            path_, line_of(o, idf_index),
            fmt::format("{}: {} '{}' is not one of {}", o.type_as_written, what, v, list));
    }

    void read_version(const EnergyPlusObject& o) {
        const std::string v = text_field(o, 0, "version_identifier");
        long major = 0, minor = 0;
        char dot = 0;
        std::istringstream in(v);
        if (in >> major) {
            if (in >> dot >> minor) {
            }
            // EnergyPlus numbers its versions 1.0 … 25.x; anything else is not a version.
            if (major < 1 || major > 999 || minor < 0 || minor > 99)
                throw InputError(path_, line_of(o, 0),
                                 fmt::format("{}: version '{}' is not an EnergyPlus version "
                                             "number (major.minor, e.g. 9.6 or 23.2)",
                                             o.type_as_written, v));
            version_ = static_cast<int>(major * 100 + minor);
        }
    }

    void read_rules(const EnergyPlusObject& o) {
        if (have_rules_)
            throw InputError(path_, o.line, "GlobalGeometryRules appears more than once");
        have_rules_ = true;
        choice(o, 0, "starting_vertex_position", "Starting Vertex Position",
               {"UpperLeftCorner", "LowerLeftCorner", "UpperRightCorner", "LowerRightCorner"},
               "upperleftcorner");
        clockwise_ = choice(o, 1, "vertex_entry_direction", "Vertex Entry Direction",
                            {"Counterclockwise", "Clockwise"}, "counterclockwise") == "clockwise";
        relative_ = choice(o, 2, "coordinate_system", "Coordinate System",
                           {"Relative", "World", "Absolute"}, "relative") == "relative";
        rect_relative_ = choice(o, 4, "rectangular_surface_coordinate_system",
                                "Rectangular Surface Coordinate System",
                                {"Relative", "World", "Absolute"}, "relative") == "relative";
    }

    void read_building(const EnergyPlusObject& o) {
        building_north_ = number(o, 1, "north_axis", "North Axis", 0.0);
    }

    void read_zone(const EnergyPlusObject& o) {
        ZoneInfo z;
        z.name = o.name;
        if (z.name.empty()) throw InputError(path_, o.line, "a Zone without a name");
        if (find_zone(z.name))
            throw InputError(path_, o.line, "zone '" + z.name + "' is defined twice");
        z.north = number(o, 1, "direction_of_relative_north", "Direction of Relative North", 0.0);
        z.x = number(o, 2, "x_origin", "X Origin", 0.0);
        z.y = number(o, 3, "y_origin", "Y Origin", 0.0);
        z.z = number(o, 4, "z_origin", "Z Origin", 0.0);
        zones_.push_back(z);
    }

    // The vertices: IDF from field `first` on (the count in field first − 1 when it is a number),
    // epJSON from the "vertices" array or the vertex_K_x_coordinate members.
    std::vector<Vec3> vertices(const EnergyPlusObject& o, std::size_t first,
                               bool json_array) const {
        std::vector<Vec3> v;
        if (o.json) {
            if (json_array) {
                auto it = o.json->find("vertices");
                if (it == o.json->end() || !it->is_array())
                    throw InputError(path_, 0,
                                     fmt::format("{} '{}' has no \"vertices\" array",
                                                 o.type_as_written, o.name));
                for (const auto& item : *it) {
                    if (!item.is_object())
                        throw InputError(path_, 0,
                                         fmt::format("{} '{}': a vertex is not an object",
                                                     o.type_as_written, o.name));
                    Vec3 p;
                    const char* keys[3] = {"vertex_x_coordinate", "vertex_y_coordinate",
                                           "vertex_z_coordinate"};
                    for (int c = 0; c < 3; ++c) {
                        auto f = item.find(keys[c]);
                        if (f == item.end() || !f->is_number() || !std::isfinite(f->get<double>()))
                            throw InputError(
                                path_, 0,
                                fmt::format("{} '{}': vertex {} has no finite {}",
                                            o.type_as_written, o.name, v.size() + 1, keys[c]));
                        p[c] = f->get<double>();
                    }
                    v.push_back(p);
                }
            } else {
                for (int k = 1; k <= 4; ++k) {
                    const std::string base = fmt::format("vertex_{}_", k);
                    if (!o.json->contains(base + "x_coordinate")) break;
                    Vec3 p;
                    const char* axes[3] = {"x", "y", "z"};
                    for (int c = 0; c < 3; ++c) {
                        const std::string key = base + axes[c] + "_coordinate";
                        auto f = o.json->find(key);
                        if (f == o.json->end() || !f->is_number() ||
                            !std::isfinite(f->get<double>()))
                            throw InputError(path_, 0,
                                             fmt::format("{} '{}': no finite {}", o.type_as_written,
                                                         o.name, key));
                        p[c] = f->get<double>();
                    }
                    v.push_back(p);
                }
            }
            return v;
        }
        const std::size_t n = o.fields.size() > first ? o.fields.size() - first : 0;
        // Trailing empty fields (an IDF editor's padding) are not coordinates.
        std::size_t used = n;
        while (used > 0 && o.fields[first + used - 1].value.empty()) --used;
        if (used % 3 != 0)
            throw InputError(path_, o.line,
                             fmt::format("{} '{}': {} vertex coordinates, not a multiple of 3",
                                         o.type_as_written, o.name, used));
        for (std::size_t k = 0; k < used; k += 3) {
            Vec3 p;
            for (std::size_t c = 0; c < 3; ++c) {
                const IdfField& f = o.fields[first + k + c];
                double x = 0.0;
                if (!detail::parse_double(f.value, x) || !std::isfinite(x))
                    throw InputError(
                        path_, f.line,
                        fmt::format("{} '{}': vertex {} {}-coordinate '{}' is not a "
                                    "finite number",
                                    o.type_as_written, o.name, k / 3 + 1, "XYZ"[c], f.value));
                p[static_cast<Eigen::Index>(c)] = x;
            }
            v.push_back(p);
        }
        const std::string count = lower(o.fields[first - 1].value);
        if (!count.empty() && count != "autocalculate") {
            std::size_t declared = 0;
            if (!detail::parse_size(count, declared) || declared != v.size())
                throw InputError(
                    path_, o.fields[first - 1].line,
                    fmt::format("{} '{}': Number of Vertices is '{}' but {} vertices "
                                "follow",
                                o.type_as_written, o.name, o.fields[first - 1].value, v.size()));
        }
        return v;
    }

    // Whether an IDF surface has the Space Name field (EnergyPlus ≥ 9.6): by the Version object,
    // else by whether the field after the zone is an outside boundary condition.
    bool has_space_field(const EnergyPlusObject& o, std::size_t zone_index) const {
        if (version_ > 0) return version_ >= 906;
        return !(o.fields.size() > zone_index + 1 &&
                 is_boundary_condition(o.fields[zone_index + 1].value));
    }

    void read_surface(const EnergyPlusObject& o) {
        SurfaceInfo s;
        s.name = o.name;
        s.type_as_written = o.type_as_written;
        s.line = o.line;
        if (s.name.empty()) throw InputError(path_, o.line, o.type_as_written + " without a name");
        // BuildingSurface:Detailed has Surface Type after the name; the others do not.
        const std::size_t zone_index = o.type == "buildingsurface:detailed" ? 3 : 2;
        s.zone = text_field(o, zone_index, "zone_name");
        if (s.zone.empty())
            throw InputError(path_, line_of(o, zone_index), where(s) + " names no zone");
        const std::size_t condition =
            zone_index + (o.json || !has_space_field(o, zone_index) ? 1 : 2);
        if (lower(text_field(o, condition, "outside_boundary_condition")) == "zone") {
            s.outside = text_field(o, condition + 1, "outside_boundary_condition_object");
            s.outside_is_zone = true;
            s.outside_line = line_of(o, condition + 1);
        }
        if (!o.json) {
            // Name, [type], construction, zone, [space], condition, condition object, sun, wind,
            // view factor to ground, number of vertices, then the coordinates.
            const std::size_t first = zone_index + (has_space_field(o, zone_index) ? 7 : 6) + 1;
            if (o.fields.size() < first)
                throw InputError(path_, o.line, where(s) + " has no vertices");
            s.vertices = vertices(o, first, true);
        } else {
            s.vertices = vertices(o, 0, true);
        }
        surfaces_.push_back(std::move(s));
    }

    void read_fenestration(const EnergyPlusObject& o) {
        SurfaceInfo s;
        s.name = o.name;
        s.type_as_written = o.type_as_written;
        s.line = o.line;
        s.fenestration = true;
        if (s.name.empty()) throw InputError(path_, o.line, o.type_as_written + " without a name");
        s.base = text_field(o, 3, "building_surface_name");
        if (s.base.empty())
            throw InputError(path_, line_of(o, 3), where(s) + " names no base surface");
        if (o.json) {
            s.multiplier = number(o, 0, "multiplier", "Multiplier", 1.0);
            s.vertices = vertices(o, 0, false);
        } else {
            // Name, type, construction, base, condition object, view factor to ground,
            // [shading control name (before 9.0)], frame and divider, multiplier, number of
            // vertices, coordinates.
            const bool shading_field = version_ > 0 ? version_ < 900 : fenestration_is_old(o);
            const std::size_t count_index = shading_field ? 9 : 8;
            if (o.fields.size() <= count_index)
                throw InputError(path_, o.line, where(s) + " has no vertices");
            s.multiplier = number(o, count_index - 1, "multiplier", "Multiplier", 1.0);
            s.vertices = vertices(o, count_index + 1, false);
        }
        if (s.vertices.size() < 3 || s.vertices.size() > 4)
            throw InputError(
                path_, o.line,
                fmt::format("{} has {} vertices (3 or 4 expected)", where(s), s.vertices.size()));
        surfaces_.push_back(std::move(s));
    }

    // A simplified object: its rectangle, zone or base surface; the vertices are made in build().
    void read_rectangle(const EnergyPlusObject& o, const RectClass& c) {
        SurfaceInfo s;
        s.name = o.name;
        s.type_as_written = o.type_as_written;
        s.line = o.line;
        s.fenestration = c.sub;
        if (s.name.empty()) throw InputError(path_, o.line, o.type_as_written + " without a name");
        Rect r;
        if (c.sub) {
            s.base = text_field(o, 2, "building_surface_name");
            if (s.base.empty())
                throw InputError(path_, line_of(o, 2), where(s) + " names no base surface");
            // Name, construction, base surface, then [outside boundary condition object],
            // [shading control name (before 9.0)], [frame and divider], multiplier.
            std::size_t k = 3;
            if (c.interzone) ++k;
            if (c.frame)
                k += version_ > 0 ? (version_ < 900 ? 2 : 1) : (o.fields.size() >= 10 ? 2 : 1);
            s.multiplier = number(o, k, "multiplier", "Multiplier", 1.0);
            r.x = number(o, k + 1, "starting_x_coordinate", "Starting X Coordinate", 0.0);
            r.z = number(o, k + 2, "starting_z_coordinate", "Starting Z Coordinate", 0.0);
            r.length = side(o, k + 3, "length", "Length");
            r.height = side(o, k + 4, "height", "Height");
        } else {
            s.zone = text_field(o, 2, "zone_name");
            if (s.zone.empty()) throw InputError(path_, line_of(o, 2), where(s) + " names no zone");
            // Name, construction, zone, [space (EnergyPlus >= 9.6)], [outside boundary condition
            // object], then seven numbers.
            const std::size_t with_space = c.interzone ? 12 : 11;
            const bool space = version_ > 0 ? version_ >= 906 : o.fields.size() >= with_space;
            const std::size_t k = 3 + (space ? 1 : 0) + (c.interzone ? 1 : 0);
            if (c.interzone) {
                s.outside = text_field(o, k - 1, "outside_boundary_condition_object");
                s.outside_line = line_of(o, k - 1);
            }
            r.azimuth = number(o, k, "azimuth_angle", "Azimuth Angle", 0.0);
            r.tilt = number(o, k + 1, "tilt_angle", "Tilt Angle", c.tilt);
            r.x = number(o, k + 2, "starting_x_coordinate", "Starting X Coordinate", 0.0);
            r.y = number(o, k + 3, "starting_y_coordinate", "Starting Y Coordinate", 0.0);
            r.z = number(o, k + 4, "starting_z_coordinate", "Starting Z Coordinate", 0.0);
            r.length = side(o, k + 5, "length", "Length");
            r.height =
                side(o, k + 6, c.second, std::string(c.second) == "width" ? "Width" : "Height");
        }
        s.rect = r;
        surfaces_.push_back(std::move(s));
    }

    // A side of a rectangle: a positive number.
    double side(const EnergyPlusObject& o, std::size_t idf_index, const char* key,
                const char* what) const {
        const double v = number(o, idf_index, key, what, 0.0);
        if (v > 0.0) return v;
        const std::string given = text_field(o, idf_index, key);
        throw InputError(path_, line_of(o, idf_index),
                         given.empty()
                             ? fmt::format("{} '{}' has no {}", o.type_as_written, o.name, what)
                             : fmt::format("{} '{}': {} '{}' is not positive", o.type_as_written,
                                           o.name, what, given));
    }

    // Without a Version object: the old layout (with Shading Control Name) is the one in which
    // the field count and the declared number of vertices agree.
    static bool fenestration_is_old(const EnergyPlusObject& o) {
        auto fits = [&](std::size_t count_index) {
            if (o.fields.size() <= count_index) return false;
            std::size_t n = 0;
            return detail::parse_size(o.fields[count_index].value, n) &&
                   o.fields.size() - count_index - 1 == 3 * n;
        };
        return !fits(8) && fits(9);
    }

    std::string path_;
    int version_ = 0;  // 100 × major + minor; 0 = no Version object
    bool have_rules_ = false, clockwise_ = false, relative_ = true;
    double building_north_ = 0.0;
    std::vector<ZoneInfo> zones_;
    bool rect_relative_ = true;  // Rectangular Surface Coordinate System
    std::vector<SurfaceInfo> surfaces_;
};

std::string read_file_text(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw InputError(path, 0, "cannot open file");
    std::ostringstream s;
    s << in.rdbuf();
    if (in.bad()) throw InputError(path, 0, "cannot read file");
    return s.str();
}

ModelBuilder read_model(const std::string& text, const std::string& path,
                        std::vector<EnergyPlusObject>& objects, Json& doc) {
    objects =
        is_epjson(path) ? detail::parse_epjson(text, path, doc) : detail::parse_idf(text, path);
    ModelBuilder m(path);
    m.read(objects);
    return m;
}

}  // namespace

std::vector<std::string> energyplus_zones(const std::string& path) {
    std::vector<EnergyPlusObject> objects;
    Json doc;
    return read_model(read_file_text(path), path, objects, doc).zone_names();
}

Scene load_energyplus_text(const std::string& text, const std::string& path,
                           const std::string& zone) {
    std::vector<EnergyPlusObject> objects;
    Json doc;
    Scene scene = read_model(text, path, objects, doc).build(zone);
    subdivide(scene, SubdivisionOptions{});
    return scene;
}

Scene load_energyplus(const std::string& path, const std::string& zone) {
    return load_energyplus_text(read_file_text(path), path, zone);
}

}  // namespace formfactor
