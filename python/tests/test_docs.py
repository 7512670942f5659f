"""The worked example of docs/python.md runs as written (its Python blocks, in order)."""

import os
import re

import pytest

from conftest import SOURCE_DIR


def test_the_worked_example_runs(tmp_path, monkeypatch):
    pytest.importorskip("matplotlib")
    text = (SOURCE_DIR / "docs" / "python.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    assert len(blocks) >= 3
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MPLBACKEND", "Agg")
    env = {}
    for block in blocks:
        exec(compile(block, "docs/python.md", "exec"), env)
    assert (tmp_path / "net_power.png").stat().st_size > 1000
    assert (tmp_path / "net_flux.png").stat().st_size > 1000
    assert abs(env["th"].relative_balance_defect) < 1e-9
