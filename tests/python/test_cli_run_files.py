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


# ---- 1. an interrupted run keeps what it produced up to the step it stopped at

def test_interrupted_spectral_run_keeps_its_snapshots_rows_and_summary(cli, tmp_path):
    status, err = interrupted_run(cli, ["run", "navier-stokes-2d", "--N", "32", "--t-end", "100000", "--fftw-wisdom",
                                        "none", "--fftw-estimate", "--snapshot-every", "200", "--snapshot-dir",
                                        "snapd", "--checkpoint", "ck.h5", "--output", "ts.csv", "--summary-json",
                                        "s.json"], tmp_path, after=2.5)
    assert status == 130, err
    line = error_line(err)
    assert line.startswith("eci: error: interrupted at step "), err
    step = int(line[len("eci: error: interrupted at step "):].split(",")[0])
    assert step > 0, err
    assert "checkpoint written to ck.h5" in err
    # (the steps of the last snapshot and row made: a snapshot every 200 steps, a row every step)
    assert "kept: the snapshots in 'snapd' to step %d, CSV output 'ts.csv' (rows to step %d), summary JSON " \
           "'s.json'" % (step // 200 * 200, step) in err, err
    rows = complete_csv(tmp_path / "ts.csv")
    assert [int(r[0]) for r in rows] == list(range(0, step + 1))
    with h5py.File(tmp_path / "ck.h5", "r") as f:
        assert int(f.attrs["step"]) == step
    taken = sorted(p.name for p in (tmp_path / "snapd").glob("vorticity_*.h5"))
    assert taken == ["vorticity_%08d.h5" % i for i in range(0, step + 1, 200)]
    for name in taken:
        with h5py.File(tmp_path / "snapd" / name, "r") as f:
            assert f["vorticity"].shape == (32, 32)
    s = json.loads((tmp_path / "s.json").read_text())
    assert s["interrupted"] is True and s["steps"] == step
    assert s["t_stopped"] == float(rows[-1][1])
    assert s["invariants"]["energy"]["final"] == float(rows[-1][2])
    assert not temporaries(tmp_path)
    # the remedy's counts so far (they were 0: the library's run added them to its statistics at the end only)
    r = run_cli(cli, "run", "navier-stokes-2d", "--N", "32", "--steps", step, "--fftw-wisdom", "none",
                "--fftw-estimate", "--summary-json", tmp_path / "whole.json")
    whole = json.loads((tmp_path / "whole.json").read_text())
    assert whole["remedied_steps"] > 0
    for key in ["remedied_steps", "components_remedied", "rhs_evals"]:
        assert s[key] == whole[key], key


# A stop writes the checkpoint a run asked for (--checkpoint, --checkpoint-every; a restart's file, continued in
# place); a run that asked for none keeps one under the default name only if no file is there: a quick test run in the
# directory of a long one replaced the long run's ns2d-checkpoint.h5 when stopped.
def test_a_stop_without_a_checkpoint_asked_keeps_another_runs_checkpoint(cli, tmp_path):
    r = subprocess.run([str(cli), *map(str, small("--steps", 6, "--checkpoint-every", 3))], cwd=tmp_path, capture_output=True,
                       text=True, timeout=120, env=NO_PICTURES)
    assert r.returncode == 0, r.stderr
    before = (tmp_path / "ns2d-checkpoint.h5").read_bytes()
    status, err = interrupted_run(cli, ["run", "navier-stokes-2d", "--N", "32", "--steps", "10000000",
                                        "--fftw-wisdom", "none", "--fftw-estimate"], tmp_path)
    assert status == 130, err
    assert "no checkpoint written ('ns2d-checkpoint.h5' exists, another run's; --checkpoint FILE keeps one)" in err
    assert (tmp_path / "ns2d-checkpoint.h5").read_bytes() == before
    # where the default name is free, the stop keeps the run there, as before
    fresh = tmp_path / "fresh"
    fresh.mkdir()
    status, err = interrupted_run(cli, ["run", "navier-stokes-2d", "--N", "32", "--steps", "10000000",
                                        "--fftw-wisdom", "none", "--fftw-estimate"], fresh)
    assert status == 130, err
    assert "checkpoint written to ns2d-checkpoint.h5 (continue with --restart ns2d-checkpoint.h5)" in err
    assert (fresh / "ns2d-checkpoint.h5").exists()


# A restart writes its own steps: an --output or --summary-json that exists (the first part's, as the same command
# line plus --restart names it) is refused, not replaced by the second part alone.
@pytest.mark.parametrize("option, name", [("--output", "seg.csv"), ("--output", "seg.h5"), ("--summary-json", "s.json")])
def test_a_restart_refuses_to_replace_an_existing_output(cli, tmp_path, option, name):
    first = subprocess.run([str(cli), *map(str, small("--steps", 4, option, name, "--checkpoint", "ck.h5",
                                                      "--checkpoint-every", 4))],
                           cwd=tmp_path, capture_output=True, text=True, timeout=120, env=NO_PICTURES)
    assert first.returncode == 0, first.stderr
    before = (tmp_path / name).read_bytes()
    r = subprocess.run([str(cli), "run", "navier-stokes-2d", "--restart", "ck.h5", "--steps", "8", "--fftw-wisdom",
                        "none", option, name], cwd=tmp_path, capture_output=True, text=True, timeout=120,
                       env=NO_PICTURES)
    assert r.returncode == 2, r.stderr
    assert error_line(r.stderr) == "eci: error: %s '%s' exists: the restarted run writes steps 5 on and would " \
                                   "replace it (name a new file)" % (option, name)
    assert (tmp_path / name).read_bytes() == before


# A failure after a restart names the checkpoint that holds the last good step (the restart file, until the run
# writes its own), and says how a smaller step is taken (a restart keeps its checkpoint's dt).
def test_a_blow_up_after_a_restart_names_the_restart_file(cli, tmp_path):
    first = subprocess.run([str(cli), "run", "navier-stokes-2d", "--N", "32", "--method", "rk4", "--dt", "0.5",
                            "--steps", "4", "--checkpoint", "bu.h5", "--checkpoint-every", "2", "--fftw-wisdom",
                            "none", "--fftw-estimate"], cwd=tmp_path, capture_output=True, text=True, timeout=120,
                           env=NO_PICTURES)
    assert first.returncode == 1 and "last good checkpoint: bu.h5 (step 2)" in first.stderr, first.stderr
    r = subprocess.run([str(cli), "run", "navier-stokes-2d", "--restart", "bu.h5", "--fftw-wisdom", "none"],
                       cwd=tmp_path, capture_output=True, text=True, timeout=120, env=NO_PICTURES)
    assert r.returncode == 1, r.stderr
    line = error_line(r.stderr)
    assert "a smaller step needs a new run (--ic bu.h5 takes its field, with a smaller --dt or --cfl)" in line, line
    assert line.endswith("; last good checkpoint: bu.h5 (step 2)"), line
    assert not (tmp_path / "ns2d-checkpoint.h5").exists()


@pytest.mark.parametrize("extra", [[], ["--rtol", "1e-9", "--method", "c-dp54"]], ids=["fixed", "adaptive"])
def test_interrupted_ode_run_keeps_its_rows_and_summary(cli, tmp_path, extra):
    (tmp_path / "x.csv").write_text("precious\n")
    status, err = interrupted_run(cli, ["run", "three-wave", "--t-end", "1e12", "--every", "1000", "--output",
                                        "x.csv", "--summary-json", "x.json", *extra], tmp_path)
    assert status == 130, err
    line = error_line(err)
    assert line.startswith("eci: error: interrupted by SIGINT at t = "), err
    rows = complete_csv(tmp_path / "x.csv")
    assert len(rows) > 1
    kept = re.search(r"; kept: CSV output 'x.csv' \(rows to t = ([^)]*)\), summary JSON 'x.json'$", line)
    assert kept and float(kept.group(1)) == float(rows[-1][0]), err
    s = json.loads((tmp_path / "x.json").read_text())
    assert s["interrupted"] is True and s["t_stopped"] == float(rows[-1][0])
    assert s["invariants"]["energy"]["final"] == float(rows[-1][4])
    assert s["invariants"]["energy"]["initial"] == float(rows[0][4])
    assert ("steps" in s) == (not extra)  # counts of an adaptive run are not known between its steps
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.csv", "x.json"]


def test_run_stopped_before_its_first_step_keeps_nothing(cli, tmp_path):
    (tmp_path / "x.csv").write_text("precious\n")

    def pending_interrupt():  # SIGINT pending from the start: the run never steps
        signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
        os.kill(os.getpid(), signal.SIGINT)

    p = subprocess.Popen([str(cli), "run", "three-wave", "--t-end", "1e9", "--output", "x.csv", "--summary-json",
                          "x.json"], cwd=tmp_path, stderr=subprocess.PIPE, text=True, preexec_fn=pending_interrupt)
    _, err = p.communicate(timeout=60)
    assert p.returncode == 130, err
    assert (tmp_path / "x.csv").read_text() == "precious\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.csv"]


