# eci.solve's progress line (progress=): drawn on sys.stderr from a second into a run, for every kind of run (a
# spectral model, an ODE model run in C++ without the GIL, a Python fun with it), erased at the end; by default only
# where sys.stderr is a terminal. Each run is in a child process, whose standard error is read whole.
import os
import pty
import subprocess
import sys

import pytest

import eci

# Runs of about 2 s each on this project's 2-core VMs (each long enough for the line, which waits a second): a spectral model, an ODE model
# and a Python fun; each prints its last state, which must not change with the line.
RUNS = """
import eci, sys
progress = {progress}
m = eci.models.NavierStokes2D(n=128)
r = eci.solve(m, (0.0, 2.5), method="c-rk4", dt=1e-3, t_eval=[2.5], progress=progress)
print(repr(float(r.y[1, -1].real)))
r = eci.solve(eci.models.ThreeWave(), (0.0, 3e5), method="c-rk4", dt=0.01, t_eval=[3e5], progress=progress)
print(repr(float(r.y[0, -1])))
r = eci.solve(lambda t, y: -y, (0.0, 700.0), [1.0], method="rk4", dt=1e-3, t_eval=[700.0], progress=progress)
print(repr(float(r.y[0, -1])))
"""


def run_child(progress, stderr=subprocess.PIPE):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    r = subprocess.run([sys.executable, "-c", RUNS.format(progress=progress)], stdout=subprocess.PIPE,
                       stderr=stderr, env=env, timeout=600, check=True)
    # (bytes decoded as they are: text mode would turn the line's carriage returns into newlines)
    return subprocess.CompletedProcess(r.args, r.returncode, r.stdout.decode(), r.stderr.decode())


def lines_drawn(err):
    """The progress lines written to err: each starts with a carriage return and a bar."""
    return [part for part in err.split("\r") if part.startswith("[")]


def test_progress_true_draws_a_line_for_every_kind_of_run_and_erases_it():
    shown = run_child(True)
    quiet = run_child(False)
    assert quiet.stderr == ""
    assert shown.stdout == quiet.stdout  # the same runs, the same states
    # each run's lines, then its erasure: three runs, each long enough to be drawn, the last erasure the stream's end
    segments = shown.stderr.split("\r\x1b[K")
    assert len(segments) == 4 and segments[-1] == "", repr(shown.stderr[-300:])
    for t_end, segment in zip((2.5, 3e5, 700.0), segments):
        drawn = lines_drawn(segment)
        assert drawn, segment
        percents = []
        for line in drawn:
            bar, rest = line[1:].split("]", 1)
            percent = float(rest.split("%")[0])
            t = float(rest.split(" t = ")[1].split()[0])
            assert len(bar) == 40 and set(bar) <= {"#", "."}, line
            # floor(40 f) marks for a fraction f shown as a percent rounded to 0.1: within 1 + 0.4 * 0.05 of it
            assert -0.02 <= 0.4 * percent - bar.count("#") < 1.02, line
            # the fraction is of the span: t (6 digits) / t_end against the percent (rounded to 0.1)
            assert abs(100.0 * t / t_end - percent) <= 0.05 + 1e-4 * percent, line
            assert rest.endswith(" s left") or " s left" in rest, line
            percents.append(percent)
        assert percents == sorted(percents) and 0.0 < percents[0] and percents[-1] <= 100.0


def test_progress_by_default_only_on_a_terminal():
    piped = run_child(None)
    assert piped.stderr == ""  # (a pipe, as in a script's redirection or a notebook's captured stream)
    leader, follower = pty.openpty()
    try:
        child = subprocess.Popen([sys.executable, "-c", RUNS.format(progress=None)], stdout=subprocess.PIPE,
                                 stderr=follower, env=dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path)))
        os.close(follower)
        err = b""
        while True:
            try:
                chunk = os.read(leader, 65536)
            except OSError:  # the terminal closed with the child
                break
            if not chunk:
                break
            err += chunk
        out, _ = child.communicate(timeout=600)
    finally:
        os.close(leader)
    assert child.returncode == 0
    assert out.decode() == piped.stdout
    assert len(lines_drawn(err.decode())) >= 3, err[-300:]


def test_progress_takes_a_bool_or_none():
    with pytest.raises(TypeError, match="progress must be True, False or None, not str"):
        eci.solve(eci.models.ThreeWave(), (0.0, 1.0), progress="yes")
    r = eci.solve(eci.models.ThreeWave(), (0.0, 1.0), progress=False)
    assert r.success
