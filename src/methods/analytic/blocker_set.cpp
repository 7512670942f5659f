// The blocker set: every blocking polygon as convex planar pieces with a bounding-volume
// hierarchy over their boxes, the closed solids among them (whose back faces a point can skip),
// and the planar convex hull the cluster trees of analytic_obstructed.cpp bound their nodes with.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <map>
#include <numeric>
#include <vector>

#include "formfactor/core/cancel.h"
#include "formfactor/geometry/polygon.h"
#include "methods/analytic/obstructed_internal.h"

namespace formfactor::detail {

namespace {

// Convex pieces of a polygon: itself when convex and small, else its triangulation.
std::vector<Polygon> convex_pieces(const Polygon& p) {
    if (p.size() == 3 || (p.size() <= static_cast<std::size_t>(kMaxPieceVertices) && is_convex(p)))
        return {p};
    std::vector<Polygon> out;
    for (const auto& t : triangulate(p)) {
        Polygon q;
        q.vertices = {p[static_cast<std::size_t>(t[0])], p[static_cast<std::size_t>(t[1])],
                      p[static_cast<std::size_t>(t[2])]};
        if (area(q) > 0.0) out.push_back(std::move(q));
    }
    return out;
}

}  // namespace

// ----------------------------------------------------------------------------------------------
// BlockerSet

std::vector<Polygon> BlockerSet::convex_parts(const Polygon& p) { return convex_pieces(p); }

void BlockerSet::add(const Polygon& p, int surface) {
    for (const Polygon& q : convex_pieces(p)) {
        Piece pc;
        pc.first = static_cast<int>(verts_.size());
        pc.count = static_cast<int>(q.size());
        pc.plane = plane_of(q);
        pc.box = bounds(q);
        pc.surface = surface;
        for (const Vec3& v : q.vertices) verts_.push_back(v);
        pieces_.push_back(pc);
    }
}

void BlockerSet::build(const std::vector<char>& inert) {
    constexpr int kLeafSize = 4;
    for (Piece& pc : pieces_) {
        const auto s = static_cast<std::size_t>(pc.surface);
        pc.inert = s < inert.size() && inert[s] != 0;
    }
    const auto box_of = [&](int k) -> const Bounds3& {
        return pieces_[static_cast<std::size_t>(k)].box;
    };
    tree_.build(pieces_.size(), box_of, kLeafSize);
}

void BlockerSet::mark_closed_solids(const std::vector<std::pair<Bounds3, int>>& patches,
                                    double tol) {
    const std::size_t np = pieces_.size();
    // Serial over every piece of a 10⁵-patch city (a second and more): a signal must not wait.
    const CancellationFlag& cancel = current_cancellation();
    auto key = [&](const Vec3& v) {
        return std::array<long long, 3>{std::llround(v.x() / tol), std::llround(v.y() / tol),
                                        std::llround(v.z() / tol)};
    };
    using EdgeKey = std::array<long long, 6>;
    std::map<EdgeKey, std::vector<int>> edges;  // directed edge → pieces
    for (std::size_t p = 0; p < np; ++p) {
        if (p % 1024 == 0) cancel.throw_if_requested();
        const Piece& pc = pieces_[p];
        if (pc.inert) continue;  // blocks nothing: the ground under buildings
        for (int k = 0; k < pc.count; ++k) {
            const auto a = key(verts_[static_cast<std::size_t>(pc.first + k)]);
            const auto b = key(verts_[static_cast<std::size_t>(pc.first + (k + 1) % pc.count)]);
            edges[{a[0], a[1], a[2], b[0], b[1], b[2]}].push_back(static_cast<int>(p));
        }
    }
    // Union–find over pieces joined by reversed edges; a piece with an unmatched edge is open.
    std::vector<int> parent(np);
    std::iota(parent.begin(), parent.end(), 0);
    std::function<int(int)> find = [&](int x) {
        while (parent[static_cast<std::size_t>(x)] != x)
            x = parent[static_cast<std::size_t>(x)] =
                parent[static_cast<std::size_t>(parent[static_cast<std::size_t>(x)])];
        return x;
    };
    std::vector<char> open(np, 0);
    cancel.throw_if_requested();
    for (const auto& [e, ps] : edges) {
        const EdgeKey rev = {e[3], e[4], e[5], e[0], e[1], e[2]};
        const auto it = edges.find(rev);
        if (it == edges.end() || ps.size() != 1 || it->second.size() != 1) {
            for (int p : ps) open[static_cast<std::size_t>(p)] = 1;
            continue;
        }
        parent[static_cast<std::size_t>(find(ps[0]))] = find(it->second[0]);
    }
    std::map<int, std::vector<int>> comps;
    for (std::size_t p = 0; p < np; ++p)
        comps[find(static_cast<int>(p))].push_back(static_cast<int>(p));
    auto set_neighbors = [&](const std::vector<int>& ps) {
        if (neighbor_.empty()) neighbor_.assign(verts_.size(), -1);
        for (int p : ps) {
            const Piece& pc = pieces_[static_cast<std::size_t>(p)];
            for (int k = 0; k < pc.count; ++k) {
                const auto a = key(verts_[static_cast<std::size_t>(pc.first + k)]);
                const auto b = key(verts_[static_cast<std::size_t>(pc.first + (k + 1) % pc.count)]);
                const auto it = edges.find({b[0], b[1], b[2], a[0], a[1], a[2]});
                neighbor_[static_cast<std::size_t>(pc.first + k)] =
                    it == edges.end() || it->second.size() != 1 ? -1 : it->second[0];
            }
        }
    };
    // A component that is a convex solid, closed or open along one planar loop of unmatched
    // edges (the face that would close it runs the other way round that loop): Piece::solid.
    // The test below is exact and costs pieces² × vertices (4,096 pieces: ~0.1 s): a faceted
    // sphere of a few thousand triangles is one solid, whose front faces then need no shadow
    // subtraction among themselves (evaluate_point()).
    constexpr std::size_t kMaxSolidPieces = 4096;
    constexpr std::size_t kSmallSolidPieces = 16;
    using Key = std::array<long long, 3>;
    auto add_convex_solid = [&](const std::vector<int>& ps) {
        std::map<Key, std::pair<Key, Vec3>> next;  // unmatched edge: start → (end, start point)
        for (int p : ps) {
            const Piece& pc = pieces_[static_cast<std::size_t>(p)];
            for (int k = 0; k < pc.count; ++k) {
                const Vec3& va = verts_[static_cast<std::size_t>(pc.first + k)];
                const auto a = key(va);
                const auto b = key(verts_[static_cast<std::size_t>(pc.first + (k + 1) % pc.count)]);
                const auto it = edges.find({b[0], b[1], b[2], a[0], a[1], a[2]});
                const bool matched = it != edges.end() && it->second.size() == 1 &&
                                     edges[{a[0], a[1], a[2], b[0], b[1], b[2]}].size() == 1;
                if (matched) continue;
                if (next.count(a)) return;  // two openings meet at a vertex
                next[a] = {b, va};
            }
        }
        Solid so;
        so.tol = tol;
        if (!next.empty()) {
            std::vector<Vec3> loop;
            const Key start = next.begin()->first;
            Key at = start;
            do {
                const auto it = next.find(at);
                if (it == next.end() || loop.size() >= next.size()) return;
                loop.push_back(it->second.second);
                at = it->second.first;
            } while (at != start);
            if (loop.size() != next.size() || loop.size() < 3) return;
            Vec3 nn = Vec3::Zero(), c = Vec3::Zero();
            for (std::size_t k = 0; k < loop.size(); ++k) {
                nn += loop[k].cross(loop[(k + 1) % loop.size()]);
                c += loop[k];
            }
            c /= static_cast<double>(loop.size());
            if (!(nn.norm() > 0.0)) return;
            nn = -nn.normalized();
            for (const Vec3& v : loop)
                if (std::abs(nn.dot(v - c)) > tol) return;  // not planar
            so.open = true;
            so.opening = Plane{nn, nn.dot(c)};
        }
        for (int p : ps) so.faces.push_back(pieces_[static_cast<std::size_t>(p)].plane);
        // Convex and not flat: every vertex behind or on every face plane and the opening, one
        // strictly behind some face.
        bool solid_inside = false;
        for (int p : ps) {
            const Piece& pc = pieces_[static_cast<std::size_t>(p)];
            for (int k = 0; k < pc.count; ++k) {
                const Vec3& v = verts_[static_cast<std::size_t>(pc.first + k)];
                if (so.open && so.opening.signed_distance(v) > tol) return;
                for (const Plane& f : so.faces) {
                    const double d = f.signed_distance(v);
                    if (d > tol) return;
                    solid_inside = solid_inside || d < -tol;
                }
            }
        }
        if (!solid_inside) return;
        std::size_t nv = 0;
        for (int p : ps) {
            const Piece& pc = pieces_[static_cast<std::size_t>(p)];
            for (int k = 0; k < pc.count; ++k, ++nv) {
                so.centre += verts_[static_cast<std::size_t>(pc.first + k)];
                so.box.extend(verts_[static_cast<std::size_t>(pc.first + k)]);
            }
        }
        so.centre /= static_cast<double>(nv);
        // A small solid's corners, for the shafts' tests of the whole solid: its pieces'
        // vertices, each bit-equal one once (not merged within tol: every vertex must be among
        // them for "all corners outside a plane" to hold for every piece).
        if (ps.size() <= kSmallSolidPieces) {
            for (int p : ps) {
                const Piece& pc = pieces_[static_cast<std::size_t>(p)];
                for (int k = 0; k < pc.count; ++k)
                    so.corners.push_back(verts_[static_cast<std::size_t>(pc.first + k)]);
            }
            const auto less = [](const Vec3& a, const Vec3& b) {
                return std::lexicographical_compare(a.data(), a.data() + 3, b.data(), b.data() + 3);
            };
            std::sort(so.corners.begin(), so.corners.end(), less);
            so.corners.erase(std::unique(so.corners.begin(), so.corners.end()), so.corners.end());
            // Every corner a corner of the box (a building along the axes): the box is the hull.
            so.box_is_hull = true;
            for (const Vec3& v : so.corners)
                for (int d = 0; d < 3; ++d)
                    so.box_is_hull =
                        so.box_is_hull && (v[d] == so.box.lo[d] || v[d] == so.box.hi[d]);
        }
        for (int p : ps) {
            const Piece& pc = pieces_[static_cast<std::size_t>(p)];
            for (int k = 0; k < pc.count; ++k)
                so.r_out = std::max(
                    so.r_out, (verts_[static_cast<std::size_t>(pc.first + k)] - so.centre).norm());
        }
        so.r_in = INFINITY;
        for (const Plane& f : so.faces) so.r_in = std::min(so.r_in, -f.signed_distance(so.centre));
        if (so.open) so.r_in = std::min(so.r_in, -so.opening.signed_distance(so.centre));
        so.r_in = std::max(0.0, so.r_in);
        const int id = static_cast<int>(solids_.size());
        solids_.push_back(std::move(so));
        for (int p : ps) pieces_[static_cast<std::size_t>(p)].solid = id;
    };
    cancel.throw_if_requested();
    for (const auto& [root, ps] : comps) {
        (void)root;
        cancel.throw_if_requested();
        if (ps.size() >= 2 && ps.size() <= kMaxSolidPieces) add_convex_solid(ps);
        bool closed = ps.size() >= 4;
        double volume = 0.0;
        Bounds3 box;
        std::vector<int> ids;
        for (int p : ps) {
            const Piece& pc = pieces_[static_cast<std::size_t>(p)];
            closed = closed && !open[static_cast<std::size_t>(p)];
            const Vec3& v0 = verts_[static_cast<std::size_t>(pc.first)];
            for (int k = 1; k + 1 < pc.count; ++k)
                volume += v0.dot(verts_[static_cast<std::size_t>(pc.first + k)].cross(
                              verts_[static_cast<std::size_t>(pc.first + k + 1)])) /
                          6.0;
            box.extend(pc.box.lo);
            box.extend(pc.box.hi);
            ids.push_back(pc.surface);
        }
        if (!closed || !(volume > 0.0)) continue;
        std::sort(ids.begin(), ids.end());
        bool empty_inside = true;
        for (const auto& [pb, id] : patches) {
            if (std::binary_search(ids.begin(), ids.end(), id)) continue;
            if ((pb.lo.array() <= box.hi.array() + tol).all() &&
                (pb.hi.array() >= box.lo.array() - tol).all()) {
                empty_inside = false;
                break;
            }
        }
        if (!empty_inside) continue;
        for (int p : ps) pieces_[static_cast<std::size_t>(p)].cull_back = true;
        set_neighbors(ps);
    }
    // The convex solids culled point by point need the neighbours too (inner edges).
    for (const auto& [root, ps] : comps) {
        (void)root;
        cancel.throw_if_requested();
        const Piece& pc = pieces_[static_cast<std::size_t>(ps.front())];
        if (pc.solid >= 0) set_neighbors(ps);
    }
}

bool BlockerSet::culls_at(int solid, const Vec3& x) const {
    const Solid& so = solids_[static_cast<std::size_t>(solid)];
    if (so.open && so.opening.signed_distance(x) > so.tol) return false;
    for (const Plane& f : so.faces)
        if (f.signed_distance(x) > so.tol) return true;
    return false;
}

bool BlockerSet::culls_at(int solid, const Vec3& x, double face_distance) const {
    const Solid& so = solids_[static_cast<std::size_t>(solid)];
    if (!(face_distance > so.tol)) return culls_at(solid, x);
    return !(so.open && so.opening.signed_distance(x) > so.tol);
}

bool BlockerSet::culls_all(int solid, const Vec3* v, int n) const {
    const Solid& so = solids_[static_cast<std::size_t>(solid)];
    if (so.open)
        for (int k = 0; k < n; ++k)
            if (so.opening.signed_distance(v[k]) > so.tol) return false;
    for (const Plane& f : so.faces) {
        bool all = true;
        for (int k = 0; k < n && all; ++k) all = f.signed_distance(v[k]) > so.tol;
        if (all) return true;
    }
    return false;
}

namespace {
// From this many faces on, solid_hides() holds segments against the solid's balls first.
constexpr std::size_t kBallFaces = 16;
}  // namespace

bool BlockerSet::solid_hides(int solid, const Vec3* a, int na, const Vec3* b, int nb) const {
    const Solid& so = solids_[static_cast<std::size_t>(solid)];
    // Neither polygon reaches into the solid: all its vertices on or in front of one of the
    // solid's planes (the opening's included: the ground a building stands on).
    auto separated = [&](const Vec3* v, int n) {
        auto in_front = [&](const Plane& f) {
            for (int k = 0; k < n; ++k)
                if (f.signed_distance(v[k]) < -so.tol) return false;
            return true;
        };
        if (so.open && in_front(so.opening)) return true;
        for (const Plane& f : so.faces)
            if (in_front(f)) return true;
        return false;
    };
    // The balls about the solid's centre first, for a solid of many faces (a faceted sphere has
    // thousands; a box's five or six planes cost less than the balls): a segment farther from
    // the centre than every vertex misses the solid, and one that passes through the ball inside
    // every face plane goes through it — each by a margin far above the rounding of the plane
    // tests below, so that they answer as those would.
    const bool balls = so.faces.size() >= kBallFaces;
    const double margin = so.tol + 1e-9 * so.r_out;
    auto ball_test = [&](const Vec3& p, const Vec3& q) {  // −1 misses, 1 through, 0 undecided
        const Vec3 d = q - p;
        const double len2 = d.squaredNorm();
        const double t = len2 > 0.0 ? std::clamp(d.dot(so.centre - p) / len2, 0.0, 1.0) : 0.0;
        const double dist = (p + t * d - so.centre).norm();
        if (dist > so.r_out + margin) return -1;
        const double r = so.r_in - margin;
        if (r > 0.0 && dist < r && len2 > 0.0 && t > 0.0 && t < 1.0 &&
            2.0 * std::sqrt(r * r - dist * dist) > 1e-9 * std::sqrt(len2))
            return 1;
        return 0;
    };
    thread_local std::vector<signed char> decided;
    if (balls) decided.assign(static_cast<std::size_t>(na * nb), 0);
    for (int i = 0; i < na && balls; ++i)
        for (int j = 0; j < nb; ++j) {
            const int bt = ball_test(a[i], b[j]);
            if (bt < 0) return false;
            decided[static_cast<std::size_t>(i * nb + j)] = static_cast<signed char>(bt);
        }
    // Cyrus–Beck: whether the segment meets the closed solid (behind or on every plane). A
    // segment that only touches it there (grazing an edge) is one of a set of measure zero unless
    // a and b lie in one plane with it, where they do not see each other.
    auto through = [&](const Vec3& p, const Vec3& q) {
        double t0 = 0.0, t1 = 1.0;
        auto plane = [&](const Plane& f) {
            const double dp = f.signed_distance(p), dq = f.signed_distance(q);
            if (dp > 0.0 && dq > 0.0) return false;
            if (dp <= 0.0 && dq <= 0.0) return true;
            const double t = dp / (dp - dq);
            if (dp > 0.0)
                t0 = std::max(t0, t);
            else
                t1 = std::min(t1, t);
            return t0 <= t1;
        };
        for (const Plane& f : so.faces)
            if (!plane(f)) return false;
        if (so.open && !plane(so.opening)) return false;
        // More than a point: a segment from a point on a face (a patch of the solid itself)
        // touches the solid where it starts, whatever it passes later.
        return t1 - t0 > 1e-12;
    };
    // Without the balls, one segment first: most solids asked about miss one of the segments,
    // and that answer costs less than the separation tests (the answer is the conjunction of
    // all the tests, in any order).
    const bool first_done = !balls && na > 0 && nb > 0;
    if (first_done && !through(a[0], b[0])) return false;
    // A point farther from the centre than every vertex is outside the solid, so in front of
    // one of its planes.
    auto outside_ball = [&](const Vec3* v, int n) {
        return balls && n == 1 && (v[0] - so.centre).norm() > so.r_out + margin;
    };
    if (!(outside_ball(a, na) || separated(a, na)) || !(outside_ball(b, nb) || separated(b, nb)))
        return false;
    for (int i = 0; i < na; ++i)
        for (int j = first_done && i == 0 ? 1 : 0; j < nb; ++j)
            if (!(balls && decided[static_cast<std::size_t>(i * nb + j)] == 1) &&
                !through(a[i], b[j]))
                return false;
    return true;
}

std::vector<Vec3> planar_convex_hull(const std::vector<Vec3>& points, const Vec3& n) {
    if (points.size() < 3) return points;
    Vec3 u, v;
    orthonormal_basis(n, u, v);
    const Vec3 o = points[0];
    struct P2 {
        double x, y;
        int k;
    };
    std::vector<P2> p;
    p.reserve(points.size());
    for (std::size_t k = 0; k < points.size(); ++k)
        p.push_back({u.dot(points[k] - o), v.dot(points[k] - o), static_cast<int>(k)});
    std::vector<P2> h;
    convex_hull_2d(p, h);
    std::vector<Vec3> out;
    for (const P2& q : h) out.push_back(points[static_cast<std::size_t>(q.k)]);
    return out;
}

}  // namespace formfactor::detail