# ---- 2. no output may be one of the run's inputs

@pytest.fixture
def checkpoint(cli, tmp_path):
    run_cli(cli, *small("--steps", 2, "--checkpoint-every", 2, "--checkpoint", tmp_path / "a2.h5"))
    return tmp_path / "a2.h5"


@pytest.mark.parametrize("option", ["--output", "--summary-json", "--fftw-wisdom"])
@pytest.mark.parametrize("how", ["same", "normalised", "symlink", "hardlink"])
def test_an_output_naming_the_restart_file_is_refused(cli, tmp_path, checkpoint, option, how):
    name = {"same": checkpoint, "normalised": tmp_path / "x" / ".." / "a2.h5", "symlink": tmp_path / "link.h5",
            "hardlink": tmp_path / "hard.h5"}[how]
    (tmp_path / "x").mkdir()
    if how == "symlink":
        name.symlink_to(checkpoint)
    if how == "hardlink":
        os.link(checkpoint, name)
    before = checkpoint.read_bytes()
    msg = cli_error(cli, "run", "navier-stokes-2d", "--restart", checkpoint, "--t-end", 0.05, option, name,
                    "--checkpoint", tmp_path / "cc.h5")
    assert msg == f"{option} and --restart name the same file '{name}': the run would overwrite its own input"
    assert checkpoint.read_bytes() == before
    assert not (tmp_path / "cc.h5").exists()


@pytest.mark.parametrize("option", ["--output", "--summary-json", "--fftw-wisdom", "--checkpoint"])
def test_an_output_naming_the_ic_file_is_refused(cli, tmp_path, checkpoint, option):
    run_cli(cli, *small("--steps", 1, "--snapshot-every", 1, "--snapshot-dir", tmp_path / "sd"))
    for ic in [checkpoint, tmp_path / "sd" / "vorticity_00000001.h5"]:
        before = ic.read_bytes()
        msg = cli_error(cli, *small("--ic", ic, "--steps", 1, option, ic, wisdom=option != "--fftw-wisdom" and "none"))
        assert msg == f"{option} and --ic name the same file '{ic}': the run would overwrite its own input"
        assert ic.read_bytes() == before


