#!/usr/bin/env python3
"""Overhead per right-hand-side call of a Python fun(t, y): eci.solve against scipy.integrate.solve_ivp, side by side.

For each fun, the time per call of fun alone (a Python loop calling it) is subtracted from each solver's time per
evaluation (run time / nfev); what remains is what the solver spends per evaluation around fun. Repetitions are
interleaved and the fastest of each kept. Target: eci's overhead <= SciPy's (ratio <= 1), for eci's fixed-step rk4
and for its adaptive dp54 at SciPy's tolerances (the same pair as RK45, so the same work per step).

    PYTHONPATH=build/python /usr/bin/python3 bench/python_overhead.py [--reps N] [--quick | --smoke]
"""
import argparse
import time

import numpy as np
from scipy.integrate import solve_ivp

import eci


def three_wave(t, y):
    return np.array([y[1] * y[2], y[2] * y[0], -2.0 * y[0] * y[1]])


def decay(t, y):
    return -y


def identity(t, y):
    return y


def fun_alone(fun, y0, calls):
    """fun's own time per call, from a plain Python loop (whose own cost, ~0.05 us, is counted as fun's)."""
    y = np.array(y0, dtype=float)
    start = time.perf_counter()
    for _ in range(calls):
        fun(0.5, y)
    return (time.perf_counter() - start) / calls


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reps", type=int, default=5)
    ap.add_argument("--quick", action="store_true", help="shorter runs (numbers noisier)")
    ap.add_argument("--smoke", action="store_true", help="token runs (CI: keeps it running; numbers mean nothing)")
    args = ap.parse_args()
    t_end = 1.0 if args.smoke else 20.0 if args.quick else 200.0
    y0 = [1.0, 0.5, -0.3]
    rows = []
    for name, fun in (("three-wave (NumPy RHS)", three_wave), ("decay: -y", decay), ("identity: y", identity)):
        best = {"fun": np.inf, "eci": np.inf, "adaptive": np.inf, "scipy": np.inf}
        nfev = {}
        for _ in range(args.reps):
            best["fun"] = min(best["fun"], fun_alone(fun, y0, 20000))
            start = time.perf_counter()
            r = eci.solve(fun, (0.0, t_end), y0, method="rk4", dt=0.01, t_eval=[t_end])
            best["eci"] = min(best["eci"], (time.perf_counter() - start) / r.nfev)
            nfev["eci"] = r.nfev
            start = time.perf_counter()
            r = eci.solve(fun, (0.0, t_end), y0, method="dp54", rtol=1e-8, atol=1e-10, t_eval=[t_end])
            best["adaptive"] = min(best["adaptive"], (time.perf_counter() - start) / r.nfev)
            nfev["adaptive"] = r.nfev
            start = time.perf_counter()
            s = solve_ivp(fun, (0.0, t_end), y0, method="RK45", rtol=1e-8, atol=1e-10, t_eval=[t_end])
            best["scipy"] = min(best["scipy"], (time.perf_counter() - start) / s.nfev)
            nfev["scipy"] = s.nfev
        over_eci, over_scipy = best["eci"] - best["fun"], best["scipy"] - best["fun"]
        over_adaptive = best["adaptive"] - best["fun"]
        rows.append((name, best["fun"], best["eci"], best["scipy"], over_eci, over_scipy, nfev, over_adaptive))
    print(f"{'fun':24s} {'fun alone':>10s} {'eci/eval':>10s} {'scipy/eval':>10s} {'eci over':>10s} "
          f"{'scipy over':>10s} {'ratio':>6s}  target <= 1 (ratio of overheads; of the whole time per eval)")
    ok = True
    for name, f, e, s, oe, os_, nfev, oa in rows:
        # an overhead below the resolution of the subtraction shows as <= 0: the ratio is then 0
        ratio = max(oe, 0.0) / os_
        ratio_adaptive = max(oa, 0.0) / os_
        ok = ok and ratio <= 1.0 and ratio_adaptive <= 1.0
        print(f"{name:24s} {f * 1e6:8.2f}us {e * 1e6:8.2f}us {s * 1e6:8.2f}us {oe * 1e6:8.2f}us {os_ * 1e6:8.2f}us "
              f"{ratio:6.3f}  {'met' if ratio <= 1.0 else 'MISSED'} ({e / s:.3f}; nfev eci {nfev['eci']}, "
              f"scipy {nfev['scipy']}); adaptive dp54 over {oa * 1e6:.2f}us, ratio {ratio_adaptive:.3f} "
              f"{'met' if ratio_adaptive <= 1.0 else 'MISSED'} (nfev {nfev['adaptive']})")
    print("(eci: rk4, dt 0.01, and dp54 rtol 1e-8, atol 1e-10; SciPy: RK45 rtol 1e-8, atol 1e-10; "
          "t_eval=[t_end]; best of "
          f"{args.reps} interleaved repetitions)")
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
