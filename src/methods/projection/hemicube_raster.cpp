#include "methods/projection/hemicube_raster.h"

#include <algorithm>
#include <cmath>
#include <limits>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace formfactor::projection {

namespace {

inline double coord(const P3& p, int k) { return p.v[k]; }

// The face whose axis is the largest coordinate of p: 0 top (c), 1 +a, 2 −a, 3 +b, 4 −b.
inline int face_of(const P3& p) {
    const double a = p.v[0], b = p.v[1], c = p.v[2];
    const double aa = std::abs(a), ab = std::abs(b);
    if (c >= aa && c >= ab) return 0;
    if (aa >= ab) return a > 0 ? 1 : 2;
    return b > 0 ? 3 : 4;
}

// ceil(x) clamped to [lo, hi]; cheaper than std::ceil on plain SSE2.
inline int ceil_clamped(double x, int lo, int hi) {
    if (!(x > lo)) return lo;  // also catches NaN
    if (x >= hi) return hi;
    const int t = static_cast<int>(x);
    return t + (static_cast<double>(t) < x ? 1 : 0);
}

// The five clip planes of a face (bit k of an outcode = outside plane k).
ClipPlane face_plane(const HemicubeFace& f, int k, double near) {
    double n[3] = {0, 0, 0};
    double off = 0.0;
    switch (k) {
        case 0:  // D − U ≥ 0
            n[f.id] += f.sd;
            n[f.iu] -= f.su;
            break;
        case 1:  // D + U ≥ 0
            n[f.id] += f.sd;
            n[f.iu] += f.su;
            break;
        case 2:  // D − V ≥ 0
            n[f.id] += f.sd;
            n[f.iv] -= f.sv;
            break;
        case 3:  // top: D + V ≥ 0; side: V ≥ 0
            if (f.top) n[f.id] += f.sd;
            n[f.iv] += f.sv;
            break;
        default:  // D ≥ near
            n[f.id] += f.sd;
            off = near;
            break;
    }
    return {n[0], n[1], n[2], off};
}

}  // namespace

HemicubeRaster::HemicubeRaster(int resolution)
    : R_(resolution),
      H_(resolution / 2),
      cells_(static_cast<std::size_t>(resolution) * resolution * 3),
      depth_(cells_ + kPadding),
      items_(cells_ + kPadding) {}

std::size_t HemicubeRaster::face_offset(int f) const {
    const std::size_t top = static_cast<std::size_t>(R_) * R_;
    return f == 0 ? 0 : top + static_cast<std::size_t>(f - 1) * R_ * H_;
}

