"""point_factors() with obstructions, and render()."""

import os

import numpy as np
import pytest

import formfactor as ff


def test_point_factors_see_past_obstructions_exactly():
    # Floor point below a ceiling, with a one-sided plate between them facing down. The plate's
    # shadow on the ceiling subtends the same cone as the plate, so the ceiling's visible factor
    # is F(ceiling) − F(plate) exactly (Lambert's formula for each).
    v = np.array([[-2, -2, 2], [-2, 2, 2], [2, 2, 2], [2, -2, 2],        # ceiling, normal −z
                  [-0.3, -0.2, 1], [-0.3, 0.4, 1], [0.5, 0.4, 1], [0.5, -0.2, 1]], float)
    ceiling = [0, 1, 2, 3]
    plate = [4, 5, 6, 7]
    alone = ff.Scene.from_arrays(v, [ceiling])
    both = ff.Scene.from_arrays(v, [ceiling, plate])
    blocked = ff.Scene.from_arrays(v, [ceiling, plate], obstruction=[False, True])
    pts = np.array([[0.0, 0.0, 0.0], [0.2, 0.1, 0.0], [1.0, 1.0, 0.0]])  # shadows inside
    up = [0, 0, 1]
    F0 = ff.point_factors(alone, pts, up)[:, 0]
    Fp = ff.point_factors(both, pts, up)
    Fb = ff.point_factors(blocked, pts, up)
    assert Fb.shape == (3, 1) and Fp.shape == (3, 2)
    assert np.abs(Fb[:, 0] - (F0 - Fp[:, 1])).max() <= 1e-13
    assert np.abs(Fp[:, 0] - Fb[:, 0]).max() <= 1e-13  # a radiating plate blocks the same
    # Normals of any length, one for all points or one per point.
    assert np.array_equal(ff.point_factors(blocked, pts, np.tile([0, 0, 7.0], (3, 1))), Fb)
    with pytest.raises(ff.OptionError) as e:
        ff.point_factors(blocked, pts, [0, 0, 0])
    assert e.value.option == "normals"
    with pytest.raises(ff.OptionError) as e:
        ff.point_factors(blocked, [[0, 0, np.nan]], up)
    assert e.value.option == "points"


def test_render_returns_pixels_and_writes_a_png(tmp_path):
    s = ff.load("cornell", subdivide=2)
    rad = ff.solve_radiosity(s, s.form_factors()).radiosity
    img = ff.render(s, rad, width=96, height=64)
    assert img.shape == (64, 96, 3) and img.dtype == np.uint8
    assert img.max() > 200 and img.min() < 50  # the light and the dark
    path = tmp_path / "heat.png"
    heat = ff.render(s, rad[:, 0], width=80, height=60, path=path, label="B", unit="W/m2")
    assert heat.shape == (60, 80, 3)
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert sorted(os.listdir(tmp_path)) == ["heat.png"]  # no temporary left behind
    preview = ff.render(s, width=32, height=32, camera={"eye": (0.5, 0.5, 3), "target": (0.5, 0.5, 0)})
    assert preview.shape == (32, 32, 3)
    with pytest.raises(ff.OptionError) as e:
        ff.render(s, np.zeros(3))
    assert e.value.option == "values"
    with pytest.raises(ff.OptionError):
        ff.render(s, camera={"eye": (0, 0, 1), "look": (0, 0, 0)})
    with pytest.raises(ff.Error):
        ff.render(s, width=32, height=32, path=tmp_path / "no-such-dir" / "x.png")
