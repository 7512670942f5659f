#pragma once
/// Whether a matrix's reciprocity defect is within what the method that made it promises. The
/// method states its promise (formfactor/methods/traits.h); this code only compares, so the
/// matrix module never needs to know which method made F.

#include <cstddef>
#include <optional>
#include <string>

#include "formfactor/matrix/form_factors.h"

namespace formfactor {

/// What a method promises about A_i F_ij = A_j F_ji.
struct ReciprocityPromise {
    enum class Kind {
        unknown,      ///< nothing known (a matrix read from a file)
        exact,        ///< relative defects below `tolerance`
        statistical,  ///< defects explained by the standard errors (Monte Carlo)
        approximate,  ///< no promise (hemicube, hemiplane: aliasing and point sampling)
    };
    Kind kind = Kind::unknown;
    /// exact: the largest row-relative defect (Diagnostics::reciprocity_row_max) allowed.
    double tolerance = 1e-9;
    /// statistical: degrees of freedom of each standard error (replicates − 1); 0 when the
    /// errors come from the i.i.d. formula of many samples (normal z-scores).
    double degrees_of_freedom = 0;
    /// Who promises, for the words ("analytic", "mc-hemisphere", ...).
    std::string method;
};

/// The comparison, in numbers and words.
struct ReciprocityVerdict {
    /// True or false when there is a promise to compare with; empty otherwise.
    std::optional<bool> within;
    /// One sentence, e.g. "within the method's promise (row-relative defect 2.2e-16 ≤ 1e-09)".
    std::string text;
    /// statistical: the largest |z| that chance explains over z_pairs pairs (probability 0.999
    /// that the maximum of z_pairs independent |z| stays below it).
    double z_max_limit = 0;
    /// statistical: the largest RMS of z that chance explains.
    double z_rms_limit = 0;
};

/// Compares the diagnostics with the promise. Exact: within when reciprocity_row_max ≤
/// tolerance. Statistical (needs Diagnostics::has_z): within when z_max ≤ z_max_limit and
/// z_rms ≤ z_rms_limit and no pair has a defect with zero standard errors; without z-scores it
/// falls back to "no standard errors to judge by". Approximate and unknown: no verdict, words
/// only.
ReciprocityVerdict assess_reciprocity(const Diagnostics& d, const ReciprocityPromise& promise);

/// Two-sided tail P(|T| > t) of Student's t with `dof` degrees of freedom (dof ≤ 0: the
/// standard normal).
double two_sided_tail(double t, double dof);

/// The t with two_sided_tail(t, dof) = p (0 < p < 1).
double two_sided_quantile(double p, double dof);

}  // namespace formfactor
