# The CLI's files through the real binary: what an interrupted run keeps (complete files up to where it stopped),
# outputs that would overwrite the run's own inputs, what a checkpoint records and how its attributes are checked on
# --restart, and the numbers the options take (decimal only).
import json
import re
import os
import signal
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest

from conftest import cli_error

h5py = pytest.importorskip("h5py")

# no pictures (ECI_GNUPLOT names no program): the snapshots' HDF5 files alone
NO_PICTURES = {**os.environ, "ECI_GNUPLOT": "/nonexistent/gnuplot"}


def small(*args, wisdom="none"):
    """A small spectral run: 16^2, FFTW_ESTIMATE plans, no wisdom file, dt 0.01."""
    return ["run", "navier-stokes-2d", "--N", "16", "--fftw-estimate", "--dt", "0.01",
            *(["--fftw-wisdom", wisdom] if wisdom else []), *args]


def run_cli(cli_path, *args, check=True):
    """Runs `eci ARGS...` (no pictures) and returns the CompletedProcess."""
    r = subprocess.run([str(cli_path), *map(str, args)], capture_output=True, text=True, timeout=120, env=NO_PICTURES)
    if check and r.returncode != 0:
        raise AssertionError(f"eci {' '.join(map(str, args))} failed: {r.stderr}")
    return r


def error_line(err):
    """The one error line of a failed run (a warning about pictures may come before it)."""
    errors = [line for line in err.strip().splitlines() if line.startswith("eci: error: ")]
    assert len(errors) == 1, err
    return errors[0]


def interrupted_run(cli, args, cwd, after=1.5):
    """Runs `eci ARGS` in cwd, sends SIGINT after `after` seconds; returns (status, stderr)."""
    p = subprocess.Popen([str(cli), *map(str, args)], cwd=cwd, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                         stderr=subprocess.PIPE, text=True, env=NO_PICTURES)
    time.sleep(after)
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=60)
    return p.returncode, err


def complete_csv(path):
    """The rows of a CSV whose every line is whole: ends with a newline, as many fields as the header."""
    text = Path(path).read_text()
    assert text.endswith("\n"), "the last row is cut"
    lines = text.splitlines()
    width = len(lines[0].split(","))
    for line in lines[1:]:
        assert len(line.split(",")) == width, line
    return [line.split(",") for line in lines[1:]]


def temporaries(d):
    return [p for p in Path(d).rglob("*") if ".eci-" in p.name]


# ---- 5. numbers are decimal

@pytest.mark.parametrize("args, value", [
    (["three-wave", "--dt", "0x10"], "0x10"), (["three-wave", "--dt", "0x1p-4"], "0x1p-4"),
    (["three-wave", "--t-end", "0X1"], "0X1"), (["three-wave", "--rtol", "0x1p-20"], "0x1p-20"),
    (["three-wave", "--atol", "1e"], "1e"), (["three-wave", "--output-dt", ".e1"], ".e1"),
    (["three-wave", "--psi", "1,0x1,1"], "0x1"), (["three-wave", "--M", "0x1,1,-2"], "0x1"),
    (["three-wave", "--dt", "1.5x"], "1.5x"), (["three-wave", "--dt", "1_0"], "1_0"),
    (["navier-stokes-2d", "--nu", "0x1p-3"], "0x1p-3"), (["navier-stokes-2d", "--cfl", "0x.8"], "0x.8"),
])
def test_numbers_are_decimal(cli, args, value):
    msg = cli_error(cli, "run", *args)
    assert f"must be a decimal number, not '{value}'" in msg, msg


@pytest.mark.parametrize("value", ["16", "+16", "-0.5", ".5", "2.", "1e-3", "1E+2", "1.5e0"])
def test_decimal_numbers_are_taken(cli, value):
    r = run_cli(cli, "run", "three-wave", "--steps", 1, "--dt", value, check=False)
    assert "decimal" not in r.stderr, r.stderr
