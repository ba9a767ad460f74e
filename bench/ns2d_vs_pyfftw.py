#!/usr/bin/python3
"""eci's navier-stokes-2d step against the pyFFTW script bench/ns2d_pyfftw.py, side by side in one run.
Usage: bench/ns2d_vs_pyfftw.py --bench BUILD/bench/eci_bench_ns2d_step --eci BUILD/eci [--sizes 256,512,1024]
           [--threads 1,2] [--rounds 3] [--reps 5] [--out DIR] [--no-memory]
For each N and thread count, `rounds` rounds each run eci_bench_ns2d_step and the script in both forms of the
nonlinear term, in a rotating order so that load from other processes hits all alike; each program steps the same
field (eci's random field, k_p = N/16, nu = 1e-4; the script's is that field after one RK4 step, which is all an eci
checkpoint can hold) at the same dt (the bench's, CFL 0.5) from the same state `reps` times and keeps its fastest
step; the table takes the fastest of the rounds. One thread: process CPU time; two: wall time (as the bench does).
Peak memory: /usr/bin/time's maximum resident set of `eci run --method c-rk4` over that of a run at N = 8 with no
step (the process), in states of N (N/2 + 1) complex doubles; "stepping" is over a run at the same N with no step.
Prints ready-to-paste markdown tables.
"""
import argparse, os, re, subprocess, sys, tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
PY = "/usr/bin/python3"


def fields(line):
    return dict(kv.split("=", 1) for kv in line.split()[1:] if "=" in kv)


def run_lines(cmd):
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode:
        sys.exit("ns2d_vs_pyfftw: %s failed:\n%s" % (" ".join(cmd), r.stderr))
    return r.stdout.splitlines()


def rows_of(lines, prefix):
    return [fields(l) for l in lines if l.startswith(prefix + " ")]


def run_rows(cmd, prefix):
    return rows_of(run_lines(cmd), prefix)


def peak_kib(cmd):
    r = subprocess.run(["/usr/bin/time", "-f", "peak_kib=%M"] + cmd, check=True, capture_output=True, text=True)
    return int(re.findall(r"peak_kib=(\d+)", r.stderr)[-1])


