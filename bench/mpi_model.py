#!/usr/bin/env python3
"""Ratios from bench/mpi.sh's measurements, and a model of the step at many ranks built from them.

Usage: mpi_model.py RAW [--nodes-cores 32] [--bandwidth 12.5e9] [--latency 1.5e-6]

RAW holds eci_bench_mpi_step's lines (N=.. ranks=.. threads=.. layout=.. crk4=.. [crk4_paper=..] rk4=.. transforms=.. transposes=..);
layout is serial, mpi, or mpi-nocma (2 ranks with Open MPI's single-copy mechanism off).

The model (stated in docs/benchmarks.md, "MPI"): a C-RK4 step of an N x N grid on P ranks costs
    T(N, P) = [16 c_fft N^2 log2(N^2) + c_pt N^2] / P + 16 t_vol(N, P) + M a (P - 1)
  - 16 two-dimensional transforms per step (4 right-hand sides, Basdevant's 2 inverse + 2 forward each);
  - c_fft: seconds per point and log2 of a transform's local work, from the 1-rank run (its transforms);
    c_pt: the rest of the step (pointwise passes, the stepper's combinations) per point;
  - t_vol: the volume of one field's all-to-all: only the K = kmax + 1 = N/3 retained columns travel, an N x K
    complex block split evenly. Each rank sends (P - 1)/P of its 16 N K / P bytes V_rank; ranks share a node's
    injection bandwidth B in groups of `cores`, so the off-node part of the volume costs
    cores V_rank (P - cores) / (P - 1) / B; the on-node part moves through shared memory at the per-rank rate b
    measured by the 2-rank run here (its all-to-alls' volume over their time):
    t_vol = V_rank (min(P, cores) - 1) / (P - 1) / b + cores V_rank (P - cores)^+ / (P - 1) / B;
  - every all-to-all sends one message per field to each of the P - 1 other ranks, latency a each: M = 16
    messages per peer per step (8 all-to-alls of 2 fields).
  - slab decomposition: every rank needs a retained column, P <= K = N/3 (beyond it, pencils).
"""
import math
import re
import sys


def parse(path):
    rows = []
    for line in open(path):
        if not line.startswith("N="):
            continue
        d = dict(kv.split("=") for kv in line.split())
        for k in ("N", "ranks", "threads"):
            d[k] = int(d[k])
        for k in ("crk4", "crk4_paper", "rk4", "transforms", "transposes"):
            if k in d:  # (crk4_paper: since the conditioned update runs distributed)
                d[k] = float(d[k])
        rows.append(d)
    return rows


def pick(rows, n, ranks, threads, layout):
    for r in rows:
        if (r["N"], r["ranks"], r["threads"], r["layout"]) == (n, ranks, threads, layout):
            return r
    return None


