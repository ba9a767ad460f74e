# The shape of the Python API: SciPy's conventions for fun, t_span, y0 and the result; every registry method by
# name; the built-in models' defaults, right-hand side and invariants; t_eval; statistics.
import re

import numpy as np
import pytest

import eci
from conftest import run_cli

M = eci.models


def test_dir_lists_what_eci_offers_not_what_it_imports():
    names = dir(eci)
    for name in eci.__all__ + ["scipy", "__version__"]:
        assert name in names
    for name in ("math", "np", "numbers", "warnings", "namedtuple"):  # listed before
        assert name not in names
    assert not [name for name in names if name.startswith("_") and not name.startswith("__")]
    models = [name for name in dir(eci.models) if not name.startswith("_")]
    assert set(eci.models.__all__) <= set(models) and "namedtuple" not in models and "np" not in models


def test_methods_are_the_registry_as_eci_list_shows_it(cli):
    listed = run_cli(cli, "list").stdout.split("Models")[0]
    # name, order, conservative or conventional, family (how it is built: one word), description
    rows = re.findall(r"^  (\S+)\s+order (\d)\s+(conservative|conventional)\s+\S+\s+(.+)$", listed, re.M)
    assert [(m.name, m.order, m.conservative, m.description) for m in eci.methods()] == [
        (name, int(order), kind == "conservative", description.strip()) for name, order, kind, description in rows]


def decay(t, y):
    return -0.5 * y


# Methods that need more than a right-hand side: Kahan (a Jacobian), relaxation and projection (the model's
# invariants), symplectic splittings (a separable Hamiltonian); they run on the models that offer it.
MODEL_ONLY = {"kahan", "stormer-verlet", "sb3a"} | {
    m.name for m in eci.methods() if m.name.split("-")[0] in ("rrk", "idt", "mrrk", "projected")}


@pytest.mark.parametrize("method", [m.name for m in eci.methods() if m.name not in MODEL_ONLY])
@pytest.mark.parametrize("y0", [[1.0, 2.0], [1.0 + 0.5j, 2.0 - 1.0j]], ids=["real", "complex"])
def test_every_method_runs_a_python_fun(method, y0):
    r = eci.solve(decay, (0.0, 1.0), y0, method=method, dt=0.125)
    assert r.method == method and r.success and r.status == 0
    info = {m.name: m for m in eci.methods()}[method]
    assert r.order == info.order and r.conservative == info.conservative
    assert r.y.shape == (2, 9) and r.y.dtype == np.asarray(y0).dtype and r.t.shape == (9,)
    assert np.array_equal(r.y[:, 0], y0) and r.t[0] == 0.0 and r.t[-1] == 1.0
    # y = y0 exp(-t/2), to the method's order at this step
    exact = np.asarray(y0) * np.exp(-0.5)
    assert np.max(np.abs(r.y[:, -1] - exact)) < 0.5 * 0.125 ** info.order * np.max(np.abs(y0))


@pytest.mark.parametrize("make", [lambda: M.ThreeWave(), lambda: M.NWave(modes=9, triads_per_mode=2),
                                  lambda: M.NWave(modes=9, triads_per_mode=2, complex=True),
                                  lambda: M.LotkaVolterra(), lambda: M.Kepler()])
def test_every_method_of_every_model(make):
    model = make()
    assert isinstance(model, M.Model)
    for method in model.methods:
        r = eci.solve(model, (0.0, 10 * model.default_dt), method=method)
        assert r.stats["steps"] == 10 and list(r.invariants) == model.invariant_names
        assert np.array_equal(r.y[:, 0], model.default_y0)


def test_model_defaults_are_the_clis(cli):
    listing = run_cli(cli, "list").stdout
    for model in (M.ThreeWave(), M.NWave(), M.NWave(complex=True), M.LotkaVolterra(), M.Kepler()):
        line = re.search(rf"^\s+methods: (.+) \(default ([^;)]+)(?:; with --rtol/--atol (\S+))?\); "
                         rf"default dt (\S+), t-end (\S+)$", listing.split(f"  {model.name} ")[1], re.M)
        assert line.group(1).split() == model.methods
        # both defaults the run takes: without a method, and with a tolerance and no method
        assert line.group(2) == model.default_method and line.group(3) == model._default_method(True)
        assert float(line.group(4)) == model.default_dt and float(line.group(5)) == model.default_t_end