void HemicubeRaster::render(const Occluders& occ, const Frame& frame, int exclude, double near,
                            double edge_on) {
    std::fill(depth_.begin(), depth_.end(), 0.0f);
    if (stamp_.size() != occ.patches) stamp_.assign(occ.patches, 0u);
    if (++epoch_ == 0u) {  // wrapped: forget every stamp
        std::fill(stamp_.begin(), stamp_.end(), 0u);
        epoch_ = 1u;
    }
    touched_.clear();
    std::fill(items_.begin(), items_.end(), kViewNothing);
    const double ox = frame.origin.x(), oy = frame.origin.y(), oz = frame.origin.z();
    const double ux = frame.u.x(), uy = frame.u.y(), uz = frame.u.z();
    const double vx = frame.v.x(), vy = frame.v.y(), vz = frame.v.z();
    const double wx = frame.w.x(), wy = frame.w.y(), wz = frame.w.z();
    const std::size_t np = occ.size();
    const double twin_offset = kRelativeTwinOffset * occ.scale;
    P3 loc[kMaxPrimitiveVertices];
    P3 buf[2][kMaxClippedVertices];
    for (std::size_t p = 0; p < np; ++p) {
        int item = occ.item[p];
        if (item == exclude) continue;
        const double s = occ.nx[p] * ox + occ.ny[p] * oy + occ.nz[p] * oz - occ.d[p];
        if (std::abs(s) <= edge_on) continue;  // seen edge-on (coplanar with the point)
        const double hc = wx * (occ.cx[p] - ox) + wy * (occ.cy[p] - oy) + wz * (occ.cz[p] - oz);
        if (hc <= -occ.r[p]) continue;  // wholly below the base plane
        const std::uint32_t f0 = occ.first[p];
        const int n = static_cast<int>(occ.first[p + 1] - f0);
        double cmax = -std::numeric_limits<double>::infinity();
        for (int k = 0; k < n; ++k) {
            const double dx = occ.x[f0 + k] - ox, dy = occ.y[f0 + k] - oy, dz = occ.z[f0 + k] - oz;
            loc[k] = {{ux * dx + uy * dy + uz * dz, vx * dx + vy * dy + vz * dz,
                       wx * dx + wy * dy + wz * dz}};
            cmax = std::max(cmax, loc[k].v[2]);
        }
        if (cmax <= 0.0) continue;
        if (item >= 0 && s < 0.0) item = kViewBackFace;
        const double nl[3] = {ux * occ.nx[p] + uy * occ.ny[p] + uz * occ.nz[p],
                              vx * occ.nx[p] + vy * occ.ny[p] + vz * occ.nz[p],
                              wx * occ.nx[p] + wy * occ.ny[p] + wz * occ.nz[p]};
        // n·(vertex − origin); back faces and obstructions pushed back (twin faces).
        const double dl = occluder_plane_offset(-s, item, twin_offset);
        // Fast path: every vertex in one face's frustum (its largest coordinate along that
        // face's axis, above the base and the near plane) → the whole primitive is there.
        {
            const int face0 = face_of(loc[0]);
            const HemicubeFace& fc = kHemicubeFaces[face0];
            bool single = true;
            for (int k = 0; k < n && single; ++k) {
                single = (k == 0 || face_of(loc[k]) == face0) && loc[k].v[2] >= 0.0 &&
                         fc.sd * loc[k].v[fc.id] >= near;
            }
            if (single) {
                draw(face0, loc, n, nl, dl, item);
                continue;
            }
        }
        for (int f = 0; f < 5; ++f) {
            const HemicubeFace& fc = kHemicubeFaces[f];
            unsigned and_code = 31u, or_code = 0u;
            for (int k = 0; k < n; ++k) {
                const double U = fc.su * loc[k].v[fc.iu];
                const double V = fc.sv * loc[k].v[fc.iv];
                const double D = fc.sd * loc[k].v[fc.id];
                unsigned code = 0u;
                if (D - U < 0.0) code |= 1u;
                if (D + U < 0.0) code |= 2u;
                if (D - V < 0.0) code |= 4u;
                if ((fc.top ? D + V : V) < 0.0) code |= 8u;
                if (D < near) code |= 16u;
                and_code &= code;
                or_code |= code;
            }
            if (and_code != 0u) continue;  // wholly outside one plane of this face's frustum
            const P3* poly = loc;
            int m = n;
            int which = 0;
            for (int k = 0; k < 5 && m >= 3; ++k) {
                if ((or_code & (1u << k)) == 0u) continue;
                m = clip_convex(poly, m, face_plane(fc, k, near), buf[which]);
                poly = buf[which];
                which ^= 1;
            }
            if (m >= 3) draw(f, poly, m, nl, dl, item);
        }
    }
}

void HemicubeRaster::draw(int face, const P3* poly, int n, const double nl[3], double dl,
                          int item) {
    if (item >= 0 && stamp_[static_cast<std::size_t>(item)] != epoch_) {
        stamp_[static_cast<std::size_t>(item)] = epoch_;
        touched_.push_back(item);
    }
    const HemicubeFace& fc = kHemicubeFaces[face];
    const double half = 0.5 * R_;
    double X[kMaxClippedVertices], Y[kMaxClippedVertices];
    for (int k = 0; k < n; ++k) {
        const double inv = 1.0 / (fc.sd * coord(poly[k], fc.id));
        X[k] = (fc.su * coord(poly[k], fc.iu) * inv + 1.0) * half;
        const double v = fc.sv * coord(poly[k], fc.iv) * inv;
        Y[k] = fc.top ? (v + 1.0) * half : v * half;
    }
    // Inverse depth 1/D is affine in the face coordinates: w = (nU u + nV v + nD) / dl.
    const double nU = fc.su * nl[fc.iu], nV = fc.sv * nl[fc.iv], nD = fc.sd * nl[fc.id];
    const double scale = 2.0 / R_;
    const double wxp = nU * scale / dl;
    const double wyp = nV * scale / dl;
    const double w0 = (nD - nU - (fc.top ? nV : 0.0)) / dl;
    raster(face, X, Y, n, wxp, wyp, w0, item);
}

