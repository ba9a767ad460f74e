#!/usr/bin/env python3
"""`mpirun -np P eci run navier-stokes-2d ...` against the same run of the tool on one process.

usage: cli_mpi_test.py ECI MPIEXEC CASE
       (CASE: state, restart, snapshot, bad-input, signal, abort, rank-failure, memory, files, write-failure,
       idle-rank)

Each case runs in a fresh temporary directory and exits 0 when every check holds; each check prints one line.

The bounds: the distributed transforms and the rank-ordered sums round differently from the serial ones, by a few eps
per operation and step; over s steps those differences add like a random walk, k eps sqrt(s) of the largest mode (k
counting the operations whose round-off enters a step; measured below 1 on 1-3 ranks, bound 16). The runs are short in
time (dt = 0.002) so the flow does not amplify the differences. E and Z of C-RK4 (inviscid) change by a few eps per
step, as a random walk: 8 eps sqrt(s).
"""
import contextlib
import csv
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time

import h5py
import numpy as np

ECI, MPIEXEC, CASE = sys.argv[1], sys.argv[2], sys.argv[3]
EPS = np.finfo(float).eps
ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
           OMPI_MCA_rmaps_base_oversubscribe="1")
# The conservative methods take their default update (the conditioned one) on any number of processes.
BASE = ["--N", "32", "--dt", "0.002", "--fftw-estimate", "--fftw-wisdom", "none"]
failures = 0


def check(ok, what):
    global failures
    print(("ok   " if ok else "FAIL ") + what, flush=True)
    if not ok:
        failures += 1


def run(np_, args, cwd, equation="navier-stokes-2d"):
    """np_ = 0: the tool on one process without mpirun."""
    cmd = [ECI, "run", equation] + args
    if np_:
        cmd = [MPIEXEC, "--oversubscribe", "-np", str(np_)] + cmd
    return subprocess.run(cmd, cwd=cwd, env=ENV, capture_output=True, text=True, timeout=240)


def state(path):
    with h5py.File(path, "r") as f:
        name = [k for k in f.keys() if k.endswith("_hat")][0]  # omega_hat, q_hat, theta_hat: the equation's symbol
        return np.array(f[name]), dict(f.attrs)


def rel(a, b):
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


def last_row(path):
    with open(path) as f:
        rows = list(csv.DictReader(f))
    return rows[0], rows[-1]


def case_state(d):
    steps = 100
    bound = 16 * EPS * np.sqrt(steps)
    for method in ("c-rk4", "rk4"):
        args = BASE + ["--method", method, "--steps", str(steps), "--checkpoint-every", str(steps)]
        r = run(0, args + ["--checkpoint", "s.h5", "--output", "s.csv"], d)
        check(r.returncode == 0, f"{method}: serial run (exit {r.returncode})")
        ref, _ = state(os.path.join(d, "s.h5"))
        for np_ in (1, 2, 3):
            r = run(np_, args + ["--checkpoint", f"p{np_}.h5", "--output", f"p{np_}.csv"], d)
            check(r.returncode == 0, f"{method} -np {np_}: exit {r.returncode} {r.stderr.strip()[-200:]}")
            if r.returncode:
                continue
            w, attrs = state(os.path.join(d, f"p{np_}.h5"))
            diff = rel(w, ref)
            check(w.shape == ref.shape and diff <= bound,
                  f"{method} -np {np_}: state after {steps} steps = serial to {diff:.3g} <= 16 eps sqrt(steps) = {bound:.3g}")
            first, last = last_row(os.path.join(d, f"p{np_}.csv"))
            if method == "c-rk4":
                de = abs(float(last["energy"]) - float(first["energy"])) / float(first["energy"])
                dz = abs(float(last["enstrophy"]) - float(first["enstrophy"])) / float(first["enstrophy"])
                b = 8 * EPS * np.sqrt(steps)
                check(de <= b and dz <= b, f"c-rk4 -np {np_}: E, Z drift {de:.3g}, {dz:.3g} <= 8 eps sqrt(steps) = {b:.3g}")
            check(r.stderr.count("eci: ") <= 1 and "energy" in r.stderr,
                  f"{method} -np {np_}: one summary (rank 0's) on stderr")
    # without --update, more than one process takes the conditioned update (the default, as on one process), and
    # --update paper the paper's: each on 2 processes = the serial tool's to round-off
    plain = BASE + ["--method", "c-rk4", "--steps", "20", "--checkpoint-every", "20"]
    run(2, plain + ["--checkpoint", "u0.h5"], d)
    run(2, plain + ["--update", "conditioned", "--checkpoint", "u1.h5"], d)
    check(np.array_equal(state(os.path.join(d, "u0.h5"))[0], state(os.path.join(d, "u1.h5"))[0]),
          "-np 2 without --update: the conditioned update, bit for bit")
    run(0, plain + ["--update", "paper", "--checkpoint", "u2.h5"], d)
    run(2, plain + ["--update", "paper", "--checkpoint", "u3.h5"], d)
    diff = rel(state(os.path.join(d, "u3.h5"))[0], state(os.path.join(d, "u2.h5"))[0])
    check(diff <= 16 * EPS * np.sqrt(20), f"-np 2 --update paper = the serial tool's to {diff:.3g}")
    # FFTW's and OpenMP's threads inside each process (hybrid MPI + threads): the same state as the serial run
    args = BASE + ["--method", "c-rk4", "--steps", "50", "--checkpoint-every", "50"]
    run(0, args + ["--checkpoint", "t0.h5"], d)
    r = run(2, args + ["--threads", "2", "--checkpoint", "t2.h5"], d)
    check(r.returncode == 0, f"-np 2 --threads 2: exit {r.returncode} {r.stderr.strip()[-200:]}")
    if r.returncode == 0:
        diff = rel(state(os.path.join(d, "t2.h5"))[0], state(os.path.join(d, "t0.h5"))[0])
        check(diff <= 16 * EPS * np.sqrt(50), f"-np 2 --threads 2: state = serial to {diff:.3g}")
    # --output-dt without --dt: the CFL step (max|u| over every process) shortened to divide it, the same on 1 and 2
    # processes, so the same rows at the same steps and times
    timed = [a for a in BASE if a not in ("--dt", "0.002")] + ["--method", "c-rk4", "--t-end", "0.3",
                                                                 "--output-dt", "0.1"]
    rows = []
    for np_ in (0, 2):
        r = run(np_, timed + ["--output", f"od{np_}.csv"], d)
        check(r.returncode == 0, f"--output-dt -np {np_}: exit {r.returncode} {r.stderr.strip()[-200:]}")
        if r.returncode == 0:
            with open(os.path.join(d, f"od{np_}.csv")) as f:
                rows.append([(row["step"], row["t"]) for row in csv.DictReader(f)])
        else:
            rows.append(None)
    check(rows[0] is not None and rows[0] == rows[1] and len(rows[0]) == 4,
          f"--output-dt 0.1 to t = 0.3: the same 4 rows' steps and times on 1 and 2 processes ({rows})")
    # the other equations run distributed from the same code
    for eq, extra in (("charney-hasegawa-mima", ["--beta", "2", "--deformation", "1"]), ("surface-qg", [])):
        args = BASE + extra + ["--steps", "50", "--checkpoint-every", "50"]
        run(0, args + ["--checkpoint", "es.h5"], d, eq)
        r = run(3, args + ["--checkpoint", "ep.h5"], d, eq)
        check(r.returncode == 0, f"{eq} -np 3: exit {r.returncode}")
        if r.returncode == 0:
            diff = rel(state(os.path.join(d, "ep.h5"))[0], state(os.path.join(d, "es.h5"))[0])
            check(diff <= 16 * EPS * np.sqrt(50), f"{eq} -np 3: state = serial to {diff:.3g}")