def test_a_snapshot_over_the_ic_or_restart_file_is_refused(cli, tmp_path, checkpoint):
    sd = tmp_path / "sd"
    run_cli(cli, *small("--steps", 2, "--snapshot-every", 1, "--snapshot-dir", sd))
    snap = sd / "vorticity_00000000.h5"
    before = snap.read_bytes()
    msg = cli_error(cli, *small("--ic", snap, "--snapshot-dir", sd, "--snapshot-every", 1, "--steps", 1))
    assert msg == (f"--snapshot-dir and --ic name the same file '{snap}': the run would overwrite its own input")
    assert snap.read_bytes() == before
    # a snapshot name that links to the input (the restart at step 2 writes step 4)
    (sd / "vorticity_00000004.h5").symlink_to(checkpoint)
    msg = cli_error(cli, "run", "navier-stokes-2d", "--fftw-wisdom", "none", "--restart", checkpoint, "--steps", 4,
                    "--snapshot-every", 1, "--snapshot-dir", sd, "--checkpoint", tmp_path / "cc.h5")
    assert msg.startswith("--snapshot-dir and --restart name the same file "), msg
    (sd / "vorticity_00000004.h5").unlink()
    # a snapshot the run does not write may be its input (steps 0 and 4 are written, not 1), but not into a directory
    # holding the other run's snapshots (1 and 2 would stay beside this run's 0 and 4): into another directory
    msg = cli_error(cli, *small("--ic", sd / "vorticity_00000001.h5", "--snapshot-dir", sd, "--snapshot-every", 5,
                                "--steps", 4, "--output", tmp_path / "o.csv"))
    assert msg == (f"--snapshot-dir '{sd}' holds another run's snapshots at steps this run does not write (step 1 "
                   "and 1 more): they would mix with this run's; give another directory or remove them"), msg
    run_cli(cli, *small("--ic", sd / "vorticity_00000001.h5", "--snapshot-dir", tmp_path / "sd2", "--snapshot-every",
                        5, "--steps", 4, "--output", tmp_path / "o.csv"))
    # a restart continues its own run's directory: the steps before its first are the run's earlier part
    run_cli(cli, *small("--steps", 4, "--snapshot-every", 2, "--snapshot-dir", tmp_path / "sd3", "--checkpoint",
                        tmp_path / "c3.h5", "--checkpoint-every", 2))
    run_cli(cli, "run", "navier-stokes-2d", "--fftw-wisdom", "none", "--restart", tmp_path / "c3.h5", "--steps", 8,
            "--snapshot-every", 2, "--snapshot-dir", tmp_path / "sd3")
    assert sorted(p.name for p in (tmp_path / "sd3").glob("vorticity_*.h5")) == [
        "vorticity_%08d.h5" % i for i in range(0, 9, 2)]


def test_a_snapshot_directory_of_another_equation_is_refused(cli, tmp_path):
    """Two equations' runs share the spectra's names: a surface-QG run into a Navier-Stokes run's directory would
    replace its spectra and leave the two runs' fields side by side, even at the very steps it writes."""
    sd = tmp_path / "sd"
    run_cli(cli, *small("--steps", 2, "--snapshot-every", 1, "--snapshot-dir", sd))
    before = {p.name: p.read_bytes() for p in sd.iterdir()}
    assert "spectrum_00000001.csv" in before
    for model in ["surface-qg", "charney-hasegawa-mima"]:
        msg = cli_error(cli, "run", model, "--N", "16", "--fftw-estimate", "--fftw-wisdom", "none", "--dt", "0.01",
                        "--steps", 2, "--snapshot-every", 1, "--snapshot-dir", sd, "--output", tmp_path / "o.csv")
        assert re.fullmatch(rf"--snapshot-dir '{re.escape(str(sd))}' holds another equation's snapshots "
                            r"\('vorticity_0000000[0-2]\.(h5|png)', navier-stokes-2d's\): this run's spectra would replace "
                            r"its; give another directory", msg), msg
        assert {p.name: p.read_bytes() for p in sd.iterdir()} == before
        assert not (tmp_path / "o.csv").exists()
    run_cli(cli, *small("--steps", 2, "--snapshot-every", 1, "--snapshot-dir", sd))  # its own run again: taken


def test_the_checkpoint_may_continue_the_restart_file_in_place(cli, tmp_path, checkpoint):
    run_cli(cli, "run", "navier-stokes-2d", "--fftw-wisdom", "none", "--restart", checkpoint, "--steps", 4,
            "--checkpoint-every", 4, "--checkpoint", checkpoint)
    with h5py.File(checkpoint, "r") as f:
        assert int(f.attrs["step"]) == 4


# ---- 3. the checkpoint records every option that changes the numbers

def last_row(path):
    return Path(path).read_text().splitlines()[-1]


def test_the_checkpoint_records_update_and_a_restart_takes_it(cli, tmp_path):
    base = ["run", "navier-stokes-2d", "--N", "32", "--fftw-wisdom", "none", "--fftw-estimate", "--dt", "0.01",
            "--method", "c-rk4", "--update", "paper"]
    run_cli(cli, *base, "--t-end", 1, "--output", tmp_path / "full.csv")
    run_cli(cli, *base, "--t-end", 0.5, "--checkpoint-every", 50, "--checkpoint", tmp_path / "half.h5")
    with h5py.File(tmp_path / "half.h5", "r") as f:
        assert f.attrs["update"] == b"paper"
    rest = ["run", "navier-stokes-2d", "--fftw-wisdom", "none", "--restart", tmp_path / "half.h5", "--t-end", 1]
    run_cli(cli, *rest, "--output", tmp_path / "rest.csv", "--checkpoint", tmp_path / "r.h5")
    assert last_row(tmp_path / "rest.csv") == last_row(tmp_path / "full.csv")
    msg = cli_error(cli, *rest, "--update", "conditioned", "--checkpoint", tmp_path / "r.h5")
    assert msg.startswith(f"--update conditioned does not match the restart file's paper ({tmp_path / 'half.h5'}"), msg
    # a checkpoint of an earlier version records none: its run took the default, conditioned
    with h5py.File(tmp_path / "half.h5", "r+") as f:
        del f.attrs["update"]
    msg = cli_error(cli, *rest, "--update", "paper", "--checkpoint", tmp_path / "r.h5")
    assert msg.startswith("--update paper does not match the restart file's conditioned"), msg
    run_cli(cli, *rest, "--update", "conditioned", "--checkpoint", tmp_path / "r.h5")


# ---- 4. every checkpoint attribute read on restart is checked

