"""Scenes: load(), Scene.from_arrays() and the per-patch views."""

import numpy as np
import pytest

import formfactor as ff
from conftest import DATA_DIR

# A closed box written the way mesh users write it: 8 shared vertices, 6 quads (normals in),
# and an obstruction-only triangle inside.
BOX_V = np.array([[0, 0, 0], [2, 0, 0], [2, 1, 0], [0, 1, 0],
                  [0, 0, 1.5], [2, 0, 1.5], [2, 1, 1.5], [0, 1, 1.5],
                  [0.5, 0.3, 0.7], [1.4, 0.3, 0.7], [0.9, 0.8, 0.7]], dtype=float)
BOX_F = [[0, 1, 2, 3], [4, 7, 6, 5], [0, 4, 5, 1], [1, 5, 6, 2], [2, 6, 7, 3], [3, 7, 4, 0],
         [8, 10, 9]]


def write_obj(path, vertices, faces, obstruction):
    with open(path, "w") as f:
        f.write("# box with an obstruction, shared vertices\n")
        for v in vertices:
            f.write("v %r %r %r\n" % tuple(float(x) for x in v))
        for k, face in enumerate(faces):
            f.write("g %s\n" % ("obstruction_tri" if obstruction[k] else "wall%d" % k))
            f.write("f " + " ".join(str(i + 1) for i in face) + "\n")


def test_from_arrays_matches_the_same_obj_file(tmp_path):
    obstruction = [False] * 6 + [True]
    path = tmp_path / "box.obj"
    write_obj(path, BOX_V, BOX_F, obstruction)
    a = ff.load(path, subdivide=2)
    b = ff.Scene.from_arrays(BOX_V, BOX_F, obstruction=obstruction, subdivide=2)
    assert len(a) == len(b) == 24
    assert np.array_equal(a.areas, b.areas)
    assert np.array_equal(a.normals, b.normals)
    assert np.array_equal(a.centroids, b.centroids)
    assert np.array_equal(a.surface_index, b.surface_index)
    Fa = a.form_factors().matrix
    Fb = b.form_factors().matrix
    assert np.array_equal(Fa, Fb)  # same geometry in two forms: the same numbers, bit for bit
    # The obstruction hides part of the floor from the ceiling.
    unblocked = ff.Scene.from_arrays(BOX_V, BOX_F[:6], subdivide=2).form_factors().matrix
    assert Fb[:4, 4:8].sum() < unblocked[:4, 4:8].sum()


def test_views_are_read_only_and_not_copies():
    s = ff.load("cornell", subdivide=2)
    for name in ("areas", "normals", "centroids", "surface_index"):
        a, b = getattr(s, name), getattr(s, name)
        assert not a.flags.writeable and not a.flags.owndata, name
        assert np.shares_memory(a, b), name
        with pytest.raises(ValueError):
            a[0] = 0
    assert s.normals.shape == (len(s), 3)
    assert np.allclose(np.linalg.norm(s.normals, axis=1), 1, atol=1e-15)
    newell = [0.5 * np.linalg.norm(np.cross(p, np.roll(p, -1, axis=0)).sum(axis=0))
              for p in (s.patch_vertices(i) for i in range(len(s)))]
    assert np.allclose(s.areas, newell, rtol=1e-12, atol=0)
    assert s.surface_index.min() == 0 and s.surface_index.max() == s.n_surfaces - 1
    # A view outlives the scene object it came from.
    v = ff.load("cube", subdivide=3).areas
    assert v.sum() == pytest.approx(6.0, rel=1e-14)


def test_polygons_of_mixed_sizes_and_triangle_arrays():
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 1.5, 0]], float)
    s = ff.Scene.from_arrays(v, [[0, 1, 2, 3], [3, 2, 4]])
    assert len(s) == 2 and s.areas[1] == pytest.approx(0.25)
    tri = ff.Scene.from_arrays(v, np.array([[0, 1, 2], [0, 2, 3]], dtype=np.int32))
    assert tri.areas.sum() == pytest.approx(1.0)
    assert tri.surface_names == ["face0", "face1"]
    named = ff.Scene.from_arrays(v, [[0, 1, 2, 3]], names=["floor"])
    assert named.surface_names == ["floor"]


