# `pip install .` from the checkout, as a Python user installs eci: in a virtual environment that sees Debian's
# packages (NumPy, SciPy, setuptools; offline, --no-build-isolation --no-index), built through the project's CMake
# build (setup.py, build directory build-pip/), imported from outside the source tree, used, and uninstalled
# without a trace; and `python3 -m build --no-isolation --wheel` (Debian's python3-build) makes a wheel holding the
# same package. The version is the one of project(eci VERSION ...) in CMakeLists.txt.
#
# Time: the module's compilation dominates. With ccache (configured with the flags of the suite's build, so its
# objects are hits) or a build-pip/ kept from an earlier run, both tests take about 25 s; cold (a clean CI: no
# ccache, no build-pip/) 6.3 minutes of CPU, about 3 minutes on two idle cores (docs/python.md).
import os
import re
import shutil
import subprocess
import zipfile
from pathlib import Path

import pytest

from conftest import BUILD, REPO

SYSTEM_PYTHON = "/usr/bin/python3"


def project_version():
    return re.search(r"project\(\s*eci\s+VERSION\s+([0-9.]+)", (REPO / "CMakeLists.txt").read_text()).group(1)


def run(args, **kw):
    r = subprocess.run([str(a) for a in args], capture_output=True, text=True, timeout=900, **kw)
    assert r.returncode == 0, f"{' '.join(map(str, args))} failed:\n{r.stdout[-3000:]}\n{r.stderr[-3000:]}"
    return r


def build_env():
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME")}
    # The suite's own build flags (scripts/test.sh: Release, -Werror), so that ccache, where there is one, has the
    # objects already; -Werror also holds the pip build to the warnings the suite holds the module to.
    args = ["-DECI_WERROR=ON"]
    if shutil.which("ccache"):
        args.append("-DCMAKE_CXX_COMPILER_LAUNCHER=ccache")
    env["ECI_CMAKE_ARGS"] = " ".join(args)
    # and the suite's generator (a new build-pip/ only): ccache gives back an object only to a compile run from the
    # same relative directory, which Ninja and Make choose differently (scripts/reproduce.sh makes build/ with Make,
    # scripts/test.sh with Ninja: either may come first)
    cache = BUILD / "CMakeCache.txt"
    generator = re.search(r"^CMAKE_GENERATOR:INTERNAL=(.+)$", cache.read_text(), re.M) if cache.exists() else None
    if generator:
        env["CMAKE_GENERATOR"] = generator.group(1)
    env.setdefault("CMAKE_BUILD_PARALLEL_LEVEL", "2")
    return env


USE = """
import sys, numpy as np, scipy.integrate, eci, eci.scipy
print(eci.__file__)
print(eci.__version__)
# a rotation: y' = A y with A antisymmetric keeps |y|^2; the conservative pair keeps it to round-off
A = np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 2.0], [0.0, -2.0, 0.0]])
y0 = np.array([1.0, 0.5, -0.25])
r = scipy.integrate.solve_ivp(lambda t, y: A @ y, (0.0, 10.0), y0, method=eci.scipy.CDP54, rtol=1e-8, atol=1e-10)
print(r.success, len(r.t), abs(r.y[:, -1] @ r.y[:, -1] / (y0 @ y0) - 1))
r = eci.solve(lambda t, y: A @ y, (0.0, 10.0), y0, method="c-rk4", dt=0.01)
print(abs(r.y[:, -1] @ r.y[:, -1] / (y0 @ y0) - 1))
"""


