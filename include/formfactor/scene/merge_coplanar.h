#pragma once
/// Merging the triangles (and other faces) of a mesh back into the planar polygons they were
/// cut from: an STL or glTF box is 12 triangles, its CAD model 6 faces.

#include <cstddef>

#include "formfactor/scene/scene.h"

namespace formfactor {

/// What merge_coplanar() did.
struct MergeReport {
    std::size_t faces_before = 0;  ///< surfaces before merging
    std::size_t faces_after = 0;   ///< surfaces after
    std::size_t regions_kept = 0;  ///< coplanar regions left unmerged (boundary not simple)
};

/// Largest distance of a face's vertex from the plane of the region it joins, relative to the
/// region's diameter: the same bound as a polygon's planarity (kPlanarityTolerance).
inline constexpr double kCoplanarTolerance = kPlanarityTolerance;

/// Merges, within each surface group, faces that share an edge and lie in one plane into one
/// polygon with holes, then rebuilds the patches (one per surface; subdivide() again for more).
/// A group: the surfaces combined with one surface (Surface::combine, as the mesh readers make
/// one per Gmsh physical group or assimp mesh), or consecutive obstruction-only surfaces of one
/// name; a surface alone (an OBJ face) is its own group and stays as it is.
/// Faces join a region through edges whose two end vertices are the same points (bit for bit)
/// and that the two faces run in opposite directions (the same front); a face joins when each
/// of its vertices is within kCoplanarTolerance × (the region's diameter) of the plane of the
/// region's first face and its normal points the same way. The region's boundary becomes the
/// polygon (its outer loop, counter-clockwise seen from the front) and its holes (the inner
/// loops); boundary vertices that lie on the segment of their neighbours within 1e-12 of it
/// are dropped, so the merged area equals the sum of the faces' areas to ~1e-12 (relative).
/// A region whose boundary is not a set of simple loops (a vertex where it touches itself) or
/// whose polygon does not pass validate_polygon() keeps its faces (counted in regions_kept).
/// Merged surfaces keep the name, material and source location of the region's first face;
/// regions come in the order of their first faces; the first region of a group is the
/// surface the others are combined with.
MergeReport merge_coplanar(Scene& scene);

}  // namespace formfactor
