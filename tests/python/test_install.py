# `cmake --install` puts the package where the interpreter it was built for looks for packages under the prefix
# (Debian: <prefix>/lib/python3.X/dist-packages, which is on sys.path for the default prefix /usr/local), and the
# installed copy works on its own, away from the build tree.
import os
import subprocess
import sys
import sysconfig

from conftest import BUILD


def test_install_into_the_interpreters_package_directory(tmp_path):
    prefix = tmp_path / "prefix"
    r = subprocess.run(["cmake", "--install", str(BUILD), "--prefix", str(prefix), "--component", "python"],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stdout + r.stderr
    relative = os.path.relpath(sysconfig.get_path("platlib"), sysconfig.get_path("data"))
    site = prefix / relative
    assert (site / "eci" / "__init__.py").exists() and list((site / "eci").glob("_eci*.so"))
    # with the default prefix (/usr/local) the package lands in a directory this interpreter searches
    cache = dict(line.split(":", 1)[0:1] + line.split("=", 1)[1:] for line in
                 (BUILD / "CMakeCache.txt").read_text().splitlines() if "=" in line and not line.startswith(("#", "//")))
    if cache.get("CMAKE_INSTALL_PREFIX") == "/usr/local":
        assert os.path.join("/usr/local", cache["ECI_PYTHON_INSTALL_DIR"]) in sys.path
    code = ("import eci; print(eci.__file__); "
            "r = eci.solve(eci.models.ThreeWave(), (0.0, 1.0)); print(r.invariants['energy']['max_rel_drift'])")
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env["PYTHONPATH"] = str(site)
    out = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True, text=True,
                         timeout=60)
    assert out.returncode == 0, out.stderr
    where, drift = out.stdout.split()
    assert where.startswith(str(site)) and float(drift) < 1e-14


# `cmake --install` installs the command too (it installed only the library and the Python package): bin/eci, the
# launcher, and bin/eci-main beside it, which it starts; the installed command runs away from the build tree.
def test_install_puts_the_command_in_bin(tmp_path):
    prefix = tmp_path / "prefix"
    r = subprocess.run(["cmake", "--install", str(BUILD), "--prefix", str(prefix), "--component", "cli"],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stdout + r.stderr
    eci_bin = prefix / "bin" / "eci"
    assert eci_bin.exists() and (prefix / "bin" / "eci-main").exists()
    out = subprocess.run([str(eci_bin), "run", "three-wave", "--steps", "10", "--output", "-"], cwd=tmp_path,
                         capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.splitlines()[0].startswith("t,") and len(out.stdout.splitlines()) == 12
