"""Example: forced 2-D turbulence kept in a checkpoint and continued, as a long run on a cluster's time limit is.

A stochastically forced Navier-Stokes run (white-in-time forcing at injection rate 0.1, viscosity and drag) goes
to t = 4 keeping a checkpoint (eci run's format: `eci run navier-stokes-2d --restart run.h5` continues it too); a
second call continues it from the file to t = 8. The two parts equal one run to t = 8 bit for bit, and the energy
budget closes: E(8) - E(0) = injected - dissipated.

    python3 examples/python/forced_turbulence_restart.py [figure.png]

Exits non-zero if the joined run differs from the single one, or the budget does not close to round-off. Needs eci
built with eci::spectral (FFTW3) and HDF5.
"""
import math
import os
import sys
import tempfile

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import eci  # noqa: E402

out = sys.argv[1] if len(sys.argv) > 1 else "forced_turbulence_restart.png"
settings = dict(n=64, nu=2e-3, drag=0.05, forcing="stochastic", forcing_k=6, injection_rate=0.1)
y0 = eci.models.NavierStokes2D(**settings).random_field(seed=7)
dt = 5e-3

with tempfile.TemporaryDirectory() as d:
    path = os.path.join(d, "run.h5")
    first = eci.solve(eci.models.NavierStokes2D(**settings), (0.0, 4.0), y0, method="c-rk4", dt=dt,
                      output_dt=0.05, checkpoint=path, checkpoint_every=200)
    c = eci.load_checkpoint(path)  # the model (settings, plans, forcing generator), state, step and totals
    print(c)
    second = eci.restart(path, 8.0, output_dt=0.05)  # continued in place: run.h5 now holds t = 8
    totals = eci.load_checkpoint(path)
whole = eci.solve(eci.models.NavierStokes2D(**settings), (0.0, 8.0), y0, method="c-rk4", dt=dt, output_dt=0.05)

same = np.array_equal(second.y[:, -1], whole.y[:, -1]) and np.array_equal(first.y[:, -1], c.y)
# E(8) - E(0) against what the forcing put in and the viscosity and drag took out, since step 0
e0, e1 = totals.initial[0], whole.invariants["energy"]["final"]
injected, dissipated = totals.budget[0], totals.budget[1]
residual = abs(e1 - e0 - (injected - dissipated)) / e1
steps = totals.step
print(f"joined run equals the single run bit for bit: {same}; energy {e0:.4g} -> {e1:.4g}, injected "
      f"{injected:.4g}, dissipated {dissipated:.4g}, budget residual {residual:.1e} over {steps} steps")

fig, (ax, im) = plt.subplots(1, 2, figsize=(11, 4.2), gridspec_kw={"width_ratios": (1.4, 1.0)})
ax.plot(whole.t, whole.invariant_values["energy"], color="0.7", lw=4, label="one run to t = 8")
ax.plot(first.t, first.invariant_values["energy"], label="eci.solve(..., checkpoint=) to t = 4")
ax.plot(second.t, second.invariant_values["energy"], "--", label="eci.restart(file, 8)")
ax.set_xlabel("t")
ax.set_ylabel("energy")
ax.legend()
ax.grid(True)
field = eci.models.NavierStokes2D(**settings).to_physical(second.y[:, -1])
big = np.abs(field).max()
image = im.imshow(field, origin="lower", cmap="RdBu_r", vmin=-big, vmax=big,
                  extent=(0, 2 * math.pi, 0, 2 * math.pi))
im.set_title("vorticity at t = 8")
fig.colorbar(image, ax=im, shrink=0.8)
fig.suptitle("forced turbulence, n = 64, C-RK4: kept in a checkpoint at t = 4 and continued")
fig.tight_layout()
fig.savefig(out, dpi=100)

# per step the budget closes to a few eps of E (errata item 9); over the run the residuals add as a random walk
bound = 16 * np.finfo(float).eps * math.sqrt(steps)
sys.exit(0 if same and residual <= bound else 1)
