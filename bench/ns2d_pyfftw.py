#!/usr/bin/python3
"""A turbulence researcher's pyFFTW solver of the 2-D vorticity equation, the competitor eci's navier-stokes-2d must
beat, in eci's conventions. Usage:
  bench/ns2d_pyfftw.py check ECI [--n 128] [--steps 100]   both nonlinear forms against each other, RK4 against eci's
  bench/ns2d_pyfftw.py time --field H5 [--threads 1] [--form basdevant] [--reps 5] [--dt DT] [--wisdom FILE]
                                                           seconds per RK4 step from an eci checkpoint's field
d omega/dt = -u . grad omega - nu |k|^2 omega on [0, 2 pi)^2. The state is the rfft2 half plane over n^2, so that
omega(x) = sum_k omega_k e^{i k.x} (rows k_y = 0..n/2, -n/2+1..-1); kept: |k_x|, |k_y| <= (n - 1)//3, k != 0.
"""
import argparse, os, pickle, subprocess, sys, tempfile, time, tracemalloc

import h5py
import numpy as np
import pyfftw

EPS = np.finfo(float).eps


class Vorticity2D:
    def __init__(self, n, nu, threads=1, form="basdevant"):
        self.n, self.form, nc = n, form, n // 2 + 1
        kx = np.arange(nc, dtype=float)[None, :]
        ky = np.fft.fftfreq(n, 1.0 / n)[:, None]
        kmax = (n - 1) // 3
        k2 = kx ** 2 + ky ** 2
        mask = ((kx <= kmax) & (np.abs(ky) <= kmax) & (k2 > 0)).astype(float)
        inv_k2 = mask / np.where(k2 > 0, k2, 1.0)
        self.mask, self.lin = mask, -nu * k2 * mask
        # u_x = i k_y omega / |k|^2, u_y = -i k_x omega / |k|^2 (omega = d_x u_y - d_y u_x, as eci)
        self.cu, self.cv = 1j * ky * inv_k2, -1j * kx * inv_k2
        # Forward transforms are unnormalised: their 1/n^2 goes into the dealiasing multipliers.
        if form == "eci":
            self.cwx, self.cwy = 1j * kx * mask, 1j * ky * mask
            self.neg = -mask / n ** 2
        else:
            # Basdevant: u.grad omega = (d_x^2 - d_y^2)(u v) + d_x d_y (v^2 - u^2), so
            # -u.grad omega has transform (k_x^2 - k_y^2) [u v]_k + k_x k_y [v^2 - u^2]_k.
            self.a, self.b = (kx ** 2 - ky ** 2) * mask / n ** 2, kx * ky * mask / n ** 2
        alloc = pyfftw.empty_aligned
        flags = ("FFTW_MEASURE",)
        m = 4 if form == "eci" else 2  # fields transformed back: (u, omega_x, v, omega_y) or (u, v)
        self.c = alloc((m, n, nc), dtype=complex)
        self.r = alloc((m, n, n), dtype=float)
        self.inv = pyfftw.FFTW(self.c, self.r, axes=(1, 2), direction="FFTW_BACKWARD", flags=flags, threads=threads)
        f = 1 if form == "eci" else 2  # products transformed forward: u.grad omega, or (u v, v^2 - u^2)
        self.q = alloc((f, n, n), dtype=float)
        self.qh = alloc((f, n, nc), dtype=complex)
        self.fwd = pyfftw.FFTW(self.q, self.qh, axes=(1, 2), direction="FFTW_FORWARD", flags=flags, threads=threads)
        self.k, self.s, self.acc, self.tmp = (alloc((n, nc), dtype=complex) for _ in range(4))

    def to_physical(self, w_hat):
        self.c[0] = w_hat
        self.inv.execute()  # unnormalised c2r: sum_k w_k e^{ik.x}
        return self.r[0].copy()

    def rhs(self, w, out):
        c, r, q, qh = self.c, self.r, self.q, self.qh
        if self.form == "eci":  # 4 inverse, 1 forward
            for i, mult in enumerate((self.cu, self.cwx, self.cv, self.cwy)):
                np.multiply(w, mult, out=c[i])
            self.inv.execute()
            np.multiply(r[0], r[1], out=q[0])
            np.multiply(r[2], r[3], out=r[2])
            q[0] += r[2]
            self.fwd.execute()
            np.multiply(qh[0], self.neg, out=out)
        else:  # Basdevant: 2 inverse, 2 forward
            np.multiply(w, self.cu, out=c[0])
            np.multiply(w, self.cv, out=c[1])
            self.inv.execute()
            u, v = r
            np.multiply(u, v, out=q[0])
            np.subtract(v, u, out=q[1])
            u += v
            q[1] *= u
            self.fwd.execute()
            np.multiply(qh[0], self.a, out=out)
            np.multiply(qh[1], self.b, out=qh[1])
            out += qh[1]
        np.multiply(w, self.lin, out=self.tmp)
        out += self.tmp

    def step(self, w, dt):
        """Classic RK4, in place: w <- w + dt/6 (k1 + 2 k2 + 2 k3 + k4)."""
        k, s, acc = self.k, self.s, self.acc
        self.rhs(w, k)
        np.multiply(k, dt / 6, out=acc)
        acc += w
        for c_stage, c_acc in ((0.5, 1 / 3), (0.5, 1 / 3), (1.0, 1 / 6)):
            np.multiply(k, c_stage * dt, out=s)
            s += w
            self.rhs(s, k)
            np.multiply(k, c_acc * dt, out=s)
            acc += s
        w[...] = acc

    def max_velocity(self, w):
        self.c[0], self.c[1] = w * self.cu, w * self.cv
        self.inv.execute()
        return np.sqrt(np.max(self.r[0] ** 2 + self.r[1] ** 2))


