# Checkpoints of the spectral models from Python: eci.solve(..., checkpoint=, checkpoint_every=), eci.load_checkpoint
# and eci.restart, in eci run's format. A run split at a checkpoint must equal the run not split, bit for bit
# (states, generator, budget totals), whichever tool wrote or continues it.
import _thread
import os
import signal
import subprocess
import sys
import threading

import h5py
import numpy as np
import pytest

import eci
from conftest import BUILD, run_cli

FLOWS = [
    ("NavierStokes2D", dict(nu=1e-3, forcing="stochastic", injection_rate=0.1)),
    ("CharneyHasegawaMima", dict(beta=2.0, deformation=1.0, hyper_nu=1e-6, forcing="deterministic")),
    ("SurfaceQG", dict(drag=0.05, forcing="stochastic", injection_rate=0.05, forcing_seed=9)),
]


def flow(name, n=32, **kw):
    return getattr(eci.models, name)(n=n, **kw)


@pytest.mark.parametrize("name,kw", FLOWS)
def test_a_split_run_equals_the_whole_bit_for_bit(tmp_path, name, kw):
    # dt 0.013 does not divide 0.5 or 1: the first part's last step is shortened, so its checkpoint keeps the step
    # before it (38, t = 0.494) and the restart to a later end goes on along the grid
    y0 = flow(name, **kw).random_field(seed=4)
    whole = eci.solve(flow(name, **kw), (0.0, 1.0), y0, method="c-rk4", dt=0.013)
    ck = tmp_path / "ck.h5"
    first = eci.solve(flow(name, **kw), (0.0, 0.5), y0, method="c-rk4", dt=0.013, checkpoint=ck)
    c = eci.load_checkpoint(ck)
    assert (c.step, c.t, c.dt, c.method, c.t_end, c.equation) == (38, 38 * 0.013, 0.013, "c-rk4", 0.5,
                                                                  c.model.equation)
    assert type(c.model).__name__ == name
    assert np.array_equal(c.y, whole.y[:, 38]) and np.array_equal(c.y, first.y[:, 38])
    (tmp_path / "copy.h5").write_bytes(ck.read_bytes())
    rest = eci.restart(ck, 1.0)  # (continues ck.h5 in place: at the end, step 76 of 0.013 before t = 1)
    assert rest.t[0] == c.t and rest.t[-1] == 1.0 and np.array_equal(rest.t, whole.t[38:])
    assert np.array_equal(rest.y, whole.y[:, 38:])
    assert eci.load_checkpoint(ck).step == 76
    # to the same end again: the shortened last step repeated, the first part's own end
    again = eci.restart(tmp_path / "copy.h5", keep_checkpoint=False)
    assert again.t[-1] == 0.5 and np.array_equal(again.y[:, -1], first.y[:, -1])


def test_the_checkpoint_after_a_restart_holds_the_whole_runs_totals(tmp_path):
    name, kw = FLOWS[0]
    y0 = flow(name, **kw).random_field(seed=2)
    eci.solve(flow(name, **kw), (0.0, 1.0), y0, method="c-rk4", dt=0.0125, checkpoint=tmp_path / "whole.h5")
    eci.solve(flow(name, **kw), (0.0, 0.5), y0, method="c-rk4", dt=0.0125, checkpoint=tmp_path / "part.h5")
    eci.restart(tmp_path / "part.h5", 1.0)  # (continued in place)
    a, b = eci.load_checkpoint(tmp_path / "whole.h5"), eci.load_checkpoint(tmp_path / "part.h5")
    assert a.step == b.step == 80 and np.array_equal(a.y, b.y)
    # summed step by step in one order from step 0 either way: equal, not merely close
    assert a.budget == b.budget and a.initial == b.initial and a.max_drift == b.max_drift
    assert a.max_budget_residual == b.max_budget_residual and a.rhs_evals == b.rhs_evals == 4 * 80


