#pragma once
/// Closed-model recognition (docs/closed-models.md): are the scene's patches a watertight
/// surface whose front sides all face an enclosed volume, so that no ray leaving the front of a
/// patch can reach infinity?
///
/// Vertices closer than the scene's vertex tolerance (kVertexTolerance × the diagonal of the
/// patches' bounding box) are welded into one. After welding, every edge of every patch must be
/// shared by exactly two patches that run it in opposite directions (a manifold, consistently
/// oriented surface). A T-junction (a vertex of one patch lying on an edge of another) leaves
/// unmatched edges: not closed. Obstruction-only surfaces take no part (they have no front).
/// Then each connected piece (shell) of the surface is either an enclosure (its fronts face the
/// volume it bounds: a room) or a body seen from outside (a box on its own, a sphere); the
/// scene is closed when every body lies inside an enclosure (a sphere in a room, not a satellite
/// in space).

#include <cstddef>
#include <string>
#include <vector>

#include "formfactor/core/types.h"
#include "formfactor/scene/scene.h"

namespace formfactor {

/// Vertices closer than this fraction of the diagonal of the patches' bounding box are one.
inline constexpr double kVertexTolerance = 1e-8;

/// The scene's vertex tolerance in scene length units: kVertexTolerance × the diagonal of the
/// patches' bounding box (0 without patches).
double vertex_tolerance(const Scene& scene);

/// The patches' vertices welded: positions[vertex[i][k]] stands for vertex k of patch i.
/// Greedy: each vertex, in patch order, joins the first earlier kept vertex within `tolerance`
/// (Euclidean), else is kept; kept vertices keep their own coordinates.
struct WeldedPatches {
    std::vector<Vec3> positions;
    std::vector<std::vector<int>> vertex;  ///< per patch, per polygon vertex
    double tolerance = 0.0;
};

/// Welds the vertices of scene.patches within vertex_tolerance(scene).
WeldedPatches weld_patches(const Scene& scene);

/// What check_closure() found.
struct Closure {
    /// Watertight and every body inside an enclosure: no ray from a front can escape.
    bool closed = false;
    /// Every welded edge shared by exactly two patches running it in opposite directions.
    bool watertight = false;
    std::size_t edges = 0;              ///< distinct welded edges
    std::size_t open_edges = 0;         ///< edges of one patch only (holes, T-junctions)
    std::size_t nonmanifold_edges = 0;  ///< edges of three patches or more
    std::size_t misoriented_edges = 0;  ///< edges two patches run the same way
    std::size_t shells = 0;             ///< connected pieces (patches joined by edges)
    std::size_t exposed_bodies = 0;     ///< bodies (fronts outwards) inside no enclosure
    double tolerance = 0.0;             ///< the vertex tolerance used, scene length units
    /// One line for people: "yes (...)" or "no: 12 open edges, ...".
    std::string summary() const;
};

/// Recognises a closed model among scene.patches (see the header comment).
Closure check_closure(const Scene& scene);
/// The same from welded patches already made (weld_patches(scene)).
Closure check_closure(const Scene& scene, const WeldedPatches& welded);

/// True when nothing can leave the scene: it is declared an enclosure (Scene::enclosure) or its
/// patches form a closed model (check_closure()). Repairs may then close its rows.
bool known_enclosure(const Scene& scene);

}  // namespace formfactor
