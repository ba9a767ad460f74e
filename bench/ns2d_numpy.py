#!/usr/bin/python3
"""An independent plain-NumPy pseudo-spectral solver of the 2-D vorticity equation, written the way many researchers
write it, to check and time eci's navier-stokes-2d. Usage:
  bench/ns2d_numpy.py check ECI [--n 128] [--steps 100]   eci's RK4 and this one from the same field: max difference
  bench/ns2d_numpy.py time ECI [--n 512] [--steps 10]     seconds per RK4 step, NumPy and eci (one thread each)
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import h5py
import numpy as np


class Vorticity2D:
    """d omega/dt = -u . grad omega - nu |k|^2 omega on [0, 2 pi)^2; omega_hat = rfft2(omega) / n^2, 2/3 square rule."""

    def __init__(self, n, nu=0.0):
        self.n = n
        ky = np.fft.fftfreq(n, 1.0 / n)[:, None]
        kx = np.arange(n // 2 + 1)[None, :]
        kmax = (n - 1) // 3
        self.kx, self.ky = kx.astype(float), ky.astype(float)
        k2 = self.kx ** 2 + self.ky ** 2
        self.mask = (np.abs(kx) <= kmax) & (np.abs(ky) <= kmax) & (k2 > 0)
        self.inv_k2 = np.where(self.mask, 1.0 / np.where(k2 > 0, k2, 1.0), 0.0)
        self.lin = -nu * k2 * self.mask

    def to_physical(self, w_hat):
        return np.fft.irfft2(w_hat * self.n ** 2, s=(self.n, self.n))

    def from_physical(self, w):
        return np.fft.rfft2(w) / self.n ** 2 * self.mask

    def rhs(self, w_hat):
        ux = self.to_physical(1j * self.ky * self.inv_k2 * w_hat)
        uy = self.to_physical(-1j * self.kx * self.inv_k2 * w_hat)
        wx = self.to_physical(1j * self.kx * w_hat)
        wy = self.to_physical(1j * self.ky * w_hat)
        return -self.from_physical(ux * wx + uy * wy) + self.lin * w_hat

    def rk4_step(self, w_hat, dt):
        k1 = self.rhs(w_hat)
        k2 = self.rhs(w_hat + 0.5 * dt * k1)
        k3 = self.rhs(w_hat + 0.5 * dt * k2)
        k4 = self.rhs(w_hat + dt * k3)
        return w_hat + dt / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)


def run_eci(eci, n, steps, out, snapshots=True):
    """eci's RK4 (one thread) from its random field; snapshots at 0 and `steps`. Returns the summary."""
    summary = os.path.join(out, "summary.json")
    cmd = [eci, "run", "navier-stokes-2d", "--N", str(n), "--method", "rk4", "--steps", str(steps), "--nu", "1e-4",
           "--k-peak", str(n / 16), "--threads", "1", "--summary-json", summary,
           "--fftw-wisdom", os.path.join(out, "wisdom")]
    if snapshots:
        cmd += ["--snapshot-every", str(max(steps, 1)), "--snapshot-dir", out]
    subprocess.run(cmd, check=True, stderr=subprocess.DEVNULL)
    with open(summary) as f:
        return json.load(f)


def snapshot(path):
    with h5py.File(path) as f:
        return np.array(f["vorticity"]), dict(f.attrs)


def check(args):
    with tempfile.TemporaryDirectory() as out:
        run_eci(args.eci, args.n, args.steps, out)
        w0, attrs = snapshot(os.path.join(out, "vorticity_%08d.h5" % 0))
        w1, _ = snapshot(os.path.join(out, "vorticity_%08d.h5" % args.steps))
        model = Vorticity2D(args.n, attrs["nu"])
        w_hat = model.from_physical(w0)
        for _ in range(args.steps):
            w_hat = model.rk4_step(w_hat, attrs["dt"])
        diff = np.max(np.abs(model.to_physical(w_hat) - w1)) / np.max(np.abs(w1))
        print("ns2d-numpy check N=%d steps=%d dt=%.6g max_rel_difference=%.3e" % (args.n, args.steps, attrs["dt"], diff))
        return 0 if diff <= 1e-10 else 1


def timing(args):
    with tempfile.TemporaryDirectory() as out:
        run_eci(args.eci, args.n, 1, out)  # the initial field, and the transforms planned into the wisdom file
        s = run_eci(args.eci, args.n, args.steps, out, snapshots=False)
        eci_step = s["wall_seconds"] / args.steps
        w0, attrs = snapshot(os.path.join(out, "vorticity_%08d.h5" % 0))
    model = Vorticity2D(args.n, attrs["nu"])
    w_hat = model.from_physical(w0)
    best = float("inf")
    for _ in range(3):
        t = time.perf_counter()
        for _ in range(args.steps):
            w_hat = model.rk4_step(w_hat, attrs["dt"])
        best = min(best, (time.perf_counter() - t) / args.steps)
    print("ns2d-numpy time N=%d numpy_step=%.4g s eci_step=%.4g s ratio=%.2f (eci: wall time of the run "
          "over its steps, diagnostics included)" % (args.n, best, eci_step, best / eci_step))
    return 0


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("mode", choices=["check", "time"])
    p.add_argument("eci", help="path of the eci binary")
    p.add_argument("--n", type=int)
    p.add_argument("--steps", type=int)
    a = p.parse_args()
    if a.mode == "check":
        a.n, a.steps = a.n or 128, a.steps or 100
        return check(a)
    a.n, a.steps = a.n or 512, a.steps or 10
    return timing(a)


if __name__ == "__main__":
    sys.exit(main())