def test_model_is_a_scipy_fun_with_the_cpp_right_hand_side():
    model = M.ThreeWave(M=(2.0, -3.0, 1.0), K=1.0, P=2.0 ** 0.5, Q=2.0)  # eqs. (2)-(3): 2 - 3 + 1 = 2 - 6 + 4 = 0
    y = np.array([0.3, -0.7, 1.1])
    assert np.array_equal(model(0.0, y), [2.0 * y[1] * y[2], -3.0 * y[2] * y[0], 1.0 * y[0] * y[1]])
    inv = model.invariants(y)
    assert inv["energy"] == 0.5 * (y[0] * y[0] + y[1] * y[1] + y[2] * y[2])
    cols = model.invariants(np.stack([y, 2 * y], axis=1))  # SciPy's layout, one value per column
    assert cols["energy"].shape == (2,) and cols["energy"][1] == pytest.approx(4 * inv["energy"], rel=1e-15)
    with pytest.raises(ValueError, match=r"y has shape \(2,\), expected \(3,\) like the three-wave state"):
        model(0.0, [1.0, 2.0])


def test_model_parameters_are_readable():
    assert M.ThreeWave().M == [1.0, 1.0, -2.0]
    assert M.LotkaVolterra(mu=2.0).mu == 2.0
    k = M.Kepler(m=2.0, K=3.0, ell=-1.0)
    assert (k.m, k.K, k.ell) == (2.0, 3.0, -1.0)
    w = M.NWave(modes=12, triads_per_mode=3, seed=5)
    assert w.modes == 12 and len(w.triads) == 12 and w.wavenumber.shape == (12,)
    assert np.array_equal(w.default_y0, M.NWave(modes=12, triads_per_mode=3, seed=5).default_y0)
    assert not np.array_equal(w.default_y0, M.NWave(modes=12, triads_per_mode=3, seed=6).default_y0)


def test_t_eval_between_grid_points_is_one_step_from_the_grid():
    model = M.ThreeWave()
    r = eci.solve(model, (0.0, 1.0), method="c-rk4", dt=0.1, t_eval=[0.0, 0.25, 1.0])
    assert np.array_equal(r.t, [0.0, 0.25, 1.0]) and r.stats["t_eval_steps"] == 1
    # the state at 0.25 is the grid state at 0.2 advanced by one step of 0.05
    grid = eci.solve(model, (0.0, 1.0), method="c-rk4", dt=0.1)
    one = eci.solve(model, (0.0, 0.05), grid.y[:, 2], method="c-rk4", dt=0.05)
    assert np.array_equal(r.y[:, 1], one.y[:, -1])
    # and the grid run itself is untouched by the extra steps
    assert np.array_equal(r.y[:, -1], grid.y[:, -1])


def test_statistics():
    r = eci.solve(M.LotkaVolterra(), (0.0, 2.0), method="c-pc", dt=0.02)
    s = r.stats
    assert s["steps"] == 100 and s["rhs_evals"] == 200 == r.nfev
    assert s["rejected_steps"] == {"step_failed": 0, "non_finite_fun": 0, "error_estimate": 0}
    assert s["solver_solves"] == 200 and s["solver_iterations"] >= s["solver_solves"]
    assert s["solver_max_iterations"] >= 1


def test_invariants_of_a_fun_by_name_or_position():
    r = eci.solve(decay, (0.0, 1.0), [3.0, 4.0], dt=0.05, invariants=[np.linalg.norm, lambda y: y[0]])
    assert list(r.invariants) == ["norm", "invariant_1"]
    assert r.invariants["norm"]["initial"] == 5.0
    assert r.invariants["norm"]["final"] == pytest.approx(5.0 * np.exp(-0.5), rel=1e-6)


def test_result_reads_like_scipys():
    r = eci.solve(M.Kepler(), (0.0, 1.05))  # the CLI's default method, c-pc
    assert r.method == "c-pc" and r["t"] is r.t and "invariants" in dir(r)
    assert r.t.shape == (11,) and r.y.shape == (3, 11)
    assert "SolveResult(method='c-pc', 11 points" in repr(r)


# Every ODE model's repr is a call that makes it again (eval in eci.models gives a model with the same parameters,
# and for the generated n-wave models the same triads: their repr was "NWave(modes=5, 33 triads)"), a preset's
# model named as such.
@pytest.mark.parametrize("make", [lambda: M.ThreeWave(), lambda: M.Kepler(ell=0.5), lambda: M.NWave(),
                                  lambda: M.NWave(modes=5, triads_per_mode=3, seed=2), lambda: M.NWaveComplex(7, 2),
                                  lambda: M.NWave.preset("standard").model, lambda: M.KeplerCartesian()])
def test_an_ode_models_repr_makes_it_again(make):
    m = make()
    again = eval(repr(m), dict(vars(M)))
    assert type(again) is type(m) and repr(again) == repr(m)
    for p in type(m)._parameters():
        if hasattr(m, p[1]):  # (a generated model's seed and triads_per_mode are not kept: its triads are, below)
            assert np.array_equal(getattr(again, p[1]), getattr(m, p[1])), p
    if hasattr(m, "triads"):
        assert np.array_equal(np.array(again.triads), np.array(m.triads)) and len(m.triads) > 0
