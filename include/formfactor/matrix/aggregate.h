#pragma once
/// Per-surface form factors from per-patch ones (View3D's output: one row per surface, after its
/// Separate and Combine steps).
///
/// For groups G, H of patches with areas A_i:
///   A_G = Σ_{i∈G} A_i,   A_G F_GH = Σ_{i∈G} Σ_{j∈H} A_i F_ij,
/// so the group's row is the area-weighted mean of its patches' rows, its columns summed.
/// Row sums and reciprocity carry over exactly: Σ_H F_GH = Σ_{i∈G} A_i (Σ_j F_ij) / A_G, and
/// A_G F_GH = A_H F_HG whenever the patch matrix is reciprocal.

#include <string>
#include <vector>

#include "formfactor/matrix/form_factors.h"
#include "formfactor/matrix/sparse.h"
#include "formfactor/scene/scene.h"

namespace formfactor {

/// A partition of the patches into groups (rows of the aggregated matrix).
struct PatchGroups {
    std::vector<int> group_of_patch;  ///< patch index → group index (0-based)
    std::vector<std::string> names;   ///< one per group
    /// The scene surfaces in each group (first = the group's own surface), for surface groups.
    std::vector<std::vector<int>> surfaces;

    std::size_t size() const { return names.size(); }
};

/// The surface groups of a scene, View3D style: one group per non-obstruction surface, in
/// surface order, named after it, except that a surface combined with another
/// (Surface::combine ≥ 0, VS3 cmb) joins the target's group (its patches become part of that
/// row and column). A surface's patches cover polygon minus holes, so a base surface's group is
/// the base minus its subsurfaces (View3D's Separate). Obstruction-only surfaces have no group.
/// Throws GeometryError when a patch names no valid surface, a combine target is an obstruction
/// or out of range.
PatchGroups surface_groups(const Scene& scene);

/// True when every group is one patch and the groups follow the patch order (a VS3 file whose
/// every surface is one patch): the aggregated matrix is then the patch matrix itself.
bool is_identity(const PatchGroups& groups);

/// Aggregates a patch matrix over groups: A_G = Σ A_i, F_GH = Σ_{i∈G} Σ_{j∈H} A_i F_ij / A_G.
/// Standard errors (when f has them) are combined as for independent entries:
/// σ_GH = sqrt(Σ_{i∈G} Σ_{j∈H} (A_i σ_ij)²) / A_G. (Entries of one Monte Carlo row are in fact
/// negatively correlated, so for row-sampled estimates this is an upper bound.)
/// Every group must hold at least one patch of positive area. Throws GeometryError when
/// groups.group_of_patch does not match f, names a group out of range, or a group is empty.
FormFactors aggregate(const FormFactors& f, const PatchGroups& groups);

/// The same for a sparse F, in CSR: row G holds the groups H that some stored F_ij (i ∈ G,
/// j ∈ H) reaches, F_GH = Σ A_i F_ij / A_G over the stored entries, the standard errors as
/// above, and the computed row sums and the dropped mass as the rows (area-weighted means), so
/// that what a threshold dropped stays accounted for. O(nonzeros + groups log groups) time,
/// O(groups) scratch: never a groups × groups block. Throws GeometryError as aggregate(), and
/// Error for inconsistent CSR arrays.
SparseFormFactors aggregate(const SparseFormFactors& f, const PatchGroups& groups);
/// aggregate(f, surface_groups(scene)): the per-surface matrix that View3D reports.
FormFactors aggregate_per_surface(const Scene& scene, const FormFactors& f);

}  // namespace formfactor