def eci_run(eci, n, steps, extra, out):
    return [eci, "run", "navier-stokes-2d", "--N", str(n), "--nu", "1e-4", "--k-peak", str(n / 16), "--steps",
            str(steps), "--fftw-wisdom", os.path.join(out, "eci-wisdom")] + extra


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--bench", required=True, help="eci_bench_ns2d_step")
    p.add_argument("--eci", required=True, help="the eci CLI")
    p.add_argument("--sizes", default="256,512,1024")
    p.add_argument("--threads", default="1,2")
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--reps", type=int, default=5)
    p.add_argument("--out", help="directory of the fields and wisdom files (default: a temporary one)")
    p.add_argument("--no-memory", action="store_true")
    a = p.parse_args()
    sizes = [int(s) for s in a.sizes.split(",")]
    threads = [int(t) for t in a.threads.split(",")]
    tmp = None if a.out else tempfile.TemporaryDirectory()
    out = a.out or tmp.name
    os.makedirs(out, exist_ok=True)
    rows, mem = [], []
    load0 = os.getloadavg()
    for n in sizes:
        # eci's random field, the one eci_bench_ns2d_step steps, after one RK4 step (eci checkpoints after steps)
        field = os.path.join(out, "field-%d.h5" % n)
        run_rows(eci_run(a.eci, n, 1, ["--method", "rk4", "--checkpoint-every", "1", "--checkpoint", field], out), "")
        for t in threads:
            progs = {
                "eci": [a.bench, str(n), str(t), str(a.reps), os.path.join(out, "eci-wisdom")],
                "eci-form": [PY, os.path.join(HERE, "ns2d_pyfftw.py"), "time", "--field", field, "--threads", str(t),
                             "--reps", str(a.reps), "--form", "eci", "--wisdom", os.path.join(out, "py-wisdom")],
            }
            progs["basdevant"] = progs["eci-form"][:-3] + ["basdevant", "--wisdom", os.path.join(out, "py-wisdom")]
            best = {}
            paired = []  # the bench's ratios paired in time (ns2d-paired: medians over its rounds), one per run
            sequential = []  # the same with each stepper continuing its own trajectory (ns2d-sequential)
            order = list(progs)
            for r in range(a.rounds):
                for name in order[r % 3:] + order[:r % 3]:
                    if name != "eci" and "--dt" not in progs[name]:
                        progs[name] += ["--dt", best["eci"]["dt"]]  # the bench's dt: CFL 0.5 of the field at step 0
                    lines = run_lines(progs[name])
                    row = rows_of(lines, "ns2d-step" if name == "eci" else "ns2d-pyfftw")[0]
                    if name == "eci":
                        paired += rows_of(lines, "ns2d-paired")
                        sequential += rows_of(lines, "ns2d-sequential")
                    prev = best.get(name)
                    if name == "eci":
                        # each time the fastest of this run's (the bench's own rounds already take minima)
                        best[name] = row if prev is None else {k: (str(min(float(prev[k]), float(row[k])))
                                                                   if k in ("rk4", "c_rk4", "fft_rk4_step", "fft_one")
                                                                   else row[k]) for k in row}
                    else:
                        best[name] = row if prev is None or float(row["rk4"]) < float(prev["rk4"]) else prev
            e, s4, s5 = best["eci"], best["basdevant"], best["eci-form"]
            crk4, rk4, fft = float(e["c_rk4"]), float(e["rk4"]), float(e["fft_rk4_step"])
            equiv = fft / 4 / float(e["fft_one"]) if "fft_one" in e else float("nan")
            def med(key, runs=paired):
                return sorted(float(q[key]) for q in runs)[len(runs) // 2] if runs else float("nan")
            rows.append(dict(n=n, t=t, clock=e["clock"], crk4=crk4, rk4=rk4, fft=fft, equiv=equiv,
                             p_fft=med("c_rk4/fft"), p_rk4=med("c_rk4/rk4"),
                             q_fft=med("c_rk4/fft", sequential), q_rk4=med("c_rk4/rk4", sequential),
                             s4=float(s4["rk4"]), s5=float(s5["rk4"]), s4_mem=s4.get("peak_states", "?"),
                             dt_eci=e.get("dt", "?"), dt_py=s4["dt"]))
            print("ns2d-vs-pyfftw N=%d threads=%d clock=%s eci_c_rk4=%.4g eci_rk4=%.4g eci_fft=%.4g "
                  "script_basdevant=%.4g script_eci_form=%.4g c_rk4/script_basdevant=%.3f c_rk4/script_eci_form=%.3f "
                  "c_rk4/fft=%.3f c_rk4/rk4=%.3f paired_c_rk4/fft=%.3f paired_c_rk4/rk4=%.3f "
                  "sequential_c_rk4/fft=%.3f sequential_c_rk4/rk4=%.3f eci_fft_equiv_per_rhs=%.2f "
                  "dt_eci=%s dt_script=%s" % (
                      n, t, e["clock"], crk4, rk4, fft, float(s4["rk4"]), float(s5["rk4"]),
                      crk4 / float(s4["rk4"]), crk4 / float(s5["rk4"]), crk4 / fft, crk4 / rk4, rows[-1]["p_fft"],
                      rows[-1]["p_rk4"], rows[-1]["q_fft"], rows[-1]["q_rk4"], equiv, e.get("dt", "?"), s4["dt"]),
                  file=sys.stderr, flush=True)
        if not a.no_memory:
            state_kib = 16 * n * (n // 2 + 1) / 1024
            base = peak_kib(eci_run(a.eci, 8, 0, [], out))
            zero = peak_kib(eci_run(a.eci, n, 0, ["--method", "c-rk4"], out))
            run = peak_kib(eci_run(a.eci, n, 3, ["--method", "c-rk4"], out))
            mem.append(dict(n=n, total=(run - base) / state_kib, stepping=(run - zero) / state_kib,
                            script=rows[-1]["s4_mem"] if rows else "?"))
            print("ns2d-vs-pyfftw-memory N=%d peak_kib=%d no_step_kib=%d process_kib=%d states=%.2f "
                  "stepping_states=%.2f" % (n, run, zero, base, mem[-1]["total"], mem[-1]["stepping"]),
                  file=sys.stderr, flush=True)
    # The transforms eci performs are the same with any number of threads; the one-thread row measures their count
    # best (with two threads on a loaded machine, a single transform's wall time is noise).
    per_rhs = {r["n"]: r["equiv"] for r in rows if r["t"] == 1}
    print("Load average (1, 5, 15 min) at the start %.2f %.2f %.2f, at the end %.2f %.2f %.2f; %d rounds of %d "
          "repetitions, fastest counts." % (load0 + os.getloadavg() + (a.rounds, a.reps)))
    print()
    print("| N | threads | clock | eci C-RK4 (s) | eci RK4 (s) | eci FFTs (s) | script Basdevant (s) "
          "| script eci form (s) | C-RK4 / script Basdevant | C-RK4 / script eci form | C-RK4 / FFTs | C-RK4 / RK4 "
          "| C-RK4 / FFTs, paired | C-RK4 / RK4, paired | C-RK4 / FFTs, sequential | C-RK4 / RK4, sequential "
          "| eci FFTs per RHS, in one-transform times (1 thread) |")
    print("|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        print("| %d | %d | %s | %.4g | %.4g | %.4g | %.4g | %.4g | %.3f | %.3f | %.3f | %.3f | %.3f | %.3f | %.3f "
              "| %.3f | %.2f |" % (
                  r["n"], r["t"], r["clock"], r["crk4"], r["rk4"], r["fft"], r["s4"], r["s5"], r["crk4"] / r["s4"],
                  r["crk4"] / r["s5"], r["crk4"] / r["fft"], r["crk4"] / r["rk4"], r["p_fft"], r["p_rk4"],
                  r["q_fft"], r["q_rk4"], per_rhs.get(r["n"], r["equiv"])))
    print()
    print("C-RK4 / FFTs and C-RK4 / RK4 above: the fastest times of each, taken at different moments. Paired: each "
          "round of eci_bench_ns2d_step times the transforms, a C-RK4 step and an RK4 step one after the other, and "
          "the median of the rounds' ratios counts (the median over this driver's rounds of those medians), each "
          "step from a fresh copy of the same field. Sequential: the same, each stepper continuing its own "
          "trajectory, as a run steps (the state the previous step wrote, no copy before a step).")
    if mem:
        print()
        print("| N | eci C-RK4 run, peak over the process (states) | of which stepping (states) "
              "| script Basdevant, solver arrays (states) |")
        print("|---:|---:|---:|---:|")
        for m in mem:
            print("| %d | %.2f | %.2f | %s |" % (m["n"], m["total"], m["stepping"], m["script"]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
