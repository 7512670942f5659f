#pragma once
/// The "city" scene of the sparse benchmarks (docs/scenes.md): an n × n grid of box buildings
/// on a ground plane, open to the sky. Most pairs of patches do not see each other (walls face
/// away, buildings hide buildings), so its form-factor matrix is sparse.
///
/// Geometry (units: one storey = one patch edge = 1): the ground is the square [0, 3n + 1]² in
/// z = 0; building (x, y), x, y = 0..n−1, stands on the footprint [3x + 1, 3x + 3] ×
/// [3y + 1, 3y + 3] (2 × 2, streets 1 wide between and around the buildings) with height
/// h(x, y) = 1 + (x + 2y) mod 4 storeys. The ground under the buildings is not part of the scene
/// (nothing overlaps); buildings have no floor.
///
/// Surfaces, in order: the ground as rectangles that tile it minus the footprints (the n + 1
/// streets along x, y = 3k, each (3n + 1) × 1; then, for each row of buildings, the n + 1
/// street pieces 1 × 2 between them), then for each building (y-major, then x) its walls facing
/// −x, +x, −y, +y and its roof; each rectangle as unit squares, every square its own surface
/// and patch (as room-N: `ground.K`, `wall.K`, `roof.K`), row-major as subdivide() would split
/// the rectangle. Normals: ground and roofs +z, walls outward.
///
/// Patch count P(n) = (n + 1)(5n + 1) [ground] + 4n² [roofs] + 8 Σ_{x,y} h(x, y) [walls]; when
/// n is even, Σ h = 2.5 n² and P(n) = 29 n² + 6 n + 1 (city-6: 1,081 patches, city-18: 9,505,
/// city-20: 11,721, city-58: 97,905, city-60: 104,761; odd n: city-19 has 10,500).

#include <cstddef>

#include "formfactor/scene/scene.h"

namespace formfactor {

/// Largest n of city_scene().
inline constexpr int kMaxCitySize = 1000;

/// The height of building (x, y) in storeys: 1 + (x + 2y) mod 4.
int city_building_height(int x, int y);

/// P(n), the number of patches of city_scene(n) (formula above).
std::size_t city_patch_count(int n);

/// The city of n × n buildings (1 ≤ n ≤ kMaxCitySize; OptionError("city") otherwise), named
/// `city-N`, not an enclosure, subdivided, with a camera looking down at it.
Scene city_scene(int n);

}  // namespace formfactor
