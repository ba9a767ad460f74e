"""Example: two co-rotating vortices merge in the inviscid 2-D Euler equations (eci.models.NavierStokes2D, FFTW),
stepped by conservative C-RK4 at CFL 0.5: energy and enstrophy stay at round-off while the vortices wind up.

    python3 examples/python/vortex_merger.py [figure.png]

Exits non-zero if E or Z drifts beyond round-off. Needs eci built with eci::spectral (FFTW3).
"""
import math
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import eci  # noqa: E402

out = sys.argv[1] if len(sys.argv) > 1 else "vortex_merger.png"
model = eci.models.NavierStokes2D(n=64)  # inviscid, unforced
w0 = model.vortex_pair(radius=0.3, separation=0.9, peak=10.0)
dt = model.cfl_step(w0)  # CFL 0.5, as `eci run navier-stokes-2d`
steps = 240
times = [k * 60 * dt for k in range(5)]
r = eci.solve(model, (0.0, steps * dt), w0, method="c-rk4", dt=dt, t_eval=times)

fig, axes = plt.subplots(1, len(times), figsize=(3 * len(times), 3.2))
for ax, t, w in zip(axes, r.t, r.y.T):
    ax.imshow(model.to_physical(w), origin="lower", cmap="RdBu_r", extent=(0, 2 * math.pi, 0, 2 * math.pi))
    ax.set_title(f"t = {t:.2f}")
    ax.set_xticks([]), ax.set_yticks([])
e, z = r.invariants["energy"], r.invariants["enstrophy"]
fig.suptitle(f"vortex merger, n = 64, C-RK4 {steps} steps: drift E {e['max_rel_drift']:.1e}, "
             f"Z {z['max_rel_drift']:.1e}")
fig.tight_layout()
fig.savefig(out, dpi=100)
print(f"{steps} steps of dt = {dt:.4g}: energy drift {e['max_rel_drift']:.2e}, enstrophy {z['max_rel_drift']:.2e}; "
      f"figure {out}")

# round-off: 8 eps per step as a random walk (tests/spectral/test_navier_stokes_2d.cpp)
bound = 8 * np.finfo(float).eps * math.sqrt(steps + 2 * r.stats["rejected_steps"]["step_failed"])
sys.exit(0 if max(e["max_rel_drift"], z["max_rel_drift"]) <= bound else 1)
