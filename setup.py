"""Builds the Python package eci for `pip install .` and `python3 -m build`: the extension eci._eci is the CMake
target eci_python of this repository's own build (pybind11; the same sources, flags and checks as `cmake --build`),
the pure-Python files are python/eci/*.py, the version is project(eci VERSION ...) in CMakeLists.txt.

The CMake build directory is build-pip/ in the checkout (kept between installs, so a second `pip install .` only
relinks what changed). Environment: ECI_CMAKE_ARGS (extra configure arguments, e.g.
"-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DECI_BUILD_SPECTRAL=OFF"), CMAKE_BUILD_PARALLEL_LEVEL (default: every core),
ECI_CMAKE_BUILD_DIR (another build directory).
"""
import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

ROOT = Path(__file__).resolve().parent


def project_version():
    text = (ROOT / "CMakeLists.txt").read_text()
    m = re.search(r"project\(\s*eci\s+VERSION\s+([0-9][0-9.]*)", text)
    if not m:
        sys.exit("setup.py: no `project(eci VERSION x.y.z ...)` in CMakeLists.txt")
    return m.group(1)


class CMakeBuild(build_ext):
    """Configures the repository with CMake (only the Python module: no tool, tests, examples or install rules)
    and builds the target eci_python, then puts its _eci*.so where setuptools expects the extension."""

    def build_extension(self, ext):
        if shutil.which("cmake") is None:
            raise RuntimeError("building eci needs CMake >= 3.25 (Debian: cmake; scripts/setup.sh installs it)")
        build_dir = Path(os.environ.get("ECI_CMAKE_BUILD_DIR", ROOT / "build-pip")).resolve()
        configure = ["cmake", "-S", str(ROOT), "-B", str(build_dir), "-DCMAKE_BUILD_TYPE=Release",
                     f"-DPython3_EXECUTABLE={sys.executable}", "-DECI_BUILD_PYTHON=ON", "-DECI_BUILD_TESTS=OFF",
                     "-DECI_BUILD_APPS=OFF", "-DECI_BUILD_EXAMPLES=OFF", "-DECI_BUILD_BENCH=OFF",
                     "-DECI_INSTALL=OFF"] + shlex.split(os.environ.get("ECI_CMAKE_ARGS", ""))
        jobs = os.environ.get("CMAKE_BUILD_PARALLEL_LEVEL") or str(os.cpu_count() or 1)
        subprocess.run(configure, check=True)
        subprocess.run(["cmake", "--build", str(build_dir), "--target", "eci_python", "-j", jobs], check=True)
        built = sorted((build_dir / "python" / "eci").glob("_eci*.so"))
        if len(built) != 1:
            raise RuntimeError(f"expected one _eci*.so in {build_dir / 'python' / 'eci'}, found {built}")
        target = Path(self.get_ext_fullpath(ext.name))
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(built[0], target)


setup(
    version=project_version(),
    packages=["eci"],
    package_dir={"eci": "python/eci"},
    ext_modules=[Extension("eci._eci", sources=[])],
    cmdclass={"build_ext": CMakeBuild},
    # setuptools' own build directory next to CMake's, not build/ (the project's CMake build directory)
    options={"build": {"build_base": "build-pip/setuptools"}},
    zip_safe=False,
)
