#!/usr/bin/env python3
"""Cost per step of eci's pairs as SciPy solvers (eci.scipy) against SciPy's own RK45, side by side.

Each solver is stepped from t0 to t_end through its OdeSolver face (solver.step() until finished: what solve_ivp
does per step, without solve_ivp's own bookkeeping, which is the same for every solver). Per accepted step:
the time, the fun calls, and the overhead = time - calls x fun's own time per call (measured alone in a Python
loop). eci.scipy.DP54 is the pair RK45 is, with SciPy's controller, so both take the same steps; CDP54 is the
conservative version. Repetitions are interleaved and the fastest of each kept.

    PYTHONPATH=build/python /usr/bin/python3 bench/scipy_overhead.py [--reps N] [--quick | --smoke]
"""
import argparse
import time

import numpy as np
from scipy.integrate import RK45, DOP853

import eci.scipy


def rotation(n):
    """y' = A y with A antisymmetric (|y|^2 kept): a NumPy matrix-vector product per call."""
    rng = np.random.default_rng(1)
    m = rng.standard_normal((n, n))
    a = m - m.T
    return (lambda t, y: a @ y), rng.standard_normal(n)


def three_wave(_n):
    return (lambda t, y: np.array([y[1] * y[2], y[2] * y[0], -2.0 * y[0] * y[1]])), np.array([1.0, 0.5, -0.3])


def fun_alone(fun, y0, calls):
    start = time.perf_counter()
    for _ in range(calls):
        fun(0.5, y0)
    return (time.perf_counter() - start) / calls


def run(cls, fun, y0, t_end, rtol, atol):
    solver = cls(fun, 0.0, y0, t_end, rtol=rtol, atol=atol)
    start = time.perf_counter()
    steps = 0
    while solver.status == "running":
        solver.step()
        steps += 1
    return time.perf_counter() - start, steps, solver.nfev


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reps", type=int, default=5)
    ap.add_argument("--quick", action="store_true", help="shorter runs (numbers noisier)")
    ap.add_argument("--smoke", action="store_true", help="token runs (CI: keeps it running; numbers mean nothing)")
    args = ap.parse_args()
    t_end = 2.0 if args.smoke else 50.0 if args.quick else 300.0
    solvers = {"RK45": RK45, "eci DP54": eci.scipy.DP54, "eci CDP54": eci.scipy.CDP54, "DOP853": DOP853,
               "eci F78": eci.scipy.F78}
    print(f"{'system':<22} {'solver':<10} {'steps':>6} {'fun/step':>8} {'us/step':>9} {'fun us':>7} "
          f"{'overhead us/step':>16} {'vs RK45':>8}")
    for label, make in (("three-wave (n=3)", three_wave), ("rotation n=10", lambda _: rotation(10)),
                        ("rotation n=200", lambda _: rotation(200))):
        fun, y0 = make(None)
        best = {k: np.inf for k in solvers}
        shape = {}
        t_fun = np.inf
        for _ in range(args.reps):
            t_fun = min(t_fun, fun_alone(fun, y0, 2000))
            for name, cls in solvers.items():
                seconds, steps, nfev = run(cls, fun, y0, t_end, 1e-6, 1e-9)
                best[name] = min(best[name], seconds)
                shape[name] = (steps, nfev)
        base = None
        for name in solvers:
            steps, nfev = shape[name]
            per_step = best[name] / steps
            overhead = per_step - nfev / steps * t_fun
            if name == "RK45":
                base = overhead
            print(f"{label:<22} {name:<10} {steps:>6} {nfev / steps:>8.2f} {per_step * 1e6:>9.1f} {t_fun * 1e6:>7.2f} "
                  f"{overhead * 1e6:>16.1f} {overhead / base:>8.2f}")


if __name__ == "__main__":
    main()