@pytest.mark.parametrize("name, value, says", [
    ("step", np.int64(-5), "attribute 'step' is -5, not a count >= 0"),
    ("step", np.float64(2.0), "attribute 'step' is not a whole number"),
    ("step", np.uint64(1), "time 0.02 is not step * dt = 1 * 0.01"),
    ("time", np.float64(7.0), "time 7 is not step * dt = 2 * 0.01"),
    ("total_steps", np.int64(-1), "attribute 'total_steps' is -1, not a count >= 0"),
    ("halvings", np.int64(-3), "attribute 'halvings' is -3, not a count >= 0"),
    ("rhs_evals", np.uint64(1), "rhs_evals 1 is fewer than the 2 steps taken"),
    ("rng_state", np.int64(-1), "attribute 'rng_state' is -1, not a count >= 0"),
    ("forcing_seed", np.float64(1.5), "attribute 'forcing_seed' is not a whole number"),
    ("N", np.float64(16.0), "attribute 'N' is not a whole number"),
    ("threads", np.int64(-2), "threads = -2 is not in 1..64"),
    ("dt", np.float64(np.inf), "dt must be a positive number"),
    ("energy0", np.float64(-1.0), "energy0 -1 is negative"),
    ("max_enstrophy_drift", np.float64(-1e-3), "max_enstrophy_drift -0.001 is negative"),
    ("energy_injection", np.float64(np.nan), "energy_injection is not finite"),
    ("update", "fast", "unknown update 'fast'"),
])
def test_a_corrupt_checkpoint_attribute_is_refused(cli, tmp_path, checkpoint, name, value, says):
    with h5py.File(checkpoint, "r+") as f:
        if isinstance(value, str):
            f.attrs.create(name, np.bytes_(value))
        else:
            f.attrs[name] = value
    msg = cli_error(cli, "run", "navier-stokes-2d", "--fftw-wisdom", "none", "--restart", checkpoint, "--steps", 4,
                    "--checkpoint", tmp_path / "cc.h5")
    assert msg.startswith("cannot restart: ") and says in msg, msg
    assert not (tmp_path / "cc.h5").exists()


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


# CLI11's sentences for a value missing or given too often were passed on as they came ("--dt: At Most 1 required
# but received 2", "--psi: At least 3 required but received 2"); they are said plainly, one line, exit 2.
@pytest.mark.parametrize("args, expected", [
    (["three-wave", "--dt", "0.1", "--dt", "0.2"], "--dt is given more than once"),
    (["three-wave", "--dt"], "--dt needs a value"),
    (["three-wave", "--method"], "--method needs a value"),
    (["three-wave", "--steps"], "--steps needs a value"),
    (["three-wave", "--psi", "1,2"], "--psi needs 3 values (separated by commas or spaces), not 2"),
    (["three-wave", "--psi", "1,2,3,4"], "--psi takes 3 values, not 4"),
    # an empty item was dropped: "1,,2" read as two values, "1,2,3," ran with psi = (1, 2, 3)
    (["three-wave", "--psi", "1,,2"], "--psi has an empty value in '1,,2' (3 numbers separated by commas)"),
    (["three-wave", "--psi", "1,2,3,"], "--psi has an empty value in '1,2,3,' (3 numbers separated by commas)"),
    (["three-wave", "--psi", ",1,2,3"], "--psi has an empty value in ',1,2,3' (3 numbers separated by commas)"),
    (["three-wave", "--psi", "1,x,3"], "--psi: must be a decimal number, not 'x'"),
    (["three-wave", "--psi"], "--psi needs a value"),
    (["three-wave", "--M", "1,1"], "--M needs 3 values (separated by commas or spaces), not 2"),
    (["three-wave", "--update", "foo"], "--update must be conditioned or paper, not 'foo'"),
    (["navier-stokes-2d", "--N"], "--N needs a value"),
    (["navier-stokes-2d", "--ic", "random", "--ic", "taylor-green"], "--ic is given more than once"),
])
def test_option_counts_are_refused_in_plain_words(cli, args, expected):
    assert cli_error(cli, "run", *args) == expected


# Spaces around a number are dropped, as Python's float() drops them: "--psi '1, 0, 2'" is (1, 0, 2).
def test_spaces_around_numbers_are_taken(cli):
    spaced = run_cli(cli, "run", "three-wave", "--steps", 3, "--psi", "1, 0 ,2", "--dt", " 0.1", "--output", "-")
    plain = run_cli(cli, "run", "three-wave", "--steps", 3, "--psi", "1,0,2", "--dt", "0.1", "--output", "-")
    assert spaced.stdout == plain.stdout
    # a list as separate words too, as a shell splits an unquoted "1, 0" or "1 0"
    lists = [["--q", "1,0", "--p", "0,1"], ["--q", "1", "0", "--p", "0", "1"], ["--q", "1,", "0", "--p", "0", ",1"]]
    outs = {run_cli(cli, "run", "kepler-cartesian", "--steps", 3, *a, "--output", "-").stdout for a in lists}
    assert len(outs) == 1


def test_a_figure_number_out_of_range_is_refused_in_plain_words(cli):
    assert cli_error(cli, "figures", "--only", "10") == "--only must be in 1..9, not 10"


# Two outputs through one descriptor would interleave in one stream: "-", /dev/stdout and /dev/fd/1 are all standard
# output ("--output /dev/stdout --summary-json -" wrote the CSV and the JSON into one stream, exit 0).
@pytest.mark.parametrize("model", ["three-wave", "navier-stokes-2d"])
@pytest.mark.parametrize("output, summary", [("/dev/stdout", "-"), ("-", "/dev/fd/1"), ("/dev/stdout", "/dev/stdout"),
                                             ("/proc/self/fd/1", "/dev/stdout")])
def test_two_outputs_to_standard_output_are_refused(cli, model, output, summary):
    extra = ["--N", "16", "--fftw-estimate", "--fftw-wisdom", "none"] if model == "navier-stokes-2d" else []
    assert cli_error(cli, "run", model, "--steps", "2", "--output", output, "--summary-json", summary, *extra) == \
        "--output and --summary-json cannot both be standard output"


