// The shaft of a pair of convex polygons (the planes bounding their convex hull) and what is
// tested against it: the blocker set's BVH query, a piece outside the shaft or hiding every
// segment, and the classification of a pair as visible, hidden or partly hidden.

#include <algorithm>
#include <cmath>
#include <iterator>
#include <vector>

#include "methods/analytic/obstructed_internal.h"
#include "methods/analytic/shadow_clip.h"

namespace formfactor::detail {

// ----------------------------------------------------------------------------------------------
// Shaft

void Shaft::build(const Vec3* a, int na, const Vec3& normal_a, const Vec3* b, int nb,
                  const Vec3& normal_b, double eps) {
    a_ = a;
    b_ = b;
    na_ = na;
    nb_ = nb;
    eps_ = eps;
    pa_ = {normal_a, normal_a.dot(a[0])};
    pb_ = {normal_b, normal_b.dot(b[0])};
    bool b_front = false, a_front = false;
    for (int k = 0; k < nb; ++k) b_front = b_front || pa_.signed_distance(b[k]) > eps;
    for (int k = 0; k < na; ++k) a_front = a_front || pb_.signed_distance(a[k]) > eps;
    facing_away_ = !a_front || !b_front;
    sides_ = 0;
    links_ = 0;
    ca_ = cb_ = Vec3::Zero();
    for (int k = 0; k < na; ++k) ca_ += a[k];
    for (int k = 0; k < nb; ++k) cb_ += b[k];
    ca_ /= na;
    cb_ /= nb;
    // The hull's edges between a and b, each once: two side faces share each such edge, and
    // seen from b's side it is the same vertices' difference negated (bit for bit), so that the
    // separating axes of piece_outside() are not tried twice.
    auto add_link = [&](const Vec3& d) {
        for (int l = 0; l < links_; ++l)
            if (link_[l] == d || link_[l] == -d) return;
        link_[links_++] = d;
    };
    // Side faces of the hull: through an edge of one polygon and a vertex of the other, with
    // every vertex of both on one side.
    auto sides_of = [&](const Vec3* p, int np, const Vec3& own, const Vec3& pc, const Vec3* q,
                        int nq) {
        for (int k = 0; k < np; ++k) {
            const Vec3& e0 = p[k];
            const Vec3 t = p[k + 1 == np ? 0 : k + 1] - e0;
            // When q is in front of p's plane, the face through this edge is the plane through
            // the vertex of q with the smallest angle above p's plane, seen along the edge
            // (angles compared by cross products, in the section across the edge, x pointing
            // out of p, y along p's normal).
            {
                Vec3 r = t.cross(own);
                if (r.dot(pc - e0) > 0.0) r = -r;
                int best = -1;
                double best_angle = 0.0, by = 0.0;
                bool front = true;
                const double tn = t.norm(), inv_tn2 = 1.0 / (tn * tn);
                for (int w = 0; w < nq && front; ++w) {
                    const Vec3 d = q[w] - e0;
                    const double x = r.dot(d), y = own.dot(d);
                    if (y < -eps) front = false;
                    // On the edge's line (distance from the line, not the cross-section
                    // coordinates: `own` is not exactly normal to an edge of a slightly
                    // non-planar polygon).
                    if ((d - t * (t.dot(d) * inv_tn2)).squaredNorm() <= eps * eps) continue;
                    // The angle above p's plane, in [0, π]: a cross-product comparison cannot
                    // order two directions 180° apart (vertices of q in p's plane on both sides
                    // of the edge, as where a wall meets the floor). Compared as the pseudo-angle
                    // 1 − x / (|x| + y), increasing with it over [0, π] (r has length tn: y
                    // scaled to match).
                    const double yt = std::max(y, 0.0) * tn;
                    const double angle = 1.0 - x / (std::abs(x) + yt);
                    if (best < 0 || angle < best_angle) {
                        best = w;
                        best_angle = angle;
                        by = y;
                    }
                }
                if (front) {
                    Vec3 m = best >= 0 ? t.cross(q[best] - e0) : Vec3::Zero();
                    const double mlen = m.norm();
                    if (best >= 0 && by > eps && mlen > 1e-9 * tn * (q[best] - e0).norm()) {
                        m /= mlen;
                        double off = m.dot(e0);
                        if (m.dot(pc) - off > 0.0) {
                            m = -m;
                            off = -off;
                        }
                        side_[sides_++] = Plane{m, off};
                        add_link(q[best] - e0);
                        add_link(q[best] - p[k + 1 == np ? 0 : k + 1]);
                    }
                    continue;
                }
            }
            for (int w = 0; w < nq; ++w) {
                Vec3 m = t.cross(q[w] - e0);
                const double len = m.norm();
                if (!(len > 1e-300)) continue;
                m /= len;
                // p's own plane (already a bound) is no side face.
                if (std::abs(m.dot(own)) > 1.0 - 1e-12) continue;
                const double off = m.dot(e0);
                double lo = 0.0, hi = 0.0;
                for (int j = 0; j < nq && !(lo < -eps && hi > eps); ++j) {
                    const double s = m.dot(q[j]) - off;
                    lo = std::min(lo, s);
                    hi = std::max(hi, s);
                }
                for (int j = 0; j < np && !(lo < -eps && hi > eps); ++j) {
                    const double s = m.dot(p[j]) - off;
                    lo = std::min(lo, s);
                    hi = std::max(hi, s);
                }
                if (hi <= eps || lo >= -eps) {
                    side_[sides_++] = hi <= eps ? Plane{m, off} : Plane{-m, -off};
                    add_link(q[w] - e0);
                    add_link(q[w] - p[k + 1 == np ? 0 : k + 1]);
                    break;
                }
            }
        }
    };
    sides_of(a, na, normal_a, ca_, b, nb);
    sides_of(b, nb, normal_b, cb_, a, na);
    // A side plane that cuts off a vertex of either polygon would make the shaft smaller than
    // the hull (not conservative): drop it (fewer planes only enlarge the shaft).
    int kept = 0;
    for (int k = 0; k < sides_; ++k) {
        bool ok = std::abs(side_[k].n.squaredNorm() - 1.0) < 1e-9 && std::isfinite(side_[k].d);
        for (int i = 0; i < na && ok; ++i) ok = side_[k].signed_distance(a[i]) <= eps;
        for (int j = 0; j < nb && ok; ++j) ok = side_[k].signed_distance(b[j]) <= eps;
        if (ok) side_[kept++] = side_[k];
    }
    sides_ = kept;
}

namespace {

// Where a convex set lies against a shaft, from its signed-distance range [lo, hi] to a plane
// (range(plane, lo, hi)): see Shaft::box_relation().
template <class Range>
int shaft_relation(const Plane& pa, const Plane& pb, const Plane* side, int sides, double eps,
                   Range range) {
    double lo, hi;
    range(pa, lo, hi);
    if (hi <= eps) return -1;
    range(pb, lo, hi);
    if (hi <= eps) return -1;
    int rel = 1;
    for (int k = 0; k < sides; ++k) {
        range(side[k], lo, hi);
        if (lo >= -eps) return -1;
        if (hi < -eps) rel = 0;
    }
    return rel;
}

}  // namespace

bool Shaft::box_outside(const Bounds3& box) const { return box_relation(box) < 0; }

int Shaft::box_relation(const Bounds3& box) const {
    const Vec3 c = 0.5 * (box.lo + box.hi), e = 0.5 * (box.hi - box.lo);
    return shaft_relation(
        pa_, pb_, side_, sides_, eps_, [&](const Plane& p, double& lo, double& hi) {
            const double s = p.signed_distance(c);
            const double r =
                std::abs(p.n.x()) * e.x() + std::abs(p.n.y()) * e.y() + std::abs(p.n.z()) * e.z();
            lo = s - r;
            hi = s + r;
        });
}

int Shaft::points_relation(const Vec3* p, int n) const {
    return shaft_relation(pa_, pb_, side_, sides_, eps_,
                          [&](const Plane& pl, double& lo, double& hi) {
                              lo = 1e300;
                              hi = -1e300;
                              for (int k = 0; k < n; ++k) {
                                  const double s = pl.signed_distance(p[k]);
                                  lo = std::min(lo, s);
                                  hi = std::max(hi, s);
                              }
                          });
}

bool Shaft::in_front_of(const Plane& pl) const {
    for (int k = 0; k < na_; ++k)
        if (pl.signed_distance(a_[k]) < -eps_) return false;
    for (int k = 0; k < nb_; ++k)
        if (pl.signed_distance(b_[k]) < -eps_) return false;
    return true;
}

bool Shaft::piece_outside(const Vec3* p, int count, const Plane& pl, bool exact) const {
    // Behind (or within eps of) a's plane or b's: the first vertex in front of both decides.
    bool front_a = false, front_b = false;
    for (int k = 0; k < count && !(front_a && front_b); ++k) {
        front_a = front_a || pa_.signed_distance(p[k]) > eps_;
        front_b = front_b || pb_.signed_distance(p[k]) > eps_;
    }
    if (!front_a || !front_b) return true;
    for (int s = 0; s < sides_; ++s) {
        double lo = 1e300;
        for (int k = 0; k < count && lo >= -eps_; ++k)
            lo = std::min(lo, side_[s].signed_distance(p[k]));
        if (lo >= -eps_) return true;
    }
    // The piece's plane with a and b on one side (a vertex on each side by more than eps ends
    // the search).
    bool below = false, above = false;
    for (int k = 0; k < na_ && !(below && above); ++k) {
        const double s = pl.signed_distance(a_[k]);
        below = below || s < -eps_;
        above = above || s > eps_;
    }
    for (int k = 0; k < nb_ && !(below && above); ++k) {
        const double s = pl.signed_distance(b_[k]);
        below = below || s < -eps_;
        above = above || s > eps_;
    }
    if (!below || !above) return true;
    if (!exact) return false;
    // A segment between a point of a and a point of b that crosses the piece well inside (by
    // kCrossMargin × eps off its plane at both ends and from its edges): the piece certainly
    // meets the shaft. The centres' segment first, then those between the centres, vertices and
    // edges' midpoints of a and b: most pieces that meet a patch pair's shaft are found so, for
    // a few dot products each instead of the separating axes below (on a triangulated urban
    // array of 3,026 facets, 12.0 M of 14.4 M such pieces).
    {
        constexpr double kCrossMargin = 4.0;
        const double margin = kCrossMargin * eps_;
        Vec3 inward[kMaxPieceVertices];  // n × e_k, pointing into the piece
        double edge_margin[kMaxPieceVertices];
        const int ne = std::min(count, kMaxPieceVertices);
        for (int k = 0; k < ne; ++k) {
            const Vec3 e = p[k + 1 == count ? 0 : k + 1] - p[k];
            inward[k] = pl.n.cross(e);
            edge_margin[k] = margin * e.norm();
        }
        auto crosses = [&](const Vec3& x, double sx, const Vec3& y, double sy) {
            if (!((sx > margin && sy < -margin) || (sx < -margin && sy > margin))) return false;
            const Vec3 z = x + (y - x) * (sx / (sx - sy));
            for (int k = 0; k < ne; ++k)
                if (!(inward[k].dot(z - p[k]) > edge_margin[k])) return false;
            return true;
        };
        // The segments from the points x[0, m) (signed distances sx to the piece's plane)
        // through c to the plane `to` of the polygon tv[0, tn), when they end in that polygon
        // (by the margin from its edges) and cross the piece well inside.
        auto through = [&](const Vec3& c, const Vec3* x, const double* sx, int m, const Plane& to,
                           const Vec3* tv, int tn) {
            for (int i = 0; i < m; ++i) {
                const Vec3 d = c - x[i];
                const double den = to.n.dot(d);
                if (!(std::abs(den) > 0.0)) continue;
                const double t = -to.signed_distance(x[i]) / den;
                if (!(t > 1.0) || !std::isfinite(t)) continue;
                const Vec3 y = x[i] + t * d;
                bool in = true;
                for (int k = 0; k < tn && in; ++k) {
                    const Vec3 e = tv[k + 1 == tn ? 0 : k + 1] - tv[k];
                    in = to.n.dot(e.cross(y - tv[k])) > margin * e.norm();
                }
                if (in && crosses(x[i], sx[i], y, pl.signed_distance(y))) return true;
            }
            return false;
        };
        auto meets_through_centre = [&](const Vec3* xa, const double* sxa, int ma, const Vec3* xb,
                                        const double* sxb, int mb) {
            auto from_either = [&](const Vec3& c) {
                return through(c, xa, sxa, ma, pb_, b_, nb_) ||
                       through(c, xb, sxb, mb, pa_, a_, na_);
            };
            auto centre = [](const Vec3* v, int nv) {
                Vec3 c = Vec3::Zero();
                for (int k = 0; k < nv; ++k) c += v[k];
                return Vec3(c / nv);
            };
            // The piece's centre first, when it is well inside the shaft's planes.
            {
                const Vec3 c = centre(p, count);
                bool in = pa_.signed_distance(c) > margin && pb_.signed_distance(c) > margin;
                for (int sd = 0; sd < sides_ && in; ++sd)
                    in = side_[sd].signed_distance(c) < -margin;
                if (in && from_either(c)) return true;
            }
            Poly3 q[2];
            int cur = 0;
            q[0].n = count;
            for (int k = 0; k < count; ++k) q[0].v[static_cast<std::size_t>(k)] = p[k];
            // Keeps n·y − off ≥ 0 (a plane that keeps every vertex leaves the polygon as it is).
            auto keep = [&](const Vec3& n, double off) {
                if (clip3_cut(q[cur].v.data(), q[cur].n, n, off, q[cur ^ 1])) cur ^= 1;
                return q[cur].n >= 3;
            };
            bool ok = keep(pa_.n, pa_.d + margin) && keep(pb_.n, pb_.d + margin);
            for (int sd = 0; sd < sides_ && ok; ++sd) ok = keep(-side_[sd].n, margin - side_[sd].d);
            return ok && from_either(centre(q[cur].v.data(), q[cur].n));
        };
        if (ne == count && na_ <= kMaxPieceVertices && nb_ <= kMaxPieceVertices) {
            if (crosses(ca_, pl.signed_distance(ca_), cb_, pl.signed_distance(cb_))) return false;
            // Points of each polygon: its centre, vertices and edges' midpoints.
            Vec3 pa[2 * kMaxPieceVertices + 1], pb[2 * kMaxPieceVertices + 1];
            double sa[2 * kMaxPieceVertices + 1], sb[2 * kMaxPieceVertices + 1];
            auto points = [&](const Vec3* v, int nv, const Vec3& c, Vec3* out, double* sd) {
                int m = 0;
                out[m++] = c;
                for (int k = 0; k < nv; ++k) {
                    out[m++] = v[k];
                    out[m++] = 0.5 * (v[k] + v[k + 1 == nv ? 0 : k + 1]);
                }
                for (int k = 0; k < m; ++k) sd[k] = pl.signed_distance(out[k]);
                return m;
            };
            const int ma = points(a_, na_, ca_, pa, sa), mb = points(b_, nb_, cb_, pb, sb);
            for (int i = 0; i < ma; ++i)
                for (int j = (i == 0 ? 1 : 0); j < mb; ++j)
                    if (crosses(pa[i], sa[i], pb[j], sb[j])) return false;
            // A piece that meets the hull only in part of it (a corner of the shaft) is missed by
            // those segments and left to the separating axes below, which then try every axis.
            // Before them, a point c well inside both the piece and the shaft's planes (the
            // centre of the piece clipped by them, each moved in by the margin), and the
            // segments through c from the points of one polygon to the other's plane: one that
            // ends in the other polygon and crosses the piece well inside settles it too. On the
            // 9,946-triangle urban array 36.6 M of the 242 M exact tests ended at the axes with
            // the piece meeting the shaft, at ~2,800 cycles each; 33.4 M of them end here.
            if (meets_through_centre(pa, sa, ma, pb, sb, mb)) return false;
        }
    }
    // Separating axis theorem for the remaining axes: an edge of the piece crossed with an edge
    // of the hull (a's and b's edges, and the edges of the side faces between them).
    // The piece's interval on the axis first, then the hull's: lo1 only falls and hi1 only
    // rises as its vertices come, so once both ends overlap the piece's the answer is no.
    // The early exits compare with a margin at least m = eps |axis| (eps times the axis's L1
    // norm): overlapping by more than it, the intervals overlap by more than m; the square
    // root of |axis| is taken only for the last comparison.
    auto separated = [&](const Vec3& axis) {
        const double l1 = std::abs(axis.x()) + std::abs(axis.y()) + std::abs(axis.z());
        if (!(l1 > 0.0)) return false;
        double lo1 = 1e300, hi1 = -1e300, lo2 = 1e300, hi2 = -1e300;
        for (int k = 0; k < count; ++k) {
            const double t = axis.dot(p[k]);
            lo2 = std::min(lo2, t);
            hi2 = std::max(hi2, t);
        }
        const double m_above = eps_ * l1;
        auto overlaps = [&] { return !(hi2 <= lo1 + m_above) && !(hi1 <= lo2 + m_above); };
        for (int k = 0; k < na_; ++k) {
            const double t = axis.dot(a_[k]);
            lo1 = std::min(lo1, t);
            hi1 = std::max(hi1, t);
            if (overlaps()) return false;
        }
        for (int k = 0; k < nb_; ++k) {
            const double t = axis.dot(b_[k]);
            lo1 = std::min(lo1, t);
            hi1 = std::max(hi1, t);
            if (overlaps()) return false;
        }
        const double m = eps_ * axis.norm();
        return hi2 <= lo1 + m || hi1 <= lo2 + m;
    };
    for (int k = 0; k < count; ++k) {
        const Vec3 e = p[k + 1 == count ? 0 : k + 1] - p[k];
        for (int i = 0; i < na_; ++i)
            if (separated(e.cross(a_[i + 1 == na_ ? 0 : i + 1] - a_[i]))) return true;
        for (int j = 0; j < nb_; ++j)
            if (separated(e.cross(b_[j + 1 == nb_ ? 0 : j + 1] - b_[j]))) return true;
        for (int l = 0; l < links_; ++l)
            if (separated(e.cross(link_[l]))) return true;
    }
    return false;
}

bool Shaft::piece_hides(const Vec3* p, int count, const Plane& pl) const {
    // The piece's plane must separate a and b strictly; then every segment crosses it inside the
    // convex hull of the vertex-to-vertex crossings, which must lie inside the piece.
    double sa[kCap], sb[kCap];
    if (na_ > kCap || nb_ > kCap) return false;
    double sign = 0.0;
    for (int k = 0; k < na_; ++k) sa[k] = pl.signed_distance(a_[k]);
    for (int k = 0; k < nb_; ++k) sb[k] = pl.signed_distance(b_[k]);
    sign = sa[0] > 0.0 ? 1.0 : -1.0;
    for (int k = 0; k < na_; ++k)
        if (!(sign * sa[k] > eps_)) return false;
    for (int k = 0; k < nb_; ++k)
        if (!(-sign * sb[k] > eps_)) return false;
    for (int i = 0; i < na_; ++i) {
        for (int j = 0; j < nb_; ++j) {
            const double t = sa[i] / (sa[i] - sb[j]);
            const Vec3 z = a_[i] + t * (b_[j] - a_[i]);
            for (int k = 0; k < count; ++k) {
                const Vec3& v0 = p[k];
                const Vec3 e = p[k + 1 == count ? 0 : k + 1] - v0;
                const double len = e.norm();
                if (e.cross(z - v0).dot(pl.n) < eps_ * len) return false;
            }
        }
    }
    return true;
}

// ----------------------------------------------------------------------------------------------
// Blocker pieces against a shaft

void BlockerSet::query(const Shaft& shaft, int skip_a, int skip_b, std::vector<int>& out) const {
    if (tree_.nodes.empty()) return;
    int stack[128];
    int top = 0;
    stack[top++] = 0;
    while (top > 0) {
        const BoxTree::Node& nd = tree_.nodes[static_cast<std::size_t>(stack[--top])];
        if (shaft.box_outside(nd.box)) continue;
        if (nd.left < 0) {
            for (int k = nd.first; k < nd.first + nd.count; ++k) {
                const int p = tree_.order[static_cast<std::size_t>(k)];
                const Piece& pc = pieces_[static_cast<std::size_t>(p)];
                if (pc.surface == skip_a || pc.surface == skip_b || pc.inert) continue;
                out.push_back(p);
            }
        } else if (top + 2 <= 128) {
            stack[top++] = nd.left;
            stack[top++] = nd.right;
        }
    }
}

ShaftClass classify_shaft(const Shaft& shaft, const BlockerSet& blockers, const int* cand, int n,
                          std::vector<int>& kept, bool exact, bool by_solid) {
    kept.clear();
    // One convex solid (a building standing on the ground, a box) may hide the whole shaft
    // though none of its faces alone does: tried as soon as one of its faces is kept, so that a
    // hidden shaft ends there rather than after every candidate. The last few solids tried are
    // remembered: the pieces of one solid come in runs.
    int tried[4] = {-1, -1, -1, -1};
    // Each solid is first placed against the shaft as a whole (Shaft::box_relation()), once per
    // run of its pieces: outside, its pieces are skipped untested (they are outside by the same
    // planes, which piece_outside() tries first); strictly inside a side plane, it cannot hide
    // the shaft (solid_hides() is not tried). by_solid: a small solid (a box, a building:
    // BlockerSet::solid_corners()) is placed by its corners, and is outside, too, when a and b
    // are in front of one of its faces; one that meets the shaft and does not hide it keeps its
    // pieces untested.
    int solid_at = -1, solid_rel = 1;
    bool whole_solid = false;
    for (int c = 0; c < n; ++c) {
        const int k = cand[c];
        const auto& pc = blockers.piece(k);
        const int so = pc.solid;
        if (so >= 0) {
            if (so != solid_at) {
                solid_at = so;
                solid_rel = shaft.box_relation(blockers.solid_box(so));
                const std::vector<Vec3>& corners = blockers.solid_corners(so);
                whole_solid = by_solid && !corners.empty();
                if (whole_solid && solid_rel >= 0 && !blockers.solid_box_is_hull(so)) {
                    solid_rel =
                        shaft.points_relation(corners.data(), static_cast<int>(corners.size()));
                    for (const Plane& f : blockers.solid_faces(so))
                        if (solid_rel >= 0 && shaft.in_front_of(f)) solid_rel = -1;
                }
                if (solid_rel == 1 && whole_solid &&
                    blockers.solid_hides(so, shaft.a(), shaft.a_count(), shaft.b(),
                                         shaft.b_count())) {
                    kept.clear();
                    return ShaftClass::kHidden;
                }
            }
            if (solid_rel < 0) continue;
            if (whole_solid) {
                kept.push_back(k);
                continue;
            }
        }
        const Vec3* v = blockers.vertices(k);
        if (shaft.piece_outside(v, pc.count, pc.plane, exact)) continue;
        if (shaft.piece_hides(v, pc.count, pc.plane)) {
            kept.clear();
            return ShaftClass::kHidden;
        }
        kept.push_back(k);
        if (so < 0 || solid_rel == 0 ||
            std::find(std::begin(tried), std::end(tried), so) != std::end(tried))
            continue;
        std::rotate(std::begin(tried), std::begin(tried) + 3, std::end(tried));
        tried[0] = so;
        if (blockers.solid_hides(so, shaft.a(), shaft.a_count(), shaft.b(), shaft.b_count())) {
            kept.clear();
            return ShaftClass::kHidden;
        }
    }
    return kept.empty() ? ShaftClass::kVisible : ShaftClass::kPartial;
}

}  // namespace formfactor::detail
