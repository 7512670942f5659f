#pragma once
/// Basic math types. Geometry is double precision throughout (DESIGN.md).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

namespace formfactor {

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;
/// An RGB triple (reflectance, emission, radiosity): linear, not sRGB.
using Rgb = Eigen::Vector3d;

/// 1/π, used by every kernel.
inline constexpr double kInvPi = 0.31830988618379067154;
inline constexpr double kPi = 3.14159265358979323846;
/// Stefan–Boltzmann constant, W/(m² K⁴) (CODATA 2018, exact).
inline constexpr double kStefanBoltzmann = 5.670374419e-8;

/// Row-major dense matrix: row i = from patch i (a form-factor matrix or a block of its rows).
using DenseMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

/// Rows [begin, end) of F (patch indices). The default is every row; end is clamped to N.
struct RowRange {
    static constexpr std::size_t kEnd = std::numeric_limits<std::size_t>::max();
    std::size_t begin = 0;
    std::size_t end = kEnd;

    /// The range within [0, n): throws OptionError("rows") when begin > min(end, n).
    RowRange clamped(std::size_t n) const;
    std::size_t size() const { return end - begin; }
    bool contains(std::size_t i) const { return i >= begin && i < end; }
};

/// An oriented plane n·x = d with unit normal n.
struct Plane {
    Vec3 n = Vec3::UnitZ();
    double d = 0.0;
    /// Signed distance of x from the plane, positive on the side n points to.
    double signed_distance(const Vec3& x) const { return n.dot(x) - d; }
};

/// Axis-aligned bounding box.
struct Bounds3 {
    Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity());
    Vec3 hi = Vec3::Constant(-std::numeric_limits<double>::infinity());
    void extend(const Vec3& p) {
        lo = lo.cwiseMin(p);
        hi = hi.cwiseMax(p);
    }
    bool empty() const { return (lo.array() > hi.array()).any(); }
    Vec3 diagonal() const { return hi - lo; }
};

}  // namespace formfactor
