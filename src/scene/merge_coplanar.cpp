#include "formfactor/scene/merge_coplanar.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <optional>
#include <utility>
#include <vector>

#include "formfactor/core/error.h"

namespace formfactor {

namespace {

using Edge = std::pair<int, int>;

// Welds vertices that are the same point bit for bit.
class VertexIds {
  public:
    int id(const Vec3& v) {
        const std::array<double, 3> key{v.x(), v.y(), v.z()};
        const auto [it, fresh] = ids_.emplace(key, static_cast<int>(points_.size()));
        if (fresh) points_.push_back(v);
        return it->second;
    }
    const Vec3& point(int id) const { return points_[static_cast<std::size_t>(id)]; }

  private:
    std::map<std::array<double, 3>, int> ids_;
    std::vector<Vec3> points_;
};

struct Face {
    int surface = -1;
    std::vector<int> v;
    Vec3 n = Vec3::Zero();
};

// Drops the vertices of a closed loop that lie on the segment of their neighbours within
// `eps` (absolute), until none does.
Polygon drop_collinear(Polygon p, double eps) {
    bool changed = true;
    while (changed && p.size() > 3) {
        changed = false;
        for (std::size_t k = 0; k < p.size() && p.size() > 3; ++k) {
            const Vec3& a = p[(k + p.size() - 1) % p.size()];
            const Vec3& b = p[k];
            const Vec3& c = p[(k + 1) % p.size()];
            const Vec3 e = c - a;
            const double len2 = e.squaredNorm();
            if (len2 <= 0) continue;
            const double t = (b - a).dot(e) / len2;
            if (t <= 0 || t >= 1) continue;
            if ((a + t * e - b).norm() > eps) continue;
            p.vertices.erase(p.vertices.begin() + static_cast<std::ptrdiff_t>(k));
            changed = true;
            --k;
        }
    }
    return p;
}

// The merged surface of a region of faces (all in one plane, the region's first face's normal
// `n`), or nothing when its boundary is not a set of simple loops with one outer loop.
std::optional<Surface> merge_region(const std::vector<Face>& faces, const std::vector<int>& region,
                                    const VertexIds& ids, const Surface& first, double diag) {
    std::map<Edge, int> count;
    for (int f : region)
        for (std::size_t k = 0; k < faces[static_cast<std::size_t>(f)].v.size(); ++k) {
            const std::vector<int>& v = faces[static_cast<std::size_t>(f)].v;
            ++count[{v[k], v[(k + 1) % v.size()]}];
        }
    std::map<int, int> next;
    for (const auto& [e, c] : count) {
        if (count.count({e.second, e.first})) continue;
        if (c != 1 || next.count(e.first)) return std::nullopt;  // the boundary touches itself
        next[e.first] = e.second;
    }
    const Vec3 n = normal(first.polygon);
    std::vector<Polygon> outer, inner;
    while (!next.empty()) {
        Polygon loop;
        const int start = next.begin()->first;
        int v = start;
        do {
            const auto it = next.find(v);
            if (it == next.end()) return std::nullopt;
            loop.vertices.push_back(ids.point(v));
            v = it->second;
            next.erase(it);
        } while (v != start);
        loop = drop_collinear(std::move(loop), 1e-12 * diag);
        (area_vector(loop).dot(n) > 0 ? outer : inner).push_back(std::move(loop));
    }
    if (outer.size() != 1) return std::nullopt;
    Surface s = first;
    s.polygon = std::move(outer[0]);
    for (Polygon& h : inner) {
        std::reverse(h.vertices.begin(), h.vertices.end());
        s.holes.push_back(std::move(h));
    }
    try {
        validate_polygon(s.polygon, s.where, "merged polygon");
        for (const Polygon& h : s.holes) validate_polygon(h, s.where, "merged hole");
    } catch (const InputError&) {
        return std::nullopt;
    }
    double sum = 0.0;
    for (int f : region) {
        Polygon p;
        for (int v : faces[static_cast<std::size_t>(f)].v) p.vertices.push_back(ids.point(v));
        sum += area(p);
    }
    if (!(std::abs(surface_area(s) - sum) <= 1e-9 * sum)) return std::nullopt;
    return s;
}

}  // namespace

MergeReport merge_coplanar(Scene& scene) {
    const std::size_t ns = scene.surfaces.size();
    MergeReport report;
    report.faces_before = ns;

    // Groups: a surface and those combined with it; runs of obstructions of one name.
    std::vector<int> group_of(ns, -1);
    std::vector<std::vector<int>> groups;
    std::vector<bool> is_base(ns, false);
    for (const Surface& s : scene.surfaces)
        if (s.base >= 0 && static_cast<std::size_t>(s.base) < ns)
            is_base[static_cast<std::size_t>(s.base)] = true;
    for (std::size_t s = 0; s < ns; ++s) {
        const Surface& x = scene.surfaces[s];
        int g = -1;
        if (!x.obstruction && x.combine >= 0) {
            int root = x.combine;
            for (std::size_t hops = 0;
                 hops <= ns && root >= 0 && static_cast<std::size_t>(root) < ns &&
                 scene.surfaces[static_cast<std::size_t>(root)].combine >= 0;
                 ++hops)
                root = scene.surfaces[static_cast<std::size_t>(root)].combine;
            if (root >= 0 && static_cast<std::size_t>(root) < ns)
                g = group_of[static_cast<std::size_t>(root)];
        } else if (x.obstruction && s > 0 && scene.surfaces[s - 1].obstruction &&
                   scene.surfaces[s - 1].name == x.name) {
            g = group_of[s - 1];
        }
        if (g < 0) {
            g = static_cast<int>(groups.size());
            groups.emplace_back();
        }
        group_of[s] = g;
        groups[static_cast<std::size_t>(g)].push_back(static_cast<int>(s));
    }
    // A group is merged when it has several faces and none takes part in holes.
    std::vector<bool> merge(groups.size(), false);
    for (std::size_t g = 0; g < groups.size(); ++g) {
        bool ok = groups[g].size() > 1;
        for (int s : groups[g]) {
            const Surface& x = scene.surfaces[static_cast<std::size_t>(s)];
            if (!x.holes.empty() || x.base >= 0 || is_base[static_cast<std::size_t>(s)]) ok = false;
        }
        merge[g] = ok;
    }

    std::vector<Surface> out;
    std::vector<int> new_index(ns, -1);
    std::vector<int> group_first(groups.size(), -1);  // the new index of its first surface
    for (std::size_t s = 0; s < ns; ++s) {
        const std::size_t g = static_cast<std::size_t>(group_of[s]);
        if (!merge[g]) {
            new_index[s] = static_cast<int>(out.size());
            out.push_back(scene.surfaces[s]);
            continue;
        }
        if (groups[g].front() != static_cast<int>(s)) continue;  // emitted with the first

        VertexIds ids;
        std::vector<Face> faces;
        std::map<Edge, std::vector<int>> edge_faces;
        for (int m : groups[g]) {
            Face f;
            f.surface = m;
            const Polygon& p = scene.surfaces[static_cast<std::size_t>(m)].polygon;
            for (const Vec3& v : p.vertices) f.v.push_back(ids.id(v));
            f.n = normal(p);
            for (std::size_t k = 0; k < f.v.size(); ++k)
                edge_faces[{f.v[k], f.v[(k + 1) % f.v.size()]}].push_back(
                    static_cast<int>(faces.size()));
            faces.push_back(std::move(f));
        }
        std::vector<int> region_of(faces.size(), -1);
        const int first_new = static_cast<int>(out.size());
        for (std::size_t seed = 0; seed < faces.size(); ++seed) {
            if (region_of[seed] >= 0) continue;
            const int r = static_cast<int>(seed);
            const Vec3 n0 = faces[seed].n;
            const Vec3 p0 = ids.point(faces[seed].v[0]);
            Bounds3 box;
            for (int v : faces[seed].v) box.extend(ids.point(v));
            std::vector<int> region{static_cast<int>(seed)}, stack{static_cast<int>(seed)};
            region_of[seed] = r;
            while (!stack.empty()) {
                const Face& f = faces[static_cast<std::size_t>(stack.back())];
                stack.pop_back();
                for (std::size_t k = 0; k < f.v.size(); ++k) {
                    const int a = f.v[k], b = f.v[(k + 1) % f.v.size()];
                    const auto fwd = edge_faces.find({a, b});
                    const auto rev = edge_faces.find({b, a});
                    if (rev == edge_faces.end() || fwd->second.size() != 1 ||
                        rev->second.size() != 1)
                        continue;
                    const int h = rev->second.front();
                    if (region_of[static_cast<std::size_t>(h)] >= 0) continue;
                    const Face& c = faces[static_cast<std::size_t>(h)];
                    if (c.n.dot(n0) <= 0) continue;
                    Bounds3 grown = box;
                    for (int v : c.v) grown.extend(ids.point(v));
                    const double tol = kCoplanarTolerance * (grown.hi - grown.lo).norm();
                    bool flat = true;
                    for (int v : c.v) flat = flat && std::abs((ids.point(v) - p0).dot(n0)) <= tol;
                    if (!flat) continue;
                    box = grown;
                    region_of[static_cast<std::size_t>(h)] = r;
                    region.push_back(h);
                    stack.push_back(h);
                }
            }
            std::sort(region.begin(), region.end());
            const Surface& first = scene.surfaces[static_cast<std::size_t>(faces[seed].surface)];
            std::optional<Surface> merged;
            if (region.size() > 1)
                merged = merge_region(faces, region, ids, first, (box.hi - box.lo).norm());
            if (region.size() > 1 && !merged) ++report.regions_kept;
            const auto emit = [&](Surface x) {
                x.combine = x.obstruction || out.size() == static_cast<std::size_t>(first_new)
                                ? -1
                                : first_new;
                out.push_back(std::move(x));
            };
            if (merged) {
                emit(std::move(*merged));
            } else {
                for (int f : region)
                    emit(scene.surfaces[static_cast<std::size_t>(
                        faces[static_cast<std::size_t>(f)].surface)]);
            }
        }
        group_first[g] = first_new;
    }
    // Surfaces kept as they were point at the new indices.
    for (Surface& x : out) {
        if (x.base >= 0) x.base = new_index[static_cast<std::size_t>(x.base)];
    }
    for (std::size_t s = 0; s < ns; ++s) {
        const int k = new_index[s];
        if (k < 0) continue;
        Surface& x = out[static_cast<std::size_t>(k)];
        const Surface& old = scene.surfaces[s];
        if (old.combine >= 0 && static_cast<std::size_t>(old.combine) < ns) {
            const std::size_t t = static_cast<std::size_t>(old.combine);
            x.combine = new_index[t] >= 0 ? new_index[t]
                                          : group_first[static_cast<std::size_t>(group_of[t])];
        }
    }
    scene.surfaces = std::move(out);
    report.faces_after = scene.surfaces.size();
    subdivide(scene, SubdivisionOptions{});
    return report;
}

}  // namespace formfactor