// Scan conversion of a convex polygon in pixel coordinates. A cell is covered when its centre
// is: rows with ymin ≤ y_c < ymax, and in a row xl ≤ x_c < xr, xl on the left chain and xr on
// the right chain of edges, both walked from the lowest vertex up. An edge's crossing is always
// computed from its lower end, so two polygons sharing an edge compute the same crossing and the
// cell goes to exactly one of them (a top-left rule): no gaps, no double counting.
void HemicubeRaster::raster(int face, const double* X, const double* Y, int n, double wx, double wy,
                            double w0, int item) {
    const int W = R_;
    const int H = face == 0 ? R_ : H_;
    double area2 = 0.0;
    int kmin = 0, kmax = 0;
    double xmin = X[0], xmax = X[0];
    for (int k = 0; k < n; ++k) {
        const int k1 = k + 1 == n ? 0 : k + 1;
        area2 += X[k] * Y[k1] - X[k1] * Y[k];
        if (Y[k] < Y[kmin]) kmin = k;
        if (Y[k] > Y[kmax]) kmax = k;
        xmin = std::min(xmin, X[k]);
        xmax = std::max(xmax, X[k]);
    }
    const int j0 = ceil_clamped(Y[kmin] - 0.5, 0, H);
    const int j1 = ceil_clamped(Y[kmax] - 0.5, 0, H);
    if (j0 >= j1) return;
    if (ceil_clamped(xmin - 0.5, 0, W) >= ceil_clamped(xmax - 0.5, 0, W)) return;
    if (area2 == 0.0 || !std::isfinite(area2)) return;
    // Counter-clockwise (X right, Y up): forward from the lowest vertex is the right chain.
    const int step_right = area2 > 0.0 ? 1 : n - 1;
    const int step_left = n - step_right;
    // Step along a chain without an integer division (step is 1 or n − 1).
    auto advance = [n](int k, int step) {
        k += step;
        return k >= n ? k - n : k;
    };
    // The chains as edge lists, lowest first; an edge serves the rows up to (excluding) `end`,
    // the first row whose centre lies above its upper end.
    struct ChainEdge {
        double x, y, slope;
        int end;
    };
    ChainEdge left[kMaxClippedVertices], right[kMaxClippedVertices];
    auto build = [&](int step, ChainEdge* out) {
        int count = 0;
        for (int k = kmin; k != kmax;) {
            const int k1 = advance(k, step);
            if (Y[k1] > Y[k]) {
                out[count++] = {X[k], Y[k], (X[k1] - X[k]) / (Y[k1] - Y[k]),
                                static_cast<int>(std::floor(Y[k1] - 0.5)) + 1};
            }
            k = k1;
        }
        return count;
    };
    const int nr = build(step_right, right);
    const int nl = build(step_left, left);
    if (nr == 0 || nl == 0) return;
    const std::size_t off = face_offset(face);
    float* depth = depth_.data() + off;
    int* items = items_.data() + off;
    const float fwx = static_cast<float>(wx);
    int ri = 0, li = 0;
    for (int j = j0; j < j1; ++j) {
        const double yc = j + 0.5;
        while (j >= right[ri].end && ri + 1 < nr) ++ri;
        while (j >= left[li].end && li + 1 < nl) ++li;
        const ChainEdge& er = right[ri];
        const ChainEdge& el = left[li];
        const double xl = el.x + (yc - el.y) * el.slope;
        const double xr = er.x + (yc - er.y) * er.slope;
        const int i0 = ceil_clamped(xl - 0.5, 0, W);
        const int i1 = ceil_clamped(xr - 0.5, 0, W);
        if (i0 >= i1) continue;
        const float wrow = static_cast<float>(w0 + wy * yc + wx * 0.5);
        float* drow = depth + static_cast<std::size_t>(j) * W;
        int* irow = items + static_cast<std::size_t>(j) * W;
#if defined(__SSE2__)
        // Aligned blocks of four cells with a lane mask for the span's ends: short spans (the
        // common case with many small triangles) take one or two blocks and no scalar tail.
        // Masked lanes store back what they loaded; the buffers have kPadding cells of padding.
        const __m128 vw = _mm_set1_ps(wrow), vdx = _mm_set1_ps(fwx);
        const __m128i vitem = _mm_set1_epi32(item);
        const __m128i vi0 = _mm_set1_epi32(i0 - 1), vi1 = _mm_set1_epi32(i1);
        auto block = [&](int b) {
            const __m128i lane = _mm_add_epi32(_mm_set1_epi32(b), _mm_setr_epi32(0, 1, 2, 3));
            const __m128i in_span =
                _mm_and_si128(_mm_cmpgt_epi32(lane, vi0), _mm_cmplt_epi32(lane, vi1));
            const __m128 w = _mm_add_ps(vw, _mm_mul_ps(vdx, _mm_cvtepi32_ps(lane)));
            const __m128 d = _mm_loadu_ps(drow + b);
            const __m128 m = _mm_and_ps(_mm_cmpgt_ps(w, d), _mm_castsi128_ps(in_span));
            _mm_storeu_ps(drow + b, _mm_or_ps(_mm_and_ps(m, w), _mm_andnot_ps(m, d)));
            const __m128i mi = _mm_castps_si128(m);
            const __m128i old = _mm_loadu_si128(reinterpret_cast<const __m128i*>(irow + b));
            _mm_storeu_si128(reinterpret_cast<__m128i*>(irow + b),
                             _mm_or_si128(_mm_and_si128(mi, vitem), _mm_andnot_si128(mi, old)));
        };
        for (int b = i0 & ~3; b < i1; b += 4) block(b);
#else
        for (int i = i0; i < i1; ++i) {
            const float w = wrow + fwx * static_cast<float>(i);
            if (w > drow[i]) {
                drow[i] = w;
                irow[i] = item;
            }
        }
#endif
    }
}

