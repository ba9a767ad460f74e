# Conservation through the Python API: the conservative methods keep every invariant to round-off, with a Python
# fun (real and complex), with a built-in model, and through a user's own transform given as Python functions.
import numpy as np
import pytest

import eci
from conftest import EPS

M = eci.models
# The conservative methods that run on a plain fun (multiple relaxation and projection need a model's invariants).
CONSERVATIVE = [m.name for m in eci.methods()
                if m.conservative and m.name.split("-")[0] not in ("mrrk", "projected")]


def bound(steps):
    # Each conservative step sets psi_k^2 (or xi) to the value that keeps the invariants; its rounding, a few eps
    # relative with no preferred sign, adds up as a random walk over the steps: c eps sqrt(steps), c of order 1
    # (the C++ tests measure at most 0.4). k = 4 leaves room for the walk's spread; the +1 covers short runs.
    return 4.0 * EPS * (np.sqrt(steps) + 1.0)


def three_wave_fun(t, y):
    return np.array([y[1] * y[2], y[2] * y[0], -2.0 * y[0] * y[1]])


@pytest.mark.parametrize("method", CONSERVATIVE)
def test_python_fun_keeps_energy_and_enstrophy(method):
    model = M.ThreeWave()
    steps = 2000
    r = eci.solve(three_wave_fun, (0.0, 20.0), [1.0, 0.5, -0.3], method=method, dt=20.0 / steps,
                  invariants={"energy": lambda y: model.invariants(y)["energy"],
                              "enstrophy": lambda y: model.invariants(y)["enstrophy"]})
    assert r.stats["steps"] == steps
    for name in ("energy", "enstrophy"):
        assert r.invariants[name]["max_rel_drift"] <= bound(steps), (name, r.invariants[name])
    # and the same drift measured afterwards on the stored states
    z = model.invariants(r.y)["enstrophy"]
    assert np.max(np.abs(z - z[0])) / z[0] <= bound(steps)


def n_wave_fun(model):
    """The n-wave right-hand side in NumPy, from the model's own triads."""
    tri = np.array(model.triads)
    k, p, q = (tri[:, i].astype(int) for i in range(3))
    mk, mp, mq = tri[:, 3], tri[:, 4], tri[:, 5]

    def fun(t, y):
        d = np.zeros_like(y)
        conj = np.conj if np.iscomplexobj(y) else (lambda v: v)
        np.add.at(d, k, mk * conj(y[p] * y[q]))
        np.add.at(d, p, mp * conj(y[q] * y[k]))
        np.add.at(d, q, mq * conj(y[k] * y[p]))
        return d
    return fun


@pytest.mark.parametrize("method", ["c-pc", "c-rk4", "c-pc-compensated"])
def test_complex_python_fun_keeps_both_invariants(method):
    model = M.NWave(modes=24, triads_per_mode=4, seed=3, complex=True)
    steps = 1000
    r = eci.solve(n_wave_fun(model), (0.0, 10.0), model.default_y0, method=method, dt=0.01)
    assert r.y.dtype == np.complex128 and r.stats["steps"] == steps
    inv = model.invariants(r.y)
    for name in ("energy", "enstrophy"):
        drift = np.max(np.abs(inv[name] - inv[name][0])) / inv[name][0]
        assert drift <= bound(steps), (name, drift)
    # the conventional method on the same problem drifts far beyond that
    rk4 = eci.solve(n_wave_fun(model), (0.0, 10.0), model.default_y0, method="rk4", dt=0.01)
    e = model.invariants(rk4.y)["energy"]
    assert np.max(np.abs(e - e[0])) / e[0] > 100 * bound(steps)


@pytest.mark.parametrize("make", [lambda: M.ThreeWave(), lambda: M.NWave(), lambda: M.NWave(complex=True),
                                  lambda: M.LotkaVolterra(), lambda: M.Kepler()])
def test_every_conservative_method_of_every_model(make):
    model = make()
    steps = 2000
    # the methods built to keep this model's invariants: the conservative engine, or its transform
    for method in [m for m, family in model.method_families.items() if family in ("conservative", "transformed")]:
        r = eci.solve(model, (0.0, steps * model.default_dt), method=method, t_eval=[steps * model.default_dt])
        assert r.stats["steps"] == steps
        for name, record in r.invariants.items():
            # Kepler's Runge-Lenz components start near 0: their drift is measured against the vector's size K e.
            scale = abs(record["initial"]) if abs(record["initial"]) > 1e-3 else 1.0
            assert record["max_abs_drift"] / scale <= bound(steps), (model.name, method, name, record)


# --- a user's transform: Lotka-Volterra's H through xi = ((x - 1) - log x, mu ((y - 1) - log y)), eq. (39) -----

MU = 1.5


def lv_fun(t, s):
    x, y = s
    return np.array([-MU * x * (1.0 - y), y * (1.0 - x)])


def g(v):
    return (v - 1.0) - np.log(v)


def invert_g(target, hint):
    """v with g(v) = target on the branch of hint (v >= 1 or v <= 1), by Newton in v or log v; None if none."""
    if not target >= 0.0:
        return None, 0
    v = hint if abs(hint - 1.0) > 1e-3 else (1.0 + np.sqrt(2 * target) * (1 if hint >= 1 else -1))
    for it in range(1, 60):
        if hint >= 1.0:
            step = (g(v) - target) * v / (v - 1.0)
            v = max(v - step, 1.0)
        else:
            w = np.log(v)
            step = (np.expm1(w) - w - target) / np.expm1(w)
            v = np.exp(min(w - step, 0.0))
            step *= v
        if abs(step) <= 4 * EPS * v:
            return v, it
    return None, 60


