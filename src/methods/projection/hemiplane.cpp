#include "formfactor/methods/hemiplane.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <string>

#include "formfactor/core/error.h"
#include "methods/projection/projection_common.h"

namespace formfactor {

double hemiplane_corner_term(double x, double y) {
    const double sx = std::sqrt(1.0 + x * x), sy = std::sqrt(1.0 + y * y);
    return (x / sx * std::atan(y / sx) + y / sy * std::atan(x / sy)) / (2.0 * kPi);
}

double hemiplane_neglected_fraction(double half_width) {
    return 1.0 - 4.0 * hemiplane_corner_term(half_width, half_width);
}

namespace {

using projection::ClipPlane;
using projection::Occluders;
using projection::P3;

// The corner terms G at the (R+1)² corners of the finest grid: the delta form factor of any
// cell of any level is a signed sum of four of them, so the levels add up exactly.
struct CornerTable {
    int R = 0;
    double W = 0;
    std::vector<double> G;  // G[i * (R + 1) + j] at (x_i, y_j)

    CornerTable(int resolution, double half_width) : R(resolution), W(half_width) {
        G.resize(static_cast<std::size_t>(R + 1) * (R + 1));
        for (int i = 0; i <= R; ++i) {
            const double x = -W + 2.0 * W * i / R;
            for (int j = 0; j <= R; ++j) {
                const double y = -W + 2.0 * W * j / R;
                G[static_cast<std::size_t>(i) * (R + 1) + j] = hemiplane_corner_term(x, y);
            }
        }
    }
    double cell(int x0, int y0, int size) const {
        const std::size_t s = static_cast<std::size_t>(R + 1);
        const std::size_t i0 = static_cast<std::size_t>(x0), i1 = i0 + size;
        const std::size_t j0 = static_cast<std::size_t>(y0), j1 = j0 + size;
        return G[i1 * s + j1] - G[i0 * s + j1] - G[i1 * s + j0] + G[i0 * s + j0];
    }
};

// An edge of a projected polygon: A x + B y + C ≥ 0 inside, (A, B) unit.
struct PlaneEdge {
    double A, B, C;
};

// A projected convex polygon on the plane, in finest-cell units ([0, R]²).
struct PlanePolygon {
    int efirst, ecount;  // edges: A x + B y + C ≥ 0 inside, (A, B) unit
    double xmin, xmax, ymin, ymax;
    double wx, wy, w0;  // inverse height-depth, affine in (x, y)
    int item;
    double w(double x, double y) const { return w0 + wx * x + wy * y; }
};

constexpr double kEdgeTolerance = 1e-9;   // cell units
constexpr double kDepthTolerance = 1e-9;  // relative

class HemiplaneSolver {
  public:
    HemiplaneSolver(const CornerTable& table) : t_(table), R_(table.R), W_(table.W) {}

    void project(const Occluders& occ, const projection::Frame& frame, int exclude, double near,
                 double edge_on);
    // Credits row[item] += weight · ΔF for every finished cell; fills ids (R × R, y up) when
    // given. Returns the ΔF of the finest cells decided by their centre.
    double solve(double weight, double* row, int* ids);
    // The patches solve() may credit after the last project() (each polygon's item, repeats
    // and obstructions included).
    const std::vector<int>& touched() const { return touched_; }

  private:
    void add_polygon(const P3* poly, int n, const double nl[3], double dl, int item);
    void recurse(int x0, int y0, int size, std::size_t lb, std::size_t le);
    void leaf(int x0, int y0, int size, int item, bool ambiguous);

