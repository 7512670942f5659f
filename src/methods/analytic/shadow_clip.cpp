// The clipping and Lambert's formula of shadow_clip.h, out of line: the point kernel calls
// them from several places, and inlined copies make it larger and slower (fewer instructions,
// more cycles, as measured).

#include "methods/analytic/shadow_clip.h"

#include <algorithm>
#include <cmath>

#include "core/fast_atan.h"

namespace formfactor::detail {

namespace {
constexpr double kTwoPi = 2.0 * kPi;
}  // namespace

void clip3(const Poly3& in, const Vec3& n, double off, Poly3& out) {
    if (!clip3_cut(in.v.data(), in.n, n, off, out)) {
        out.n = in.n;
        std::copy(in.v.begin(), in.v.begin() + in.n, out.v.begin());
    }
}

bool clip3_cut(const Vec3* v, int count, const Vec3& n, double off, Poly3& out) {
    out.n = 0;
    if (count == 0) return true;
    double d[kCap];
    bool all_in = true, all_out = true;
    for (int k = 0; k < count; ++k) {
        d[k] = n.dot(v[k]) - off;
        all_in = all_in && d[k] >= 0.0;
        all_out = all_out && d[k] < 0.0;
    }
    if (all_out) return true;
    if (all_in) return false;
    for (int k = 0; k < count; ++k) {
        const int m = k + 1 == count ? 0 : k + 1;
        const Vec3& a = v[k];
        if (d[k] >= 0.0 && out.n < kCap) out.v[static_cast<std::size_t>(out.n++)] = a;
        if ((d[k] > 0.0 && d[m] < 0.0) || (d[k] < 0.0 && d[m] > 0.0)) {
            const double t = d[k] / (d[k] - d[m]);
            if (out.n < kCap) out.v[static_cast<std::size_t>(out.n++)] = a + t * (v[m] - a);
        }
    }
    if (out.n < 3) out.n = 0;
    return true;
}

void clip2(const Poly2& in, double ax, double ay, double ex, double ey, double sign, Poly2& out) {
    out.n = 0;
    double d[kCap];
    bool all_in = true, all_out = true;
    for (int k = 0; k < in.n; ++k) {
        d[k] = sign * (ex * (in.y[static_cast<std::size_t>(k)] - ay) -
                       ey * (in.x[static_cast<std::size_t>(k)] - ax));
        all_in = all_in && d[k] >= 0.0;
        all_out = all_out && d[k] <= 0.0;
    }
    if (all_out) return;
    if (all_in) {
        copy2(in, out);
        return;
    }
    for (int k = 0; k < in.n; ++k) {
        const int m = k + 1 == in.n ? 0 : k + 1;
        const auto ks = static_cast<std::size_t>(k), ms = static_cast<std::size_t>(m);
        if (d[k] >= 0.0 && out.n < kCap) {
            out.x[static_cast<std::size_t>(out.n)] = in.x[ks];
            out.y[static_cast<std::size_t>(out.n++)] = in.y[ks];
        }
        if ((d[k] > 0.0 && d[m] < 0.0) || (d[k] < 0.0 && d[m] > 0.0)) {
            const double t = d[k] / (d[k] - d[m]);
            if (out.n < kCap) {
                out.x[static_cast<std::size_t>(out.n)] = in.x[ks] + t * (in.x[ms] - in.x[ks]);
                out.y[static_cast<std::size_t>(out.n++)] = in.y[ks] + t * (in.y[ms] - in.y[ks]);
            }
        }
    }
    if (out.n < 3) out.n = 0;
}

void split2(const Poly2& in, double ax, double ay, double ex, double ey, Poly2& left,
            Poly2& right) {
    const int side = split2_cut(in, ax, ay, ex, ey, left, right);
    if (side == 1) {
        copy2(in, left);
        right.n = 0;
    } else if (side == -1) {
        left.n = 0;
        copy2(in, right);
    }
}

int split2_cut(const Poly2& in, double ax, double ay, double ex, double ey, Poly2& left,
               Poly2& right) {
    double d[kCap];
    bool none_neg = true, none_pos = true;  // no d < 0, no d > 0
    for (int k = 0; k < in.n; ++k) {
        d[k] = ex * (in.y[static_cast<std::size_t>(k)] - ay) -
               ey * (in.x[static_cast<std::size_t>(k)] - ax);
        none_neg = none_neg && d[k] >= 0.0;
        none_pos = none_pos && d[k] <= 0.0;
    }
    // As clip2(): a side with every vertex on the line or beyond it is empty, else one with
    // every vertex on it or on its side is `in` whole.
    if (none_neg && !none_pos) return 1;
    if (none_pos && !none_neg) return -1;
    left.n = 0;
    right.n = 0;
    if (none_neg && none_pos) return 0;
    for (int k = 0; k < in.n; ++k) {
        const int m = k + 1 == in.n ? 0 : k + 1;
        const auto ks = static_cast<std::size_t>(k), ms = static_cast<std::size_t>(m);
        if (d[k] >= 0.0 && left.n < kCap) {
            left.x[static_cast<std::size_t>(left.n)] = in.x[ks];
            left.y[static_cast<std::size_t>(left.n++)] = in.y[ks];
        }
        if (d[k] <= 0.0 && right.n < kCap) {
            right.x[static_cast<std::size_t>(right.n)] = in.x[ks];
            right.y[static_cast<std::size_t>(right.n++)] = in.y[ks];
        }
        if ((d[k] > 0.0 && d[m] < 0.0) || (d[k] < 0.0 && d[m] > 0.0)) {
            const double t = d[k] / (d[k] - d[m]);
            const double x = in.x[ks] + t * (in.x[ms] - in.x[ks]);
            const double y = in.y[ks] + t * (in.y[ms] - in.y[ks]);
            if (left.n < kCap) {
                left.x[static_cast<std::size_t>(left.n)] = x;
                left.y[static_cast<std::size_t>(left.n++)] = y;
            }
            if (right.n < kCap) {
                right.x[static_cast<std::size_t>(right.n)] = x;
                right.y[static_cast<std::size_t>(right.n++)] = y;
            }
        }
    }
    if (left.n < 3) left.n = 0;
    if (right.n < 3) right.n = 0;
    return 0;
}

double lambert2(const Poly2& q, const Vec3& xl, const Vec3& nl) {
    double sum = 0.0;
    for (int k = 0; k < q.n; ++k) {
        const int m = k + 1 == q.n ? 0 : k + 1;
        const Vec3 r0(q.x[static_cast<std::size_t>(k)] - xl.x(),
                      q.y[static_cast<std::size_t>(k)] - xl.y(), -xl.z());
        const Vec3 r1(q.x[static_cast<std::size_t>(m)] - xl.x(),
                      q.y[static_cast<std::size_t>(m)] - xl.y(), -xl.z());
        const Vec3 cr = r0.cross(r1);
        const double len = cr.norm();
        if (len == 0.0) continue;
        sum += atan2_upper(len, r0.dot(r1)) * nl.dot(cr) / len;
    }
    return std::max(0.0, -sum / kTwoPi);
}

}  // namespace formfactor::detail
