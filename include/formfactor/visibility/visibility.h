#pragma once
/// Ray-cast visibility between points of a scene (DESIGN.md, "Data flow": Visibility).
///
/// Every patch and every obstruction-only surface is geometry; every surface blocks from both
/// sides. Queries come in batches (one virtual call per batch, never per ray) and are
/// thread-safe: any number of threads may query one Visibility at once.
///
/// Precision. The ray tracer (Embree) works in single precision. To keep that precision
/// independent of where the scene sits, geometry and queries are translated (in double) so that
/// the scene's bounding-box centre is the origin before they are rounded to float: a scene at
/// 1e4 from the origin is traced as accurately as one at the origin. Ray ends that lie on a
/// patch are then moved off that patch's plane by epsilon() = relative_epsilon × the bounding
/// box diagonal (default 1e-5; float resolution is ~6e-8 of the diagonal), along the patch normal
/// towards the side the ray leaves from (or arrives at). A patch is planar, so a ray that starts
/// (ends) off its plane on the side it travels into can never hit it: no patch shadows itself,
/// coplanar neighbours cannot catch grazing rays, and queries need no hit-filter callbacks. The
/// price: a blocker closer than epsilon() to a ray end is missed (a relative 1e-5 sliver).
///
/// Twin faces. A thin plate is often modelled as two one-sided patches back to back (one facing
/// each way, on one plane). A segment ending on either is not blocked by the other (its end is
/// moved off the plane, towards the side it comes from). A first hit follows the same rule: when
/// a ray first meets the back of a patch or an obstruction, and meets the front of a patch
/// within epsilon() of that surface's plane, the front face takes the hit. A back face with no
/// front face coincident stays a blocker (patches are opaque), and so does an obstruction: it
/// blocks from both sides, and only a patch lying on it is seen before it.
///
/// Closed models (formfactor/scene/closure.h, docs/closed-models.md). Single-precision ray
/// casting is not watertight: a ray through a shared edge or vertex can slip between two
/// triangles, and a ray that starts within float resolution of a neighbouring face can pass
/// behind it. When the patches form a closed model, the ray tracer's triangles take the welded
/// vertices, and every first hit that finds nothing, or the back of a patch (impossible from
/// inside), is cast again in double precision from the exact origin on its patch (carried
/// onto the welded surface) against the welded triangles with a watertight test (Woop, Benthin
/// & Wald 2013): the front of a patch (or an obstruction) it meets first takes the hit. A ray
/// that this misses too is reported as a miss; the methods count it (it is a bug). Segment
/// queries (occluded()) of a closed model are made as watertight: a segment the ray tracer
/// finds clear that passes within epsilon() of a triangle's edge (where single precision can
/// miss a crossing; found with capsules of that radius around the edges) is checked again, with
/// the same double-precision test from its exact ends, for any surface between them (not
/// closer than epsilon() to an end, and not the end patches): a segment between two points of
/// the model that slips out of it through a shared edge or vertex, and back in, is blocked.
/// Open scenes are traced as before, bit for bit.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>

#include "formfactor/core/types.h"
#include "formfactor/scene/scene.h"

namespace formfactor {

/// Is the segment from `from` to `to` blocked? from_patch / to_patch name the patches the ends
/// lie on (−1: a free point, not moved; e.g. a differential element in space).
struct SegmentQuery {
    Vec3 from = Vec3::Zero();
    Vec3 to = Vec3::Zero();
    int from_patch = -1;
    int to_patch = -1;
};

/// A ray from `origin` (on patch from_patch, or −1 for a free point) along `direction` (any
/// length > 0: it is normalised; hit distances are in scene length units).
struct RayQuery {
    Vec3 origin = Vec3::Zero();
    Vec3 direction = Vec3::UnitZ();
    int from_patch = -1;
};

/// What a ray hit first.
struct RayHit {
    /// Patch index (≥ 0), kObstructionHit for an obstruction-only surface, kMiss for nothing.
    int patch = -2;
    /// True when the ray arrived on the front side of the patch (or obstruction).
    bool front = false;
    /// Distance from the query origin to the hit, in scene length units (∞ on a miss).
    double distance = std::numeric_limits<double>::infinity();

    static constexpr int kObstructionHit = -1;
    static constexpr int kMiss = -2;
    bool hit() const { return patch != kMiss; }
};

/// Options of the visibility structure.
struct VisibilityOptions {
    /// Ray-end offset relative to the scene's bounding-box diagonal (see the header comment).
    double relative_epsilon = 1e-5;
    /// Embree's robust mode (RTC_SCENE_FLAG_ROBUST: no accuracy-reducing shortcuts, slower).
    bool robust = false;
    /// How batches go to the ray tracer: one ray at a time (rtcOccluded1/rtcIntersect1), 16-wide
    /// packets (rtcOccluded16; first hits use single rays), or the stream interface
    /// (rtcOccluded1M/rtcIntersect1M). All give the same answers. Measured on incoherent rays in
    /// the Cornell box (1.4k and 9.7k triangles, 2 cores, bench_visibility): the stream is the
    /// fastest for occlusion (1.4–1.9× single rays), equal for first hits.
    enum class Batching { single, packet16, stream };
    Batching batching = Batching::stream;
};

/// Batched visibility queries against a fixed scene.
class Visibility {
  public:
    virtual ~Visibility() = default;

    /// blocked[k] = 1 when queries[k]'s segment meets any surface strictly between its ends
    /// (ends moved off their own patches, see above), else 0. Sizes must match.
    virtual void occluded(std::span<const SegmentQuery> queries,
                          std::span<std::uint8_t> blocked) const = 0;
    /// hits[k] = the first surface along queries[k] (ray start moved off its patch); the front
    /// of a patch coincident with a back face or an obstruction comes first (see "Twin faces").
    virtual void first_hit(std::span<const RayQuery> queries, std::span<RayHit> hits) const = 0;

    /// Ray-end offset in scene length units.
    virtual double epsilon() const = 0;
    /// True when the patches form a closed model (check_closure()): first hits are then
    /// re-cast watertight (see the header comment) and a miss is a bug to count.
    virtual bool closed() const = 0;
    /// First hits this structure has re-cast in double precision so far (closed models only).
    virtual std::uint64_t recast_rays() const = 0;
    /// Segments found clear by the ray tracer, passing near a triangle's edge, and checked
    /// again in double precision so far (closed models only).
    virtual std::uint64_t rechecked_segments() const = 0;
    /// Of those, the segments the double-precision check found blocked: segments that single
    /// precision let through the closed model's surface (a shared edge or vertex).
    virtual std::uint64_t segments_blocked_by_recheck() const = 0;
    /// Number of triangles in the acceleration structure (patches and obstructions).
    virtual std::size_t triangle_count() const = 0;
    /// Short description of the backend ("embree 3.13.5, ...").
    virtual std::string description() const = 0;
};

/// The warning for `escapes` rays that met no front face of a closed model (a method's report
/// field `closed_model_warning`).
inline std::string closed_model_escape_warning(std::uint64_t escapes) {
    return std::to_string(escapes) + (escapes == 1 ? " ray" : " rays") +
           " escaped a closed model (no front face met, even by the watertight re-cast): left "
           "out of their rows' estimates; this is a bug, please report the scene";
}

/// Builds the visibility structure of scene.patches and the scene's obstruction-only surfaces.
/// Throws GeometryError if the scene has no geometry, Error when the ray tracer reports one.
std::unique_ptr<Visibility> make_visibility(const Scene& scene,
                                            const VisibilityOptions& options = {});

}  // namespace formfactor