def test_either_tool_continues_the_others_checkpoint(tmp_path, cli):
    common = ["--N", "32", "--nu", "1e-3", "--forcing", "stochastic", "--injection-rate", "0.1", "--dt", "0.0125",
              "--method", "c-rk4"]
    # eci run's checkpoint (FFTW_MEASURE plans, its wisdom in the file) continued by Python and by eci run
    run_cli(cli, "run", "navier-stokes-2d", *common, "--t-end", "0.5", "--checkpoint", tmp_path / "cli.h5",
            "--output", tmp_path / "a.csv")
    (tmp_path / "cli2.h5").write_bytes((tmp_path / "cli.h5").read_bytes())
    run_cli(cli, "run", "navier-stokes-2d", "--restart", tmp_path / "cli.h5", "--t-end", "1",
            "--output", tmp_path / "b.csv")
    r = eci.restart(tmp_path / "cli2.h5", 1.0)
    by_cli, by_python = eci.load_checkpoint(tmp_path / "cli.h5"), eci.load_checkpoint(tmp_path / "cli2.h5")
    assert by_python.model.fftw_measure and by_python.step == by_cli.step == 80
    assert np.array_equal(by_python.y, by_cli.y) and np.array_equal(r.y[:, -1], by_cli.y)
    assert by_python.budget == by_cli.budget and by_python.max_drift == by_cli.max_drift
    # Python's checkpoint continued by eci run equals the Python run not split
    m = eci.models.NavierStokes2D(n=32, nu=1e-3, forcing="stochastic", injection_rate=0.1)
    y0 = m.random_field(seed=5)
    whole = eci.solve(m, (0.0, 1.0), y0, method="c-rk4", dt=0.0125)
    eci.solve(eci.models.NavierStokes2D(n=32, nu=1e-3, forcing="stochastic", injection_rate=0.1), (0.0, 0.5), y0,
              method="c-rk4", dt=0.0125, checkpoint=tmp_path / "py.h5")
    run_cli(cli, "run", "navier-stokes-2d", "--restart", tmp_path / "py.h5", "--t-end", "1",
            "--output", tmp_path / "c.csv")
    assert np.array_equal(eci.load_checkpoint(tmp_path / "py.h5").y, whole.y[:, -1])


def test_checkpoint_every_writes_along_the_run(tmp_path):
    name, kw = FLOWS[0]
    path = tmp_path / "ck.h5"
    seen = []

    def probe(y):  # measured after every step, after that step's checkpoint (if any) is written
        if path.exists():
            with h5py.File(path, "r") as f:
                seen.append(int(f.attrs["step"]))
        return 0.0

    eci.solve(flow(name, **kw), (0.0, 0.25), method="c-rk4", dt=0.0125, checkpoint=path, checkpoint_every=7,
              invariants={"probe": probe})
    # the probe runs after steps 1 .. 20: the file appears at step 7, then 14, and the end's after the run
    assert seen == [7] * 7 + [14] * 7, seen
    assert eci.load_checkpoint(path).step == 20
    assert not [p for p in os.listdir(tmp_path) if p != "ck.h5"]  # no temporary left


def test_ctrl_c_keeps_the_step_reached_and_the_restart_goes_on_bit_for_bit(tmp_path):
    name, kw = FLOWS[0]
    kw = dict(kw, n=64)
    y0 = flow(name, **kw).random_field(seed=1)
    path = tmp_path / "ck.h5"
    timer = threading.Timer(0.3, _thread.interrupt_main)  # (the run would take many minutes)
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            eci.solve(flow(name, **kw), (0.0, 1e4), y0, method="c-rk4", dt=0.01, checkpoint=path)
    finally:
        timer.cancel()
    c = eci.load_checkpoint(path)
    assert 0 < c.step < 10 ** 6 and c.t_end == 1e4 and c.t == c.step * 0.01
    # the state of that step of the run, and the restart from it goes on as the run would have
    whole = eci.solve(flow(name, **kw), (0.0, c.t + 0.5), y0, method="c-rk4", dt=0.01, t_eval=[c.t, c.t + 0.5])
    assert np.array_equal(c.y, whole.y[:, 0])
    rest = eci.restart(c, c.t + 0.5, keep_checkpoint=False)
    assert np.array_equal(rest.y[:, -1], whole.y[:, -1])
    # the same Checkpoint again (its model's forcing generator has moved on): the same run
    again = eci.restart(c, c.t + 0.5, keep_checkpoint=False)
    assert np.array_equal(again.y, rest.y)


