"""`pip install --no-build-isolation .`: builds the extension formfactor._core with CMake (the
project's own build, Debian's packages only) and installs the package python/formfactor.

The CMake tree is build-python/cmake (configured once: Release, no tests, no benchmarks), or
the tree FORMFACTOR_BUILD_DIR names (an existing build, e.g. `build`, reused as it is)."""

import os
import pathlib
import shutil
import subprocess
import sys

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

SOURCE = pathlib.Path(__file__).parent.resolve()
(SOURCE / "build-python").mkdir(exist_ok=True)  # setuptools' build and egg-info folder


class CMakeExtension(Extension):
    def __init__(self, name):
        super().__init__(name, sources=[])


class CMakeBuild(build_ext):
    def build_extension(self, ext):
        given = os.environ.get("FORMFACTOR_BUILD_DIR")
        tree = pathlib.Path(given).resolve() if given else SOURCE / "build-python" / "cmake"
        if not (tree / "CMakeCache.txt").exists():
            subprocess.check_call([
                "cmake", "-S", str(SOURCE), "-B", str(tree), "-DCMAKE_BUILD_TYPE=Release",
                "-DFF_BUILD_TESTS=OFF", "-DFF_BUILD_BENCH=OFF", "-DFF_INSTALL=OFF",
                "-DFF_BUILD_PYTHON=ON", "-DPython_EXECUTABLE=" + sys.executable])
        jobs = os.environ.get("CMAKE_BUILD_PARALLEL_LEVEL", str(os.cpu_count() or 2))
        subprocess.check_call(["cmake", "--build", str(tree), "--target", "formfactor_python",
                               "-j", jobs])
        built = sorted((tree / "python" / "formfactor").glob("_core*.so"))
        if not built:
            raise RuntimeError("the CMake build made no formfactor/_core*.so in " + str(tree))
        dest = pathlib.Path(self.get_ext_fullpath(ext.name))
        dest.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(built[0], dest)


setup(
    packages=["formfactor"],
    package_dir={"": "python"},
    package_data={"formfactor": ["py.typed", "*.pyi"]},
    ext_modules=[CMakeExtension("formfactor._core")],
    cmdclass={"build_ext": CMakeBuild},
    options={"build": {"build_base": "build-python"}, "egg_info": {"egg_base": "build-python"}},
)
