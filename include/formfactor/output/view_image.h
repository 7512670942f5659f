#pragma once
/// Pictures of what a point sees through a projection method (hemicube cross or hemiplane
/// square): each cell coloured by the patch it sees, optionally weighted by its delta form
/// factor, or the delta-form-factor map alone in false colour (written by write_png(), image.h).

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "formfactor/output/image.h"
#include "formfactor/scene/projection_view.h"

namespace formfactor {

/// A stable, well-spread colour for patch `item` (≥ 0): the same id always gets the same
/// colour, neighbouring ids very different ones. Special items: kViewNothing black,
/// kViewBackFace dark grey (64), kViewObstruction darker grey (40), kViewUnused white.
std::array<std::uint8_t, 3> item_colour(int item);

/// The item buffer as a picture: each cell in its patch's colour; with `weights`, scaled by
/// the cell's delta form factor relative to the largest (what each cell contributes to F).
/// Each cell becomes `scale` × `scale` pixels (scale ≥ 1).
Image render_view(const ProjectionView& view, bool weights = false, int scale = 1);

/// The delta form factors alone, in false colour (dark blue = 0 → yellow = the largest
/// cell); unused pixels white.
Image render_delta_map(const ProjectionView& view, int scale = 1);

}  // namespace formfactor