def read_state(path):
    """omega_hat of an eci checkpoint (complex, rows x (n/2 + 1)) and its attributes."""
    with h5py.File(path) as f:
        v = np.array(f["omega_hat"])
        return np.ascontiguousarray(v[:, 0::2] + 1j * v[:, 1::2]), dict(f.attrs)


def eci_rk4(eci, n, steps, out):
    """eci's RK4 (one thread) from its random field (k_p = n/16) after one step, and `steps` steps further: eci
    checkpoints only after a step, and --ic of a checkpoint starts from its exact state."""
    common = ["run", "navier-stokes-2d", "--N", str(n), "--method", "rk4", "--nu", "1e-4", "--threads", "1",
              "--fftw-wisdom", os.path.join(out, "w")]
    c1, c2 = os.path.join(out, "c1.h5"), os.path.join(out, "c2.h5")

    def run(args):
        r = subprocess.run([eci] + common + args, capture_output=True, text=True)
        if r.returncode:
            sys.exit("ns2d-pyfftw: %s failed:\n%s" % (" ".join([eci] + common + args), r.stderr))

    run(["--k-peak", str(n / 16), "--steps", "1", "--checkpoint-every", "1", "--checkpoint", c1])
    w0, attrs = read_state(c1)
    run(["--ic", c1, "--dt", repr(float(attrs["dt"])), "--steps", str(steps), "--checkpoint-every", str(steps),
         "--checkpoint", c2])
    return (w0, attrs), read_state(c2)


