# The Python examples run as a user runs them (Agg backend), make their figure, and pass their own checks.
import os
import subprocess
import sys

import pytest

from conftest import BUILD, REPO

EXAMPLES = sorted((REPO / "examples" / "python").glob("*.py"))
sys.path.insert(0, str(BUILD / "python"))
import eci  # noqa: E402

# the Navier-Stokes examples need the module built with eci::spectral (FFTW3)
SKIP = set() if hasattr(eci.models, "NavierStokes2D") else {"vortex_merger.py", "forced_turbulence_restart.py"}


def test_there_are_examples():
    assert {p.name for p in EXAMPLES} >= {"three_wave.py", "user_system.py"}


@pytest.mark.parametrize("script", EXAMPLES, ids=lambda p: p.name)
def test_example_runs_and_draws(script, tmp_path):
    if script.name in SKIP:
        pytest.skip("built without eci::spectral")
    figure = tmp_path / "figure.png"
    env = dict(os.environ, MPLBACKEND="Agg", PYTHONPATH=str(BUILD / "python"), MPLCONFIGDIR=str(tmp_path))
    r = subprocess.run([sys.executable, str(script), str(figure)], cwd=tmp_path, env=env, capture_output=True,
                       text=True, timeout=300)
    assert r.returncode == 0, r.stdout + r.stderr
    assert figure.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and figure.stat().st_size > 10000