HemicubeDelta::HemicubeDelta(const std::vector<double>& delta, int resolution) {
    const std::size_t top = static_cast<std::size_t>(resolution) * resolution;
    const std::size_t side = top / 2;
    top_.assign(delta.begin(), delta.begin() + static_cast<std::ptrdiff_t>(top));
    side_.assign(delta.begin() + static_cast<std::ptrdiff_t>(top),
                 delta.begin() + static_cast<std::ptrdiff_t>(top + side));
}

void HemicubeRaster::accumulate(const HemicubeDelta& delta, double weight, double* row,
                                std::size_t patches) {
    // Four interleaved partial sums, indexed by item + 4 (negative items land in slots 0-3 and
    // are dropped): no branches, and four independent add chains instead of one per item. The
    // sums stay allocated and zero between hemicubes; only the patches drawn in this one are
    // read and cleared, so the cost does not grow with the number of patches.
    const std::size_t stride = patches + 4;
    if (partial_.size() != 4 * stride) partial_.assign(4 * stride, 0.0);
    double* p0 = partial_.data() + 4;
    double* p1 = p0 + stride;
    double* p2 = p1 + stride;
    double* p3 = p2 + stride;
    auto add = [&](const int* ids, const float* d, std::size_t n) {
        std::size_t k = 0;
        for (; k + 4 <= n; k += 4) {
            p0[ids[k]] += d[k];
            p1[ids[k + 1]] += d[k + 1];
            p2[ids[k + 2]] += d[k + 2];
            p3[ids[k + 3]] += d[k + 3];
        }
        for (; k < n; ++k) p0[ids[k]] += d[k];
    };
    add(items_.data(), delta.top(), static_cast<std::size_t>(R_) * R_);
    for (int f = 1; f < 5; ++f) {
        add(items_.data() + face_offset(f), delta.side(), static_cast<std::size_t>(R_) * H_);
    }
    for (const int j : touched_) {
        const double sum = (p0[j] + p1[j]) + (p2[j] + p3[j]);
        if (sum != 0.0) row[j] += weight * sum;
        p0[j] = p1[j] = p2[j] = p3[j] = 0.0;
    }
    for (int k = -4; k < 0; ++k) p0[k] = p1[k] = p2[k] = p3[k] = 0.0;
}

}  // namespace formfactor::projection
