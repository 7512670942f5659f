
#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "formfactor/core/atomic_file.h"
#include "formfactor/core/error.h"
#include "output/render_internal.h"

namespace formfactor::detail {

namespace {

struct VertexKey {
    std::array<long long, 7> k;
    bool operator==(const VertexKey& o) const { return k == o.k; }
};

struct VertexKeyHash {
    std::size_t operator()(const VertexKey& v) const {
        std::size_t h = 1469598103934665603ULL;
        for (long long x : v.k) {
            h ^= static_cast<std::size_t>(x) + 0x9e3779b97f4a7c15ULL + (h << 6) + (h >> 2);
        }
        return h;
    }
};

double scene_diameter(const Scene& scene) {
    Bounds3 b;
    for (const Patch& p : scene.patches)
        for (const Vec3& v : p.polygon.vertices) b.extend(v);
    return b.empty() ? 1.0 : std::max(b.diagonal().norm(), 1e-300);
}

}  // namespace

ShadedMesh shaded_mesh(const Scene& scene, const std::vector<Rgb>& values, bool flat) {
    ShadedMesh mesh;
    const std::size_t n = scene.patches.size();
    FF_ASSERT(values.size() == n);
    // Corners closer than 1e-7 of the scene's size are at the same position. Among the patches
    // meeting at a position, those whose normals differ by less than the crease angle share one
    // vertex if they also share the material (so a surface split into near-coplanar pieces
    // shades smoothly), the others get their own (so a wall's colour never bleeds round the
    // corner onto the next wall, nor a light's into the ceiling around it).
    const double cell = 1e-7 * scene_diameter(scene);
    const double cos_crease = std::cos(20.0 * kPi / 180.0);
    struct Corner {
        int patch;
        int k;
    };
    std::unordered_map<VertexKey, int, VertexKeyHash> group_of;
    std::vector<std::vector<Corner>> groups;
    std::vector<std::vector<int>> corner(n);
    std::vector<Vec3> normals(n);
    std::vector<int> material(n, -1);
    for (std::size_t p = 0; p < n; ++p) {
        const Patch& patch = scene.patches[p];
        if (patch.surface >= 0 && static_cast<std::size_t>(patch.surface) < scene.surfaces.size())
            material[p] = scene.surfaces[static_cast<std::size_t>(patch.surface)].material;
        const Polygon& poly = patch.polygon;
        normals[p] = patch.normal.squaredNorm() > 0 ? patch.normal : normal(poly);
        corner[p].assign(poly.size(), -1);
        for (std::size_t k = 0; k < poly.size(); ++k) {
            const Vec3& x = poly[k];
            const VertexKey key{{std::llround(x.x() / cell), std::llround(x.y() / cell),
                                 std::llround(x.z() / cell), 0, 0, 0, 0}};
            auto [it, inserted] = group_of.try_emplace(key, static_cast<int>(groups.size()));
            if (inserted) groups.emplace_back();
            groups[static_cast<std::size_t>(it->second)].push_back(
                {static_cast<int>(p), static_cast<int>(k)});
        }
    }
    std::vector<Rgb> sum;
    std::vector<double> weight;
    auto add = [&](std::size_t p, int id) {
        if (!values[p].allFinite()) return;
        const double w = flat ? 1.0 : std::max(scene.patches[p].area, 0.0) + 1e-300;
        sum[static_cast<std::size_t>(id)] += w * values[p];
        weight[static_cast<std::size_t>(id)] += w;
    };
    auto new_vertex = [&](const Vec3& x) {
        mesh.positions.push_back(x);
        sum.push_back(Rgb::Zero());
        weight.push_back(0.0);
        return static_cast<int>(mesh.positions.size()) - 1;
    };
    for (const auto& g : groups) {
        struct Cluster {
            Vec3 normal;  // of the first member
            int material;
            int vertex;
        };
        std::vector<Cluster> clusters;
        for (const Corner& c : g) {
            const auto p = static_cast<std::size_t>(c.patch);
            const Vec3& x = scene.patches[p].polygon[static_cast<std::size_t>(c.k)];
            int id = -1;
            if (!flat)
                for (const Cluster& cl : clusters)
                    if (cl.material == material[p] && cl.normal.dot(normals[p]) >= cos_crease) {
                        id = cl.vertex;
                        break;
                    }
            if (id < 0) {
                id = new_vertex(x);
                clusters.push_back({normals[p], material[p], id});
            }
            corner[p][static_cast<std::size_t>(c.k)] = id;
            add(p, id);
        }
    }
    for (std::size_t p = 0; p < n; ++p)
        for (const auto& t : triangulate(scene.patches[p].polygon)) {
            mesh.triangles.push_back({corner[p][static_cast<std::size_t>(t[0])],
                                      corner[p][static_cast<std::size_t>(t[1])],
                                      corner[p][static_cast<std::size_t>(t[2])]});
            mesh.triangle_patch.push_back(static_cast<int>(p));
        }
    mesh.values.resize(mesh.positions.size());
    for (std::size_t v = 0; v < mesh.positions.size(); ++v)
        mesh.values[v] = weight[v] > 0.0 ? Rgb(sum[v] / weight[v])
                                         : Rgb::Constant(std::numeric_limits<double>::quiet_NaN());
    return mesh;
}

double linear_to_srgb(double v) {
    if (!(v > 0.0)) return 0.0;
    if (v >= 1.0) return 1.0;
    return v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055;
}

double srgb_to_linear(double c) {
    return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4);
}

std::uint8_t linear_to_srgb8(double v) {
    return static_cast<std::uint8_t>(std::lround(255.0 * linear_to_srgb(v)));
}

double patch_luminance_quantile(const Scene& scene, const std::vector<Rgb>& values,
                                const std::vector<bool>& emitters, double q) {
    std::vector<std::pair<double, double>> lw;  // (luminance, area)
    double total = 0.0;
    for (std::size_t i = 0; i < values.size(); ++i) {
        if (i < emitters.size() && emitters[i]) continue;
        const double y = luminance(values[i]);
        if (!std::isfinite(y)) continue;
        const double a = i < scene.patches.size() ? scene.patches[i].area : 1.0;
        lw.emplace_back(y, a);
        total += a;
    }
    if (lw.empty() || total <= 0.0) return 0.0;
    std::sort(lw.begin(), lw.end());
    double acc = 0.0;
    for (const auto& [y, a] : lw) {
        acc += a;
        if (acc >= q * total) return y;
    }
    return lw.back().first;
}

void write_bytes_atomically(const std::string& path, const std::string& bytes) {
    write_file_atomically(path, [&](std::ostream& out) {
        out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    });
}

}  // namespace formfactor::detail
