"""Built-in models whose right-hand side and whole integration run in C++ (eci.solve(model, t_span)).

Each is callable as model(t, y) (SciPy's fun, so it can be compared with scipy.integrate.solve_ivp directly),
evaluates its invariants with model.invariants(y), and carries the CLI's defaults: default_y0, default_dt,
default_t_end and the methods it accepts. Invalid parameters raise ValueError with the CLI's message.
"""

from ._eci import Kepler, LotkaVolterra, Model, ThreeWave
from ._eci import NWave as _NWaveReal
from ._eci import NWaveComplex as _NWaveComplex

__all__ = ["Model", "ThreeWave", "NWave", "LotkaVolterra", "Kepler"]


def NWave(modes=30, triads_per_mode=20, seed=1, complex=False):
    """A random n-wave system (paper §III.C): `modes` real (or, with complex=True, complex) modes, each in about
    `triads_per_mode` triads obeying eqs. (2)-(3); triads_per_mode=1 gives independent triads. The system and its
    default initial condition are drawn from `seed` by a portable generator: the same as `eci run n-wave --seed`."""
    cls = _NWaveComplex if complex else _NWaveReal
    return cls(modes=modes, triads_per_mode=triads_per_mode, seed=seed)
