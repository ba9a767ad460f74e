# The models' named presets (the paper's set-ups, as `eci run MODEL --preset NAME`) and Kahan's method on a Python
# fun with its Jacobian (jac=, SciPy's convention).
import math

import numpy as np
import pytest

import eci
from conftest import EPS
from test_cli_agreement import cli_run

M = eci.models


def test_presets_list_the_cli_set_ups():
    names = [p.name for p in M.ThreeWave.presets()]
    assert names == ["standard", "fig1", "fig2", "fig5"]
    p = M.ThreeWave.preset("fig2")
    assert (p.method, p.dt, p.t_end) == ("c-pc", 0.2, 10.0)
    assert np.allclose(p.y0, [math.sqrt(1.5), 0.0, math.sqrt(1.5)], rtol=0, atol=0)
    assert isinstance(p.model, M.ThreeWave) and "Fig" in p.description
    assert [q.name for q in M.LotkaVolterra.presets()] and [q.name for q in M.Kepler.presets()]
    assert M.NWave.presets()[0].name == "standard" and M.NWave.presets(complex=True)[0].model.name == "n-wave-complex"
    with pytest.raises(ValueError, match=r"unknown preset 'fig9' \(presets: standard, fig1, fig2, fig5\)"):
        M.ThreeWave.preset("fig9")


@pytest.mark.parametrize("model, preset", [("three-wave", "fig2"), ("kepler", None)])
def test_preset_solve_is_the_cli_preset_run(cli, tmp_path, model, preset):
    cls = {"three-wave": M.ThreeWave, "kepler": M.Kepler}[model]
    p = cls.preset(preset) if preset else cls.presets()[-1]
    t, columns, summary = cli_run(cli, tmp_path, model, p.method, p.dt, p.t_end, "--preset", p.name)
    r = p.solve()
    assert np.array_equal(r.t, t)
    assert r.stats["steps"] == summary["steps"] and r.nfev == summary["rhs_evals"]
    state_columns = [c for c in columns if c != "t"][: r.y.shape[0]]
    for i, name in enumerate(state_columns):
        assert np.array_equal(r.y[i], columns[name]), name
    # overrides: another method on the same set-up
    assert p.solve(method="rk4").method == "rk4"


def three_wave_fun(t, y):
    return np.array([1.0 * y[1] * y[2], 1.0 * y[2] * y[0], -2.0 * y[0] * y[1]])


def three_wave_jac(t, y):
    return np.array([[0.0, y[2], y[1]], [y[2], 0.0, y[0]], [-2.0 * y[1], -2.0 * y[0], 0.0]])


def lv_fun(t, y, mu=1.5):
    """Eq. (36), written as the C++ model writes it (same operations, same order)."""
    return np.array([-mu * y[0] * (1.0 - y[1]), y[1] * (1.0 - y[0])])


def lv_jac(t, y, mu=1.5):
    return np.array([[-mu * (1.0 - y[1]), mu * y[0]], [-y[1], 1.0 - y[0]]])


def test_kahan_with_python_jac_matches_the_model_bit_for_bit(cli, tmp_path):
    # Lotka-Volterra is the model with a Jacobian (Kahan's method is symplectic there, Sanz-Serna)
    t, columns, summary = cli_run(cli, tmp_path, "lotka-volterra", "kahan", 0.05, 20.0)
    y0 = M.LotkaVolterra().default_y0
    r = eci.solve(lv_fun, (0.0, 20.0), y0, method="kahan", dt=0.05, jac=lv_jac)
    assert r.method == "kahan" and np.array_equal(r.t, t)
    for i, name in enumerate(["x", "y"]):
        assert np.array_equal(r.y[i], columns[name]), name
    assert r.nfev == summary["rhs_evals"]
    m = eci.solve(M.LotkaVolterra(), (0.0, 20.0), method="kahan", dt=0.05)
    assert np.array_equal(m.y, r.y)