# A restarted run's summary says where it began (it said "t 0 to T" from any checkpoint).
def test_a_restarts_summary_names_its_start(cli, tmp_path, checkpoint):
    r = run_cli(cli, "run", "navier-stokes-2d", "--fftw-wisdom", "none", "--restart", checkpoint, "--steps", 5,
                "--checkpoint", tmp_path / "b.h5")
    assert ", dt 0.01, t 0.02 to 0.05\n" in r.stderr, r.stderr


# A snapshot directory under a regular file: the message says so (it said the directory did not exist).
def test_a_snapshot_directory_under_a_file_is_named_as_such(cli, tmp_path):
    (tmp_path / "regfile").write_text("x")
    msg = cli_error(cli, *small("--steps", 1, "--snapshot-every", 1, "--snapshot-dir", tmp_path / "regfile" / "x"))
    assert msg == f"cannot create snapshot directory '{tmp_path / 'regfile' / 'x'}': '{tmp_path / 'regfile'}' is " \
        "not a directory"
    assert (tmp_path / "regfile").read_text() == "x"


def csv_table(path):
    """The header and the rows (as floats) of a CSV the CLI wrote."""
    lines = Path(path).read_text().splitlines()
    return lines[0].split(","), np.array([[float(v) for v in line.split(",")] for line in lines[1:]])


def h5_names(data):
    return [c.decode() for c in data[:]]


# --output FILE.h5: the CSV's numbers as HDF5 datasets, bit for bit (the CSV's 17 digits read back exactly), with the
# columns' names; every kind of row: a state with derived columns, a relaxation method's time lag, complex modes,
# adaptive steps at --output-dt times, and a spectral run's diagnostics.
@pytest.mark.parametrize("args", [
    ["kepler", "--t-end", "3"],
    ["rigid-body", "--method", "rrk-rk4", "--t-end", "1"],
    ["n-wave-complex", "--modes", "40", "--steps", "30", "--every", "7"],
    ["three-wave", "--rtol", "1e-8", "--t-end", "2", "--output-dt", "0.25"],
    small("--steps", "12", "--nu", "0.01", "--forcing", "stochastic")[1:],
], ids=["derived", "time-lag", "complex", "adaptive", "spectral"])
def test_hdf5_output_holds_the_csv_rows(cli, tmp_path, args):
    run_cli(cli, "run", *args, "--output", tmp_path / "r.csv")
    run_cli(cli, "run", *args, "--output", tmp_path / "r.h5")
    header, rows = csv_table(tmp_path / "r.csv")
    with h5py.File(tmp_path / "r.h5", "r") as f:
        assert f.attrs["format"] == b"eci run series" and f.attrs["version"] == 1
        assert f.attrs["model"].decode() == args[0]
        t = f["t"][:]
        spectral = "diagnostics" in f
        assert np.array_equal(t, rows[:, header.index("t")])
        columns = {}
        for group in ("state", "derived", "invariants", "diagnostics"):
            if group in f:
                names = h5_names(f[group + "_columns"])
                assert f[group].shape == (len(t), len(names))
                columns.update({n: f[group][:, i] for i, n in enumerate(names)})
        if "time_lag" in f:
            columns["time_lag"] = f["time_lag"][:, 0]
        assert sorted(columns) == sorted(c for c in header if c != "t"), (sorted(columns), header)
        for name, values in columns.items():
            assert np.array_equal(values, rows[:, header.index(name)]), name
        assert spectral == (args[0] == "navier-stokes-2d")


def test_hdf5_output_to_a_stream_or_fifo_is_refused_and_nothing_is_written(cli, tmp_path):
    # a FIFO (without a reader: the message said "no reader", as if one would do) and a device through a symlink
    os.mkfifo(tmp_path / "pipe.h5")
    (tmp_path / "null.h5").symlink_to("/dev/null")
    for name in ("pipe.h5", "null.h5"):
        r = run_cli(cli, "run", "three-wave", "--output", tmp_path / name, "--summary-json", tmp_path / "s.json",
                    check=False)
        assert r.returncode == 2, r.stderr
        assert "HDF5 is written to a regular file, not to a stream, device or FIFO" in error_line(r.stderr)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["null.h5", "pipe.h5"]


