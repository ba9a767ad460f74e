# SciPy's solve_ivp (RK45, the default) drifts on conservative problems where eci's conservative methods keep the
# invariants to round-off: the same fun, the same interval, side by side.
import numpy as np
from scipy.integrate import solve_ivp

import eci
from conftest import EPS


def bound(steps):
    return 4.0 * EPS * (np.sqrt(steps) + 1.0)  # the random walk of the rounding, as in test_conservation.py


def relative_drift(values):
    return np.max(np.abs(values - values[0])) / abs(values[0])


def test_lotka_volterra_rk45_drifts_c_rk4_does_not():
    lv = eci.models.LotkaVolterra()  # callable as fun(t, y): SciPy integrates the very same right-hand side
    t_end, dt = 2000.0, 0.02
    scipy = solve_ivp(lv, (0.0, t_end), lv.default_y0, method="RK45", rtol=1e-6, atol=1e-9)
    assert scipy.success
    scipy_drift = relative_drift(lv.invariants(scipy.y)["hamiltonian"])
    r = eci.solve(lv, (0.0, t_end), method="c-rk4", dt=dt, t_eval=[t_end])
    steps = r.stats["steps"]
    eci_drift = r.invariants["hamiltonian"]["max_rel_drift"]
    print(f"\nLotka-Volterra t = {t_end}: RK45 (rtol 1e-6, {scipy.nfev} evaluations) H drift {scipy_drift:.2e}; "
          f"eci c-rk4 ({r.nfev} evaluations) {eci_drift:.2e}")
    assert eci_drift <= bound(steps)
    assert scipy_drift > 1000 * bound(steps)


def three_wave(t, y):
    return np.array([y[1] * y[2], y[2] * y[0], -2.0 * y[0] * y[1]])


def test_three_wave_python_fun_rk45_drifts_c_pc_does_not():
    model = eci.models.ThreeWave()
    t_end, dt = 500.0, 0.02
    scipy = solve_ivp(three_wave, (0.0, t_end), model.default_y0, rtol=1e-6, atol=1e-9)
    r = eci.solve(three_wave, (0.0, t_end), model.default_y0, method="c-pc", dt=dt)
    steps = r.stats["steps"]
    for name in ("energy", "enstrophy"):
        scipy_drift = relative_drift(model.invariants(scipy.y)[name])
        eci_drift = relative_drift(model.invariants(r.y)[name])
        print(f"\nthree-wave t = {t_end}, {name}: RK45 drift {scipy_drift:.2e} ({scipy.nfev} evaluations); "
              f"eci c-pc {eci_drift:.2e} ({r.nfev} evaluations)")
        assert eci_drift <= bound(steps)
        assert scipy_drift > 1000 * bound(steps)
