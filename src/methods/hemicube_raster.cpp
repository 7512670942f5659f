#include "methods/hemicube_raster.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace formfactor::projection {

namespace {

inline double coord(const P3& p, int k) { return k == 0 ? p.a : (k == 1 ? p.b : p.c); }

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
      depth_(static_cast<std::size_t>(resolution) * resolution * 3),
      items_(depth_.size()) {}

std::size_t HemicubeRaster::face_offset(int f) const {
    const std::size_t top = static_cast<std::size_t>(R_) * R_;
    return f == 0 ? 0 : top + static_cast<std::size_t>(f - 1) * R_ * H_;
}

void HemicubeRaster::render(const Occluders& occ, const Frame& frame, int exclude, double near,
                            double edge_on) {
    std::fill(depth_.begin(), depth_.end(), 0.0f);
    std::fill(items_.begin(), items_.end(), kViewNothing);
    const double ox = frame.origin.x(), oy = frame.origin.y(), oz = frame.origin.z();
    const double ux = frame.u.x(), uy = frame.u.y(), uz = frame.u.z();
    const double vx = frame.v.x(), vy = frame.v.y(), vz = frame.v.z();
    const double wx = frame.w.x(), wy = frame.w.y(), wz = frame.w.z();
    const std::size_t np = occ.size();
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
            loc[k] = {ux * dx + uy * dy + uz * dz, vx * dx + vy * dy + vz * dz,
                      wx * dx + wy * dy + wz * dz};
            cmax = std::max(cmax, loc[k].c);
        }
        if (cmax <= 0.0) continue;
        if (item >= 0 && s < 0.0) item = kViewBackFace;
        const double nl[3] = {ux * occ.nx[p] + uy * occ.ny[p] + uz * occ.nz[p],
                              vx * occ.nx[p] + vy * occ.ny[p] + vz * occ.nz[p],
                              wx * occ.nx[p] + wy * occ.ny[p] + wz * occ.nz[p]};
        const double dl = -s;  // n·(vertex − origin)
        for (int f = 0; f < 5; ++f) {
            const HemicubeFace& fc = kHemicubeFaces[f];
            unsigned and_code = 31u, or_code = 0u;
            for (int k = 0; k < n; ++k) {
                const double U = fc.su * coord(loc[k], fc.iu);
                const double V = fc.sv * coord(loc[k], fc.iv);
                const double D = fc.sd * coord(loc[k], fc.id);
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
// is: rows with ymin ≤ y_c < ymax, and in a row xl ≤ x_c < xr, where xl is the largest crossing
// of a left edge and xr the smallest of a right edge. Each edge's crossing is computed from its
// lower end, so two polygons sharing an edge compute the same crossing: the cell goes to exactly
// one of them (a top-left rule), no gaps, no double counting.
void HemicubeRaster::raster(int face, const double* X, const double* Y, int n, double wx, double wy,
                            double w0, int item) {
    const int W = R_;
    const int H = face == 0 ? R_ : H_;
    double area2 = 0.0;
    double ymin = Y[0], ymax = Y[0];
    for (int k = 0; k < n; ++k) {
        const int k1 = k + 1 == n ? 0 : k + 1;
        area2 += X[k] * Y[k1] - X[k1] * Y[k];
        ymin = std::min(ymin, Y[k]);
        ymax = std::max(ymax, Y[k]);
    }
    if (area2 == 0.0 || !std::isfinite(area2)) return;
    const int j0 = std::max(0, static_cast<int>(std::ceil(ymin - 0.5)));
    const int j1 = std::min(H, static_cast<int>(std::ceil(ymax - 0.5)));
    if (j0 >= j1) return;
    const bool ccw = area2 > 0.0;
    double lx[kMaxClippedVertices], ly[kMaxClippedVertices], ls[kMaxClippedVertices];
    double rx[kMaxClippedVertices], ry[kMaxClippedVertices], rs[kMaxClippedVertices];
    int nl = 0, nr = 0;
    for (int k = 0; k < n; ++k) {
        const int k1 = k + 1 == n ? 0 : k + 1;
        if (Y[k] == Y[k1]) continue;
        const bool up = Y[k1] > Y[k];
        const int lo = up ? k : k1, hi = up ? k1 : k;
        const double slope = (X[hi] - X[lo]) / (Y[hi] - Y[lo]);
        if (up == ccw) {
            rx[nr] = X[lo];
            ry[nr] = Y[lo];
            rs[nr++] = slope;
        } else {
            lx[nl] = X[lo];
            ly[nl] = Y[lo];
            ls[nl++] = slope;
        }
    }
    const std::size_t off = face_offset(face);
    float* depth = depth_.data() + off;
    int* items = items_.data() + off;
    const float fwx = static_cast<float>(wx);
    for (int j = j0; j < j1; ++j) {
        const double yc = j + 0.5;
        double xl = -std::numeric_limits<double>::infinity();
        double xr = std::numeric_limits<double>::infinity();
        for (int e = 0; e < nl; ++e) xl = std::max(xl, lx[e] + (yc - ly[e]) * ls[e]);
        for (int e = 0; e < nr; ++e) xr = std::min(xr, rx[e] + (yc - ry[e]) * rs[e]);
        const int i0 = std::max(0, static_cast<int>(std::ceil(xl - 0.5)));
        const int i1 = std::min(W, static_cast<int>(std::ceil(xr - 0.5)));
        if (i0 >= i1) continue;
        const float wrow = static_cast<float>(w0 + wy * yc + wx * 0.5);
        float* drow = depth + static_cast<std::size_t>(j) * W;
        int* irow = items + static_cast<std::size_t>(j) * W;
        for (int i = i0; i < i1; ++i) {
            const float w = wrow + fwx * static_cast<float>(i);
            if (w > drow[i]) {
                drow[i] = w;
                irow[i] = item;
            }
        }
    }
}

void HemicubeRaster::accumulate(const std::vector<double>& delta, double weight,
                                double* row) const {
    // Runs of one item are summed first: no store-to-load chain through row[] per cell.
    const std::size_t n = items_.size();
    int cur = items_[0];
    double acc = 0.0;
    for (std::size_t k = 0; k < n; ++k) {
        const int it = items_[k];
        if (it != cur) {
            if (cur >= 0) row[cur] += weight * acc;
            cur = it;
            acc = 0.0;
        }
        acc += delta[k];
    }
    if (cur >= 0) row[cur] += weight * acc;
}

}  // namespace formfactor::projection