def test_an_interrupted_run_keeps_a_whole_hdf5_file(cli, tmp_path):
    (tmp_path / "x.h5").write_text("precious\n")
    status, err = interrupted_run(cli, ["run", "three-wave", "--t-end", "1e12", "--every", "1000", "--output",
                                        "x.h5", "--summary-json", "x.json"], tmp_path)
    assert status == 130, err
    kept = re.search(r"; kept: HDF5 output 'x.h5' \(rows to t = ([^)]*)\), summary JSON 'x.json'$", error_line(err))
    assert kept, err
    with h5py.File(tmp_path / "x.h5", "r") as f:
        t = f["t"][:]
        assert len(t) > 1 and t[-1] == float(kept.group(1))
        assert f["state"].shape == (len(t), 3) and f["invariants"].shape == (len(t), 2)
        s = json.loads((tmp_path / "x.json").read_text())
        assert s["invariants"]["energy"]["final"] == f["invariants"][-1, 0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.h5", "x.json"]


# A directory of outputs in /proc or /sys is refused as such (mkdir's error there said no such file or directory,
# and "directory '/proc' does not exist").
@pytest.mark.parametrize("args", [["figures", "--out", "/proc/eci-figures"],
                                  small("--steps", "1", "--snapshot-every", "1", "--snapshot-dir", "/proc/eci-snaps"),
                                  small("--steps", "1", "--snapshot-every", "1", "--snapshot-dir", "/sys")],
                         ids=["figures", "new-snapshot-dir", "existing-dir"])
def test_an_output_directory_in_a_kernel_interface_is_refused_as_such(cli, args):
    r = run_cli(cli, *args, check=False)
    assert r.returncode == 2, r.stderr
    line = error_line(r.stderr)
    assert "a kernel interface, not a place for data files" in line, line


# A file size limit (ulimit -f) is a write error like a full disk: one line naming the file, exit 1, the old file kept
# and no temporary left (SIGXFSZ killed the process and left the temporaries).
@pytest.mark.parametrize("name", ["big.csv", "big.h5"])
def test_a_file_size_limit_is_a_write_error_that_leaves_nothing(cli, tmp_path, name):
    import resource
    (tmp_path / name).write_text("precious\n")

    def limit():
        resource.setrlimit(resource.RLIMIT_FSIZE, (100 * 1024, 100 * 1024))

    r = subprocess.run([str(cli), "run", "n-wave", "--modes", "1000", "--steps", "1000", "--output", name],
                       cwd=tmp_path, capture_output=True, text=True, timeout=120, preexec_fn=limit)
    assert r.returncode == 1, r.stderr
    line = error_line(r.stderr)
    assert f"'{name}'" in line and "File too large" in line and "no output was replaced" in line, line
    assert (tmp_path / name).read_text() == "precious\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == [name]


# A spectral run that cannot write its CSV (here a file size limit) fails naming the checkpoint it keeps, as a
# blow-up does: the run can go on from there (the message said only that no output was replaced).
def test_a_write_failure_names_the_checkpoint_kept(cli, tmp_path):
    import resource

    def limit():
        resource.setrlimit(resource.RLIMIT_FSIZE, (40 * 1024, 40 * 1024))

    r = subprocess.run([str(cli), *map(str, small("--steps", 400, "--output", "uf.csv", "--checkpoint",
                                                  "uf_ck.h5", "--checkpoint-every", 50))],
                       cwd=tmp_path, capture_output=True, text=True, timeout=120, preexec_fn=limit, env=NO_PICTURES)
    assert r.returncode == 1, r.stderr
    line = error_line(r.stderr)
    assert "'uf.csv'" in line and "File too large" in line, line
    with h5py.File(tmp_path / "uf_ck.h5", "r") as f:
        step = int(f.attrs["step"])
    assert line.endswith("; last good checkpoint: uf_ck.h5 (step %d)" % step), line
    assert not (tmp_path / "uf.csv").exists()


# --ic FILE without --N takes the file's grid (it said "holds a 32^2 grid, not N = 256": the default N); another
# --N is still refused.
def test_an_ic_file_gives_the_grid_when_n_is_not_given(cli, tmp_path):
    run_cli(cli, *small("--steps", 2, "--checkpoint-every", 2, "--checkpoint", tmp_path / "c.h5", "--snapshot-every",
                        2, "--snapshot-dir", tmp_path / "sd"))
    for ic in [tmp_path / "c.h5", tmp_path / "sd" / "vorticity_00000002.h5"]:
        out = tmp_path / "out.h5"
        out.unlink(missing_ok=True)
        run_cli(cli, "run", "surface-qg", "--ic", ic, "--steps", 1, "--fftw-estimate", "--fftw-wisdom", "none",
                "--checkpoint-every", 1, "--checkpoint", out)
        with h5py.File(out, "r") as f:
            assert int(f.attrs["N"]) == 16
        msg = cli_error(cli, "run", "navier-stokes-2d", "--ic", ic, "--N", "32", "--steps", 1, "--fftw-wisdom", "none")
        assert msg == f"--ic '{ic}': it holds a 16^2 grid, not N = 32", msg
    msg = cli_error(cli, "run", "navier-stokes-2d", "--ic", tmp_path / "missing.h5", "--steps", 1)
    assert msg == f"--ic '{tmp_path / 'missing.h5'}': no such file", msg


# A finite value damaged or edited in a checkpoint's state is refused by its checksum (it restarted silently from the
# changed field), for --restart and --ic alike; a checkpoint of an earlier version, without one, restarts unchecked.
def test_a_checkpoint_whose_state_was_changed_is_refused(cli, tmp_path, checkpoint):
    run_cli(cli, "run", "navier-stokes-2d", "--fftw-wisdom", "none", "--restart", checkpoint, "--steps", 4,
            "--checkpoint", tmp_path / "ok.h5", "--checkpoint-every", 4)  # (unchanged: taken)
    with h5py.File(checkpoint, "r+") as f:
        assert "state_checksum" in f.attrs
        f["omega_hat"][3, 4] = f["omega_hat"][3, 4] * (1 + 2 ** -52) + 1e-300
    msg = cli_error(cli, "run", "navier-stokes-2d", "--fftw-wisdom", "none", "--restart", checkpoint, "--steps", 4,
                    "--checkpoint", tmp_path / "cc.h5")
    assert msg == f"cannot restart: {checkpoint}: omega_hat does not match its checksum (a damaged or edited file)", msg
    msg = cli_error(cli, *small("--ic", checkpoint, "--steps", 1))
    assert msg == f"--ic '{checkpoint}': omega_hat does not match its checksum (a damaged or edited file)", msg
    assert not (tmp_path / "cc.h5").exists()
    with h5py.File(checkpoint, "r+") as f:
        del f.attrs["state_checksum"]
    run_cli(cli, "run", "navier-stokes-2d", "--fftw-wisdom", "none", "--restart", checkpoint, "--steps", 4,
            "--checkpoint", tmp_path / "cc.h5", "--checkpoint-every", 4)


# Three-wave's K, P and Q are magnitudes of wavenumbers; the equations hold only their squares, so a negative one ran
# as its absolute value, exit 0.
@pytest.mark.parametrize("flag", ["--K", "--P", "--Q"])
def test_a_negative_wavenumber_magnitude_is_refused(cli, flag):
    assert cli_error(cli, "run", "three-wave", flag, "-1") == (
        f"invalid three-wave model: three-wave {flag[2:]} is a wavenumber's magnitude and must not be negative, "
        "got -1")


def h5_step(path):
    with h5py.File(path, "r") as f:
        return int(f.attrs["step"])


# A checkpoint asked for is also written at the run's end: a restart without --checkpoint-every left its file at the
# step it restarted from, so the next --restart took those steps again (and a crash lost them).
def test_a_restart_continues_its_checkpoint_to_its_end(cli, tmp_path):
    run_cli(cli, *small("--steps", 4, "--checkpoint", tmp_path / "c.h5"))
    assert h5_step(tmp_path / "c.h5") == 4
    run_cli(cli, "run", "navier-stokes-2d", "--fftw-wisdom", "none", "--restart", tmp_path / "c.h5", "--steps", 7)
    assert h5_step(tmp_path / "c.h5") == 7


# --checkpoint-every without --checkpoint writes the default name: where that file exists (another run's, in the same
# directory) the run is refused before any work, the file as it was.
def test_checkpoint_every_does_not_replace_another_runs_default_checkpoint(cli, tmp_path):
    def run(*args):
        return subprocess.run([str(cli), *map(str, small(*args))], cwd=tmp_path, capture_output=True, text=True,
                              timeout=120, env=NO_PICTURES)
    assert run("--steps", 4, "--checkpoint-every", 2).returncode == 0
    before = (tmp_path / "ns2d-checkpoint.h5").read_bytes()
    r = run("--steps", 2, "--checkpoint-every", 1, "--nu", "0.1")
    assert r.returncode == 2, r.stderr
    assert error_line(r.stderr) == ("eci: error: --checkpoint-every would replace 'ns2d-checkpoint.h5', another run's "
                                    "checkpoint: --checkpoint FILE names this run's (that file, to replace it)")
    assert (tmp_path / "ns2d-checkpoint.h5").read_bytes() == before
    # named, it is replaced
    assert run("--steps", 2, "--checkpoint-every", 1, "--checkpoint", "ns2d-checkpoint.h5").returncode == 0
    assert h5_step(tmp_path / "ns2d-checkpoint.h5") == 2


# The same steps' snapshots of another grid are another run's: refused, not replaced.
def test_a_snapshot_directory_of_another_grid_is_refused(cli, tmp_path):
    sd = tmp_path / "sd"
    run_cli(cli, *small("--steps", 2, "--snapshot-every", 1, "--snapshot-dir", sd))
    before = {p.name: p.read_bytes() for p in sd.iterdir()}
    msg = cli_error(cli, "run", "navier-stokes-2d", "--N", "32", "--fftw-estimate", "--fftw-wisdom", "none", "--dt",
                    "0.01", "--steps", 2, "--snapshot-every", 1, "--snapshot-dir", sd)
    assert msg == (f"--snapshot-dir '{sd}' holds another run's snapshots ('vorticity_00000000.h5' is of N = 16, this "
                   "run's N = 32): give another directory or remove them"), msg
    assert {p.name: p.read_bytes() for p in sd.iterdir()} == before
    run_cli(cli, *small("--steps", 2, "--snapshot-every", 1, "--snapshot-dir", sd))  # the same run replaces its own


# Initial fields and forcings that cannot be what was asked: refused with their reason, not run.
@pytest.mark.parametrize("args, message", [
    (["--ic", "vortex-pair", "--vortex-radius", "0.1"],
     "initial condition: vortex radius 0.1 is below half the grid spacing (pi / N = 0.196 at N = 16): the vortices "
     "would fall between the grid points"),
    (["--k-peak", "6"], "--k-peak 6 is beyond the retained modes (|k_x|, |k_y| <= kmax = 5 at N = 16)"),
    (["--k-peak", "inf"], "initial condition: peak wavenumber must be a positive finite number"),
    (["--forcing", "stochastic", "--forcing-k", "2", "--injection-rate", "1e308"],
     "navier-stokes-2d: the forcing overflows (injection rate too large for N = 16)"),
    (["--forcing", "deterministic", "--forcing-k", "2", "--forcing-amplitude", "1e200"],
     "navier-stokes-2d: the forcing overflows (forcing amplitude too large for N = 16)"),
])
def test_fields_and_forcings_that_cannot_be_made_are_refused(cli, tmp_path, args, message):
    assert cli_error(cli, *small("--steps", 1, *args)) == message


# A field file's mean and its modes beyond the retained ones are not evolved: the run takes the dealiased, zero-mean
# projection and says how much of the field that dropped (it did so silently). An eci snapshot drops nothing.
def test_a_field_file_with_a_mean_or_modes_beyond_kmax_is_run_with_a_warning(cli, tmp_path):
    x = 2 * np.pi * np.arange(32) / 32
    X, Y = np.meshgrid(x, x)  # rows are y
    field = np.sin(X) * np.cos(Y) + 0.5 + 0.1 * np.cos(15 * X)  # mean 0.5; k = 15 beyond kmax = 10
    ic = tmp_path / "mine.h5"
    with h5py.File(ic, "w") as f:
        f["vorticity"] = field
    r = run_cli(cli, "run", "navier-stokes-2d", "--N", "32", "--fftw-estimate", "--fftw-wisdom", "none", "--dt",
                "0.01", "--steps", 2, "--ic", ic, "--snapshot-every", 2, "--snapshot-dir", tmp_path / "sd")
    # mean squares: sin x cos y 1/4, the mean 1/4, the stripe 0.005: (0.25 + 0.005) / 0.505 dropped
    warnings = [line for line in r.stderr.splitlines() if line.startswith("eci: warning: --ic")]
    assert warnings == [f"eci: warning: --ic '{ic}': {100 * 0.255 / 0.505:.3g} % of the field's mean square is in its "
                        "mean and its modes beyond |k_x|, |k_y| <= kmax = 10, which the run drops (it evolves the "
                        "dealiased, zero-mean field)"], r.stderr
    # the run's own snapshot, taken up again: nothing dropped, nothing said
    r = run_cli(cli, "run", "navier-stokes-2d", "--N", "32", "--fftw-estimate", "--fftw-wisdom", "none", "--dt",
                "0.01", "--steps", 2, "--ic", tmp_path / "sd" / "vorticity_00000002.h5")
    assert "warning" not in r.stderr, r.stderr


# ---- --ic FILE: a user's own field

def write_field(path, data, name="vorticity", **attrs):
    """An HDF5 file as a user writes one with h5py: the field, and attributes as h5py stores them (a str is a
    variable-length string)."""
    with h5py.File(path, "w") as f:
        f[name] = data
        for key, value in attrs.items():
            f.attrs[key] = value
    return path


def a_field(n=16):
    x = 2 * np.pi * np.arange(n) / n
    X, Y = np.meshgrid(x, x)  # rows are y
    return np.sin(X) * np.cos(2 * Y) + 0.5 * np.cos(3 * X + Y)


def final_state(cli, tmp_path, equation, ic, name):
    run_cli(cli, "run", equation, "--ic", ic, "--steps", 2, "--dt", "0.01", "--fftw-estimate", "--fftw-wisdom",
            "none", "--checkpoint", tmp_path / name)
    with h5py.File(tmp_path / name, "r") as f:
        return next(f[k][()] for k in f if k.endswith("_hat"))


# A user's field file: its string attributes may be variable-length (h5py's default for `f.attrs["x"] = "text"`;
# they were refused, "attribute 'field' is not a fixed-length string"), and its dataset may be the equation's own
# field (surface-qg's buoyancy, charney-hasegawa-mima's potential_vorticity; "dataset 'vorticity' missing" before).
# Each runs as the same field stored as 'vorticity' without attributes (still taken) runs, bit for bit.
@pytest.mark.parametrize("equation, own", [("navier-stokes-2d", "vorticity"), ("surface-qg", "buoyancy"),
                                           ("charney-hasegawa-mima", "potential_vorticity")])
def test_an_ic_file_of_the_equations_own_field_and_h5py_strings_is_taken(cli, tmp_path, equation, own):
    field = a_field()
    plain = final_state(cli, tmp_path, equation, write_field(tmp_path / "plain.h5", field), "plain-ck.h5")
    for name, ic in [
        ("own", write_field(tmp_path / "own.h5", field, own)),
        ("named", write_field(tmp_path / "named.h5", field, own, field=own, format="my field", note="text")),
        ("format", write_field(tmp_path / "format.h5", field, format="a field of mine")),
    ]:
        with h5py.File(ic, "r") as f:  # (h5py's strings are variable-length)
            assert all(h5py.check_string_dtype(f.attrs.get_id(k).dtype).length is None for k in f.attrs)
        assert np.array_equal(final_state(cli, tmp_path, equation, ic, name + "-ck.h5"), plain), name


# Every problem of an --ic file is said as `--ic 'FILE': ...` (some named neither: a 33 x 33 field said "grid size N
# must be even", a zero field "the initial velocity is zero").
@pytest.mark.parametrize("equation, make, says", [
    ("navier-stokes-2d", lambda p: write_field(p, a_field(33)),
     "its 33^2 grid is not one navier-stokes-2d runs on: grid size N must be even and at least 8, not 33"),
    ("navier-stokes-2d", lambda p: write_field(p, np.zeros((16, 18))), "vorticity is 16x18, not a square grid"),
    ("navier-stokes-2d", lambda p: write_field(p, np.zeros((16, 16))), "the initial velocity is zero: give --dt"),
    ("navier-stokes-2d", lambda p: write_field(p, a_field().astype(complex)),
     "dataset 'vorticity' does not hold real numbers"),
    ("surface-qg", lambda p: write_field(p, a_field(), "theta"), "dataset 'buoyancy' (or 'vorticity') missing"),
    ("navier-stokes-2d", lambda p: write_field(p, a_field(), "omega"), "dataset 'vorticity' missing"),
    ("navier-stokes-2d", lambda p: write_field(p, a_field(), field="omega"),
     "dataset 'omega' (named by its attribute 'field') missing"),
    ("navier-stokes-2d", lambda p: write_field(p, a_field(), field=3), "attribute 'field' is not a string"),
    ("navier-stokes-2d", lambda p: (p.write_text("not HDF5\n"), p)[1], "it is not an HDF5 file"),
    ("navier-stokes-2d", lambda p: p, "no such file"),
])
def test_every_problem_of_an_ic_file_names_the_option_and_the_file(cli, tmp_path, equation, make, says):
    ic = make(tmp_path / "ic.h5")
    msg = cli_error(cli, "run", equation, "--ic", ic, "--steps", 1, "--fftw-estimate", "--fftw-wisdom", "none",
                    "--output", tmp_path / "o.csv")
    assert msg == f"--ic '{ic}': {says}", msg
    assert not (tmp_path / "o.csv").exists()


# A restart's forcing and powers are its checkpoint's: a setting its run has no use for is refused as a fresh run
# refuses it (before, --forcing-amplitude on a stochastic checkpoint was compared with its unused default 1 and
# taken, another value "did not match"); the settings its run uses are compared as before.
def test_a_restart_refuses_a_setting_its_checkpoints_run_has_no_use_for(cli, tmp_path):
    ck = tmp_path / "ck.h5"
    run_cli(cli, *small("--steps", 2, "--forcing", "stochastic", "--injection-rate", "0.5", "--checkpoint", ck))
    restart = ["run", "navier-stokes-2d", "--fftw-wisdom", "none", "--restart", ck, "--steps", 3, "--checkpoint",
               tmp_path / "next.h5"]
    for setting in [["--forcing-amplitude", "1"], ["--forcing-amplitude", "2"]]:
        assert cli_error(cli, *restart, *setting) == (
            "--forcing-amplitude sets the deterministic forcing, and this run's --forcing is stochastic: the restart "
            f"file's ('{ck}'), which a restart cannot change")
    assert cli_error(cli, *restart, "--forcing", "deterministic") == (
        f"--forcing deterministic does not match the restart file's stochastic ({ck}; a restart continues its "
        "checkpoint's forcing)")
    assert cli_error(cli, *restart, "--injection-rate", "1") == (
        f"--injection-rate 1 does not match the restart file's 0.5 ({ck})")
    assert not (tmp_path / "next.h5").exists()
    run_cli(cli, *restart, "--injection-rate", "0.5", "--forcing-k", "4", "--forcing", "stochastic")
    assert h5_step(tmp_path / "next.h5") == 3