def test_pip_install_import_outside_the_tree_and_uninstall(tmp_path):
    if not os.path.exists(SYSTEM_PYTHON):
        pytest.fail(f"{SYSTEM_PYTHON} (Debian's python3, which the module is built for) is missing")
    venv = tmp_path / "venv"
    run([SYSTEM_PYTHON, "-m", "venv", "--system-site-packages", venv])
    python = venv / "bin" / "python"
    env = build_env()
    # --no-index: offline; the dependency (NumPy) is found among the system's packages the venv sees
    run([python, "-m", "pip", "install", "--no-build-isolation", "--no-index", REPO], cwd=tmp_path, env=env)
    site = run([python, "-c", "import sysconfig; print(sysconfig.get_path('platlib'))"], env=env).stdout.strip()

    out = run([python, "-c", USE], cwd=tmp_path, env=env).stdout.split("\n")
    where, version, scipy_run, fixed_drift = out[0], out[1], out[2].split(), float(out[3])
    assert where == os.path.join(site, "eci", "__init__.py")  # the installed copy, not the checkout's
    assert version == project_version()
    # |y|^2 is a sum of squares: its relative change is a few roundings per step (the steps' psi^2 and their sum):
    # bounded by eps times the steps taken, with a factor 8 for the sum over three components and the square root.
    eps = 2.0 ** -52
    assert scipy_run[0] == "True" and float(scipy_run[2]) < 8 * eps * int(scipy_run[1])
    assert fixed_drift < 8 * eps * 1000  # 1000 steps of c-rk4

    files = run([python, "-m", "pip", "show", "-f", "eci"], env=env).stdout
    assert f"Version: {project_version()}" in files and "eci/scipy.py" in files and "eci/_eci" in files

    run([python, "-m", "pip", "uninstall", "-y", "eci"], env=env)
    left = [p.name for p in Path(site).iterdir() if p.name.lower().startswith("eci")] if os.path.isdir(site) else []
    assert left == [], f"pip uninstall left {left} in {site}"
    r = subprocess.run([str(python), "-c", "import eci"], cwd=tmp_path, env=env, capture_output=True, text=True)
    assert r.returncode != 0 and "No module named 'eci'" in r.stderr


def test_build_makes_a_wheel(tmp_path):
    r = subprocess.run([SYSTEM_PYTHON, "-c", "import build"], capture_output=True)
    if r.returncode != 0:
        pytest.fail("python3 -m build needs Debian's python3-build (scripts/setup.sh installs it)")
    dist = tmp_path / "dist"
    run([SYSTEM_PYTHON, "-m", "build", "--no-isolation", "--wheel", "--outdir", dist, REPO], cwd=tmp_path,
        env=build_env())
    wheels = list(dist.glob("*.whl"))
    assert len(wheels) == 1 and wheels[0].name.startswith(f"eci-{project_version()}-")
    names = zipfile.ZipFile(wheels[0]).namelist()
    assert {"eci/__init__.py", "eci/scipy.py", "eci/models.py"} <= set(names)
    assert any(re.fullmatch(r"eci/_eci\..*\.so", n) for n in names)
    assert f"eci-{project_version()}.dist-info/METADATA" in names


def test_the_sdist_holds_every_file_the_module_builds_from(tmp_path):
    # `python3 -m build` makes the wheel from the sdist: a file the module's build reads but MANIFEST.in leaves out
    # (the tool's checkpoint code in apps/eci, which the module links) fails only there. The sdist is built, unpacked
    # and configured as setup.py configures it, and the targets whose sources live outside python/ and src/ are built.
    # (from a copy of the checkout's files: setuptools also packs what an eci.egg-info/SOURCES.txt left in the
    # checkout by an earlier build lists, which a clean checkout does not have)
    tree = tmp_path / "tree"
    if (REPO / ".git").exists():
        files = run(["git", "-C", REPO, "ls-files", "-z"]).stdout.split("\0")
        for f in filter(None, files):
            (tree / f).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(REPO / f, tree / f)
    else:
        shutil.copytree(REPO, tree, ignore=shutil.ignore_patterns("*.egg-info", "build*", ".git"))
    run([SYSTEM_PYTHON, "-m", "build", "--sdist", "--no-isolation", "--outdir", tmp_path / "dist", tree],
        env=build_env())
    (sdist,) = (tmp_path / "dist").glob("eci-*.tar.gz")
    shutil.unpack_archive(sdist, tmp_path / "src")
    (root,) = (tmp_path / "src").iterdir()
    env = build_env()
    generator = ["-G", env.pop("CMAKE_GENERATOR")] if "CMAKE_GENERATOR" in env else []
    run(["cmake", "-S", root, "-B", tmp_path / "b", *generator, "-DCMAKE_BUILD_TYPE=Release",
         "-DECI_BUILD_PYTHON=ON", "-DECI_BUILD_TESTS=OFF", "-DECI_BUILD_APPS=OFF", "-DECI_BUILD_EXAMPLES=OFF",
         "-DECI_BUILD_BENCH=OFF", "-DECI_INSTALL=OFF", *env["ECI_CMAKE_ARGS"].split()], env=env)
    if "eci_cli_ns2d_output" not in run(["cmake", "--build", tmp_path / "b", "--target", "help"], env=env).stdout:
        pytest.skip("built without the spectral models (no FFTW3): no checkpoint code to link")
    run(["cmake", "--build", tmp_path / "b", "--target", "eci_cli_ns2d_output", "eci_cli_output"], env=env)
