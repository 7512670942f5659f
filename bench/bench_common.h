#pragma once
// Shared set-up of the visibility and Monte-Carlo benchmarks: scenes and pre-generated
// incoherent rays (the "raw" ray-tracer throughput that the estimators are compared with).

#include <benchmark/benchmark.h>
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <vector>

#include "formfactor/core/parallel.h"
#include "formfactor/core/random.h"
#include "formfactor/geometry/sampling.h"
#include "formfactor/scene/scene.h"
#include "formfactor/visibility/visibility.h"

namespace formfactor::bench {

/// CPU seconds of the whole process so far (all threads).
inline double process_cpu_seconds() {
    timespec t{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

/// Registers `fn` as benchmark `name` once per size listed in the environment variable `env`
/// (comma-separated integers > 0; nothing when unset), each run once, in seconds, wall time.
template <class Fn>
bool register_sizes_from_env(const char* name, Fn fn, const char* env) {
    const char* list = std::getenv(env);
    std::string rest = list ? list : "";
    while (!rest.empty()) {
        const std::size_t comma = rest.find(',');
        const int n = std::atoi(rest.substr(0, comma).c_str());
        if (n > 0)
            benchmark::RegisterBenchmark(name, fn)
                ->Arg(n)
                ->Iterations(1)
                ->Unit(benchmark::kSecond)
                ->UseRealTime();
        rest = comma == std::string::npos ? "" : rest.substr(comma + 1);
    }
    return true;
}

/// The Cornell box (with blocks) subdivided n×n per surface.
inline Scene cornell(int n) {
    Scene s = load_scene("cornell");
    subdivide(s, SubdivisionOptions{n, 0.0});
    return s;
}

/// Segments between uniform points of random patch pairs that face each other (mc-area's rays).
inline std::vector<SegmentQuery> random_segments(const Scene& s, std::size_t count) {
    std::vector<PolygonSampler> samplers;
    for (const Patch& p : s.patches) samplers.emplace_back(p.polygon);
    std::vector<SegmentQuery> q;
    q.reserve(count);
    PointSet4 rnd(SamplerKind::random, 12345, 0);
    for (std::uint32_t k = 0; q.size() < count; ++k) {
        const auto u = rnd(k);
        const auto v = rnd(k + 0x40000000u);
        const std::size_t i = static_cast<std::size_t>(v[0] * s.patches.size());
        const std::size_t j = static_cast<std::size_t>(v[1] * s.patches.size());
        if (i == j) continue;
        const Vec3 x = samplers[i](u[0], u[1]), y = samplers[j](u[2], u[3]);
        if (s.patches[i].normal.dot(y - x) <= 0 || s.patches[j].normal.dot(x - y) <= 0) continue;
        q.push_back({x, y, static_cast<int>(i), static_cast<int>(j)});
    }
    return q;
}

/// Segments as mc-target casts them: `per_pair` consecutive segments between uniform points of
/// one random pair of patches that face each other, pair after pair (coherent batches).
inline std::vector<SegmentQuery> pair_segments(const Scene& s, std::size_t count,
                                               std::uint32_t per_pair) {
    std::vector<PolygonSampler> samplers;
    for (const Patch& p : s.patches) samplers.emplace_back(p.polygon);
    std::vector<SegmentQuery> q;
    q.reserve(count);
    PointSet4 rnd(SamplerKind::random, 4242, 0);
    std::uint32_t k = 0;
    while (q.size() < count) {
        const auto v = rnd(k++);
        const std::size_t i = static_cast<std::size_t>(v[0] * s.patches.size());
        const std::size_t j = static_cast<std::size_t>(v[1] * s.patches.size());
        if (i == j) continue;
        const Patch &pi = s.patches[i], &pj = s.patches[j];
        if (pi.normal.dot(pj.centroid - pi.centroid) <= 0 ||
            pj.normal.dot(pi.centroid - pj.centroid) <= 0)
            continue;
        for (std::uint32_t m = 0, tries = 0; m < per_pair && tries < 64 * per_pair; ++tries) {
            const auto u = rnd(k++);
            const Vec3 x = samplers[i](u[0], u[1]), y = samplers[j](u[2], u[3]);
            if (pi.normal.dot(y - x) <= 0 || pj.normal.dot(x - y) <= 0) continue;
            q.push_back({x, y, static_cast<int>(i), static_cast<int>(j)});
            ++m;
        }
    }
    q.resize(count);
    return q;
}

/// Cosine-distributed rays from uniform points of random patches (mc-hemisphere's rays).
inline std::vector<RayQuery> random_rays(const Scene& s, std::size_t count) {
    std::vector<PolygonSampler> samplers;
    for (const Patch& p : s.patches) samplers.emplace_back(p.polygon);
    std::vector<RayQuery> q;
    q.reserve(count);
    PointSet4 rnd(SamplerKind::random, 777, 0);
    for (std::uint32_t k = 0; q.size() < count; ++k) {
        const auto u = rnd(k);
        const std::size_t i = static_cast<std::size_t>(rnd(k + 0x40000000u)[0] * s.patches.size());
        Vec3 t, b;
        const Vec3& n = s.patches[i].normal;
        orthonormal_basis(n, t, b);
        const Vec3 d = cosine_direction(u[2], u[3]);
        q.push_back(
            {samplers[i](u[0], u[1]), d.x() * t + d.y() * b + d.z() * n, static_cast<int>(i)});
    }
    return q;
}

/// Casts all queries on `threads` threads in chunks of 256 (as the estimators do).
inline std::size_t cast_occlusion(const Visibility& v, const std::vector<SegmentQuery>& q,
                                  std::vector<std::uint8_t>& out, int threads) {
    out.resize(q.size());
    const std::size_t chunks = (q.size() + 255) / 256;
    parallel_for(chunks, threads, [&](std::size_t c) {
        const std::size_t a = c * 256, m = std::min<std::size_t>(256, q.size() - a);
        v.occluded(std::span<const SegmentQuery>(q.data() + a, m),
                   std::span<std::uint8_t>(out.data() + a, m));
    });
    return q.size();
}

inline std::size_t cast_rays(const Visibility& v, const std::vector<RayQuery>& q,
                             std::vector<RayHit>& out, int threads) {
    out.resize(q.size());
    const std::size_t chunks = (q.size() + 255) / 256;
    parallel_for(chunks, threads, [&](std::size_t c) {
        const std::size_t a = c * 256, m = std::min<std::size_t>(256, q.size() - a);
        v.first_hit(std::span<const RayQuery>(q.data() + a, m),
                    std::span<RayHit>(out.data() + a, m));
    });
    return q.size();
}

}  // namespace formfactor::bench