def test_subdivided_is_a_new_scene():
    s = ff.load("plates")
    t = s.subdivided(3)
    assert len(t) == 9 * len(s)
    assert t.areas.sum() == pytest.approx(s.areas.sum(), rel=1e-14)
    assert len(s.subdivided(max_edge=0.25)) > len(s)


@pytest.mark.parametrize("vertices, faces, option", [
    (np.zeros((3, 2)), [[0, 1, 2]], "vertices"),
    (BOX_V, [[0, 1, 99]], "faces"),
    (BOX_V, [[0, 1]], "faces"),
    (BOX_V, [[0, 1, 6, 3]], "faces"),        # not planar
    (BOX_V, np.array([[0.0, 1.0, 2.0]]), "faces"),  # float indices
    (BOX_V, [], "faces"),
])
def test_bad_arrays_name_the_argument(vertices, faces, option):
    with pytest.raises(ff.OptionError) as e:
        ff.Scene.from_arrays(vertices, faces)
    assert e.value.option == option
    assert isinstance(e.value, ValueError) and isinstance(e.value, ff.Error)


def test_nan_vertex_and_bad_masks():
    v = BOX_V.copy()
    v[0, 0] = np.nan
    with pytest.raises(ff.OptionError, match="not finite"):
        ff.Scene.from_arrays(v, BOX_F[:1])
    with pytest.raises(ff.OptionError) as e:
        ff.Scene.from_arrays(BOX_V, BOX_F, obstruction=[True])
    assert e.value.option == "obstruction"
    with pytest.raises(ff.OptionError):
        ff.Scene.from_arrays(BOX_V, BOX_F[:1], obstruction=[True])
    with pytest.raises(ff.OptionError) as e:
        ff.Scene.from_arrays(BOX_V, BOX_F, subdivide=0)
    assert e.value.option == "subdivide"


def test_load_errors_carry_file_and_line(tmp_path):
    bad = tmp_path / "bad.obj"
    bad.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n")
    with pytest.raises(ff.InputError) as e:
        ff.load(bad)
    assert e.value.file == str(bad) and e.value.line == 4
    assert isinstance(e.value, ValueError)
    assert str(e.value).startswith(str(bad) + ":4:")
    with pytest.raises(ff.InputError) as e:
        ff.load(tmp_path / "missing.vs3")
    assert e.value.line is None
    with pytest.raises(ff.InputError):
        ff.load("no-such-builtin")


def test_builtins_and_properties():
    assert "cornell" in ff.builtin_scenes()
    s = ff.load("cornell")
    p = s.properties()
    assert p["reflectance"].shape == (len(s), 3) and p["emissivity"].shape == (len(s),)
    assert (p["emission"].max(axis=1) > 0).any()  # the light
    assert "cornell" in repr(s)


@pytest.mark.parametrize("name, subdivide", [("cornell", 2), ("room-4-obstruction", None),
                                             (str(DATA_DIR / "room.obj"), 3)])
def test_to_arrays_and_back_gives_the_same_scene_and_matrix(name, subdivide):
    s = ff.load(name, subdivide=subdivide)
    v, faces, obstruction, names = s.to_arrays()
    t = ff.Scene.from_arrays(v, faces, obstruction=obstruction, names=names,
                             enclosure=s.enclosure, subdivide=subdivide)
    assert t.surface_names == s.surface_names
    assert np.array_equal(t.areas, s.areas) and np.array_equal(t.normals, s.normals)
    assert np.array_equal(t.form_factors().matrix, s.form_factors().matrix)
    # The patches themselves as faces: the same rows and columns again.
    v, faces, obstruction, names = s.to_arrays(patches=True)
    p = ff.Scene.from_arrays(v, faces, obstruction=obstruction)
    assert len(p) == len(s) and np.array_equal(p.areas, s.areas)