def case_restart(d):
    # viscous, stochastically forced: the restart carries the generator, drawn per global mode
    args = BASE + ["--nu", "1e-3", "--forcing", "stochastic", "--forcing-k", "3"]
    r = run(0, args + ["--steps", "100", "--checkpoint-every", "100", "--checkpoint", "whole.h5"], d)
    check(r.returncode == 0, "uninterrupted serial run of 100 steps")
    ref, _ = state(os.path.join(d, "whole.h5"))
    r = run(2, args + ["--steps", "50", "--checkpoint-every", "50", "--checkpoint", "half.h5"], d)
    check(r.returncode == 0, f"-np 2: 50 steps, checkpoint (exit {r.returncode})")
    bound = 16 * EPS * np.sqrt(100)
    for np_ in (0, 1, 3):
        # (a checkpoint does not record --update: the default, the conditioned update, is taken again)
        r = run(np_, ["--restart", "half.h5", "--steps", "100", "--checkpoint-every", "100",
                      "--checkpoint", f"r{np_}.h5", "--fftw-wisdom", "none"], d)
        who = "serial tool" if np_ == 0 else f"-np {np_}"
        check(r.returncode == 0, f"restart of the 2-rank checkpoint on {who}: exit {r.returncode} {r.stderr.strip()[-200:]}")
        if r.returncode == 0:
            w, attrs = state(os.path.join(d, f"r{np_}.h5"))
            diff = rel(w, ref)
            check(int(attrs["step"]) == 100 and diff <= bound,
                  f"restart on {who}: step 100 = the uninterrupted run to {diff:.3g} <= {bound:.3g}")
    # and the other way: a checkpoint written by 3 processes (each its own columns) read by 2 (each its own)
    r = run(3, args + ["--steps", "50", "--checkpoint-every", "50", "--checkpoint", "third.h5"], d)
    check(r.returncode == 0, f"-np 3: 50 steps, checkpoint (exit {r.returncode})")
    r = run(2, ["--restart", "third.h5", "--steps", "100", "--checkpoint-every", "100", "--checkpoint", "r32.h5",
                "--fftw-wisdom", "none"], d)
    check(r.returncode == 0, f"restart of the 3-rank checkpoint on -np 2: exit {r.returncode} {r.stderr.strip()[-200:]}")
    if r.returncode == 0:
        diff = rel(state(os.path.join(d, "r32.h5"))[0], ref)
        check(diff <= bound, f"restart 3 -> 2 ranks: step 100 = the uninterrupted run to {diff:.3g} <= {bound:.3g}")
    # a checkpoint as --ic, read by columns on 3 processes: the same state as the serial tool reads
    for np_, name in ((0, "ic0.h5"), (3, "ic3.h5")):
        run(np_, BASE + ["--ic", "half.h5", "--steps", "10", "--checkpoint-every", "10", "--checkpoint", name], d)
    a, b = state(os.path.join(d, "ic0.h5"))[0], state(os.path.join(d, "ic3.h5"))[0]
    diff = rel(b, a)
    check(diff <= 16 * EPS * np.sqrt(10), f"--ic CHECKPOINT on -np 3 = on the serial tool to {diff:.3g}")


