# pytest set-up for the Python module: import eci from the build tree (ECI_BUILD_DIR, default <repo>/build) and
# find the CLI there, so the tests compare the module with the very binary built next to it.
import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
BUILD = Path(os.environ.get("ECI_BUILD_DIR", REPO / "build")).resolve()
sys.path.insert(0, str(BUILD / "python"))

EPS = 2.0 ** -52


@pytest.fixture(scope="session")
def cli():
    """The eci binary of the same build."""
    path = BUILD / "eci"
    if not path.exists():
        pytest.fail(f"the eci CLI is not built at {path} (cmake --build {BUILD} --target eci_cli)")
    return path


def run_cli(cli_path, *args, check=True):
    """Runs `eci ARGS...` and returns the CompletedProcess (text)."""
    r = subprocess.run([str(cli_path), *map(str, args)], capture_output=True, text=True, timeout=120)
    if check and r.returncode != 0:
        raise AssertionError(f"eci {' '.join(map(str, args))} failed: {r.stderr}")
    return r


def cli_error(cli_path, *args):
    """The one-line message of a CLI run that must fail with status 2 (bad input), without 'eci: error: '."""
    r = run_cli(cli_path, *args, check=False)
    assert r.returncode == 2, (r.returncode, r.stderr)
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("eci: error: "), r.stderr
    return lines[0][len("eci: error: "):]


def failure_of(r, cls):
    """The failure of a run that stopped early: SciPy's status -1, success False, the message, and the eci
    exception describing it in r.failure (not raised)."""
    assert r.status == -1 and not r.success, (r.status, r.message)
    assert isinstance(r.failure, cls) and isinstance(r.failure, RuntimeError)
    assert r.message == str(r.failure)
    return r.failure
