#pragma once
/// The "room" benchmark scene of the obstructed analytic method (docs/analytic.md): a unit cube
/// room, faces inward, each split n×n, with a floating box [0.3, 0.7]² × [0.1, 0.5] inside.

#include "formfactor/scene/scene.h"

namespace formfactor {

/// How the room's box is modelled.
enum class RoomBox {
    kPatches,      ///< six outward faces split (n/2)×(n/2): rows and columns of the matrix
    kObstruction,  ///< six whole obstruction-only faces (VS3 `O` records): block only
    kNone,         ///< no box
};

/// The room: every patch is its own surface (as in a View3D input listing every patch), named
/// `wall.K` / `box.K`; patch order: faces x=0, x=1, y=0, y=1, z=0, z=1 (each n×n, row-major),
/// then the box's faces x=0.3, x=0.7, y=0.3, y=0.7, z=0.1, z=0.5. n ≥ 2 and even when the box
/// has patches. Throws OptionError("room", ...) otherwise.
Scene room_scene(int n, RoomBox box = RoomBox::kPatches);

}  // namespace formfactor
