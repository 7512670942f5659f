#pragma once
// Random obstructed scenes for the differential harness (test_differential.cpp): the unit room
// (faces n×n, inward) with blockers inside — boxes axis-aligned or tilted, resting on a wall,
// touching or overlapping each other, thin plates, single quads, closed solids of triangles —
// optionally with vertex jitter where edges nearly meet, and each geometry written in every
// form the project reads: the in-memory Scene, OBJ with the blockers as radiating faces or in an
// `obstruction` group, VS3 with `S` or `O` records (text written here in the styles other
// programs write, and by the project's save_obj / save_vs3), loaded back by the normal loaders.

#include <cstdint>
#include <string>
#include <vector>

#include "formfactor/geometry/polygon.h"
#include "formfactor/scene/scene.h"

namespace formfactor::testing {

/// Options of random_geometry().
struct GeneratorOptions {
    std::vector<int> room_n = {2, 3};      ///< room faces n×n, n drawn from this list
    int max_blockers = 2;                  ///< 1..max_blockers blockers (a pair counts as one)
    std::vector<int> blocker_split = {1};  ///< blocker faces m×m patches, m from this list
    double jitter_probability = 0.3;       ///< chance that the geometry carries vertex jitter
};

/// One geometry: the polygons every form describes, in patch order.
struct Geometry {
    std::string label;  ///< what was drawn, for messages
    int n = 0;          ///< room faces n×n
    double jitter = 0;  ///< largest relative vertex jitter (0: none)
    /// Room patches (faces x=0, x=1, y=0, y=1, z=0, z=1 as room_scene(), each n×n row-major,
    /// facing inward): the rows and columns of every form.
    std::vector<Polygon> room;
    /// The blockers' faces as patches (rows and columns of the radiating forms, after the room).
    std::vector<Polygon> blockers;
    /// The blockers as the obstruction forms write them: the same polygons, or (without jitter)
    /// sometimes the blockers' whole faces — the same region either way.
    std::vector<Polygon> obstructions;
    /// Closed: the room and every blocker are closed solids that neither touch nor overlap, so
    /// that every row of the radiating forms sums to 1.
    bool closed = false;
    /// Text style of the foreign writers (a different mix per geometry).
    std::uint64_t style = 0;
};

/// The geometry of `seed` (a pure function of seed and options).
Geometry random_geometry(std::uint64_t seed, const GeneratorOptions& options = {});

/// The unit room plus the given blockers (whole faces; split m×m as patches, and as
/// obstructions too when split_obstructions). No jitter; text style: shared vertices.
Geometry room_with_blockers(int n, const std::vector<std::vector<Polygon>>& blocker_faces, int m,
                            bool closed, const std::string& label, bool split_obstructions = false);

/// The forms a geometry is written in.
enum class Form {
    kScene,                     ///< in-memory Scene, blockers radiating (the reference form)
    kSceneObstruction,          ///< in-memory Scene, blockers obstruction-only
    kObj,                       ///< OBJ text, blockers as faces
    kObjObstruction,            ///< OBJ text, blockers in an `obstruction*` group or object
    kVs3,                       ///< VS3 text, blockers as S records
    kVs3Obstruction,            ///< VS3 text, blockers as O records
    kSavedObj,                  ///< save_obj() of kScene
    kSavedObjObstruction,       ///< save_obj() of kSceneObstruction
    kSavedVs3,                  ///< save_vs3() of kScene
    kSavedVs3Obstruction,       ///< save_vs3() of kSceneObstruction
    kScenePermuted,             ///< kScene with its patches in a shuffled order
    kSceneObstructionPermuted,  ///< kSceneObstruction, patches and obstructions shuffled
};

/// Every form, in the order above.
std::vector<Form> all_forms();
/// A short name ("vs3-O", ...).
std::string form_name(Form f);
/// True when the blockers are patches (rows and columns) in this form.
bool blockers_radiate(Form f);
/// order[k] = the index, in the kScene numbering (room, then blockers), of patch k of form f:
/// the identity except for the permuted forms.
std::vector<std::size_t> patch_order(const Geometry& g, Form f);

/// The in-memory Scene (scene_of()): one surface per patch (room, then blockers when radiating,
/// else obstruction-only surfaces), patches = surfaces.
Scene make_scene(const Geometry& g, bool blockers_radiate);

/// OBJ text in the foreign style of g.style (shared or per-face vertices, negative indices,
/// `g`/`o` records); polygon k starts at its vertex k mod size.
std::string obj_text(const Geometry& g, bool blockers_radiate);
/// VS3 text (`F 3`) in the foreign style of g.style (shared or per-surface vertices, tabs);
/// polygon k starts at its vertex k mod size; S records first, O records after them.
std::string vs3_text(const Geometry& g, bool blockers_radiate);

/// The geometry in form f, written into `dir` when the form is a file and loaded back by
/// load_scene() (patches = surfaces).
Scene load_form(const Geometry& g, Form f, const std::string& dir);

/// The outward faces of a box: centre c, half-extents h, rotation R (columns = box axes).
std::vector<Polygon> box_faces(const Vec3& c, const Vec3& h, const Mat3& R);
/// The outward faces of an icosahedron of circumradius r centred at c, rotated by R.
std::vector<Polygon> icosahedron_faces(const Vec3& c, double r, const Mat3& R);

}  // namespace formfactor::testing
