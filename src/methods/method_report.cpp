// A method's report as one Fields tree, for the run report (output/report.h).

#include "formfactor/methods/method.h"

namespace formfactor {

Fields to_fields(const MethodReport& r) {
    Fields f = r.details.is_null() ? Fields::object() : r.details;
    if (r.error_bound_per_entry) f["error_bound_per_entry"] = *r.error_bound_per_entry;
    if (r.pairs) {
        f["pairs"] = r.pairs->pairs;
        f["pairs_zero"] = r.pairs->zero;
        f["pairs_exact"] = r.pairs->exact;
        f["pairs_far_field"] = r.pairs->far_field;
    }
    if (r.rays_cast) f["rays_cast"] = *r.rays_cast;
    if (r.seconds) f["seconds"] = *r.seconds;
    return f;
}

}  // namespace formfactor
