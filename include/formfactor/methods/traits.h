#pragma once
/// What each method promises about the matrix it makes, for the checks around a run: whether it
/// fills standard errors (memory: N² more doubles) and what its reciprocity defect may be (the
/// report's verdict). Kept beside the methods so that the matrix and output modules never need
/// to know which method made F.

#include <string>

#include "formfactor/matrix/reciprocity.h"
#include "formfactor/methods/method.h"
#include "formfactor/scene/scene.h"

namespace formfactor {

/// What a method promises.
struct MethodTraits {
    /// The method fills FormFactors::standard_error (the Monte-Carlo methods).
    bool standard_errors = false;
    /// analytic: exact, tolerance max(1e-9, options.tolerance, and options.obstructed_tolerance
    /// when `scene` may obstruct); mc-*: statistical, degrees of freedom replicates − 1 (15 for
    /// the random sampler's i.i.d. formula too: the plug-in error of a few hits is itself
    /// uncertain); hemicube, hemiplane: approximate.
    ReciprocityPromise reciprocity;
};

/// The traits of `method` with `options` on `scene` (may be null: then no obstruction is
/// assumed).
MethodTraits method_traits(MethodKind method, const MethodOptions& options,
                           const Scene* scene = nullptr);

}  // namespace formfactor
