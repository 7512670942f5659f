#pragma once
// The `analytic` method (private header: the registry creates it by name).

#include "formfactor/methods/method.h"

namespace formfactor {

/// Exact unobstructed form factors for every pair of patches: the double contour integral for
/// near pairs, a tensor Gauss rule with an a-priori error bound ≤ options.tolerance for far
/// pairs, reciprocity for the other half. Refuses scenes where a surface may block another.
class AnalyticMethod final : public Method {
  public:
    std::string name() const override;
    void check(const Scene& scene) const override;
    FormFactors compute(const Scene& scene, const MethodOptions& options,
                        nlohmann::json& details) const override;
};

}  // namespace formfactor