@pytest.mark.parametrize("release", [True, False], ids=["gil-released", "python-invariant"])
def test_ctrl_c_between_the_halvings_of_a_failing_step_keeps_that_steps_start(tmp_path, release):
    # 32 CFL steps with the paper's update: every step fails about ten times before it passes halved, so Ctrl-C is
    # mostly seen between the attempts of a step, where x is part-way through it; the checkpoint must then hold the
    # step's start and the generator before its draw (and between steps, the step reached): either way the state of
    # that step of the run, from which the restart goes on bit for bit
    kw = dict(n=32, forcing="stochastic", injection_rate=0.5)
    y0 = eci.models.NavierStokes2D(**kw).random_field(seed=1)
    dt = 32 * eci.models.NavierStokes2D(**kw).cfl_step(y0)
    path = tmp_path / "ck.h5"
    extra = {} if release else {"invariants": {"zero": lambda y: 0.0}}  # (a Python invariant holds the GIL)
    timer = threading.Timer(0.3, _thread.interrupt_main)
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            eci.solve(eci.models.NavierStokes2D(**kw), (0.0, 1e6 * dt), y0, method="c-rk4", dt=dt, update="paper",
                      checkpoint=path, **extra)
    finally:
        timer.cancel()
    c = eci.load_checkpoint(path)
    assert c.step > 0
    whole = eci.solve(eci.models.NavierStokes2D(**kw), (0.0, (c.step + 3) * dt), y0, method="c-rk4", dt=dt,
                      update="paper", output_dt=dt)
    assert np.array_equal(c.y, whole.y[:, c.step])
    rest = eci.restart(c, (c.step + 3) * dt, keep_checkpoint=False)
    assert np.array_equal(rest.y[:, -1], whole.y[:, -1])


def test_bad_requests_are_refused_with_nothing_written(tmp_path):
    ns = eci.models.NavierStokes2D(n=16)
    with pytest.raises(ValueError, match="checkpoint is for the spectral models"):
        eci.solve(eci.models.ThreeWave(), (0.0, 1.0), checkpoint=tmp_path / "a.h5")
    with pytest.raises(ValueError, match="checkpoint is for the spectral models"):
        eci.solve(lambda t, y: -y, (0.0, 1.0), [1.0], dt=0.1, checkpoint=tmp_path / "a.h5")
    with pytest.raises(ValueError, match="checkpoint_every needs checkpoint"):
        eci.solve(ns, (0.0, 0.1), checkpoint_every=3)
    for bad in (0, -1, 2.5, True):
        with pytest.raises(ValueError, match="checkpoint_every must be a whole number"):
            eci.solve(ns, (0.0, 0.1), checkpoint=tmp_path / "a.h5", checkpoint_every=bad)
    with pytest.raises(TypeError, match="checkpoint must be a file name"):
        eci.solve(ns, (0.0, 0.1), checkpoint=3)
    with pytest.raises(ValueError, match="t_span from 0"):
        eci.solve(ns, (1.0, 1.1), checkpoint=tmp_path / "a.h5")
    with pytest.raises(OSError, match="cannot write checkpoint"):
        eci.solve(ns, (0.0, 0.1), checkpoint=tmp_path / "no" / "such" / "dir.h5")
    assert os.listdir(tmp_path) == []