def case_snapshot(d):
    args = BASE + ["--steps", "20", "--snapshot-every", "20"]
    r0 = run(0, args + ["--snapshot-dir", "s"], d)
    r2 = run(2, args + ["--snapshot-dir", "p"], d)
    check(r0.returncode == 0 and r2.returncode == 0, "serial and -np 2 runs with snapshots")
    names_s, names_p = sorted(os.listdir(os.path.join(d, "s"))), sorted(os.listdir(os.path.join(d, "p")))
    check(names_s == names_p and any(n.endswith(".h5") for n in names_s), f"the same snapshot files: {names_p}")
    for n in names_s:
        if n.endswith(".h5"):
            with h5py.File(os.path.join(d, "s", n)) as a, h5py.File(os.path.join(d, "p", n)) as b:
                check(sorted(a.keys()) == sorted(b.keys()) and sorted(a.attrs) == sorted(b.attrs),
                      f"{n}: the serial layout (datasets {sorted(b.keys())})")
                for k in a.keys():
                    x, y = np.array(a[k]), np.array(b[k])
                    diff = float(np.max(np.abs(x - y)) / max(np.max(np.abs(x)), 1e-300))
                    check(x.shape == y.shape and diff <= 16 * EPS * np.sqrt(20), f"{n}/{k}: = serial to {diff:.3g}")
        elif n.endswith(".csv"):
            x = np.loadtxt(os.path.join(d, "s", n), delimiter=",", skiprows=1)
            y = np.loadtxt(os.path.join(d, "p", n), delimiter=",", skiprows=1)
            diff = float(np.max(np.abs(x - y)) / np.max(np.abs(x)))
            check(x.shape == y.shape and diff <= 16 * EPS * np.sqrt(20), f"{n}: spectra and fluxes = serial to {diff:.3g}")
    # The files of the processes' rows have the serial file's layout byte for byte (h5py: every attribute's value,
    # every dataset's type, shape and place in the file, the coordinates' bytes); the field's values differ only by
    # the distributed transforms' round-off (above).
    for n in names_s:
        if not n.endswith(".h5"):
            continue
        with h5py.File(os.path.join(d, "s", n)) as a, h5py.File(os.path.join(d, "p", n)) as b:
            same = all(np.array_equal(a.attrs[k], b.attrs[k]) for k in a.attrs)
            check(same, f"{n}: every attribute as the serial file's")
            for k in a.keys():
                x, y = a[k], b[k]
                check((x.dtype, x.shape, x.chunks, x.id.get_offset(), x.id.get_storage_size()) ==
                      (y.dtype, y.shape, y.chunks, y.id.get_offset(), y.id.get_storage_size()),
                      f"{n}/{k}: {y.dtype} {y.shape} at byte {y.id.get_offset()}, as in the serial file")
            check(np.array_equal(a["x"][()], b["x"][()]) and np.array_equal(a["y"][()], b["y"][()]),
                  f"{n}: x and y bit for bit")
        check(os.path.getsize(os.path.join(d, "s", n)) == os.path.getsize(os.path.join(d, "p", n)),
              f"{n}: the serial file's size")
    # the same run on 3 processes: every row of the field written once (an uneven split, 11 + 11 + 10 rows)
    r3 = run(3, args + ["--snapshot-dir", "q"], d)
    check(r3.returncode == 0, f"-np 3 run with snapshots (exit {r3.returncode})")
    for n in names_s:
        if n.endswith(".h5") and r3.returncode == 0:
            with h5py.File(os.path.join(d, "s", n)) as a, h5py.File(os.path.join(d, "q", n)) as b:
                k = a.attrs["field"]
                k = k.decode() if isinstance(k, bytes) else str(k)
                x, y = np.array(a[k]), np.array(b[k])
                diff = float(np.max(np.abs(x - y)) / np.max(np.abs(x)))
                check(diff <= 16 * EPS * np.sqrt(20), f"-np 3 {n}/{k}: = serial to {diff:.3g}")
    # a snapshot of the MPI run is an initial condition for the serial tool, and for 3 processes reading their rows
    snap = [n for n in names_p if n.endswith(".h5")][-1]
    r = run(0, BASE + ["--steps", "2", "--ic", os.path.join("p", snap), "--checkpoint-every", "2",
                       "--checkpoint", "ic0.h5"], d)
    check(r.returncode == 0, f"the serial tool starts from the MPI run's snapshot {snap} (--ic)")
    r = run(3, BASE + ["--steps", "2", "--ic", os.path.join("p", snap), "--checkpoint-every", "2",
                       "--checkpoint", "ic3.h5"], d)
    check(r.returncode == 0, f"-np 3 starts from the snapshot {snap}, each process reading its rows (--ic)")
    if r.returncode == 0:
        diff = rel(state(os.path.join(d, "ic3.h5"))[0], state(os.path.join(d, "ic0.h5"))[0])
        check(diff <= 16 * EPS * np.sqrt(2), f"--ic SNAPSHOT on -np 3 = on the serial tool to {diff:.3g}")
    check("--ic" not in r.stderr, "an eci snapshot as --ic drops nothing: no warning on -np 3")
    # a field with a mean: the share the projection drops, summed over the processes' rows, said once, as serially
    with h5py.File(os.path.join(d, "p", snap), "r") as f:
        k = f.attrs["field"]
        k = k.decode() if isinstance(k, bytes) else str(k)
        field = np.array(f[k])
    with h5py.File(os.path.join(d, "mean.h5"), "w") as f:
        f["vorticity"] = field + np.sqrt(np.mean(field * field))  # the mean holds half the mean square
    said = []
    for np_ in (0, 3):
        r = run(np_, BASE + ["--steps", "1", "--ic", "mean.h5"], d)
        said.append([line for line in r.stderr.splitlines() if line.startswith("eci: warning: --ic")])
    check(len(said[0]) == 1 and said[0][0].startswith("eci: warning: --ic 'mean.h5': 50 % of the field's mean square"),
          f"a field with a mean as --ic: warned serially ({said[0]})")
    check(said[1] == said[0], f"-np 3 warns once, as the serial tool ({said[1]})")


def case_bad_input(d):
    for np_, args, what in ((2, ["--N", "7", "--steps", "5"], "--N 7"),
                            (3, ["--N", "32", "--steps", "5", "--ic", "missing.h5"], "--ic missing.h5"),
                            (2, ["--N", "32", "--restart", "missing.h5"], "--restart missing.h5"),
                            (3, ["--N", "32", "--steps", "5", "--dt", "-1"], "--dt -1"),
                            (2, ["--N", "32", "--steps", "5", "--update", "exact"], "--update exact"),
                            (3, ["--N", "32", "--steps", "5", "--plot", "p.gif"], "--plot p.gif")):
        sub = tempfile.mkdtemp(dir=d)
        start = time.monotonic()
        r = run(np_, args + ["--output", "o.csv", "--summary-json", "o.json", "--checkpoint-every", "1",
                             "--checkpoint", "c.h5"], sub)
        lines = [l for l in r.stderr.splitlines() if l.strip()]
        # mpirun adds its own report of a non-zero exit after the tool's line: the tool's lines are those of eci
        own = [l for l in lines if l.startswith("eci")]
        check(r.returncode == 2 or ("exit code: 2" in r.stderr.lower()),
              f"-np {np_} {what}: exit 2 (mpirun {r.returncode}) in {time.monotonic() - start:.1f} s")
        check(len(own) == 1, f"-np {np_} {what}: one line from rank 0: {own}")
        check(os.listdir(sub) == [], f"-np {np_} {what}: nothing written ({os.listdir(sub)})")
    # an output rank 0 cannot open (a directory that does not exist): exit 2 on every process with one line, as on
    # one process (it was MPI_Abort: exit 1 and mpirun's banner); the other outputs are not created
    for np_, option in ((2, "--output"), (3, "--summary-json")):
        sub = tempfile.mkdtemp(dir=d)
        r = run(np_, BASE + ["--steps", "2", option, "nodir/x.out", "--checkpoint", "c.h5",
                             "--checkpoint-every", "1"], sub)
        own = [l for l in r.stderr.splitlines() if l.startswith("eci")]
        check(r.returncode == 2 or ("exit code: 2" in r.stderr.lower()),
              f"-np {np_} {option} nodir/x.out: exit 2 (mpirun {r.returncode}): {r.stderr[-300:]}")
        check("MPI_ABORT" not in r.stderr, f"-np {np_} {option} nodir/x.out: no MPI_Abort")
        check(len(own) == 1 and "nodir/x.out" in own[0], f"-np {np_} {option} nodir/x.out: one line: {own}")
        check(os.listdir(sub) == [], f"-np {np_} {option} nodir/x.out: nothing written ({os.listdir(sub)})")
    # what the tool prints on standard output without running (--version, --help, eci list) is printed once, as
    # serially (every process printed it before)
    for cmd in (["--version"], ["list"], ["run", "navier-stokes-2d", "--help"]):
        serial = subprocess.run([ECI] + cmd, env=ENV, capture_output=True, text=True, timeout=60)
        spread = subprocess.run([MPIEXEC, "--oversubscribe", "-np", "3", ECI] + cmd, env=ENV, capture_output=True,
                                text=True, timeout=60)
        check(spread.returncode == 0 and spread.stdout == serial.stdout and serial.stdout,
              f"-np 3 eci {' '.join(cmd)}: the serial tool's output, once ({spread.stdout.count(serial.stdout[:20])} "
              f"times)")
    # --fftw-wisdom FILE, which the serial run writes, is not used by a spread run: one warning, no file
    sub = tempfile.mkdtemp(dir=d)
    r = run(2, ["--N", "32", "--steps", "1", "--fftw-estimate", "--fftw-wisdom", "w.wis"], sub)
    own = [l for l in r.stderr.splitlines() if l.startswith("eci: warning")]
    check(r.returncode == 0 and len(own) == 1 and "'w.wis' is not used" in own[0] and os.listdir(sub) == [],
          f"-np 2 --fftw-wisdom w.wis: one warning, no file ({own}, {os.listdir(sub)})")
    # a model whose run is not spread over processes: every process would run it whole and write the same files
    sub = tempfile.mkdtemp(dir=d)
    r = run(2, ["--output", "o.csv"], sub, equation="three-wave")
    own = [l for l in r.stderr.splitlines() if l.startswith("eci")]
    check(r.returncode == 2 or ("exit code: 2" in r.stderr.lower()), f"-np 2 three-wave: exit 2 (mpirun {r.returncode})")
    check(len(own) == 1 and "runs on one process, not 2" in own[0], f"-np 2 three-wave: one line from rank 0: {own}")
    check(os.listdir(sub) == [], f"-np 2 three-wave: nothing written ({os.listdir(sub)})")


