"""`pip install --no-build-isolation .` into a virtual environment that sees Debian's numpy and
scipy (--system-site-packages), reusing the build tree (FORMFACTOR_BUILD_DIR) so that the test
does not compile the library a second time; then the installed package imports and computes
from a folder outside the source tree."""

import os
import subprocess
import sys

import pytest

from conftest import BUILD_DIR, SOURCE_DIR


@pytest.mark.skipif(not (BUILD_DIR / "CMakeCache.txt").exists(), reason="needs the CMake tree")
def test_pip_install_from_the_source_tree(tmp_path):
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--system-site-packages", str(venv)],
                   check=True)
    py = venv / "bin" / "python"
    env = dict(os.environ, FORMFACTOR_BUILD_DIR=str(BUILD_DIR), PIP_NO_INDEX="1",
               PIP_DISABLE_PIP_VERSION_CHECK="1")
    env.pop("PYTHONPATH", None)
    p = subprocess.run([str(py), "-m", "pip", "install", "--no-build-isolation",
                        "-q", str(SOURCE_DIR)], env=env, capture_output=True, text=True,
                       cwd=tmp_path)
    assert p.returncode == 0, p.stdout + p.stderr
    check = ("import formfactor, importlib.metadata as m, numpy as np;"
             "assert formfactor.__file__.startswith(%r), formfactor.__file__;"
             "assert m.version('formfactor') == formfactor.__version__;"
             "r = formfactor.load('plates').form_factors();"
             "print(formfactor.__version__, r.matrix.shape)" % str(venv))
    p = subprocess.run([str(py), "-c", check], env=env, capture_output=True, text=True,
                       cwd=tmp_path)
    assert p.returncode == 0, p.stderr
    assert "(2, 2)" in p.stdout
    # The stubs and the typing marker are installed with it.
    site = subprocess.run([str(py), "-c", "import formfactor, os;"
                           "print(os.path.dirname(formfactor.__file__))"], env=env,
                          capture_output=True, text=True, cwd=tmp_path).stdout.strip()
    assert os.path.exists(os.path.join(site, "py.typed"))
    assert os.path.exists(os.path.join(site, "__init__.pyi"))
