"""Result.to_html() and Result._repr_html_(): the result page from Python, its data block
against the matrix, and the notebook's sandboxed frame."""

import base64
import html
import json
import re
import zlib

import numpy as np
import pytest

import formfactor as ff


def page_data(text):
    """The page's data block, with F's entries (the block after the script) in its matrix."""
    m = re.search(r'<script type="application/json" id="ff-data">(.*?)</script>', text, re.S)
    assert m, "the page has its data block"
    d = json.loads(m.group(1))
    if "matrix" in d:
        block = d["matrix"].pop("entries_block")
        e = re.search(r'<script type="application/json" id="%s">(.*?)</script>' % block, text, re.S)
        assert e, "the page has the block of F's entries"
        d["matrix"].update(json.loads(e.group(1)))
    return d


def array(entry):
    dtype = {"f32": "<f4", "f64": "<f8", "u16": "<u2", "u32": "<u4"}[entry["dtype"]]
    raw = base64.b64decode(entry["base64"])
    if entry.get("compression") == "deflate":
        raw = zlib.decompress(raw)
    if entry.get("byte_planes"):
        # Byte planes within each segment (the whole array: one segment).
        width = np.dtype(dtype).itemsize
        bounds = entry.get("segments", [0, entry["count"]])
        raw = b"".join(
            np.frombuffer(raw[a * width:b * width], dtype=np.uint8).reshape(width, -1).T.tobytes()
            for a, b in zip(bounds[:-1], bounds[1:]))
    a = np.frombuffer(raw, dtype=dtype)
    assert a.size == entry["count"]
    return a


def values(m):
    """The matrix's stored values (from its palette of pairs when it has one)."""
    if "palette" in m:
        return array(m["palette"]["val"])[array(m["entry_index"])]
    return array(m["val"])


def columns(m):
    """The matrix's column indices, each row's steps summed back."""
    ptr, col = array(m["row_ptr"]), array(m["col"]).astype(np.int64)
    if m.get("col_coding") == "row-delta":
        for i in range(ptr.size - 1):
            col[ptr[i]:ptr[i + 1]] = np.cumsum(col[ptr[i]:ptr[i + 1]])
    return col


def test_to_html_writes_a_self_contained_page_whose_rows_are_the_matrix(tmp_path):
    scene = ff.load("cornell", subdivide=2)
    r = scene.form_factors()
    out = tmp_path / "result.html"
    r.to_html(str(out), solution=ff.solve_radiosity(scene, r), title="Cornell from Python")
    text = out.read_text(encoding="utf-8")
    assert "Content-Security-Policy" in text and "default-src 'none'" in text
    assert "http://" not in text.split("<script")[0]  # nothing fetched by the head
    d = page_data(text)
    assert d["title"] == "Cornell from Python"
    n = r.matrix.shape[0]
    ptr, col, val = array(d["matrix"]["row_ptr"]), columns(d["matrix"]), values(d["matrix"])
    assert ptr.size == n + 1 and d["matrix"]["threshold"] == 0
    dense = np.zeros((n, n), dtype=np.float32)
    for i in range(n):
        dense[i, col[ptr[i]:ptr[i + 1]]] = val[ptr[i]:ptr[i + 1]]
    assert np.array_equal(dense, r.matrix.astype(np.float32))
    assert np.allclose(array(d["matrix"]["row_sum"]), r.matrix.sum(axis=1), rtol=0, atol=1e-12)
    keys = [f["key"] for f in d["fields"]]
    assert "radiosity" in keys and "row_sum" in keys
    assert d["report"]["method"] == r.method


def test_a_budget_of_entries_keeps_the_largest_and_states_the_dropped_mass(tmp_path):
    r = ff.load("cornell", subdivide=3).form_factors()
    out = tmp_path / "small.html"
    r.to_html(str(out), max_entries=2000)
    m = page_data(out.read_text(encoding="utf-8"))["matrix"]
    val, dropped, ptr = values(m), array(m["dropped"]), array(m["row_ptr"])
    assert 0 < m["stored_entries"] <= 2000 < m["nonzeros"]
    assert m["threshold"] > 0 and val.min() > m["threshold"]
    kept = np.add.reduceat(val.astype(np.float64), ptr[:-1]) * (np.diff(ptr) > 0)
    assert np.allclose(kept + dropped, r.matrix.sum(axis=1), atol=1e-5)


def test_repr_html_is_the_page_in_a_sandboxed_frame():
    r = ff.load("plates").form_factors()
    frame = r._repr_html_()
    assert frame.startswith('<iframe sandbox="allow-scripts"')
    m = re.search(r'srcdoc="([^"]*)"', frame)
    assert m, "the page is in srcdoc, escaped for the attribute"
    assert "Content-Security-Policy" in html.unescape(m.group(1))


def test_a_row_block_or_a_bad_solution_is_refused(tmp_path):
    scene = ff.load("cornell", subdivide=2)
    with pytest.raises(ff.OptionError, match="whole matrix"):
        scene.form_factors(rows=(0, 10)).to_html(str(tmp_path / "x.html"))
    with pytest.raises(ff.OptionError, match="shape"):
        scene.form_factors().to_html(str(tmp_path / "x.html"), solution=np.zeros((3, 3)))
    assert not (tmp_path / "x.html").exists()


def test_to_html_takes_a_path_object_as_load_does(tmp_path):
    ff.load("plates").form_factors().to_html(tmp_path / "plates.html")
    assert (tmp_path / "plates.html").read_text().startswith("<!DOCTYPE html>")
