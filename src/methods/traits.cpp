#include "formfactor/methods/traits.h"

#include <algorithm>

#include "formfactor/core/error.h"
#include "formfactor/core/random.h"
#include "formfactor/scene/obstruction.h"

namespace formfactor {

MethodTraits method_traits(MethodKind method, const MethodOptions& options, const Scene* scene) {
    MethodTraits t;
    t.reciprocity.method = to_string(method);
    using Kind = ReciprocityPromise::Kind;
    if (method == MethodKind::analytic) {
        t.reciprocity.kind = Kind::exact;
        double tol = std::max(1e-9, options.tolerance);
        if (scene && may_obstruct(*scene)) tol = std::max(tol, options.obstructed_tolerance);
        t.reciprocity.tolerance = tol;
    } else if (method == MethodKind::mc_area || method == MethodKind::mc_hemisphere ||
               method == MethodKind::mc_target) {
        t.standard_errors = true;
        t.reciprocity.kind = Kind::statistical;
        // Replicate standard errors (16 replicates for the default sample counts) have
        // replicates − 1 degrees of freedom. The i.i.d. formula of the random sampler has many,
        // but an entry of a few hits has a plug-in standard error that is itself uncertain and a
        // skewed count: its z has tails as heavy; 15 stands for that too (on the Cornell box,
        // 6,500 pairs, 5 seeds: max |z| up to 5.4 where a normal gives 5.25 at 99.9 %).
        const std::uint32_t r =
            replicate_count(options.sampler, options.samples ? options.samples : 1024);
        t.reciprocity.degrees_of_freedom = r > 1 ? static_cast<double>(r - 1) : 15.0;
    } else {  // hemicube, hemiplane
        t.reciprocity.kind = Kind::approximate;
    }
    return t;
}

}  // namespace formfactor