    const CornerTable& t_;
    int R_;
    double W_;
    std::vector<PlanePolygon> polys_;
    std::vector<PlaneEdge> edges_;
    std::vector<int> list_;
    std::vector<int> touched_;
    double weight_ = 1.0;
    double* row_ = nullptr;
    int* ids_ = nullptr;
    double ambiguous_ = 0.0;
};

void HemiplaneSolver::project(const Occluders& occ, const projection::Frame& frame, int exclude,
                              double near, double edge_on) {
    polys_.clear();
    edges_.clear();
    touched_.clear();
    const ClipPlane planes[5] = {
        {-1, 0, W_, 0}, {1, 0, W_, 0}, {0, -1, W_, 0}, {0, 1, W_, 0}, {0, 0, 1, near}};
    const Vec3& o = frame.origin;
    const double twin_offset = projection::kRelativeTwinOffset * occ.scale;
    P3 loc[projection::kMaxPrimitiveVertices];
    P3 buf[2][projection::kMaxClippedVertices];
    for (std::size_t p = 0; p < occ.size(); ++p) {
        int item = occ.item[p];
        if (item == exclude) continue;
        const Vec3 n(occ.nx[p], occ.ny[p], occ.nz[p]);
        const double s = n.dot(o) - occ.d[p];
        if (std::abs(s) <= edge_on) continue;
        const Vec3 c(occ.cx[p], occ.cy[p], occ.cz[p]);
        if (frame.w.dot(c - o) <= -occ.r[p]) continue;
        const std::uint32_t f0 = occ.first[p];
        const int m = static_cast<int>(occ.first[p + 1] - f0);
        unsigned and_code = 31u, or_code = 0u;
        for (int k = 0; k < m; ++k) {
            const Vec3 d = Vec3(occ.x[f0 + k], occ.y[f0 + k], occ.z[f0 + k]) - o;
            loc[k] = {{frame.u.dot(d), frame.v.dot(d), frame.w.dot(d)}};
            unsigned code = 0u;
            for (int q = 0; q < 5; ++q) {
                if (planes[q].distance(loc[k]) < 0.0) code |= 1u << q;
            }
            and_code &= code;
            or_code |= code;
        }
        if (and_code != 0u) continue;
        if (item >= 0 && s < 0.0) item = kViewBackFace;
        const P3* poly = loc;
        int cnt = m;
        int which = 0;
        for (int q = 0; q < 5 && cnt >= 3; ++q) {
            if ((or_code & (1u << q)) == 0u) continue;
            cnt = projection::clip_convex(poly, cnt, planes[q], buf[which]);
            poly = buf[which];
            which ^= 1;
        }
        if (cnt < 3) continue;
        const double nl[3] = {frame.u.dot(n), frame.v.dot(n), frame.w.dot(n)};
        // Back faces and obstructions pushed back: a coincident front face wins (twin faces).
        add_polygon(poly, cnt, nl, projection::occluder_plane_offset(-s, item, twin_offset), item);
    }
}

void HemiplaneSolver::add_polygon(const P3* poly, int n, const double nl[3], double dl, int item) {
    const double k = R_ / (2.0 * W_);  // cells per plane unit
    double X[projection::kMaxClippedVertices], Y[projection::kMaxClippedVertices];
    double area2 = 0.0;
    PlanePolygon pp;
    pp.xmin = pp.ymin = std::numeric_limits<double>::infinity();
    pp.xmax = pp.ymax = -std::numeric_limits<double>::infinity();
    for (int i = 0; i < n; ++i) {
        X[i] = (poly[i].v[0] / poly[i].v[2] + W_) * k;
        Y[i] = (poly[i].v[1] / poly[i].v[2] + W_) * k;
        pp.xmin = std::min(pp.xmin, X[i]);
        pp.xmax = std::max(pp.xmax, X[i]);
        pp.ymin = std::min(pp.ymin, Y[i]);
        pp.ymax = std::max(pp.ymax, Y[i]);
    }
    for (int i = 0; i < n; ++i) {
        const int j = i + 1 == n ? 0 : i + 1;
        area2 += X[i] * Y[j] - X[j] * Y[i];
    }
    if (!(std::abs(area2) > 1e-18) || !std::isfinite(area2)) return;
    const double orient = area2 > 0.0 ? 1.0 : -1.0;
    pp.efirst = static_cast<int>(edges_.size());
    for (int i = 0; i < n; ++i) {
        const int j = i + 1 == n ? 0 : i + 1;
        const double ex = X[j] - X[i], ey = Y[j] - Y[i];
        const double len = std::hypot(ex, ey);
        if (!(len > 1e-12)) continue;
        const double A = -ey / len * orient, B = ex / len * orient;
        edges_.push_back({A, B, -(A * X[i] + B * Y[i])});
    }
    pp.ecount = static_cast<int>(edges_.size()) - pp.efirst;
    if (pp.ecount < 3) {
        edges_.resize(static_cast<std::size_t>(pp.efirst));
        return;
    }
    // w = (n_a u + n_b v + n_c) / dl with u = x / k − W, v = y / k − W.
    pp.wx = nl[0] / k / dl;
    pp.wy = nl[1] / k / dl;
    pp.w0 = (nl[2] - W_ * nl[0] - W_ * nl[1]) / dl;
    pp.item = item;
    polys_.push_back(pp);
    touched_.push_back(item);
}

void HemiplaneSolver::leaf(int x0, int y0, int size, int item, bool ambiguous) {
    const double dF = t_.cell(x0, y0, size);
    if (item >= 0) row_[item] += weight_ * dF;
    if (ambiguous) ambiguous_ += dF;
    if (ids_) {
        for (int y = y0; y < y0 + size; ++y) {
            std::fill_n(ids_ + static_cast<std::size_t>(y) * R_ + x0, size, item);
        }
    }
}

void HemiplaneSolver::recurse(int x0, int y0, int size, std::size_t lb, std::size_t le) {
    const std::size_t mark = list_.size();
    const double X0 = x0, X1 = x0 + size, Y0 = y0, Y1 = y0 + size;
    const double xc = 0.5 * (X0 + X1), yc = 0.5 * (Y0 + Y1);
    int best = -1;
    double best_w = -std::numeric_limits<double>::infinity();
    for (std::size_t idx = lb; idx < le; ++idx) {
        const int q = list_[idx];
        const PlanePolygon& P = polys_[static_cast<std::size_t>(q)];
        if (P.xmax <= X0 + kEdgeTolerance || P.xmin >= X1 - kEdgeTolerance ||
            P.ymax <= Y0 + kEdgeTolerance || P.ymin >= Y1 - kEdgeTolerance) {
            continue;
        }
        bool contains = true, disjoint = false;
        for (int e = P.efirst; e < P.efirst + P.ecount; ++e) {
            const PlaneEdge& E = edges_[static_cast<std::size_t>(e)];
            const double ax0 = E.A * X0, ax1 = E.A * X1, by0 = E.B * Y0, by1 = E.B * Y1;
            const double emax = E.C + std::max(ax0, ax1) + std::max(by0, by1);
            if (emax <= kEdgeTolerance) {
                disjoint = true;
                break;
            }
            const double emin = E.C + std::min(ax0, ax1) + std::min(by0, by1);
            contains = contains && emin >= -kEdgeTolerance;
        }
        if (disjoint) continue;
        list_.push_back(q);
        if (contains) {
            const double w = P.w(xc, yc);
            if (w > best_w) {
                best_w = w;
                best = q;
            }
        }
    }
    std::size_t end = list_.size();
    if (end == mark) {
        leaf(x0, y0, size, kViewNothing, false);
        return;
    }
    if (best >= 0) {
        // Drop what the nearest covering polygon hides over the whole cell (affine depths:
        // the difference is smallest at a corner).
        const PlanePolygon& B = polys_[static_cast<std::size_t>(best)];
        const double tol = kDepthTolerance * std::abs(best_w);
        std::size_t out = mark;
        for (std::size_t idx = mark; idx < end; ++idx) {
            const int q = list_[idx];
            if (q != best) {
                const PlanePolygon& Q = polys_[static_cast<std::size_t>(q)];
                const double dx = B.wx - Q.wx, dy = B.wy - Q.wy;
                const double dmin =
                    (B.w0 - Q.w0) + dx * (dx > 0 ? X0 : X1) + dy * (dy > 0 ? Y0 : Y1);
                if (dmin >= -tol) continue;
            }
            list_[out++] = q;
        }
        list_.resize(out);
        end = out;
        if (end - mark == 1) {
            leaf(x0, y0, size, B.item, false);
            list_.resize(mark);
            return;
        }
    }
    if (size == 1) {
        int item = kViewNothing;
        double wbest = -std::numeric_limits<double>::infinity();
        for (std::size_t idx = mark; idx < end; ++idx) {
            const PlanePolygon& P = polys_[static_cast<std::size_t>(list_[idx])];
            bool inside = true;
            for (int e = P.efirst; e < P.efirst + P.ecount && inside; ++e) {
                const PlaneEdge& E = edges_[static_cast<std::size_t>(e)];
                inside = E.A * xc + E.B * yc + E.C >= 0.0;
            }
            if (!inside) continue;
            const double w = P.w(xc, yc);
            if (w > wbest) {
                wbest = w;
                item = P.item;
            }
        }
        leaf(x0, y0, 1, item, true);
        list_.resize(mark);
        return;
    }
    const int h = size / 2;
    recurse(x0, y0, h, mark, end);
    recurse(x0 + h, y0, h, mark, end);
    recurse(x0, y0 + h, h, mark, end);
    recurse(x0 + h, y0 + h, h, mark, end);
    list_.resize(mark);
}

double HemiplaneSolver::solve(double weight, double* row, int* ids) {
    weight_ = weight;
    row_ = row;
    ids_ = ids;
    ambiguous_ = 0.0;
    list_.clear();
    for (std::size_t q = 0; q < polys_.size(); ++q) list_.push_back(static_cast<int>(q));
    recurse(0, 0, R_, 0, list_.size());
    return ambiguous_;
}

void check_half_width(double W) {
    if (!(W > 0.0) || !std::isfinite(W)) {
        throw OptionError("half_width", "the hemiplane's half-width must be positive");
    }
}

// The hemiplane of one point, projected: the start of hemiplane_point_row and hemiplane_view.
struct PointHemiplane {
    CornerTable table;
    HemiplaneSolver solver;

