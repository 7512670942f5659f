"""Shared fixtures of the Python tests. CTest sets PYTHONPATH to the build tree's package and
FF_CLI, FF_TEST_DATA_DIR, FF_SOURCE_DIR, FF_BUILD_DIR (python/CMakeLists.txt)."""

import os
import pathlib
import subprocess

import pytest

SOURCE_DIR = pathlib.Path(os.environ.get("FF_SOURCE_DIR", pathlib.Path(__file__).parents[2]))
DATA_DIR = pathlib.Path(os.environ.get("FF_TEST_DATA_DIR", SOURCE_DIR / "tests" / "data"))
BUILD_DIR = pathlib.Path(os.environ.get("FF_BUILD_DIR", SOURCE_DIR / "build"))
CLI = pathlib.Path(os.environ.get("FF_CLI", BUILD_DIR / "bin" / "formfactor"))


@pytest.fixture
def data_dir():
    return DATA_DIR


def run_cli(*args, check=True):
    """Runs the formfactor CLI; returns the CompletedProcess (text)."""
    p = subprocess.run([str(CLI), *map(str, args)], capture_output=True, text=True)
    if check and p.returncode != 0:
        raise AssertionError("formfactor %s failed (%d):\n%s" % (" ".join(map(str, args)),
                                                                 p.returncode, p.stderr))
    return p