WRAPPER = r"""
import os, signal, subprocess, sys
child = subprocess.Popen(sys.argv[2:])
for s in (signal.SIGTERM, signal.SIGINT):
    signal.signal(s, lambda n, f: child.send_signal(n))
rc = child.wait()
with open(sys.argv[1] + "." + os.environ.get("OMPI_COMM_WORLD_RANK", "x"), "w") as f:
    f.write(str(rc))
"""


def case_signal(d):
    # every rank's exit status, through a wrapper that forwards mpirun's SIGTERM to the tool and records its status
    with open(os.path.join(d, "wrap.py"), "w") as f:
        f.write(WRAPPER)
    cmd = [MPIEXEC, "--oversubscribe", "-np", "2", sys.executable, "wrap.py", "rc", ECI, "run", "navier-stokes-2d",
           "--N", "64", "--dt", "0.001", "--steps", "10000000", "--fftw-estimate", "--fftw-wisdom", "none",
           "--checkpoint", "sig.h5", "--output", "sig.csv"]
    # odls_base_sigkill_timeout: how long mpirun waits after forwarding SIGTERM before it sends SIGKILL (default
    # 1 s: the checkpoint must be written in that time; docs/turbulence.md says to raise it for large grids)
    env = dict(ENV, OMPI_MCA_odls_base_sigkill_timeout="5")
    p = subprocess.Popen(cmd, cwd=d, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(3.0)
    p.send_signal(signal.SIGINT)  # Ctrl-C reaches mpirun
    out, err = p.communicate(timeout=60)
    rcs = sorted(open(os.path.join(d, n)).read() for n in os.listdir(d) if n.startswith("rc."))
    check(rcs == ["130", "130"], f"SIGINT to mpirun: every rank exits 130 ({rcs}; mpirun {p.returncode})")
    check("checkpoint written to sig.h5" in err, "the interruption is reported once, with the checkpoint")
    w, attrs = state(os.path.join(d, "sig.h5"))
    check(int(attrs["step"]) > 0, f"the checkpoint holds step {int(attrs['step'])}")
    # the rows so far are kept, complete, to the checkpoint's step (rank 0 commits them on every process's word)
    rows = open(os.path.join(d, "sig.csv")).read() if os.path.exists(os.path.join(d, "sig.csv")) else ""
    check(rows.endswith("\n") and rows.splitlines()[-1].split(",")[0] == str(int(attrs["step"])),
          "the interrupted run keeps its CSV, complete, to the checkpoint's step")
    check("kept: CSV output 'sig.csv'" in err, "the message says what was kept")
    r = run(0, ["--restart", "sig.h5", "--steps", str(int(attrs["step"]) + 2), "--fftw-wisdom", "none",
                "--checkpoint", "again.h5"], d)
    check(r.returncode == 0, "the serial tool continues from it")


@contextlib.contextmanager
def tmpfs(path, options):
    """A tmpfs made and mounted at path with `options` for the block, unmounted after it. Yields False, saying why,
    where mounting is not allowed (not root)."""
    os.mkdir(path)
    if subprocess.run(["mount", "-t", "tmpfs", "-o", options, "tmpfs", path], capture_output=True).returncode:
        print(f"skipped: cannot mount a tmpfs ({options}) here (not root?)")
        yield False
        return
    try:
        yield True
    finally:
        subprocess.run(["umount", "-l", path])


def case_abort(d):
    # A failure on rank 0 alone (it creates the checkpoint's file, on a full disk) ends every process: exit
    # non-zero at once, no hang, the reason named, nothing left behind.
    m = os.path.join(d, "m")
    with tmpfs(m, "size=64k") as mounted:
        if not mounted:
            return
        try:  # fill the disk (the write, or the close, fails with ENOSPC)
            with open(os.path.join(m, "fill"), "wb") as f:
                while True:
                    f.write(b"x" * 4096)
                    f.flush()
        except OSError:
            pass
        start = time.monotonic()
        r = run(2, BASE + ["--steps", "5", "--checkpoint-every", "1", "--checkpoint", "m/ck.h5"], d)
        took = time.monotonic() - start
        own = [l for l in r.stderr.splitlines() if l.startswith("eci")]
        check(r.returncode != 0, f"-np 2, rank 0's write fails: exit {r.returncode} after {took:.1f} s")
        check(len(own) == 1 and "No space left on device" in own[0], f"one line naming the reason: {own}")
        check(sorted(os.listdir(m)) == ["fill"], f"nothing left on the full disk: {os.listdir(m)}")
        # Room for the file's header but not for its field (24 KiB left, a 64^2 checkpoint's field is 33 KiB): rank 0
        # creates the file and fails while it writes the field's zeros, before any process writes its block; the
        # same ending, for the checkpoint and for a snapshot.
        os.remove(os.path.join(m, "fill"))
        with open(os.path.join(m, "fill"), "wb") as f:
            f.write(b"x" * 40960)
        for what, args in (("checkpoint", ["--checkpoint-every", "1", "--checkpoint", "m/ck.h5"]),
                           ("snapshot", ["--snapshot-every", "1", "--snapshot-dir", "m/snaps"])):
            start = time.monotonic()
            r = run(2, ["--N", "64", "--dt", "0.002", "--fftw-estimate", "--fftw-wisdom", "none", "--steps", "2"] +
                    args, d)
            took = time.monotonic() - start
            own = [l for l in r.stderr.splitlines() if l.startswith("eci")]
            check(r.returncode != 0, f"-np 2, no room for the {what}'s field: exit {r.returncode} after {took:.1f} s")
            check(len(own) == 1 and "No space left on device" in own[0], f"{what}: one line naming the reason: {own}")
            check(sorted(os.listdir(m)) == ["fill"], f"{what}: nothing left on the disk: {os.listdir(m)}")


# Runs a command as one MPI process, records its exit status and peak memory (ru_maxrss, KiB) in
# RC.<rank> ("status kib"); with a limit > 0, the command may write no file beyond that many bytes (RLIMIT_FSIZE, with
# SIGXFSZ ignored: a write past it fails with EFBIG, "File too large"). The limit does reach the tool under mpirun
# (Open MPI leaves it alone: /proc/PID/limits of the rank shows it, and strace shows rank 1's pwrite of its block
# failing with EFBIG); the limit is recorded in RC.<rank>.limit as the tool's process saw it.
LIMITED = r"""
import os, resource, signal, subprocess, sys
rc, limit, cmd = sys.argv[1], int(sys.argv[2]), sys.argv[3:]
def limited():
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    if limit > 0:
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
child = subprocess.Popen(cmd, preexec_fn=limited)
rank = os.environ.get("OMPI_COMM_WORLD_RANK", "x")
try:
    seen = [l for l in open(f"/proc/{child.pid}/limits") if l.startswith("Max file size")][0].split()[3]
except (OSError, IndexError):
    seen = "?"
_, status, usage = os.wait4(child.pid, 0)
with open(rc + "." + rank + ".limit", "w") as f:
    f.write(seen)
with open(rc + "." + rank, "w") as f:
    f.write(f"{os.waitstatus_to_exitcode(status)} {usage.ru_maxrss}")
"""


def ranks_run(d, tag, per_rank, args, env=None, timeout=240):
    """mpirun of one process per entry of per_rank (a file size limit, 0: none), each through LIMITED; returns
    mpirun's result (with .took, seconds, and .hung: killed after `timeout`) and every rank's (status, peak KiB)."""
    with open(os.path.join(d, "limited.py"), "w") as f:
        f.write(LIMITED)
    cmd = [MPIEXEC, "--oversubscribe"]
    for k, limit in enumerate(per_rank):
        if k:
            cmd.append(":")
        cmd += ["-np", "1", sys.executable, os.path.join(d, "limited.py"), os.path.join(d, tag), str(limit), ECI,
                "run", "navier-stokes-2d"] + args
    start = time.monotonic()
    # A process left waiting for another (a hang) is a failure of the case, not of the suite: past `timeout`, mpirun
    # is sent SIGTERM (it ends its processes), then SIGKILL; r.hung says so, and the statuses are then missing.
    p = subprocess.Popen(cmd, cwd=d, env=env or ENV, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    hung = False
    try:
        out, err = p.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        hung = True
        p.terminate()
        try:
            out, err = p.communicate(timeout=30)
        except subprocess.TimeoutExpired:
            p.kill()
            out, err = p.communicate()
    r = subprocess.CompletedProcess(cmd, p.returncode, out, err)
    r.took = time.monotonic() - start
    r.hung = hung
    out = []
    for k in range(len(per_rank)):
        try:
            status, kib = open(os.path.join(d, f"{tag}.{k}")).read().split()
            out.append((int(status), int(kib)))
        except OSError:
            out.append((None, None))
    return r, out


def case_rank_failure(d):
    # A write failing on rank 1 alone (its block of the checkpoint or snapshot, past a file size limit only it has,
    # RLIMIT_FSIZE of 1 KiB: rank 0 creates the whole file, zeros in the field, with no limit; rank 1's block lies
    # beyond 1 KiB, and a write at an offset past the limit fails even where the file already has its bytes): every
    # process exits 1 with rank 1's reason, at once (no process left waiting: a hang is killed after 60 s and fails
    # the case); one line from rank 0; no temporary, checkpoint or snapshot left. (Rank 1 finds it by checking the
    # file's size against its limit before the collective write; left to that write, it ended both processes too,
    # but as MPI-IO's short write, whose reason HDF5 does not give: "file write failed".)
    # (What hid it before: HDF5 keeps such a small hyperslab write in the dataset's sieve buffer and writes it at
    # H5Dclose, whose failure the writer did not check; the file's flush and close then succeeded, and rank 1's
    # columns were silently missing from a checkpoint committed as whole.)
    # (TCP between the processes: the limit would stop shared memory's backing files too.)
    env = dict(ENV, OMPI_MCA_btl="self,tcp", OMPI_MCA_btl_tcp_if_include="lo")
    outputs = (("checkpoint", ["--checkpoint-every", "1", "--checkpoint", "ck.h5"]),
               ("snapshot", ["--snapshot-every", "1", "--snapshot-dir", "snaps"]))
    # the control: the same runs without a limit succeed in this set-up (so the failure below is the limit's)
    sub = tempfile.mkdtemp(dir=d)
    r, ranks = ranks_run(sub, "rc", [0, 0], BASE + ["--steps", "3", "--output", "o.csv"] + outputs[0][1] +
                         outputs[1][1], env, timeout=120)
    check(not r.hung and [s for s, _ in ranks] == [0, 0] and os.path.exists(os.path.join(sub, "ck.h5")),
          f"without a limit the same run succeeds ({ranks}, {r.took:.1f} s)")
    for what, args in outputs:
        sub = tempfile.mkdtemp(dir=d)
        r, ranks = ranks_run(sub, "rc", [0, 1024], BASE + ["--steps", "3", "--output", "o.csv"] + args, env,
                             timeout=60)
        limits = [open(os.path.join(sub, f"rc.{k}.limit")).read() if os.path.exists(os.path.join(sub, f"rc.{k}.limit"))
                  else None for k in (0, 1)]
        check(limits == ["unlimited", "1024"], f"{what}: the tool's processes run with file size limits {limits}")
        check(not r.hung, f"{what}: no process left waiting (mpirun returned after {r.took:.1f} s)")
        own = [l for l in r.stderr.splitlines() if l.startswith("eci")]
        check([s for s, _ in ranks] == [1, 1], f"{what} of rank 1 fails: every rank exits 1 ({ranks}) in {r.took:.1f} s")
        check(len(own) == 1 and "File too large" in own[0], f"{what}: one line from rank 0, rank 1's reason: {own}")
        left = sorted(n for n in os.listdir(sub) if not n.startswith(("rc.", "limited.py")))
        check(left == [], f"{what}: nothing left behind ({left})")


def case_memory(d):
    # No process but rank 0 (for the picture) holds a whole field: rank 1's peak memory with a snapshot and a
    # checkpoint at every step is its run's without them plus less than two whole fields (N^2 doubles each). What it
    # legitimately adds: its rows of the field (half a field on 2 processes) or its block of the half plane (at most
    # 2/3 of a field: the retained columns are split evenly, the zero columns beyond them are the last process's),
    # the snapshot's spectra and fluxes (a state's worth), HDF5's code and heap and what the allocator keeps of
    # freed blocks (measured: 9 MiB of the 14 MiB at N = 1024). Gathering the field, as every process did before,
    # costs a field and a half plane more (16 MiB) on top of all that.
    n = 1024
    field_kib = n * n * 8 // 1024
    args = ["--N", str(n), "--dt", "1e-4", "--steps", "2", "--fftw-estimate", "--fftw-wisdom", "none",
            "--update", "paper", "--method", "c-rk4"]
    env = dict(ENV, ECI_GNUPLOT="false")  # (no picture: rank 0's gnuplot is not what is measured)
    _, plain = ranks_run(d, "plain", [0, 0], args)
    _, files = ranks_run(d, "files", [0, 0], args + ["--snapshot-every", "1", "--snapshot-dir", "s",
                                                     "--checkpoint-every", "1", "--checkpoint", "ck.h5"], env)
    check(all(s == 0 for s, _ in plain + files), f"N = {n} on 2 processes, without and with files: {plain} {files}")
    if all(s == 0 for s, _ in plain + files):
        extra = files[1][1] - plain[1][1]
        check(extra < 2 * field_kib, f"rank 1's peak with a snapshot and a checkpoint per step: {plain[1][1]} KiB + "
              f"{extra} KiB < two fields ({2 * field_kib} KiB); rank 0: {plain[0][1]} + {files[0][1] - plain[0][1]} KiB")


def attrs_equal(a, b, skip=(), rtol=0.0, atol=0.0):
    """The names and values of two files' attributes, as h5py reads them (fixed-length strings as bytes): strings and
    whole numbers exactly, floating-point values to rtol (the run's sums, added in another order on more processes)."""
    if sorted(a.attrs) != sorted(b.attrs):
        return False, f"names differ: {sorted(set(a.attrs) ^ set(b.attrs))}"
    def same(x, y):
        if isinstance(x, (float, np.floating)) and isinstance(y, (float, np.floating)):
            if np.isnan(x) or np.isnan(y):  # (a checkpoint's t_end of a run by --steps: NaN in both)
                return bool(np.isnan(x) and np.isnan(y))
            return x == y or abs(x - y) <= rtol * max(abs(x), abs(y)) + atol
        return type(x) == type(y) and np.array_equal(x, y)
    bad = [k for k in a.attrs if k not in skip and not same(a.attrs[k], b.attrs[k])]
    return not bad, f"differ: {[(k, a.attrs[k], b.attrs[k]) for k in bad]}" if bad else "all equal"


def case_files(d):
    # A snapshot and a checkpoint of the same run on 1 (serial tool), 2 and 3 processes: the same datasets, shapes,
    # types and attributes (every value, but a checkpoint's FFTW wisdom, which an MPI run does not keep, and its
    # state's checksum, which follows the state's bits), the values equal to round-off (the distributed transforms;
    # the bound of case_state). Each file's checksum matches its own state: the serial tool restarts from it below.
    steps = 20
    bound = 16 * EPS * np.sqrt(steps)
    args = BASE + ["--nu", "1e-3", "--forcing", "stochastic", "--forcing-k", "3", "--steps", str(steps),
                   "--snapshot-every", str(steps), "--checkpoint-every", str(steps)]
    for np_ in (0, 2, 3):
        r = run(np_, args + ["--snapshot-dir", f"s{np_}", "--checkpoint", f"c{np_}.h5"], d)
        check(r.returncode == 0, f"-np {np_}: {steps} steps with a snapshot and a checkpoint (exit {r.returncode}) "
                                 f"{r.stderr.strip()[-200:] if r.returncode else ''}")
        if r.returncode:
            return
    snap = [n for n in sorted(os.listdir(os.path.join(d, "s0"))) if n.endswith(".h5")][-1]
    for np_ in (2, 3):
        for kind, a_path, b_path, skip in (("snapshot", os.path.join(d, "s0", snap), os.path.join(d, f"s{np_}", snap), ()),
                                           ("checkpoint", os.path.join(d, "c0.h5"), os.path.join(d, f"c{np_}.h5"),
                                            ("fftw_wisdom", "state_checksum"))):
            with h5py.File(a_path, "r") as a, h5py.File(b_path, "r") as b:
                # (a checkpoint's E0, Z0, budgets, drifts and residuals are the run's sums: to round-off, 1e-9
                # relative or 1e-12 of E0, Z0 absolute; every other attribute, the parameters, step, time, generator
                # and counters, exactly)
                scale = max(abs(float(a.attrs.get("energy0", 0))), abs(float(a.attrs.get("enstrophy0", 0))))
                ok, what = attrs_equal(a, b, skip, *((0.0, 0.0) if kind == "snapshot" else (1e-9, 1e-12 * scale)))
                check(ok, f"-np {np_} {kind}: attributes as the serial file's ({what})")
                check(sorted(a.keys()) == sorted(b.keys()), f"-np {np_} {kind}: datasets {sorted(b.keys())}")
                for k in a.keys():
                    x, y = np.array(a[k]), np.array(b[k])
                    same = x.dtype == y.dtype and x.shape == y.shape
                    diff = float(np.max(np.abs(x - y)) / max(np.max(np.abs(x)), 1e-300)) if same else float("inf")
                    check(same and diff <= bound, f"-np {np_} {kind}/{k}: {y.dtype} {y.shape}, = serial to {diff:.3g}")
                if kind == "checkpoint":
                    check(a.attrs["fftw_wisdom"] != b"" and b.attrs["fftw_wisdom"] == b"",
                          f"-np {np_} checkpoint: no FFTW wisdom (the serial one's kept)")
        # its state's checksum, the sum of every process's part: the serial tool checks it on restart
        r = run(0, ["--fftw-wisdom", "none", "--restart", f"c{np_}.h5", "--steps", str(steps + 1), "--checkpoint",
                    f"r{np_}.h5"], d)
        check(r.returncode == 0, f"-np {np_} checkpoint restarts in the serial tool (its checksum: its state's) "
                                 f"{r.stderr.strip()[-200:] if r.returncode else ''}")
    # --output FILE.h5 on 2 processes: rank 0 writes the rows as HDF5, the serial tool's diagnostics to round-off
    r0 = run(0, BASE + ["--steps", "5", "--output", "h0.h5"], d)
    r2 = run(2, BASE + ["--steps", "5", "--output", "h2.h5"], d)
    check(r0.returncode == 0 and r2.returncode == 0, f"--output FILE.h5 serial and -np 2 (exit {r0.returncode}, "
                                                     f"{r2.returncode})")
    if r0.returncode == 0 and r2.returncode == 0:
        with h5py.File(os.path.join(d, "h0.h5"), "r") as a, h5py.File(os.path.join(d, "h2.h5"), "r") as b:
            x, y = np.array(a["diagnostics"]), np.array(b["diagnostics"])
            same = x.shape == y.shape and np.array_equal(a["t"][:], b["t"][:])
            check(same, f"-np 2 --output h2.h5: rows {y.shape} at the serial file's times")
            names = [c.decode() for c in b["diagnostics_columns"][:]]
            for k in ("energy", "enstrophy", "max_velocity") if same else ():
                i = names.index(k)
                err = float(np.max(np.abs(x[:, i] - y[:, i])) / np.max(np.abs(x[:, i])))
                check(err <= bound, f"-np 2 --output h2.h5: {k} = serial to {err:.3g}")
    # --plot on 2 processes: rank 0 draws the picture (a whole PNG, committed with the CSV), as the serial tool does
    if shutil.which("gnuplot"):
        r = run(2, BASE + ["--steps", "5", "--plot", "p2.png", "--output", "p2.csv"], d)
        png = b""
        if r.returncode == 0 and os.path.exists(os.path.join(d, "p2.png")):
            with open(os.path.join(d, "p2.png"), "rb") as f:
                png = f.read()
        check(r.returncode == 0 and png[1:4] == b"PNG" and png[-8:-4] == b"IEND",
              f"-np 2 --plot p2.png: a whole PNG (exit {r.returncode}, {len(png)} bytes)")
    # Read by rows and written again by other processes: the 2-process snapshot as --ic on 3 processes, whose
    # snapshot at step 0 is the same field (through the half plane and back: round-off of one transform pair).
    r = run(3, BASE + ["--steps", "1", "--ic", os.path.join("s2", snap), "--snapshot-every", "1",
                       "--snapshot-dir", "ic3"], d)
    check(r.returncode == 0, f"-np 3 from the 2-process snapshot (--ic) with a snapshot at step 0 (exit {r.returncode})")
    if r.returncode == 0:
        first = [n for n in sorted(os.listdir(os.path.join(d, "ic3"))) if n.endswith(".h5")][0]
        with h5py.File(os.path.join(d, "s2", snap), "r") as a, h5py.File(os.path.join(d, "ic3", first), "r") as b:
            k = a.attrs["field"]
            k = k.decode() if isinstance(k, bytes) else str(k)
            x, y = np.array(a[k]), np.array(b[k])
            diff = float(np.max(np.abs(x - y)) / np.max(np.abs(x)))
            # (the field goes to the half plane and back: one forward and one inverse transform of round-off)
            check(x.shape == y.shape and diff <= 16 * EPS, f"-np 3 step-0 snapshot of the --ic field = it to {diff:.3g}")


def case_write_failure(d):
    # A snapshot or checkpoint that cannot be written on 2 or 3 processes: one line (rank 0's), the documented exit
    # status (2: found before the run, as the serial tool finds it; 1: found by the write), nothing left behind, and
    # no process left waiting (mpirun under a time limit).
    def attempt(np_, args, what, statuses, sub, expect_in=None):
        start = time.monotonic()
        try:
            r = subprocess.run([MPIEXEC, "--oversubscribe", "-np", str(np_), ECI, "run", "navier-stokes-2d"] + BASE +
                               ["--steps", "4", "--output", "o.csv"] + args, cwd=sub, env=ENV, capture_output=True,
                               text=True, timeout=90)
        except subprocess.TimeoutExpired:
            check(False, f"-np {np_} {what}: no process left waiting (killed after 90 s)")
            return
        took = time.monotonic() - start
        own = [l for l in r.stderr.splitlines() if l.startswith("eci")]
        status = next((s for s in statuses if r.returncode == s or f"exit code: {s}" in r.stderr.lower()), None)
        check(status is not None, f"-np {np_} {what}: exit {statuses} (mpirun {r.returncode}) in {took:.1f} s")
        check(len(own) == 1 and (expect_in is None or expect_in in own[0]), f"-np {np_} {what}: one line: {own}")
        return r

    for np_ in (2, 3):
        # the checkpoint's path is a directory
        sub = tempfile.mkdtemp(dir=d)
        os.mkdir(os.path.join(sub, "ck.h5"))
        attempt(np_, ["--checkpoint-every", "2", "--checkpoint", "ck.h5"], "--checkpoint DIRECTORY", (2,), sub)
        left = sorted(os.listdir(sub))
        check(left == ["ck.h5"] and os.listdir(os.path.join(sub, "ck.h5")) == [],
              f"-np {np_} --checkpoint DIRECTORY: nothing written ({left})")
        # a read-only file system under the checkpoint and under the snapshots (root writes to any directory, not to
        # a read-only mount)
        m = os.path.join(sub, "ro")
        with tmpfs(m, "ro,size=64k") as mounted:
            if not mounted:
                continue
            for what, args in (("checkpoint on a read-only file system", ["--checkpoint-every", "2", "--checkpoint",
                                                                           "ro/ck.h5"]),
                               ("snapshots on a read-only file system", ["--snapshot-every", "2", "--snapshot-dir",
                                                                         "ro/snaps"])):
                for n in os.listdir(sub):
                    if n not in ("ro", "ck.h5"):
                        os.remove(os.path.join(sub, n))
                attempt(np_, args, what, (1, 2), sub, "Read-only file system")
                left = sorted(n for n in os.listdir(sub) if n not in ("ro", "ck.h5"))
                check(left == [] and os.listdir(m) == [], f"-np {np_} {what}: nothing written ({left}, {os.listdir(m)})")
    # found by the write itself (the run under way): the checkpoint's directory replaced by a file after the run
    # checked it; every process ends with exit 1 and rank 0's one line, no temporary left
    for np_ in (2, 3):
        sub = tempfile.mkdtemp(dir=d)
        os.mkdir(os.path.join(sub, "out"))
        p = subprocess.Popen([MPIEXEC, "--oversubscribe", "-np", str(np_), ECI, "run", "navier-stokes-2d", "--N", "64",
                              "--dt", "1e-4", "--steps", "100000000", "--fftw-estimate", "--fftw-wisdom", "none",
                              "--update", "paper", "--checkpoint-every", "200000000", "--checkpoint", "out/ck.h5"],
                             cwd=sub, env=ENV, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        time.sleep(2.0)
        os.rmdir(os.path.join(sub, "out"))
        with open(os.path.join(sub, "out"), "w") as f:
            f.write("x")
        start = time.monotonic()
        p.send_signal(signal.SIGINT)  # the interruption's checkpoint: its directory is gone
        try:
            out, err = p.communicate(timeout=60)
            own = [l for l in err.splitlines() if l.startswith("eci")]
            check(any("cannot write checkpoint" in l for l in own) and len(own) == 1,
                  f"-np {np_} checkpoint's directory gone mid-run: one line after {time.monotonic() - start:.1f} s: {own}")
            check(p.returncode != 0, f"-np {np_} checkpoint's directory gone mid-run: exit non-zero ({p.returncode})")
        except subprocess.TimeoutExpired:
            p.kill()
            p.communicate()
            check(False, f"-np {np_} checkpoint's directory gone mid-run: no process left waiting (killed after 60 s)")
        check(sorted(os.listdir(sub)) == ["out"], f"-np {np_} checkpoint's directory gone mid-run: nothing left "
                                                  f"({sorted(os.listdir(sub))})")


def case_idle_rank(d):
    # More processes than retained columns (N = 8: k_max + 1 = 3 columns; on 4 and 5 processes the last hold none,
    # docs/turbulence.md): such a process takes part in every collective with an empty share. The conditioned
    # update's rescale read its "largest weight" out of an empty array (a segmentation fault on every such run
    # before the fix). The run, its files and a restart on another count of idle processes = the serial tool's.
    steps = 6
    bound = 16 * EPS * np.sqrt(steps)
    args = ["--N", "8", "--dt", "0.002", "--fftw-estimate", "--fftw-wisdom", "none", "--nu", "1e-3",
            "--forcing", "stochastic", "--forcing-k", "2", "--snapshot-every", "3"]
    r = run(0, args + ["--steps", str(steps), "--checkpoint-every", "3", "--checkpoint", "s.h5", "--output", "s.csv",
                       "--snapshot-dir", "s"], d)
    check(r.returncode == 0, f"N = 8 serially (exit {r.returncode})")
    ref, _ = state(os.path.join(d, "s.h5"))
    for np_ in (4, 5):
        r = run(np_, args + ["--steps", str(steps), "--checkpoint-every", "3", "--checkpoint", f"p{np_}.h5",
                             "--output", f"p{np_}.csv", "--snapshot-dir", f"p{np_}"], d)
        check(r.returncode == 0, f"N = 8 on -np {np_} (a process without columns): exit {r.returncode}"
                                 + (f" {r.stderr.strip()[-300:]}" if r.returncode else ""))
        if r.returncode:
            continue
        diff = rel(state(os.path.join(d, f"p{np_}.h5"))[0], ref)
        check(diff <= bound, f"N = 8 -np {np_}: state = serial to {diff:.3g} <= {bound:.3g}")
        check(sorted(os.listdir(os.path.join(d, f"p{np_}"))) == sorted(os.listdir(os.path.join(d, "s"))),
              f"N = 8 -np {np_}: the serial run's snapshot files")
    # a checkpoint of 4 processes (one idle) continued on 5 (two idle) = the uninterrupted serial run
    r = run(4, args + ["--steps", "3", "--checkpoint-every", "3", "--checkpoint", "half.h5"], d)
    r = run(5, ["--restart", "half.h5", "--steps", str(steps), "--checkpoint", "r.h5", "--fftw-wisdom", "none"], d)
    check(r.returncode == 0, f"N = 8: a 4-process checkpoint restarted on 5: exit {r.returncode}")
    if r.returncode == 0:
        diff = rel(state(os.path.join(d, "r.h5"))[0], ref)
        check(diff <= bound, f"N = 8: restart 4 -> 5 processes = the serial run to {diff:.3g}")
    for eq in ("charney-hasegawa-mima", "surface-qg"):
        r = run(4, ["--N", "8", "--dt", "0.002", "--fftw-estimate", "--fftw-wisdom", "none", "--steps", "3"], d, eq)
        check(r.returncode == 0, f"{eq} N = 8 on -np 4: exit {r.returncode}")


with tempfile.TemporaryDirectory() as d:
    {"state": case_state, "restart": case_restart, "snapshot": case_snapshot, "bad-input": case_bad_input,
     "signal": case_signal, "abort": case_abort, "rank-failure": case_rank_failure,
     "memory": case_memory, "files": case_files, "write-failure": case_write_failure,
     "idle-rank": case_idle_rank}[CASE](d)
print(f"{CASE}: {'FAILED' if failures else 'passed'} ({failures} failure(s))")
sys.exit(1 if failures else 0)
