#pragma once
// The `analytic` method (private header: the registry creates it by name).

#include "formfactor/methods/method.h"
#include "formfactor/scene/obstruction.h"
#include "kernels/analytic_internal.h"
#include "kernels/unobstructed.h"

namespace formfactor {

/// Form factors for every pair of patches: exact unobstructed values (the double contour
/// integral for near pairs, a tensor Gauss rule with an a-priori error bound ≤ options.tolerance
/// for far pairs, reciprocity for the other half); in scenes where something may block, pairs
/// are then classified by conservative shaft tests (fully visible: kept; fully hidden: 0; partly
/// hidden: adaptive integration to options.obstructed_tolerance).
class AnalyticMethod final : public Method {
  public:
    MethodKind kind() const override { return MethodKind::analytic; }
    void check(const Scene& scene) const override;
    /// A row range [b, e) costs its rows and the b × (e − b) pairs before them (plus, when the
    /// scene may obstruct, the classification of the whole scene and the integration of every
    /// partly hidden pair with a patch in the range, unless ctx.partly_hidden gives them), and
    /// is bit-identical to the same rows of the whole matrix.
    MethodResult compute(const MethodContext& ctx) const override;
    /// In a scene that may obstruct: the rows go sparse (ctx.sparse_rows), computed only for
    /// the pairs the classification finds visible or partly hidden (no N² work, no rows × N
    /// block); the same values as the dense matrix (docs/sparse.md).
    using Method::emits_sparse_rows;
    bool emits_sparse_rows(const Scene& scene) const override {
        return formfactor::may_obstruct(scene);
    }
    bool sparse_rows_at_once() const override { return true; }

    /// Largest tolerance of the unobstructed values in an obstructed scene (see compute()).
    static constexpr double kVisibleTolerance = 1e-10;
    /// The tolerance of the unobstructed values: options.tolerance, at most kVisibleTolerance
    /// where the scene may obstruct; an OptionError unless options.tolerance is a positive number.
    static double visible_tolerance(const MethodOptions& options, bool obstructed);

  private:
    /// The patches' table of ctx.partly_hidden, made once for all its blocks; null without.
    static const detail::PatchTable* given_table(const MethodContext& ctx);
    /// The obstruction pass over an unobstructed matrix (analytic_obstructed.cpp): corrects
    /// `out` and fills details["obstructions"] and the error bound's input.
    /// With `block`, only its rows are corrected (out.F is then unused).
    static void apply_obstructions(const MethodContext& ctx, FormFactors& out, Fields& details,
                                   detail::UnobstructedBlock* block = nullptr);
    /// The sparse rows of an obstructed scene (analytic_obstructed.cpp): ctx.rows into
    /// *ctx.sparse_rows, the unobstructed values at tolerance `visible_tolerance`.
    static void sparse_obstructed_rows(const MethodContext& ctx, double visible_tolerance,
                                       MethodResult& result);
};

}  // namespace formfactor