def check(a):
    if a.steps > 100:
        sys.exit("ns2d-pyfftw check: at most 100 steps (beyond, the flow amplifies round-off past the bound)")
    with tempfile.TemporaryDirectory() as out:
        (w0, attrs), (w_eci, _) = eci_rk4(a.eci, a.n, a.steps, out)
    nu, dt, ok = attrs["nu"], attrs["dt"], True
    models = {f: Vorticity2D(a.n, nu, 1, f) for f in ("eci", "basdevant")}
    n5, n4 = np.empty_like(w0), np.empty_like(w0)
    models["eci"].rhs(w0, n5)
    models["basdevant"].rhs(w0, n4)
    # Both forms sum the same exact products through transforms of length n^2 (round-off ~ eps log2(n^2) each):
    # they agree to a few eps log2(n^2) of max|N|; 8 of those leaves room for the rounding of k^2 |...|.
    forms = np.max(np.abs(n5 - n4)) / np.max(np.abs(n5))
    tol = 8 * EPS * np.log2(a.n ** 2)
    ok &= forms <= tol
    print("ns2d-pyfftw check N=%d forms: max|N_eci - N_basdevant| / max|N| = %.3e (bound 8 eps log2 N^2 = %.1e)"
          % (a.n, forms, tol))
    for form, model in models.items():
        w = w0.copy()
        for _ in range(a.steps):
            model.step(w, dt)
        wmax = np.max(np.abs(model.to_physical(w_eci)))
        diff = np.max(np.abs(model.to_physical(w) - model.to_physical(w_eci))) / wmax
        # Two RK4s of the same equations differ per step by the round-off of their transforms and sums: independent
        # roundings of ~eps max|omega| add up like a random walk, ~eps sqrt(steps). The Basdevant form rounds other
        # products than eci's, so its bits differ from the first step. Turbulence then amplifies any difference
        # exponentially: at CFL 0.5 we measure <= 7 eps sqrt(steps) up to 100 steps (N = 32..512), 23 at 200 and
        # 230-670 at 400 steps. So the bound, 100 eps sqrt(steps), is for runs of at most 100 steps.
        tol = 100 * EPS * np.sqrt(a.steps)
        ok &= diff <= tol
        print("ns2d-pyfftw check N=%d steps=%d dt=%.4g form=%s: max|omega - omega_eci| / max|omega_eci| = %.3e "
              "= %.2f eps sqrt(steps) (bound 100)" % (a.n, a.steps, dt, form, diff, diff / (EPS * np.sqrt(a.steps))))
    return 0 if ok else 1


def timing(a):
    w0, attrs = read_state(a.field)
    n = 2 * (w0.shape[1] - 1)
    if a.wisdom and os.path.exists(a.wisdom):
        with open(a.wisdom, "rb") as f:
            pyfftw.import_wisdom(pickle.load(f))
    tracemalloc.start()  # the arrays NumPy allocates for the solver and one step (not FFTW's plans), then off
    model = Vorticity2D(n, attrs["nu"], a.threads, a.form)
    if a.wisdom:
        with open(a.wisdom + ".tmp%d" % os.getpid(), "wb") as f:
            pickle.dump(pyfftw.export_wisdom(), f)
        os.replace(a.wisdom + ".tmp%d" % os.getpid(), a.wisdom)
    w = pyfftw.empty_aligned(w0.shape, dtype=complex)
    dt = a.dt or 0.5 * (2 * np.pi / n) / model.max_velocity(w0)  # CFL 0.5, as eci
    # One thread: process CPU time (a slice lost to another process is not counted), as eci_bench_ns2d_step does;
    # two threads: wall time.
    clock = time.process_time if a.threads == 1 else time.perf_counter
    w[...] = w0
    model.step(w, dt)  # warm up
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    best = float("inf")
    for _ in range(a.reps):
        w[...] = w0
        t = clock()
        model.step(w, dt)
        best = min(best, clock() - t)
    print("ns2d-pyfftw N=%d threads=%d form=%s clock=%s dt=%.6g rk4=%.6g peak_states=%.2f" % (
        n, a.threads, a.form, "cpu" if a.threads == 1 else "wall", dt, best, peak / (16 * w0.size)))
    return 0


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("mode", choices=["check", "time"])
    p.add_argument("eci", nargs="?", help="check: path of the eci binary")
    p.add_argument("--n", type=int, default=128)
    p.add_argument("--steps", type=int, default=100)
    p.add_argument("--field", help="time: an eci checkpoint (.h5) holding omega_hat")
    p.add_argument("--threads", type=int, default=1)
    p.add_argument("--form", choices=["eci", "basdevant"], default="basdevant")
    p.add_argument("--reps", type=int, default=5)
    p.add_argument("--dt", type=float, help="time: the time step (default: CFL 0.5 from the field)")
    p.add_argument("--wisdom", help="time: pickled pyFFTW wisdom, read before and written after planning")
    a = p.parse_args()
    if a.mode == "check":
        return check(a)
    return timing(a)


if __name__ == "__main__":
    sys.exit(main())