def main(argv):
    args = argv[1:]
    opts = {"--nodes-cores": 32.0, "--bandwidth": 12.5e9, "--latency": 1.5e-6}
    path = None
    messages = 16  # messages per peer per step: 8 all-to-alls (one each way per right-hand side) of 2 fields
    while args:
        a = args.pop(0)
        if a in opts:
            opts[a] = float(args.pop(0))
        elif path is None:
            path = a
        else:
            sys.exit(f"mpi_model.py: unexpected argument {a}")
    if path is None:
        sys.exit("usage: mpi_model.py RAW [--nodes-cores C] [--bandwidth B] [--latency A]")
    rows = parse(path)
    cores, bw, lat = opts["--nodes-cores"], opts["--bandwidth"], opts["--latency"]

    print("\n| N | C-RK4: 2 ranks / 1 rank (speed-up, target >= 1.6) | RK4 speed-up | 1-rank MPI / serial, 1 thread "
          "(target <= 1.05) | 1-rank MPI / serial, 2 threads | 2 ranks / serial 2 threads (speed-up) | 1-rank step / "
          "its transforms | 2 ranks: transposes / transforms |")
    print("|---|---|---|---|---|---|---|---|")
    fit = None
    for n in sorted({r["N"] for r in rows}):
        s1, m1 = pick(rows, n, 1, 1, "serial"), pick(rows, n, 1, 1, "mpi")
        s2, m12 = pick(rows, n, 1, 2, "serial"), pick(rows, n, 1, 2, "mpi")
        m2 = pick(rows, n, 2, 1, "mpi")
        if not (s1 and m1 and m2):
            continue
        cells = [f"{m1['crk4'] / m2['crk4']:.2f}", f"{m1['rk4'] / m2['rk4']:.2f}", f"{m1['crk4'] / s1['crk4']:.3f}",
                 f"{m12['crk4'] / s2['crk4']:.3f}" if s2 and m12 else "-",
                 f"{s2['crk4'] / m2['crk4']:.2f}" if s2 else "-", f"{m1['crk4'] / m1['transforms']:.2f}",
                 f"{m2['transposes'] / m2['transforms']:.2f}"]
        print(f"| {n} | " + " | ".join(cells) + " |")
        print(f"|   | seconds: serial {s1['crk4']:.4g}, 1 rank {m1['crk4']:.4g}, 2 ranks {m2['crk4']:.4g} "
              f"(transforms {m2['transforms']:.4g}, transposes {m2['transposes']:.4g}) | | | | | | |")
        if "crk4_paper" in m1 and "crk4_paper" in m2:
            print(f"|   | the paper's update: 1 rank / 2 ranks {m1['crk4_paper'] / m2['crk4_paper']:.2f}; the conditioned "
                  f"update costs {m1['crk4'] / m1['crk4_paper']:.3f} (1 rank), {m2['crk4'] / m2['crk4_paper']:.3f} "
                  f"(2 ranks) x the paper's | | | | | | |")
        nc = pick(rows, n, 2, 1, "mpi-nocma")
        if nc:
            print(f"|   | 2 ranks without the single-copy mechanism (layout=mpi-nocma): C-RK4 {nc['crk4']:.4g} s, "
                  f"speed-up {m1['crk4'] / nc['crk4']:.2f}, transforms {nc['transforms']:.4g}, transposes "
                  f"{nc['transposes']:.4g} | | | | | | |")
        points = float(n) * n
        c_fft = (m1["transforms"] - m1["transposes"]) / (16 * points * math.log2(points))
        c_pt = (m1["crk4"] - m1["transforms"]) / points
        v2 = 16.0 * n * ((n - 1) // 3 + 1) / 2 / 2  # bytes a rank sends in one field's 2-rank all-to-all
        fit = (n, c_fft, c_pt, v2 / (m2["transposes"] / 16))
    if fit is None:
        print("(no complete set of 1- and 2-rank rows)")
        return 0

    n0, c_fft, c_pt, shm = fit
    print(f"\nModel from N = {n0}: c_fft = {c_fft:.3g} s per point per log2, c_pt = {c_pt:.3g} s per point, "
          f"on-node transpose {shm / 1e9:.2f} GB/s per rank (measured); network (assumed): {cores:.0f} ranks per node "
          f"sharing {bw / 1e9:.1f} GB/s, {lat * 1e6:.1f} us per message; {messages} messages per peer per step "
          f"(8 all-to-alls of the retained columns of 2 fields)")
    print("\n| N | P | compute s/step | all-to-all s/step | step s | parallel efficiency | state per rank |")
    print("|---|---|---|---|---|---|---|")
    for n in (8192, 16384, 32768, 65536):
        points = float(n) * n
        for p in (16, 64, 256, 1024, 4096):
            kept = (n - 1) // 3 + 1
            if p > kept:
                print(f"| {n} | {p} | slab limit: P > N/3 ranks would hold no retained column (pencils needed) "
                      "| | | | |")
                continue
            compute = (16 * c_fft * points * math.log2(points) + c_pt * points) / p
            v_rank = 16.0 * n * kept / p * (p - 1) / p
            off_node = max(p - cores, 0.0) / (p - 1)
            on_node = (min(p, cores) - 1) / (p - 1)
            a2a = 16 * (v_rank * on_node / shm + min(cores, p) * v_rank * off_node / bw) + messages * lat * (p - 1)
            step = compute + a2a
            state = 16.0 * (2 * kept - 1) * kept / p
            print(f"| {n} | {p} | {compute:.3g} | {a2a:.3g} | {step:.3g} | {compute / step:.2f} | "
                  f"{state / 2**20:.0f} MiB |")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