    PointHemiplane(const Scene& scene, const Vec3& point, const Vec3& normal, int resolution,
                   double rotation, int exclude_patch, double half_width)
        : table(checked_table(resolution, half_width)), solver(table) {
        const Occluders occ = projection::build_occluders(scene);
        solver.project(occ, projection::point_frame("hemiplane", point, normal, rotation),
                       exclude_patch, projection::kRelativeNear * occ.scale,
                       projection::kRelativeEdgeOn * occ.scale);
    }

    PointHemiplane(const PointHemiplane&) = delete;  // solver refers to table
    PointHemiplane& operator=(const PointHemiplane&) = delete;

    static CornerTable checked_table(int resolution, double half_width) {
        projection::check_projection_options(resolution, 1, true);
        check_half_width(half_width);
        return CornerTable(resolution, half_width);
    }
};

}  // namespace

HemiplaneRow hemiplane_point_row(const Scene& scene, const Vec3& point, const Vec3& normal,
                                 int resolution, double rotation, int exclude_patch,
                                 double half_width) {
    PointHemiplane h(scene, point, normal, resolution, rotation, exclude_patch, half_width);
    HemiplaneRow out;
    out.F.assign(scene.patches.size(), 0.0);
    out.neglected = hemiplane_neglected_fraction(half_width);
    out.ambiguous = h.solver.solve(1.0, out.F.data(), nullptr);
    return out;
}

ProjectionView hemiplane_view(const Scene& scene, const Vec3& point, const Vec3& normal,
                              int resolution, double rotation, int exclude_patch,
                              double half_width) {
    PointHemiplane h(scene, point, normal, resolution, rotation, exclude_patch, half_width);
    const CornerTable& table = h.table;
    const int R = resolution;
    std::vector<double> row(scene.patches.size(), 0.0);
    std::vector<int> ids(static_cast<std::size_t>(R) * R, kViewNothing);
    h.solver.solve(1.0, row.data(), ids.data());
    ProjectionView view;
    view.kind = ProjectionView::Kind::hemiplane;
    view.resolution = view.width = view.height = R;
    view.neglected = hemiplane_neglected_fraction(half_width);
    view.items.resize(ids.size());
    view.delta.resize(ids.size());
    for (int y = 0; y < R; ++y) {
        for (int x = 0; x < R; ++x) {
            const std::size_t pix = static_cast<std::size_t>(R - 1 - y) * R + x;
            view.items[pix] = ids[static_cast<std::size_t>(y) * R + x];
            view.delta[pix] = table.cell(x, y, 1);
        }
    }
    return view;
}

void HemiplaneMethod::check(const Scene& scene) const {
    check_half_width(half_width_);
    projection::check_patch_normals(scene, "hemiplane");
}

MethodResult HemiplaneMethod::compute(const MethodContext& ctx) const {
    const Scene& scene = ctx.scene;
    const MethodOptions& options = ctx.options;
    projection::check_projection_options(options.resolution, options.points, true);
    check(scene);
    const RowRange rows = ctx.rows.clamped(scene.patches.size());
    const std::size_t n = rows.size();
    MethodResult result;
    result.report.method = kind();
    FormFactors& out = result.form_factors;
    Fields& details = result.report.details;
    const CornerTable table(options.resolution, half_width_);
    const Occluders occ = projection::build_occluders(scene);
    const double near = projection::kRelativeNear * occ.scale;
    const double edge_on = projection::kRelativeEdgeOn * occ.scale;
    std::vector<double> ambiguous(n, 0.0);  // entry i - rows.begin: written by row i only
    auto make = [&] { return std::make_unique<HemiplaneSolver>(table); };
    auto visit = [&](HemiplaneSolver& solver, std::size_t i, const projection::Frame& frame,
                     double weight, double* row) {
        solver.project(occ, frame, static_cast<int>(i), near, edge_on);
        ambiguous[i - rows.begin] += weight * solver.solve(weight, row, nullptr);
    };
    const std::size_t planes =
        projection::project_rows<HemiplaneSolver>(ctx, "hemiplane", out, make, visit);
    double amb_max = 0.0, amb_sum = 0.0;
    for (double a : ambiguous) {
        amb_max = std::max(amb_max, a);
        amb_sum += a;
    }
    details["resolution"] = options.resolution;
    details["points"] = options.points;
    details["hemiplanes"] = planes;
    details["plane_half_width"] = half_width_;
    details["plane_height"] = 1.0;
    details["neglected_fraction"] = hemiplane_neglected_fraction(half_width_);
    details["ambiguous_max"] = amb_max;
    details["ambiguous_mean"] = n > 0 ? amb_sum / static_cast<double>(n) : 0.0;
    details["seed"] = options.seed;
    return result;
}

}  // namespace formfactor
