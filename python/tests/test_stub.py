"""The type stub (python/formfactor/__init__.pyi) says what the module does: its generated
methods are those of the keyword tables, and mypy's stubtest finds nothing the module and the
stub disagree on."""

import importlib.util
import os
import subprocess
import sys

import pytest

import formfactor as ff
from conftest import SOURCE_DIR

STUB = SOURCE_DIR / "python" / "formfactor" / "__init__.pyi"


def _generator():
    spec = importlib.util.spec_from_file_location("generate_stub",
                                                  SOURCE_DIR / "python" / "generate_stub.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_stub_holds_the_methods_of_the_keyword_tables():
    text = STUB.read_text()
    assert "# <generated Scene>" in text
    assert _generator().render(text, ff._core._signatures()) == text, \
        "run python/generate_stub.py"


def test_the_keyword_tables_give_the_signatures_python_sees():
    import inspect

    sig = inspect.signature(ff.Scene.form_factors)
    params = list(sig.parameters.values())
    assert params[0].name == "self"
    assert params[1].name == "method" and params[1].kind == params[1].POSITIONAL_OR_KEYWORD
    assert all(p.kind == p.KEYWORD_ONLY for p in params[2:])
    assert sig.parameters["force_closure"].default is False
    assert inspect.signature(ff.Scene.hierarchical).parameters["tolerance"].default == 1e-6
    assert "tolerance" in ff.Scene.form_factors.__doc__


def test_module_functions_come_from_keyword_tables_too():
    import inspect

    load = inspect.signature(ff.load).parameters
    assert list(load) == ["path", "subdivide", "max_edge", "merge_coplanar", "zone"]
    assert load["path"].default is inspect.Parameter.empty
    assert load["merge_coplanar"].default is False
    assert "zone" in ff.load.__doc__
    points = inspect.signature(ff.point_factors).parameters
    assert [p.kind for p in points.values()][:3] == [inspect.Parameter.POSITIONAL_OR_KEYWORD] * 3
    assert points["threads"].kind == inspect.Parameter.KEYWORD_ONLY
    with pytest.raises(TypeError, match="missing required argument: 'path'"):
        ff.load()
    with pytest.raises(ff.OptionError, match="path"):
        ff.load(3)
    with pytest.raises(ff.OptionError, match="merge_coplanar"):
        ff.load("cube", merge_coplanar=1)
    with pytest.raises(ff.OptionError, match="scene"):
        ff.point_factors("cube", [[0, 0, 0]], [0, 0, 1])


@pytest.mark.skipif(importlib.util.find_spec("mypy") is None, reason="needs mypy (Debian: mypy)")
def test_stubtest_finds_the_stub_and_the_module_agree(tmp_path):
    config = tmp_path / "mypy.ini"
    config.write_text("[mypy]\nignore_missing_imports = True\ncache_dir = %s\n"
                      % (tmp_path / "cache"))
    p = subprocess.run([sys.executable, "-m", "mypy.stubtest", "formfactor",
                        "--mypy-config-file", str(config),
                        "--allowlist", str(SOURCE_DIR / "python" / "stubtest_allowlist.txt")],
                       capture_output=True, text=True, cwd=tmp_path, env=dict(os.environ))
    assert p.returncode == 0, p.stdout + p.stderr
