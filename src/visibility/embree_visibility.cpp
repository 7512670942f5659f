// The Embree back-end of Visibility: the only file of formfactor that includes Embree.
#include <embree3/rtcore.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "formfactor/core/error.h"
#include "formfactor/scene/closure.h"
#include "formfactor/visibility/visibility.h"
#include "geometry/box_tree.h"

namespace formfactor {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

const char* error_name(RTCError code) {
    switch (code) {
        case RTC_ERROR_NONE:
            return "no error";
        case RTC_ERROR_UNKNOWN:
            return "unknown error";
        case RTC_ERROR_INVALID_ARGUMENT:
            return "invalid argument";
        case RTC_ERROR_INVALID_OPERATION:
            return "invalid operation";
        case RTC_ERROR_OUT_OF_MEMORY:
            return "out of memory";
        case RTC_ERROR_UNSUPPORTED_CPU:
            return "unsupported CPU";
        case RTC_ERROR_CANCELLED:
            return "cancelled";
    }
    return "unrecognised error";
}

// Collects the first error Embree reports through its callback; checked after each API step so
// that it becomes a formfactor::Error on the caller's thread (never thrown from a callback).
struct ErrorSink {
    std::atomic<bool> failed{false};
    std::mutex mutex;
    std::string message;
    static void callback(void* user, RTCError code, const char* str) {
        auto* self = static_cast<ErrorSink*>(user);
        std::lock_guard<std::mutex> lock(self->mutex);
        if (self->message.empty())
            self->message = std::string(error_name(code)) + (str ? std::string(": ") + str : "");
        self->failed = true;
    }
    void check(const char* what) {
        if (!failed.load(std::memory_order_relaxed)) return;
        std::lock_guard<std::mutex> lock(mutex);
        throw Error(std::string("ray tracer (Embree) ") + what + ": " + message);
    }
};

struct DeviceDeleter {
    void operator()(RTCDevice d) const { rtcReleaseDevice(d); }
};
struct SceneDeleter {
    void operator()(RTCScene s) const { rtcReleaseScene(s); }
};
using DeviceHandle = std::unique_ptr<RTCDeviceTy, DeviceDeleter>;
using SceneHandle = std::unique_ptr<RTCSceneTy, SceneDeleter>;

class EmbreeVisibility final : public Visibility {
  public:
    EmbreeVisibility(const Scene& scene, const VisibilityOptions& options) : options_(options) {
        // A closed model is traced on its welded vertices (shared edges then share their
        // floats) and its first hits are re-cast watertight when they find no front face.
        const WeldedPatches welded = weld_patches(scene);
        closed_ = check_closure(scene, welded).closed;
        tolerance_ = welded.tolerance;
        std::vector<Polygon> welded_polys;
        if (closed_) {
            welded_polys.resize(scene.patches.size());
            for (std::size_t p = 0; p < scene.patches.size(); ++p)
                for (int v : welded.vertex[p])
                    welded_polys[p].vertices.push_back(
                        welded.positions[static_cast<std::size_t>(v)]);
        }
        // Geometry: every patch, then every obstruction-only surface.
        Bounds3 box;
        std::vector<const Polygon*> polys;
        std::vector<int> owner;  // patch index or −1
        std::vector<Vec3> owner_normal;
        for (std::size_t p = 0; p < scene.patches.size(); ++p) {
            polys.push_back(closed_ ? &welded_polys[p] : &scene.patches[p].polygon);
            owner.push_back(static_cast<int>(p));
            Vec3 n = scene.patches[p].normal;
            if (!(n.squaredNorm() > 0)) n = normal(scene.patches[p].polygon);
            owner_normal.push_back(n);
            patch_normal_.push_back(n);
        }
        for (const Surface& s : scene.surfaces) {
            if (!s.obstruction) continue;
            polys.push_back(&s.polygon);
            owner.push_back(RayHit::kObstructionHit);
            owner_normal.push_back(normal(s.polygon));
        }
        for (const Polygon* p : polys)
            for (const Vec3& v : p->vertices) {
                if (!v.allFinite()) throw GeometryError("visibility: non-finite vertex coordinate");
                box.extend(v);
            }
        if (box.empty()) throw GeometryError("visibility: the scene has no surfaces");
        center_ = 0.5 * (box.lo + box.hi);
        const double diag = box.diagonal().norm();
        // Float resolution at the (centred) coordinates' magnitude: never go below ~64 ulps.
        const double ulp = diag * std::ldexp(1.0, -23);
        epsilon_ = std::max(options.relative_epsilon * diag, 64.0 * ulp);
        if (!(epsilon_ > 0)) epsilon_ = 1e-9;

        std::vector<std::array<float, 3>> verts;
        std::vector<std::array<unsigned, 3>> tris;
        for (std::size_t k = 0; k < polys.size(); ++k) {
            const Polygon& poly = *polys[k];
            const unsigned base = static_cast<unsigned>(verts.size());
            for (const Vec3& v : poly.vertices) {
                const Vec3 c = v - center_;
                verts.push_back({static_cast<float>(c.x()), static_cast<float>(c.y()),
                                 static_cast<float>(c.z())});
            }
            std::vector<std::array<int, 3>> t;
            if (poly.size() == 3)
                t.push_back({0, 1, 2});
            else
                t = triangulate(poly);
            if (closed_) {
                if (owner[k] >= 0) patch_first_tri_.push_back(exact_.size());
                for (const auto& tri : t) {
                    std::array<Vec3, 3> welded_tri, raw_tri;
                    for (int j = 0; j < 3; ++j) {
                        const auto v = static_cast<std::size_t>(tri[static_cast<std::size_t>(j)]);
                        welded_tri[static_cast<std::size_t>(j)] = poly[v];
                        if (owner[k] >= 0)
                            raw_tri[static_cast<std::size_t>(j)] =
                                scene.patches[static_cast<std::size_t>(owner[k])].polygon[v];
                    }
                    exact_.push_back(welded_tri);
                    if (owner[k] >= 0) raw_.push_back(raw_tri);
                    exact_owner_.push_back(owner[k]);
                    exact_normal_.push_back(owner_normal[k]);
                }
            }
            for (const auto& tri : t) {
                tris.push_back({base + static_cast<unsigned>(tri[0]),
                                base + static_cast<unsigned>(tri[1]),
                                base + static_cast<unsigned>(tri[2])});
                tri_owner_.push_back(owner[k]);
                const Vec3& n = owner_normal[k];
                tri_normal_.push_back({static_cast<float>(n.x()), static_cast<float>(n.y()),
                                       static_cast<float>(n.z())});
            }
        }
        if (tris.empty()) throw GeometryError("visibility: the scene has no triangles");
        if (closed_) {
            patch_first_tri_.push_back(raw_.size());
            // Boxes padded by the vertex tolerance: the traversal's rounding cannot lose a hit.
            std::vector<Bounds3> boxes(exact_.size());
            for (std::size_t k = 0; k < exact_.size(); ++k) {
                for (const Vec3& v : exact_[k]) boxes[k].extend(v);
                boxes[k].lo.array() -= tolerance_;
                boxes[k].hi.array() += tolerance_;
            }
            exact_tree_.build(
                boxes.size(), [&](int k) -> const Bounds3& { return boxes[std::size_t(k)]; }, 4);
        }

        {
            // Embree's device creation writes process-wide state (ThreadSanitizer saw two
            // computations started at once race inside rtcNewDevice): one at a time.
            static std::mutex device_mutex;
            std::lock_guard<std::mutex> lock(device_mutex);
            device_.reset(rtcNewDevice(nullptr));
        }
        if (!device_)
            throw Error(std::string("ray tracer (Embree) device: ") +
                        error_name(rtcGetDeviceError(nullptr)));
        rtcSetDeviceErrorFunction(device_.get(), &ErrorSink::callback, &errors_);
        scene_.reset(rtcNewScene(device_.get()));
        // The context filter serves only the re-queries of the twin rule (first_hit); queries
        // without a filter in their context do not call it.
        rtcSetSceneFlags(scene_.get(),
                         (options.robust ? RTC_SCENE_FLAG_ROBUST : RTC_SCENE_FLAG_NONE) |
                             RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION);
        rtcSetSceneBuildQuality(scene_.get(), RTC_BUILD_QUALITY_HIGH);
        RTCGeometry geom = rtcNewGeometry(device_.get(), RTC_GEOMETRY_TYPE_TRIANGLE);
        errors_.check("geometry");
        auto* vb = static_cast<float*>(rtcSetNewGeometryBuffer(
            geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), verts.size()));
        auto* ib = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
            geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), tris.size()));
        if (!vb || !ib) {
            rtcReleaseGeometry(geom);
            errors_.check("buffers");
            throw Error("ray tracer (Embree): could not allocate geometry buffers");
        }
        std::copy(&verts[0][0], &verts[0][0] + 3 * verts.size(), vb);
        std::copy(&tris[0][0], &tris[0][0] + 3 * tris.size(), ib);
        rtcCommitGeometry(geom);
        rtcAttachGeometry(scene_.get(), geom);
        rtcReleaseGeometry(geom);
        rtcCommitScene(scene_.get());
        errors_.check("scene build");
        triangles_ = tris.size();
        if (closed_) build_edge_scene();
    }

    ~EmbreeVisibility() override {
        edge_scene_.reset();  // scenes before their device
        scene_.reset();
    }
    EmbreeVisibility(const EmbreeVisibility&) = delete;
    EmbreeVisibility& operator=(const EmbreeVisibility&) = delete;

    double epsilon() const override { return epsilon_; }
    bool closed() const override { return closed_; }
    std::uint64_t recast_rays() const override { return recast_.load(std::memory_order_relaxed); }
    std::uint64_t rechecked_segments() const override {
        return rechecked_.load(std::memory_order_relaxed);
    }
    std::uint64_t segments_blocked_by_recheck() const override {
        return recheck_blocked_.load(std::memory_order_relaxed);
    }
    std::size_t triangle_count() const override { return triangles_; }
    std::string description() const override {
        return "embree " + std::to_string(RTC_VERSION_MAJOR) + "." +
               std::to_string(RTC_VERSION_MINOR) + "." + std::to_string(RTC_VERSION_PATCH) + ", " +
               std::to_string(triangles_) + " triangles";
    }

    void occluded(std::span<const SegmentQuery> queries,
                  std::span<std::uint8_t> blocked) const override {
        FF_ASSERT(queries.size() == blocked.size());
        constexpr std::size_t kChunk = 64;
        RTCIntersectContext ctx;
        rtcInitIntersectContext(&ctx);
        ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
        for (std::size_t start = 0; start < queries.size(); start += kChunk) {
            const std::size_t m = std::min(kChunk, queries.size() - start);
            switch (options_.batching) {
                case VisibilityOptions::Batching::single:
                    for (std::size_t k = 0; k < m; ++k) {
                        RTCRay ray;
                        make_segment(queries[start + k], ray);
                        rtcOccluded1(scene_.get(), &ctx, &ray);
                        blocked[start + k] = ray.tfar < 0.0f ? 1 : 0;
                    }
                    break;
                case VisibilityOptions::Batching::stream: {
                    std::array<RTCRay, kChunk> rays;
                    for (std::size_t k = 0; k < m; ++k) make_segment(queries[start + k], rays[k]);
                    rtcOccluded1M(scene_.get(), &ctx, rays.data(), static_cast<unsigned>(m),
                                  sizeof(RTCRay));
                    for (std::size_t k = 0; k < m; ++k)
                        blocked[start + k] = rays[k].tfar < 0.0f ? 1 : 0;
                    break;
                }
                case VisibilityOptions::Batching::packet16:
                    for (std::size_t b = 0; b < m; b += 16) {
                        alignas(64) RTCRay16 packet;
                        alignas(64) int valid[16];
                        const std::size_t w = std::min<std::size_t>(16, m - b);
                        for (std::size_t k = 0; k < 16; ++k) {
                            valid[k] = k < w ? -1 : 0;
                            RTCRay ray;
                            if (k < w)
                                make_segment(queries[start + b + k], ray);
                            else
                                ray = RTCRay{0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0};
                            store(packet, k, ray);
                        }
                        rtcOccluded16(valid, scene_.get(), &ctx, &packet);
                        for (std::size_t k = 0; k < w; ++k)
                            blocked[start + b + k] = packet.tfar[k] < 0.0f ? 1 : 0;
                    }
                    break;
            }
        }
        errors_.check("occlusion query");
        if (closed_) recheck_segments(queries, blocked);
        errors_.check("edge query");
    }

    void first_hit(std::span<const RayQuery> queries, std::span<RayHit> hits) const override {
        FF_ASSERT(queries.size() == hits.size());
        constexpr std::size_t kChunk = 64;
        RTCIntersectContext ctx;
        rtcInitIntersectContext(&ctx);
        ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
        std::array<RTCRayHit, kChunk> rh;
        std::uint64_t recast = 0;
        for (std::size_t start = 0; start < queries.size(); start += kChunk) {
            const std::size_t m = std::min(kChunk, queries.size() - start);
            for (std::size_t k = 0; k < m; ++k) {
                make_ray(queries[start + k], rh[k].ray);
                rh[k].hit.geomID = RTC_INVALID_GEOMETRY_ID;
                rh[k].hit.primID = RTC_INVALID_GEOMETRY_ID;
                rh[k].hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
            }
            if (options_.batching == VisibilityOptions::Batching::stream) {
                rtcIntersect1M(scene_.get(), &ctx, rh.data(), static_cast<unsigned>(m),
                               sizeof(RTCRayHit));
            } else {
                for (std::size_t k = 0; k < m; ++k) rtcIntersect1(scene_.get(), &ctx, &rh[k]);
            }
            for (std::size_t k = 0; k < m; ++k) {
                RayHit& out = hits[start + k];
                if (rh[k].hit.geomID == RTC_INVALID_GEOMETRY_ID) {
                    out = RayHit{};
                } else {
                    const unsigned prim = rh[k].hit.primID;
                    out.patch = tri_owner_[prim];
                    const auto& n = tri_normal_[prim];
                    out.front =
                        n[0] * rh[k].ray.dir_x + n[1] * rh[k].ray.dir_y + n[2] * rh[k].ray.dir_z <
                        0.0f;
                    out.distance = rh[k].ray.tfar;
                    if (!out.front || out.patch < 0) resolve_twin(rh[k].ray, prim, out);
                }
                // From inside a closed model only a front face (or an obstruction) can be met.
                if (closed_ && (out.patch == RayHit::kMiss || (out.patch >= 0 && !out.front))) {
                    ++recast;
                    recast_exact(queries[start + k], out);
                }
            }
        }
        if (recast) recast_.fetch_add(recast, std::memory_order_relaxed);
        errors_.check("intersection query");
    }

  private:
    // Capsules of radius epsilon() around every edge of every welded triangle (closed models):
    // the segments that pass near an edge, which recheck_segments() checks again.
    void build_edge_scene() {
        edge_scene_.reset(rtcNewScene(device_.get()));
        RTCGeometry geom = rtcNewGeometry(device_.get(), RTC_GEOMETRY_TYPE_ROUND_LINEAR_CURVE);
        errors_.check("edge geometry");
        const std::size_t edges = 3 * exact_.size();
        auto* vb = static_cast<float*>(rtcSetNewGeometryBuffer(
            geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4, 4 * sizeof(float), 2 * edges));
        auto* ib = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
            geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT, sizeof(unsigned), edges));
        if (!vb || !ib) {
            rtcReleaseGeometry(geom);
            errors_.check("edge buffers");
            throw Error("ray tracer (Embree): could not allocate edge buffers");
        }
        const auto radius = static_cast<float>(epsilon_);
        std::size_t e = 0;
        for (const auto& tri : exact_)
            for (int k = 0; k < 3; ++k, ++e) {
                for (int end = 0; end < 2; ++end) {
                    const Vec3 v = tri[static_cast<std::size_t>((k + end) % 3)] - center_;
                    float* out = vb + 4 * (2 * e + static_cast<std::size_t>(end));
                    out[0] = static_cast<float>(v.x());
                    out[1] = static_cast<float>(v.y());
                    out[2] = static_cast<float>(v.z());
                    out[3] = radius;
                }
                ib[e] = static_cast<unsigned>(2 * e);
            }
        rtcCommitGeometry(geom);
        rtcAttachGeometry(edge_scene_.get(), geom);
        rtcReleaseGeometry(geom);
        rtcCommitScene(edge_scene_.get());
        errors_.check("edge scene build");
    }

    // The ray of q cast again in double precision from q.origin itself (not moved off its
    // patch, but onto its welded triangles) against the welded triangles (closed models): the
    // nearest front face of a patch other than q.from_patch at t ≥ −tolerance_, or an
    // obstruction at t > 0, replaces `out`;
    // when there is none, `out` stays. Watertight: Woop, Benthin & Wald, "Watertight
    // Ray/Triangle Intersection", JCGT 2(1), 2013 — the edge functions of a shared edge are
    // computed from the same two transformed vertices, so a ray through the edge (or a shared
    // vertex) meets at least one of its triangles. The library is built with -ffp-contract=off,
    // so no fused multiply-add breaks their antisymmetry.
    // A grazing ray (nearly in the plane of its patch) can leave through the crease where its
    // patch meets a neighbour tilted by rounding or jitter, crossing the neighbour's plane on
    // their common edge: neither triangle then has to take it (a direction sampled at θ = 90°
    // lies in the patch's plane). Such a ray is cast once more from the vertex tolerance in
    // front of its patch (the side that faces the inside of a closed model).
    void recast_exact(const RayQuery& q, RayHit& out) const {
        if (exact_tree_.nodes.empty()) return;
        const double len = q.direction.norm();
        const Vec3 d = len > 0 ? Vec3(q.direction / len) : Vec3::UnitZ();
        const Vec3 o = q.from_patch >= 0 ? on_welded(q.origin, q.from_patch) : q.origin;
        double t = 0.0;
        int tri = exact_first_hit(o, d, q.from_patch, t);
        if (tri < 0 && q.from_patch >= 0) {
            const Vec3& n = patch_normal_[static_cast<std::size_t>(q.from_patch)];
            tri = exact_first_hit(o + tolerance_ * n, d, q.from_patch, t);
        }
        if (tri < 0) return;
        const auto bt = static_cast<std::size_t>(tri);
        out.patch = exact_owner_[bt];
        out.front = exact_normal_[bt].dot(d) < 0;
        out.distance = std::max(t, 0.0);
    }

    // The segments of a closed model that the ray tracer found clear, checked again. Single
    // precision misses a crossing only within its rounding of a triangle's edge; a segment that
    // passes no edge closer than epsilon() (~100 times that rounding; Embree's capsules of that
    // radius around every triangle edge, edge_scene_) has had every crossing found. The others
    // are checked in double precision against the welded triangles with the watertight test of
    // recast_exact(): a segment between two points of the model that leaves the volume crosses
    // its surface, and a crossing through a shared edge or vertex is found there. Ends as in
    // make_segment(): a blocker closer than epsilon() to an end is not seen (nor an edge), and
    // the end patches never block.
    void recheck_segments(std::span<const SegmentQuery> queries,
                          std::span<std::uint8_t> blocked) const {
        if (exact_tree_.nodes.empty() || !edge_scene_) return;
        constexpr std::size_t kChunk = 64;
        RTCIntersectContext ctx;
        rtcInitIntersectContext(&ctx);
        ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
        std::array<RTCRay, kChunk> rays;
        std::array<std::size_t, kChunk> which;
        std::uint64_t checked = 0, found = 0;
        for (std::size_t start = 0; start < queries.size();) {
            // The next clear segments, as rays over [margin, 1 − margin] of the segment.
            std::size_t m = 0;
            for (; start < queries.size() && m < kChunk; ++start) {
                if (blocked[start]) continue;
                make_segment(queries[start], rays[m]);
                const double len = std::sqrt(double(rays[m].dir_x) * rays[m].dir_x +
                                             double(rays[m].dir_y) * rays[m].dir_y +
                                             double(rays[m].dir_z) * rays[m].dir_z);
                if (!(len > 2 * epsilon_)) continue;
                rays[m].tnear = static_cast<float>(epsilon_ / len);
                rays[m].tfar = static_cast<float>(1.0 - epsilon_ / len);
                which[m++] = start;
            }
            if (m == 0) continue;
            rtcOccluded1M(edge_scene_.get(), &ctx, rays.data(), static_cast<unsigned>(m),
                          sizeof(RTCRay));
            for (std::size_t k = 0; k < m; ++k) {
                if (!(rays[k].tfar < 0.0f)) continue;  // no edge nearby
                ++checked;
                if (exact_segment_blocked(queries[which[k]])) {
                    blocked[which[k]] = 1;
                    ++found;
                }
            }
        }
        if (checked) rechecked_.fetch_add(checked, std::memory_order_relaxed);
        if (found) recheck_blocked_.fetch_add(found, std::memory_order_relaxed);
    }

    // Is segment q blocked, in double precision against the welded triangles (see
    // recheck_segments)?
    bool exact_segment_blocked(const SegmentQuery& q) const {
        const Vec3 a = q.from_patch >= 0 ? on_welded(q.from, q.from_patch) : q.from;
        const Vec3 b = q.to_patch >= 0 ? on_welded(q.to, q.to_patch) : q.to;
        const Vec3 d = b - a;
        const double len = d.norm();
        if (!(len > 2 * epsilon_)) return false;
        const double margin = epsilon_ / len;  // t of the segment runs over [0, 1]
        const int from = q.from_patch, to = q.to_patch;
        double t = 0.0;
        return exact_traverse(
                   a, d, margin, 1.0 - margin, true,
                   [&](int owner, double, double) {
                       return owner < 0 || (owner != from && owner != to);
                   },
                   t) >= 0;
    }

    // The welded triangle the unit ray o + t d meets first (see recast_exact), its t in `hit_t`;
    // −1 for none.
    int exact_first_hit(const Vec3& o, const Vec3& d, int from_patch, double& hit_t) const {
        return exact_traverse(
            o, d, -tolerance_, std::numeric_limits<double>::infinity(), false,
            [&](int owner, double c, double t) {
                if (owner < 0) return t > 0;  // an obstruction blocks from both sides
                // Another patch's front (a patch's back cannot be met from inside).
                return owner != from_patch && c < 0;
            },
            hit_t);
    }

    // The welded triangles that the ray o + t d (d of any length > 0) meets for t in
    // [t_lo, t_hi] and that accept(owner, normal · d, t) takes: the nearest one (any_hit false)
    // or the first one found (any_hit true), its t in `hit_t`; −1 for none. The watertight test
    // of Woop, Benthin & Wald (2013): the ray is sheared so that it runs along +z, and the
    // signed areas u, w, x of the triangle's edges seen from the ray are computed from the same
    // two transformed vertices for both triangles of a shared edge.
    template <class Accept>
    int exact_traverse(const Vec3& o, const Vec3& d, double t_lo, double t_hi, bool any_hit,
                       const Accept& accept, double& hit_t) const {
        int kz = 0;
        if (std::abs(d.y()) > std::abs(d[kz])) kz = 1;
        if (std::abs(d.z()) > std::abs(d[kz])) kz = 2;
        int kx = (kz + 1) % 3, ky = (kx + 1) % 3;
        if (d[kz] < 0) std::swap(kx, ky);
        const double sx = d[kx] / d[kz], sy = d[ky] / d[kz], sz = 1.0 / d[kz];
        double best = t_hi;
        int best_tri = -1;
        int stack[128];
        int top = 0;
        stack[top++] = 0;
        while (top > 0) {
            const detail::BoxTree::Node& node =
                exact_tree_.nodes[static_cast<std::size_t>(stack[--top])];
            if (!box_hit(node.box, o, d, t_lo, best)) continue;
            if (node.left < 0) {
                for (int k = node.first; k < node.first + node.count; ++k) {
                    const int tri = exact_tree_.order[static_cast<std::size_t>(k)];
                    const auto ti = static_cast<std::size_t>(tri);
                    const auto& v = exact_[ti];
                    double ex[3], ey[3], ez[3];
                    for (int j = 0; j < 3; ++j) {
                        const Vec3 r = v[static_cast<std::size_t>(j)] - o;
                        ex[j] = r[kx] - sx * r[kz];
                        ey[j] = r[ky] - sy * r[kz];
                        ez[j] = sz * r[kz];
                    }
                    const double u = ex[2] * ey[1] - ey[2] * ex[1];
                    const double w = ex[0] * ey[2] - ey[0] * ex[2];
                    const double x = ex[1] * ey[0] - ey[1] * ex[0];
                    if ((u < 0 || w < 0 || x < 0) && (u > 0 || w > 0 || x > 0)) continue;
                    const double det = u + w + x;
                    if (det == 0) continue;
                    const double t = (u * ez[0] + w * ez[1] + x * ez[2]) / det;
                    if (!(t >= t_lo && t < best)) continue;
                    if (!accept(exact_owner_[ti], exact_normal_[ti].dot(d), t)) continue;
                    best = t;
                    best_tri = tri;
                    if (any_hit) {
                        hit_t = best;
                        return best_tri;
                    }
                }
            } else {
                FF_ASSERT(top + 2 <= 128);  // median splits: depth ~ log2(triangles)
                stack[top++] = node.right;
                stack[top++] = node.left;
            }
        }
        hit_t = best;
        return best_tri;
    }

    // The point of patch p's welded triangles with the barycentric coordinates that `x` has in
    // its own (unwelded) triangles, in the triangle that holds it best: a sample point of the
    // patch moved onto the welded surface, so that it is never outside the closed model.
    Vec3 on_welded(const Vec3& x, int p) const {
        const auto pp = static_cast<std::size_t>(p);
        double best = -std::numeric_limits<double>::infinity();
        Vec3 at = x;
        for (std::size_t k = patch_first_tri_[pp]; k < patch_first_tri_[pp + 1]; ++k) {
            const auto& r = raw_[k];
            const Vec3 e0 = r[1] - r[0], e1 = r[2] - r[0], e2 = x - r[0];
            const double d00 = e0.dot(e0), d01 = e0.dot(e1), d11 = e1.dot(e1);
            const double d20 = e2.dot(e0), d21 = e2.dot(e1);
            const double den = d00 * d11 - d01 * d01;
            if (!(den > 0)) continue;
            const double b1 = (d11 * d20 - d01 * d21) / den, b2 = (d00 * d21 - d01 * d20) / den;
            const double b0 = 1.0 - b1 - b2;
            const double worst = std::min(b0, std::min(b1, b2));
            if (worst > best) {
                best = worst;
                const auto& w = exact_[k];
                at = b0 * w[0] + b1 * w[1] + b2 * w[2];
            }
        }
        return at;
    }

    // Does the ray o + t d meet `box` for some t in [t0, t1]? (Boxes are padded by
    // tolerance_, far more than the rounding of these divisions.)
    static bool box_hit(const Bounds3& box, const Vec3& o, const Vec3& d, double t0, double t1) {
        for (int a = 0; a < 3; ++a) {
            if (d[a] == 0) {
                if (o[a] < box.lo[a] || o[a] > box.hi[a]) return false;
                continue;
            }
            double ta = (box.lo[a] - o[a]) / d[a], tb = (box.hi[a] - o[a]) / d[a];
            if (ta > tb) std::swap(ta, tb);
            t0 = std::max(t0, ta);
            t1 = std::min(t1, tb);
        }
        return t0 <= t1;
    }

    // An intersection context whose filter accepts only hits on the front of a patch.
    struct FrontOnlyContext {
        RTCIntersectContext context;  // first: Embree passes a pointer to it to the filter
        const EmbreeVisibility* self;
    };

    static void front_only_filter(const RTCFilterFunctionNArguments* args) {
        const auto* self = reinterpret_cast<const FrontOnlyContext*>(args->context)->self;
        const unsigned N = args->N;
        for (unsigned i = 0; i < N; ++i) {
            if (args->valid[i] != -1) continue;
            const unsigned prim = RTCHitN_primID(args->hit, N, i);
            const auto& n = self->tri_normal_[prim];
            const float c = n[0] * RTCRayN_dir_x(args->ray, N, i) +
                            n[1] * RTCRayN_dir_y(args->ray, N, i) +
                            n[2] * RTCRayN_dir_z(args->ray, N, i);
            if (self->tri_owner_[prim] < 0 || !(c < 0.0f)) args->valid[i] = 0;
        }
    }

    // The twin rule (visibility.h): `ray` first met triangle `prim`, the back of a patch or an
    // obstruction, at ray.tfar. If the ray meets the front of a patch within epsilon() of that
    // triangle's plane (a one-sided face modelled back to back with this one, or a patch lying
    // on an obstruction), that front face takes the hit. Only these rays pay for the re-query:
    // in a closed scene they are rare.
    void resolve_twin(const RTCRay& ray, unsigned prim, RayHit& out) const {
        const auto& n = tri_normal_[prim];
        const float c = std::abs(n[0] * ray.dir_x + n[1] * ray.dir_y + n[2] * ray.dir_z);
        // The slab |distance to the plane| ≤ epsilon() along the ray (grazing rays: at most
        // 1e6 epsilon() long).
        const float half = static_cast<float>(epsilon_) / std::max(c, 1e-6f);
        RTCRayHit rh;
        rh.ray = ray;
        rh.ray.tnear = std::max(0.0f, ray.tfar - half);
        rh.ray.tfar = ray.tfar + half;
        rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
        rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
        rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
        FrontOnlyContext ctx;
        rtcInitIntersectContext(&ctx.context);
        ctx.context.filter = &front_only_filter;
        ctx.self = this;
        rtcIntersect1(scene_.get(), &ctx.context, &rh);
        if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return;
        out.patch = tri_owner_[rh.hit.primID];
        out.front = true;
        out.distance = rh.ray.tfar;
    }

    // Segment: both ends moved off their own patch's plane, towards the side the segment lies.
    void make_segment(const SegmentQuery& q, RTCRay& ray) const {
        Vec3 a = q.from, b = q.to;
        const Vec3 d = b - a;
        if (q.from_patch >= 0) {
            const Vec3& n = patch_normal_[static_cast<std::size_t>(q.from_patch)];
            a += (d.dot(n) >= 0 ? epsilon_ : -epsilon_) * n;
        }
        if (q.to_patch >= 0) {
            const Vec3& n = patch_normal_[static_cast<std::size_t>(q.to_patch)];
            b += (d.dot(n) <= 0 ? epsilon_ : -epsilon_) * n;
        }
        fill_ray(a - center_, b - a, 1.0f, ray);
    }

    void make_ray(const RayQuery& q, RTCRay& ray) const {
        const double len = q.direction.norm();
        const Vec3 dir = len > 0 ? Vec3(q.direction / len) : Vec3::UnitZ();
        Vec3 a = q.origin;
        if (q.from_patch >= 0) {
            const Vec3& n = patch_normal_[static_cast<std::size_t>(q.from_patch)];
            a += (dir.dot(n) >= 0 ? epsilon_ : -epsilon_) * n;
        }
        fill_ray(a - center_, dir, kInf, ray);
    }

    // A ray from o (relative to center_) along dir, t in [0, tfar], in single precision.
    static void fill_ray(const Vec3& o, const Vec3& dir, float tfar, RTCRay& ray) {
        ray.org_x = static_cast<float>(o.x());
        ray.org_y = static_cast<float>(o.y());
        ray.org_z = static_cast<float>(o.z());
        ray.dir_x = static_cast<float>(dir.x());
        ray.dir_y = static_cast<float>(dir.y());
        ray.dir_z = static_cast<float>(dir.z());
        ray.tnear = 0.0f;
        ray.tfar = tfar;
        ray.time = 0.0f;
        ray.mask = 0xFFFFFFFFu;
        ray.id = 0;
        ray.flags = 0;
    }

    static void store(RTCRay16& p, std::size_t k, const RTCRay& r) {
        p.org_x[k] = r.org_x;
        p.org_y[k] = r.org_y;
        p.org_z[k] = r.org_z;
        p.tnear[k] = r.tnear;
        p.dir_x[k] = r.dir_x;
        p.dir_y[k] = r.dir_y;
        p.dir_z[k] = r.dir_z;
        p.time[k] = r.time;
        p.tfar[k] = r.tfar;
        p.mask[k] = r.mask;
        p.id[k] = r.id;
        p.flags[k] = r.flags;
    }

    VisibilityOptions options_;
    DeviceHandle device_;
    SceneHandle scene_;
    SceneHandle edge_scene_;  // closed models: capsules around the triangles' edges
    mutable ErrorSink errors_;
    Vec3 center_ = Vec3::Zero();
    double epsilon_ = 0.0;
    std::size_t triangles_ = 0;
    std::vector<Vec3> patch_normal_;
    std::vector<int> tri_owner_;
    std::vector<std::array<float, 3>> tri_normal_;
    // Closed models: the welded triangles in double, their owners and normals, their tree.
    bool closed_ = false;
    double tolerance_ = 0.0;
    std::vector<std::array<Vec3, 3>> exact_;
    std::vector<std::array<Vec3, 3>> raw_;      // the patches' triangles before welding
    std::vector<std::size_t> patch_first_tri_;  // patch p: triangles [first[p], first[p + 1])
    std::vector<int> exact_owner_;
    std::vector<Vec3> exact_normal_;
    detail::BoxTree exact_tree_;
    mutable std::atomic<std::uint64_t> recast_{0};
    mutable std::atomic<std::uint64_t> rechecked_{0}, recheck_blocked_{0};
};

}  // namespace

std::unique_ptr<Visibility> make_visibility(const Scene& scene, const VisibilityOptions& options) {
    return std::make_unique<EmbreeVisibility>(scene, options);
}

}  // namespace formfactor
