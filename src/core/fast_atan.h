#pragma once
// atan2 for a non-negative first argument, without the library call: the angle between two
// vectors from |a × b| and a · b, as Lambert's formula and the projected-solid-angle sampler
// need it for every edge of every polygon they see. The library's atan2 was 15 % of the
// obstructed analytic method's time.

#include "formfactor/core/types.h"

namespace formfactor::detail {

/// atan(z) for z ≥ 0: Cephes' atan (range reduction at tan(3π/8) and 0.66, then a degree 4/5
/// rational in z²; relative error ≤ 2.3e-16, about one ulp).
inline double atan_nonneg(double z) {
    constexpr double kT3P8 = 2.41421356237309504880, kMoreBits = 6.123233995736765886130e-17;
    double base = 0.0, extra = 0.0;
    if (z > kT3P8) {
        base = 0.5 * kPi;
        extra = kMoreBits;
        z = -1.0 / z;
    } else if (z > 0.66) {
        base = 0.25 * kPi;
        extra = 0.5 * kMoreBits;
        z = (z - 1.0) / (z + 1.0);
    }
    const double w = z * z;
    const double p = (((-8.750608600031904122785e-1 * w - 1.615753718733365076637e1) * w -
                       7.500855792314704667340e1) *
                          w -
                      1.228866684490136173410e2) *
                         w -
                     6.485021904942025371773e1;
    const double q = ((((w + 2.485846490142306297962e1) * w + 1.650270098316988542046e2) * w +
                       4.328810604912902668951e2) *
                          w +
                      4.853903996359136964868e2) *
                         w +
                     1.945506571482613964425e2;
    return base + (z * w * p / q + z + extra);
}

/// atan2(y, x) in [0, π] for y ≥ 0 (the angle between two vectors with |a × b| = y and
/// a · b = x).
inline double atan2_upper(double y, double x) {
    if (x > 0) return atan_nonneg(y / x);
    if (x < 0) return kPi - atan_nonneg(y / -x);
    return y > 0 ? 0.5 * kPi : 0.0;
}

}  // namespace formfactor::detail