def test_kahan_is_second_order_with_a_constant_jacobian():
    # y' = A y (linear): Kahan's method is the trapezoidal rule; error at t = 1 falls by 4 per halving of dt
    A = np.array([[0.0, 1.0], [-1.0, 0.0]])
    errors = []
    for dt in (0.1, 0.05, 0.025):
        r = eci.solve(lambda t, y: A @ y, (0.0, 1.0), [1.0, 0.0], method="kahan", dt=dt, jac=A)
        errors.append(abs(r.y[0, -1] - math.cos(1.0)))
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(np.abs(orders - 2.0) < 0.05), orders
    # the trapezoidal rule keeps |y|^2 of a rotation exactly, up to round-off per step
    r = eci.solve(lambda t, y: A @ y, (0.0, 100.0), [1.0, 0.0], method="kahan", dt=0.1, jac=A)
    norm = np.sum(r.y ** 2, axis=0)
    assert np.max(np.abs(norm - 1.0)) <= 10 * EPS * math.sqrt(len(r.t))


@pytest.mark.parametrize("kwargs, pattern", [
    (dict(method="kahan"), r"method kahan needs the Jacobian of fun: give jac=jac\(t, y\)"),
    (dict(method="kahan", jac=np.eye(2)), r"jac must be callable jac\(t, y\) or an array of shape \(3, 3\)"),
    (dict(method="kahan", jac=lambda t, y: np.eye(2)), r"jac\(t, y\) returned an array of shape \(2, 2\), expected "
                                                       r"\(3, 3\)"),
])
def test_kahan_bad_jac(kwargs, pattern):
    with pytest.raises(ValueError, match=pattern):
        eci.solve(three_wave_fun, (0.0, 1.0), [1.0, 0.5, -0.3], dt=0.1, **kwargs)


def test_jac_is_ignored_by_explicit_methods_with_scipys_warning():
    with pytest.warns(UserWarning, match="no effect for a chosen solver: `jac`"):
        r = eci.solve(three_wave_fun, (0.0, 1.0), [1.0, 0.5, -0.3], method="rk4", dt=0.1, jac=three_wave_jac)
    assert np.array_equal(r.y, eci.solve(three_wave_fun, (0.0, 1.0), [1.0, 0.5, -0.3], method="rk4", dt=0.1).y)


def test_kahan_limits():
    with pytest.raises(ValueError, match="jac is for a Python fun; model lotka-volterra has its own Jacobian"):
        eci.solve(M.LotkaVolterra(), (0.0, 1.0), method="kahan", jac=lv_jac)
    with pytest.raises(ValueError, match="takes up to 8 unknowns"):
        eci.solve(lambda t, y: -y, (0.0, 1.0), np.ones(9), method="kahan", dt=0.1, jac=-np.eye(9))


@pytest.mark.parametrize("n", range(1, 9))
def test_kahan_with_jac_runs_at_every_size_it_takes(n):
    # each size has its own compiled stepper (a fixed-size linear solve): a rotation in the plane of the first two
    # unknowns (x' = -x for one), whose quadratic invariant |x|^2 Kahan's method keeps for this linear field
    A = np.zeros((n, n))
    if n == 1:
        A[0, 0] = -1.0
    else:
        A[0, 1], A[1, 0] = 1.0, -1.0
    y0 = np.linspace(1.0, 2.0, n)
    r = eci.solve(lambda t, y: A @ y, (0.0, 1.0), y0, method="kahan", dt=0.1, jac=A)
    assert r.success and r.method == "kahan" and r.y.shape == (n, 11)
    if n > 1:  # the rotation keeps |x|^2 to round-off (eps per step, 10 steps, a factor 8 of slack)
        assert abs(r.y[:, -1] @ r.y[:, -1] - y0 @ y0) <= 8 * np.finfo(float).eps * np.sqrt(10) * (y0 @ y0)
    else:  # x' = -x: Kahan's method is the trapezoidal rule here, (1 - h/2) / (1 + h/2) per step
        assert np.isclose(r.y[0, -1], y0[0] * (0.95 / 1.05) ** 10, rtol=1e-14)


def test_kahan_with_jac_has_no_error_estimate():
    with pytest.raises(ValueError, match="method kahan has no error estimate for rtol/atol"):
        eci.solve(lambda t, y: -y, (0.0, 1.0), [1.0, 2.0], method="kahan", rtol=1e-6, jac=-np.eye(2))
