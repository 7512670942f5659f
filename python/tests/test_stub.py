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


def _keyword_functions():
    scene = ff.load("plates")
    return {"load": ff.load, "energyplus_zones": ff.energyplus_zones,
            "point_factors": ff.point_factors, "solve_radiosity": ff.solve_radiosity,
            "solve_thermal": ff.solve_thermal, "repair": ff.repair,
            "exchange_factors": ff.exchange_factors, "render": ff.render,
            "form_factors": scene.form_factors, "hierarchical": scene.hierarchical}


# A misspelt keyword of each function and the keyword meant.
MISSPELT = [("load", "subdivid", "subdivide"), ("energyplus_zones", "pth", "path"),
            ("point_factors", "normal", "normals"), ("solve_radiosity", "residul", "residual"),
            ("solve_thermal", "ambient_temprature", "ambient_temperature"),
            ("repair", "force_closer", "force_closure"), ("exchange_factors", "emisivity",
                                                          "emissivity"),
            ("render", "widht", "width"), ("form_factors", "tolerence", "tolerance"),
            ("hierarchical", "leafsize", "leaf_size")]


@pytest.mark.parametrize("function, given, meant", MISSPELT)
def test_a_misspelt_keyword_names_the_function_and_the_nearest_keyword(function, given, meant):
    f = _keyword_functions()[function]
    with pytest.raises(TypeError) as e:
        f(**{given: 1})
    assert str(e.value) == "%s() got an unexpected keyword argument '%s'; did you mean '%s'?" % (
        function, given, meant)


def test_every_function_with_a_keyword_table_is_in_the_misspelling_test():
    tables = {s["name"] for s in ff._core._signatures()}
    assert tables == set(_keyword_functions()) == {m[0] for m in MISSPELT}


@pytest.mark.parametrize("function", [m[0] for m in MISSPELT])
def test_an_unknown_keyword_lists_the_keywords_the_function_takes(function):
    f = _keyword_functions()[function]
    with pytest.raises(TypeError) as e:
        f(colour_scheme=1)
    message = str(e.value)
    assert message.startswith("%s() got an unexpected keyword argument 'colour_scheme' (it takes "
                              % function)
    names = [k["name"] for s in ff._core._signatures() if s["name"] == function
             for k in s["keywords"]]
    assert message.endswith(", ".join(names) + ")")


def test_the_solve_functions_take_their_arguments_by_position_and_by_keyword():
    import inspect

    for f, positional in ((ff.solve_radiosity, ["scene", "F", "reflectance", "emission"]),
                          (ff.solve_thermal, ["scene", "F", "emissivity", "temperature",
                                              "net_flux"]),
                          (ff.repair, ["F", "areas", "mode"]),
                          (ff.exchange_factors, ["F", "emissivity"]),
                          (ff.render, ["scene", "values"]),
                          (ff.energyplus_zones, ["path"])):
        params = inspect.signature(f).parameters.values()
        assert [p.name for p in params if p.kind == p.POSITIONAL_OR_KEYWORD] == positional
        assert f.__doc__.count("\n\n") >= 2  # the summary, then the arguments
    assert inspect.signature(ff.repair).parameters["mode"].default == "both"
    assert inspect.signature(ff.solve_radiosity).parameters["residual"].default == 1e-8
    with pytest.raises(ff.OptionError) as e:
        ff.solve_radiosity("cube", [[0.0]])
    assert e.value.option == "scene"
    with pytest.raises(ff.OptionError) as e:
        ff.solve_radiosity(ff.load("plates"), ff.load("plates").form_factors(), threads=True)
    assert e.value.option == "threads"
    with pytest.raises(ff.OptionError) as e:
        ff.render(ff.load("plates"), path=3)
    assert e.value.option == "path"
