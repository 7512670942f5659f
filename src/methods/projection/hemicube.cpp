#include "formfactor/methods/hemicube.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>

#include "formfactor/core/error.h"
#include "methods/projection/hemicube_raster.h"
#include "methods/projection/projection_common.h"

namespace formfactor {

using projection::HemicubeRaster;

std::vector<double> hemicube_delta_form_factors(int resolution) {
    projection::check_projection_options(resolution, 1, false);
    const int R = resolution, H = resolution / 2;
    std::vector<double> d(static_cast<std::size_t>(R) * R * 3);
    const double dA = 4.0 / (static_cast<double>(R) * R);
    std::size_t k = 0;
    for (int Y = 0; Y < R; ++Y) {
        const double v = (2.0 * Y + 1.0) / R - 1.0;
        for (int X = 0; X < R; ++X) {
            const double u = (2.0 * X + 1.0) / R - 1.0;
            const double q = u * u + v * v + 1.0;
            d[k++] = dA / (kPi * q * q);
        }
    }
    for (int f = 1; f < 5; ++f) {
        for (int Y = 0; Y < H; ++Y) {
            const double z = (2.0 * Y + 1.0) / R;
            for (int X = 0; X < R; ++X) {
                const double s = (2.0 * X + 1.0) / R - 1.0;
                const double q = s * s + z * z + 1.0;
                d[k++] = z * dA / (kPi * q * q);
            }
        }
    }
    double sum = 0.0;
    for (double x : d) sum += x;
    for (double& x : d) x /= sum;
    return d;
}

namespace {

// The hemicube of one point, rendered: the start of hemicube_point_row and hemicube_view.
struct PointHemicube {
    std::vector<double> delta;
    HemicubeRaster raster;

    PointHemicube(const Scene& scene, const Vec3& point, const Vec3& normal, int resolution,
                  double rotation, int exclude_patch)
        : delta(hemicube_delta_form_factors(resolution)), raster(resolution) {
        const projection::Occluders occ = projection::build_occluders(scene);
        raster.render(occ, projection::point_frame("hemicube", point, normal, rotation),
                      exclude_patch, projection::kRelativeNear * occ.scale,
                      projection::kRelativeEdgeOn * occ.scale);
    }
};

}  // namespace

std::vector<double> hemicube_point_row(const Scene& scene, const Vec3& point, const Vec3& normal,
                                       int resolution, double rotation, int exclude_patch) {
    PointHemicube h(scene, point, normal, resolution, rotation, exclude_patch);
    std::vector<double> row(scene.patches.size(), 0.0);
    h.raster.accumulate(projection::HemicubeDelta(h.delta, resolution), 1.0, row.data(),
                        row.size());
    return row;
}

ProjectionView hemicube_view(const Scene& scene, const Vec3& point, const Vec3& normal,
                             int resolution, double rotation, int exclude_patch) {
    const PointHemicube h(scene, point, normal, resolution, rotation, exclude_patch);
    const std::vector<double>& delta = h.delta;
    const HemicubeRaster& raster = h.raster;
    const int R = resolution, H = resolution / 2;
    ProjectionView view;
    view.kind = ProjectionView::Kind::hemicube;
    view.resolution = R;
    view.width = view.height = 2 * R;
    view.items.assign(static_cast<std::size_t>(4) * R * R, kViewUnused);
    view.delta.assign(view.items.size(), 0.0);
    const std::vector<int>& items = raster.items();
    for (int f = 0; f < 5; ++f) {
        const auto& fc = projection::kHemicubeFaces[f];
        const int rows = f == 0 ? R : H;
        const std::size_t off = raster.face_offset(f);
        for (int Y = 0; Y < rows; ++Y) {
            for (int X = 0; X < R; ++X) {
                // Direction of the cell centre in the local frame.
                const double u = (2.0 * X + 1.0) / R - 1.0;
                const double v = fc.top ? (2.0 * Y + 1.0) / R - 1.0 : (2.0 * Y + 1.0) / R;
                double dir[3] = {0, 0, 0};
                dir[fc.iu] += fc.su * u;
                dir[fc.iv] += fc.sv * v;
                dir[fc.id] += fc.sd;
                const double a = dir[0], b = dir[1], c = dir[2];
                double x, y;  // position in the unfolded cross, [−2, 2]²
                if (f == 0) {
                    x = a / c;
                    y = b / c;
                } else if (f == 1) {
                    x = 2.0 - c / a;
                    y = b / a;
                } else if (f == 2) {
                    x = -2.0 + c / -a;
                    y = b / -a;
                } else if (f == 3) {
                    y = 2.0 - c / b;
                    x = a / b;
                } else {
                    y = -2.0 + c / -b;
                    x = a / -b;
                }
                const int col =
                    std::clamp(static_cast<int>(std::floor((x + 2.0) * 0.5 * R)), 0, 2 * R - 1);
                const int row =
                    2 * R - 1 -
                    std::clamp(static_cast<int>(std::floor((y + 2.0) * 0.5 * R)), 0, 2 * R - 1);
                const std::size_t cell = off + static_cast<std::size_t>(Y) * R + X;
                const std::size_t pix = static_cast<std::size_t>(row) * 2 * R + col;
                view.items[pix] = items[cell];
                view.delta[pix] = delta[cell];
            }
        }
    }
    return view;
}

void HemicubeMethod::check(const Scene& scene) const {
    projection::check_patch_normals(scene, "hemicube");
}

MethodResult HemicubeMethod::compute(const MethodContext& ctx) const {
    const Scene& scene = ctx.scene;
    const MethodOptions& options = ctx.options;
    projection::check_projection_options(options.resolution, options.points, false);
    check(scene);
    const std::size_t n = scene.patches.size();
    MethodResult result;
    result.report.method = kind();
    FormFactors& out = result.form_factors;
    Fields& details = result.report.details;
    const int R = options.resolution;
    const projection::HemicubeDelta delta(hemicube_delta_form_factors(R), R);
    const projection::Occluders occ = projection::build_occluders(scene);
    const double near = projection::kRelativeNear * occ.scale;
    const double edge_on = projection::kRelativeEdgeOn * occ.scale;
    auto make = [R] { return std::make_unique<HemicubeRaster>(R); };
    auto visit = [&](HemicubeRaster& raster, std::size_t i, const projection::Frame& frame,
                     double weight, double* row) {
        raster.render(occ, frame, static_cast<int>(i), near, edge_on);
        raster.accumulate(delta, weight, row, n);
    };
    const std::size_t hemicubes =
        projection::project_rows<HemicubeRaster>(ctx, "hemicube", out, make, visit);
    details["resolution"] = R;
    details["points"] = options.points;
    details["hemicubes"] = hemicubes;
    details["cells_per_hemicube"] = 3 * R * R;
    details["seed"] = options.seed;
    return result;
}

}  // namespace formfactor