def test_files_that_are_not_good_checkpoints_are_refused(tmp_path):
    with pytest.raises(FileNotFoundError):
        eci.load_checkpoint(tmp_path / "missing.h5")
    (tmp_path / "text.h5").write_text("not hdf5\n")
    with pytest.raises(ValueError, match="cannot restart"):
        eci.load_checkpoint(tmp_path / "text.h5")
    ns = eci.models.NavierStokes2D(n=16)
    path = tmp_path / "ck.h5"
    eci.solve(ns, (0.0, 0.1), dt=0.01, checkpoint=path)
    with pytest.raises(ValueError, match="before the checkpoint's t"):
        eci.restart(path, 0.05)
    with pytest.raises(ValueError, match="t_end must be a finite number, not inf"):
        eci.restart(path, float("inf"))
    # settings the file holds that the model refuses, or a method it does not have: named with the file
    for attr, value, said in (("nu", -1.0, "viscosity nu must be finite and >= 0"),
                              ("method", np.bytes_(b"rk5"), "method 'rk5' is not a method of navier-stokes-2d")):
        bad = tmp_path / f"bad_{attr}.h5"
        bad.write_bytes(path.read_bytes())
        with h5py.File(bad, "r+") as f:
            del f.attrs[attr]
            f.attrs[attr] = value
        with pytest.raises(ValueError, match=f"^cannot restart: {bad}: .*{said}"):
            eci.load_checkpoint(bad)
    with h5py.File(path, "r+") as f:  # one mode changed: still finite, caught by the checksum
        name = [k for k in f.keys() if k.endswith("_hat")][0]
        d = f[name][...]
        d.flat[5] += 1e-3
        f[name][...] = d
    with pytest.raises(ValueError, match="checksum|does not match"):
        eci.load_checkpoint(path)


def test_short_runs_keep_their_end_on_the_grid(tmp_path):
    m = eci.models.NavierStokes2D(n=16, nu=1e-3)
    y0 = m.random_field(seed=3)
    # one step, shortened (0.005 of 0.01): the state before it is the start, kept as step 0
    eci.solve(m, (0.0, 0.005), y0, dt=0.01, checkpoint=tmp_path / "a.h5")
    c = eci.load_checkpoint(tmp_path / "a.h5")
    assert c.step == 0 and c.t_end == 0.005 and np.array_equal(c.y, y0)
    r = eci.restart(c)
    assert r.t[-1] == 0.005 and np.array_equal(r.y[:, -1], eci.solve(m, (0.0, 0.005), y0, dt=0.01).y[:, -1])
    # no step at all: the start itself
    eci.solve(m, (0.0, 0.0), y0, dt=0.01, checkpoint=tmp_path / "b.h5")
    assert eci.load_checkpoint(tmp_path / "b.h5").step == 0


def test_a_checkpoint_that_cannot_be_written_mid_run_raises_oserror(tmp_path):
    d = tmp_path / "out"
    d.mkdir()
    path = d / "ck.h5"

    def probe(y):  # after the first checkpoint (step 2), the directory goes away
        if path.exists():
            path.unlink()
            d.rmdir()
        return 0.0

    with pytest.raises(OSError, match="cannot write checkpoint"):
        eci.solve(eci.models.NavierStokes2D(n=16), (0.0, 0.1), dt=0.01, checkpoint=path, checkpoint_every=2,
                  invariants={"probe": probe})
    assert not d.exists()


def test_a_batch_systems_sigterm_is_kept_as_ctrl_c_is(tmp_path):
    # a job's time limit: SIGTERM to a process that routes it to KeyboardInterrupt, as docs/python.md says
    script = tmp_path / "job.py"
    script.write_text(
        "import eci, signal, sys\n"
        "signal.signal(signal.SIGTERM, signal.default_int_handler)\n"
        "print('ready', flush=True)\n"
        "eci.solve(eci.models.NavierStokes2D(n=64, nu=1e-3), (0.0, 1e4), dt=0.01, checkpoint=sys.argv[1])\n")
    env = dict(os.environ, PYTHONPATH=str(BUILD / "python"))
    p = subprocess.Popen([sys.executable, str(script), str(tmp_path / "ck.h5")], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True, env=env)
    assert p.stdout.readline() == "ready\n"
    threading.Event().wait(1.0)  # (well into the run: planning and the first steps)
    p.send_signal(signal.SIGTERM)
    _, err = p.communicate(timeout=60)
    assert p.returncode != 0 and "KeyboardInterrupt" in err, err  # (Python ends by SIGINT then)
    c = eci.load_checkpoint(tmp_path / "ck.h5")
    assert c.step > 0 and c.t_end == 1e4