def lv_inverse(xi, hint):
    x, ix = invert_g(xi[0], hint[0])
    y, iy = invert_g(xi[1] / MU, hint[1])
    if x is None or y is None:
        return None
    return np.array([x, y]), ix + iy


LV_TRANSFORM = eci.Transform(
    forward=lambda s: np.array([g(s[0]), MU * g(s[1])]),
    inverse=lv_inverse,
    rate=lambda s, f: np.array([MU * (s[0] - 1.0) * (s[1] - 1.0), -MU * (s[0] - 1.0) * (s[1] - 1.0)]))

LV_TRANSFORM_BY_JACOBIAN = eci.Transform(
    forward=LV_TRANSFORM.forward, inverse=lv_inverse,
    jacobian=lambda s: np.array([[1.0 - 1.0 / s[0], 0.0], [0.0, MU * (1.0 - 1.0 / s[1])]]))


@pytest.mark.parametrize("transform", [LV_TRANSFORM, LV_TRANSFORM_BY_JACOBIAN], ids=["rate", "jacobian"])
@pytest.mark.parametrize("method", ["c-pc", "c-rk2", "c-rk4"])
def test_user_transform_keeps_a_hamiltonian_that_is_not_a_sum_of_squares(transform, method):
    model = M.LotkaVolterra(mu=MU)
    steps = 1000
    H = lambda s: model.invariants(s)["hamiltonian"]  # noqa: E731
    r = eci.solve(lv_fun, (0.0, 20.0), [1.0, 0.4], method=method, dt=0.02, transform=transform,
                  invariants={"H": H})
    assert r.stats["steps"] == steps and r.stats["solver_solves"] > 0
    assert r.invariants["H"]["max_rel_drift"] <= bound(steps), r.invariants["H"]
    # The built-in transform of the same model follows the same orbit: both inverses converge to round-off, by
    # different Newton paths, so each step may differ by a few eps; on this non-chaotic orbit that grows at most
    # linearly (measured: at most 127 eps over the 1000 steps).
    ref = eci.solve(model, (0.0, 20.0), [1.0, 0.4], method=method, dt=0.02)
    assert np.max(np.abs(r.y - ref.y)) <= EPS * steps * np.max(np.abs(ref.y))
    # while the conventional method drifts
    rk = eci.solve(lv_fun, (0.0, 20.0), [1.0, 0.4], method=method.replace("c-", ""), dt=0.02, invariants={"H": H})
    assert rk.invariants["H"]["max_rel_drift"] > 100 * bound(steps)


# A quadratic system is free of scale: if y(t) solves it, so does a y(a t). With a = 2^k, the state times a and
# every time over a, each product a method forms is the unscaled run's times a power of two, exactly, so the run is
# the unscaled run times a, bit for bit, while nothing leaves the range of double. The conservative methods' rate of
# psi^2 (sum 2 b Y S, cubic in the scale) overflowed at 2^400 and underflowed at 2^-400, where C-RK4 and the
# conservative pairs silently left the state unchanged; the relaxation and projection methods failed or stopped
# their Newton early (docs/methods.md, "Across the range of double"; the C++ test EveryMethodAcrossTheRange runs
# every method of the library). Here through both Python paths: a built-in model (the run in C++) and a NumPy fun.
SCALED_ON_MODEL = ["rk4", "c-rk2", "c-rk4", "c-pc-compensated", "c-dp54", "rrk-rk4", "mrrk-rk4", "projected-rk4"]
SCALED_ON_FUN = ["c-rk4", "c-pc-compensated", "c-dp54"]


def scaled_pair(fun, method, k, adaptive):
    a = 2.0 ** k
    y0 = np.array([1.0, 0.5, -0.3])
    times = np.linspace(0.3, 3.0, 10)

    def run(s):
        if adaptive:  # the first step given (the initial-step rule takes a root of a scaled quantity: not exact)
            return eci.solve(fun, (0.0, 3.0 / s), y0 * s, method=method, rtol=1e-8, atol=1e-8 * s, t_eval=times / s,
                             first_step=1e-3 / s)
        return eci.solve(fun, (0.0, 3.0 / s), y0 * s, method=method, dt=0.01 / s)
    return run(1.0), run(a), a


@pytest.mark.parametrize("k", [-400, 400])
@pytest.mark.parametrize("method", SCALED_ON_MODEL)
def test_a_scaled_run_of_a_model_is_the_run_scaled(method, k):
    for adaptive in (False, True) if method == "c-dp54" else (False,):
        r, s, a = scaled_pair(M.ThreeWave(), method, k, adaptive)
        assert r.success and s.success, (r.message, s.message)
        assert r.nfev == s.nfev and np.array_equal(s.t * a, r.t)
        assert np.array_equal(s.y / a, r.y), (method, adaptive, np.max(np.abs(s.y / a - r.y)))


@pytest.mark.parametrize("k", [-400, 400])
@pytest.mark.parametrize("method", SCALED_ON_FUN)
def test_a_scaled_run_of_a_numpy_fun_is_the_run_scaled(method, k):
    for adaptive in (False, True) if method == "c-dp54" else (False,):
        r, s, a = scaled_pair(three_wave_fun, method, k, adaptive)
        assert r.success and s.success, (r.message, s.message)
        assert r.nfev == s.nfev and np.array_equal(s.t * a, r.t)
        assert np.array_equal(s.y / a, r.y), (method, adaptive, np.max(np.abs(s.y / a - r.y)))