def test_surfaces_with_holes_export_as_patches(data_dir):
    s = ff.load(data_dir / "room-windows.vs3")
    with pytest.raises(ff.OptionError) as e:
        s.to_arrays()
    assert e.value.option == "patches"
    v, faces, obstruction, names = s.to_arrays(patches=True)
    p = ff.Scene.from_arrays(v, faces, obstruction=obstruction)
    assert np.allclose(p.form_factors().matrix, s.form_factors().matrix, atol=1e-9, rtol=0)


def write_binary_stl(path, vertices, triangles):
    """Binary STL as its specification lays it out: an 80-byte header, a little-endian uint32
    count, then per triangle a normal, three vertices (float32) and a uint16 attribute."""
    record = np.dtype([("normal", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")])
    data = np.zeros(len(triangles), dtype=record)
    corners = vertices[np.asarray(triangles)]
    n = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    data["normal"] = n / np.linalg.norm(n, axis=1)[:, None]
    data["v"] = corners
    with open(path, "wb") as f:
        f.write(b"binary STL written by numpy".ljust(80, b" "))
        f.write(np.uint32(len(triangles)).tobytes())
        f.write(data.tobytes())


def test_merge_coplanar_turns_an_stl_box_back_into_the_obj_box(tmp_path):
    quads = BOX_F[:6]
    tris = [t for q in quads for t in ([q[0], q[1], q[2]], [q[0], q[2], q[3]])]
    write_binary_stl(tmp_path / "box.stl", BOX_V, tris)
    write_obj(tmp_path / "box.obj", BOX_V, quads, [False] * 6)
    triangles = ff.load(tmp_path / "box.stl")
    merged = ff.load(tmp_path / "box.stl", merge_coplanar=True)
    box = ff.load(tmp_path / "box.obj")
    assert len(triangles) == 12
    assert len(merged) == len(box) == 6
    assert np.allclose(merged.areas, box.areas, rtol=0, atol=1e-15)
    F = merged.form_factors().matrix
    assert np.abs(F - box.form_factors().matrix).max() <= 1e-12
    assert np.allclose(F.sum(axis=1), 1.0, atol=1e-9)


def two_zone_idf(tmp_path):
    """EnergyPlus's one-zone example plus a copy of its zone under other names."""
    text = (DATA_DIR / "energyplus" / "1ZoneUncontrolled_win_1.idf").read_text()
    second = text[text.index("  Zone,"):]
    second = second.replace("ZONE ONE", "Zone Two").replace("Zn001", "Zn002")
    rules = second.index("  GlobalGeometryRules,")
    second = second[:rules] + second[second.index("  BuildingSurface:Detailed,", rules):]
    path = tmp_path / "two.idf"
    path.write_text(text + second)
    return path


def test_zone_picks_one_enclosure_of_an_energyplus_model(tmp_path):
    path = two_zone_idf(tmp_path)
    assert ff.energyplus_zones(path) == ["ZONE ONE", "Zone Two"]
    one = ff.load(DATA_DIR / "energyplus" / "1ZoneUncontrolled_win_1.idf")
    two = ff.load(path, zone="zone two")     # EnergyPlus names match without regard to case
    assert two.surface_names == [n.replace("Zn001", "Zn002") for n in one.surface_names]
    assert np.abs(two.form_factors("analytic").matrix
                  - one.form_factors("analytic").matrix).max() <= 1e-12
    assert ff.load(path, zone="ZONE ONE", subdivide=2).surface_names == one.surface_names


def test_zone_errors_name_the_zones_or_the_keyword(tmp_path):
    path = two_zone_idf(tmp_path)
    with pytest.raises(ff.InputError, match="2 zones; choose one .*: ZONE ONE, Zone Two") as e:
        ff.load(path)
    assert e.value.file == str(path)
    with pytest.raises(ff.InputError, match=r"zone 'Attic' is not in the model \(zones: ZONE ONE"):
        ff.load(path, zone="Attic")
    with pytest.raises(ff.OptionError) as e:
        ff.load("cube", zone="ZONE ONE")
    assert e.value.option == "zone"
    with pytest.raises(ff.OptionError) as e:
        ff.load(path, zone=2)
    assert e.value.option == "zone"
    with pytest.raises(ff.InputError):
        ff.energyplus_zones(tmp_path / "missing.idf")
