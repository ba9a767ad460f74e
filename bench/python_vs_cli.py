#!/usr/bin/env python3
"""A built-in model's integration through eci.solve against `eci run` of the same integration, side by side.

Both run the same steps in C++ and measure every invariant after every step; the CLI writes no CSV and eci.solve
keeps only the end point (t_eval=[t_end]; adaptive: both output and measure at 0 and t_end, --output-dt t_end).
Each repetition runs the CLI (wall time of the whole process, and the
loop time it reports in --summary-json) and eci.solve in this process, in alternating order; the ratio reported is
the median over the repetitions of each pair's ratio (load from other processes drifts slowly, so a pair sees about
the same load), with the ratio of the fastest runs beside it. Target: eci.solve <= 1.05x the CLI's process.

    PYTHONPATH=build/python /usr/bin/python3 bench/python_vs_cli.py [--cli build/eci] [--reps N] [--quick | --smoke]
"""
import argparse
import json
import os
import statistics
import subprocess
import tempfile
import time

import eci

CASES = [  # (CLI model and options, Python model, method, dt, t_end, rtol: None for fixed steps)
    (["three-wave"], lambda: eci.models.ThreeWave(), "c-pc", 0.01, 1e5, None),
    (["three-wave"], lambda: eci.models.ThreeWave(), "c-rk4", 0.01, 5e4, None),
    (["n-wave-complex"], lambda: eci.models.NWave(complex=True), "c-rk4", 0.01, 2e3, None),
    (["lotka-volterra"], lambda: eci.models.LotkaVolterra(), "c-pc", 0.02, 16000.0, None),
    (["kepler"], lambda: eci.models.Kepler(), "c-pc", 0.105, 2.1e4, None),
    # adaptive: the CLI's default dt is the first step of both
    (["three-wave"], lambda: eci.models.ThreeWave(), "c-dp54", 0.01, 5e4, 1e-10),
    (["kepler"], lambda: eci.models.Kepler(), "c-dp54", 0.105, 5e3, 1e-10),
]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cli", default=os.path.join(os.path.dirname(__file__), "..", "build", "eci"))
    ap.add_argument("--reps", type=int, default=5)
    ap.add_argument("--quick", action="store_true", help="runs 10x shorter (numbers noisier)")
    ap.add_argument("--smoke", action="store_true",
                    help="runs 1000x shorter (CI: keeps it running; numbers mean nothing)")
    ap.add_argument("--only", help="only the cases of this model (CLI name)")
    args = ap.parse_args()
    scale = 1e-3 if args.smoke else 0.1 if args.quick else 1.0
    print(f"{'model':16s} {'method':7s} {'steps':>9s} {'CLI process':>12s} {'CLI loop':>10s} {'eci.solve':>10s} "
          f"{'ratio':>6s}  target <= 1.05 (eci.solve / CLI process)")
    ok = True
    with tempfile.TemporaryDirectory() as tmp:
        summary = os.path.join(tmp, "s.json")
        for cli_model, make, method, dt, t_end, rtol in CASES:
            if args.only and cli_model[0] != args.only:
                continue
            t_end *= scale
            model = make()
            best = {"process": float("inf"), "loop": float("inf"), "python": float("inf")}
            pairs = []

            def run_cli():
                start = time.perf_counter()
                # adaptive: rows (and invariants, as the CLI measures them) at 0 and t_end only, as t_eval below
                tol = [] if rtol is None else ["--rtol", repr(rtol), "--output-dt", repr(t_end)]
                subprocess.run([args.cli, "run", *cli_model, "--method", method, "--dt", repr(dt), "--t-end",
                                repr(t_end), "--summary-json", summary, *tol], check=True, stderr=subprocess.DEVNULL)
                elapsed = time.perf_counter() - start
                with open(summary) as f:
                    return elapsed, json.load(f)

            def run_python():
                start = time.perf_counter()
                if rtol is None:
                    r = eci.solve(model, (0.0, t_end), method=method, dt=dt, t_eval=[t_end])
                else:
                    # the CLI's --rtol alone sets atol = rtol; eci.solve keeps SciPy's atol default: pass both
                    r = eci.solve(model, (0.0, t_end), method=method, rtol=rtol, atol=rtol, first_step=dt,
                                  t_eval=[0.0, t_end])
                return time.perf_counter() - start, r

            for rep in range(args.reps):
                if rep % 2 == 0:
                    (process, s), (python, r) = run_cli(), run_python()
                else:
                    (python, r), (process, s) = run_python(), run_cli()
                assert r.stats["steps"] == s["steps"] and r.nfev == s["rhs_evals"]
                best["process"] = min(best["process"], process)
                best["loop"] = min(best["loop"], s["wall_seconds"])
                best["python"] = min(best["python"], python)
                pairs.append(python / process)
            ratio = statistics.median(pairs)
            ok = ok and ratio <= 1.05
            label = method if rtol is None else f"{method} rtol {rtol:g}"
            print(f"{model.name:16s} {label:7s} {s['steps']:9d} {best['process']:10.3f} s {best['loop']:8.3f} s "
                  f"{best['python']:8.3f} s {ratio:6.3f}  {'met' if ratio <= 1.05 else 'MISSED'} "
                  f"(fastest runs {best['python'] / best['process']:.3f}, vs CLI loop {best['python'] / best['loop']:.3f})")
    print(f"(times: fastest of {args.reps} alternating repetitions; ratio: median of the paired ratios)")
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
