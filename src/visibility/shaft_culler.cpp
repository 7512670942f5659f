#include "visibility/shaft_culler.h"

#include <algorithm>
#include <cmath>

#include "formfactor/geometry/polygon.h"

namespace formfactor {

namespace {

constexpr int kLeafSize = 4;

// Unit normal of a planar polygon by Newell's method (zero when degenerate).
Vec3 newell_normal(const Vec3* v, int count) {
    Vec3 n = Vec3::Zero();
    for (int a = 0; a < count; ++a) n += v[a].cross(v[(a + 1) % count]);
    const double len = n.norm();
    return len > 0 ? Vec3(n / len) : Vec3::Zero();
}

Vec3 centre_of(const Vec3* v, int count) {
    Vec3 c = Vec3::Zero();
    for (int a = 0; a < count; ++a) c += v[a];
    return c / count;
}

}  // namespace

ShaftCuller::ShaftCuller(const Scene& scene) {
    Bounds3 all;
    auto add = [&](const Polygon& p) {
        Poly q;
        q.first = static_cast<int>(verts_.size());
        q.count = static_cast<int>(p.size());
        for (const Vec3& v : p.vertices) {
            verts_.push_back(v);
            q.box.extend(v);
            all.extend(v);
        }
        q.normal = newell_normal(verts_.data() + q.first, q.count);
        q.offset = q.count > 0 ? q.normal.dot(verts_[static_cast<std::size_t>(q.first)]) : 0.0;
        polys_.push_back(q);
    };
    for (const Patch& p : scene.patches) add(p.polygon);
    patch_count_ = scene.patches.size();
    for (const Surface& s : scene.surfaces)
        if (s.obstruction) add(s.polygon);
    eps_ = all.empty() ? 0.0 : 1e-9 * all.diagonal().norm();
    const auto box_of = [&](int k) -> const Bounds3& {
        return polys_[static_cast<std::size_t>(k)].box;
    };
    tree_.build(polys_.size(), box_of, kLeafSize);
}

bool ShaftCuller::unoccluded(int i, int j) const {
    const Poly& pi = polys_[static_cast<std::size_t>(i)];
    const Poly& pj = polys_[static_cast<std::size_t>(j)];
    return clear(verts_.data() + pi.first, pi.count, verts_.data() + pj.first, pj.count, i, j);
}

bool ShaftCuller::unoccluded(const Polygon& a, const Polygon& b) const {
    return clear(a.vertices.data(), static_cast<int>(a.size()), b.vertices.data(),
                 static_cast<int>(b.size()), -1, -1);
}

bool ShaftCuller::clear(const Vec3* vi, int ni, const Vec3* vj, int nj, int skip_i,
                        int skip_j) const {
    if (ni < 3 || nj < 3 || ni > kMaxVertices || nj > kMaxVertices) return false;
    const Vec3 normal_i = newell_normal(vi, ni), normal_j = newell_normal(vj, nj);
    if (normal_i.isZero() || normal_j.isZero()) return false;
    std::array<Vec3, 2 * kMaxVertices> both;
    const int nb = ni + nj;
    std::copy(vi, vi + ni, both.begin());
    std::copy(vj, vj + nj, both.begin() + ni);

    // The shaft's planes: the backs of both patches' planes, then the hull's bridge faces.
    std::array<Plane, kMaxPlanes> planes;
    int np = 0;
    planes[np++] = {-normal_i, -normal_i.dot(vi[0])};
    planes[np++] = {-normal_j, -normal_j.dot(vj[0])};
    // A plane through an edge of one patch and a vertex of the other is a face of the hull when
    // every vertex lies on one side: oriented away from the edge's own patch (its centre's
    // side), checked with early exits, normalised only when kept; a face found twice (parallel
    // edges) is kept once.
    const Vec3 ci = centre_of(vi, ni), cj = centre_of(vj, nj);
    auto bridge = [&](const Vec3* e, int ne, const Vec3& ce, const Vec3* w, int nw) {
        for (int a = 0; a < ne && np < kMaxPlanes; ++a) {
            const Vec3& p = e[a];
            const Vec3 edge = e[(a + 1) % ne] - p;
            for (int b = 0; b < nw && np < kMaxPlanes; ++b) {
                Vec3 m = edge.cross(w[b] - p);
                const double len2 = m.squaredNorm();
                if (!(len2 > 0)) continue;
                if (m.dot(ce - p) > 0) m = -m;
                const double tol = eps_ * std::sqrt(len2);
                bool face = true;
                for (int c = 0; c < nw && face; ++c) face = m.dot(w[c] - p) <= tol;
                for (int c = 0; c < ne && face; ++c) face = m.dot(e[c] - p) <= tol;
                if (!face) continue;
                m /= std::sqrt(len2);
                const double d = m.dot(p);
                bool seen = false;
                for (int k = 2; k < np && !seen; ++k) {
                    const Plane& q = planes[static_cast<std::size_t>(k)];
                    seen = q.m.dot(m) > 1 - 1e-12 && std::abs(q.d - d) <= eps_;
                }
                if (!seen) planes[np++] = {m, d};
            }
        }
    };
    bridge(vi, ni, ci, vj, nj);
    bridge(vj, nj, cj, vi, ni);

    Bounds3 query;
    for (int c = 0; c < nb; ++c) query.extend(both[static_cast<std::size_t>(c)]);
    const Vec3 qc = 0.5 * (query.lo + query.hi), qh = 0.5 * (query.hi - query.lo);

    // A box is cleared by a plane when its nearest corner is on or beyond it.
    auto box_cleared = [&](const Vec3& c, const Vec3& h) {
        if (((c - qc).cwiseAbs() - h - qh).maxCoeff() > eps_) return true;  // boxes apart
        for (int k = 0; k < np; ++k) {
            const Plane& pl = planes[static_cast<std::size_t>(k)];
            if (pl.m.dot(c) - pl.m.cwiseAbs().dot(h) >= pl.d - eps_) return true;
        }
        return false;
    };
    auto poly_cleared = [&](const Poly& q) {
        const Vec3* v = verts_.data() + q.first;
        for (int k = 0; k < np; ++k) {
            const Plane& pl = planes[static_cast<std::size_t>(k)];
            bool beyond = true;
            for (int a = 0; a < q.count && beyond; ++a) beyond = pl.m.dot(v[a]) >= pl.d - eps_;
            if (beyond) return true;
        }
        if (q.normal.isZero()) return false;
        // The blocker's own plane: both patches on one side (or in it).
        double lo = 0, hi = 0;
        for (int c = 0; c < nb; ++c) {
            const double s = q.normal.dot(both[static_cast<std::size_t>(c)]) - q.offset;
            lo = std::min(lo, s);
            hi = std::max(hi, s);
        }
        return hi <= eps_ || lo >= -eps_;
    };

    if (tree_.nodes.empty()) return true;  // nothing in the scene can block
    int stack[64];
    int top = 0;
    stack[top++] = 0;
    while (top > 0) {
        const detail::BoxTree::Node& node = tree_.nodes[static_cast<std::size_t>(stack[--top])];
        const Vec3 nc = 0.5 * (node.box.lo + node.box.hi), nh = 0.5 * (node.box.hi - node.box.lo);
        if (box_cleared(nc, nh)) continue;
        if (node.left < 0) {
            for (int k = node.first; k < node.first + node.count; ++k) {
                const int b = tree_.order[static_cast<std::size_t>(k)];
                if (b == skip_i || b == skip_j) continue;
                const Poly& q = polys_[static_cast<std::size_t>(b)];
                const Vec3 c = 0.5 * (q.box.lo + q.box.hi), h = 0.5 * (q.box.hi - q.box.lo);
                if (box_cleared(c, h)) continue;
                if (!poly_cleared(q)) return false;
            }
            continue;
        }
        if (top + 2 > 64) return false;  // deeper than any balanced tree here: give up
        stack[top++] = node.left;
        stack[top++] = node.right;
    }
    return true;
}

}  // namespace formfactor
