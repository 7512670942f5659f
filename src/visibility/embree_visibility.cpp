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
#include "formfactor/visibility/visibility.h"

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
        // Geometry: every patch, then every obstruction-only surface.
        Bounds3 box;
        std::vector<const Polygon*> polys;
        std::vector<int> owner;  // patch index or −1
        std::vector<Vec3> owner_normal;
        for (std::size_t p = 0; p < scene.patches.size(); ++p) {
            polys.push_back(&scene.patches[p].polygon);
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
    }

    ~EmbreeVisibility() override {
        scene_.reset();  // before its device
    }
    EmbreeVisibility(const EmbreeVisibility&) = delete;
    EmbreeVisibility& operator=(const EmbreeVisibility&) = delete;

    double epsilon() const override { return epsilon_; }
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
    }

    void first_hit(std::span<const RayQuery> queries, std::span<RayHit> hits) const override {
        FF_ASSERT(queries.size() == hits.size());
        constexpr std::size_t kChunk = 64;
        RTCIntersectContext ctx;
        rtcInitIntersectContext(&ctx);
        ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
        std::array<RTCRayHit, kChunk> rh;
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
                    continue;
                }
                const unsigned prim = rh[k].hit.primID;
                out.patch = tri_owner_[prim];
                const auto& n = tri_normal_[prim];
                out.front =
                    n[0] * rh[k].ray.dir_x + n[1] * rh[k].ray.dir_y + n[2] * rh[k].ray.dir_z < 0.0f;
                out.distance = rh[k].ray.tfar;
                if (!out.front || out.patch < 0) resolve_twin(rh[k].ray, prim, out);
            }
        }
        errors_.check("intersection query");
    }

  private:
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
    mutable ErrorSink errors_;
    Vec3 center_ = Vec3::Zero();
    double epsilon_ = 0.0;
    std::size_t triangles_ = 0;
    std::vector<Vec3> patch_normal_;
    std::vector<int> tri_owner_;
    std::vector<std::array<float, 3>> tri_normal_;
};

}  // namespace

std::unique_ptr<Visibility> make_visibility(const Scene& scene, const VisibilityOptions& options) {
    return std::make_unique<EmbreeVisibility>(scene, options);
}

}  // namespace formfactor
