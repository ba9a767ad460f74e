# Adaptive step control through eci.solve (rtol/atol): conservation at every tolerance, error proportional to the
# tolerance, bit-for-bit agreement with `eci run --rtol`, SciPy's RK45 drifting where c-dp54 does not, bad input.
import json
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import eci
from conftest import EPS, failure_of, run_cli

M = eci.models


def three_wave_fun(t, y):
    """Eq. (1) with the default coefficients, written as the C++ model writes it (same operations, same order)."""
    return np.array([1.0 * y[1] * y[2], 1.0 * y[2] * y[0], -2.0 * y[0] * y[1]])


def drift_bound(steps, k=20.0):
    """k eps sqrt(steps): the round-off of an exactly conservative method's updates, a random walk over the steps
    (k covers the few roundings of each update of a three-term sum)."""
    return k * EPS * math.sqrt(max(steps, 1))


@pytest.mark.parametrize("rtol", [1e-4, 1e-7, 1e-10])
@pytest.mark.parametrize("method", ["c-bs32", "c-dp54", "c-f78"])
def test_conservative_pairs_keep_energy_and_enstrophy_at_every_tolerance(method, rtol):
    r = eci.solve(M.ThreeWave(), (0.0, 50.0), method=method, rtol=rtol, atol=rtol)
    assert r.stats["steps"] > 10 and r.stats["adaptive"]
    for name in ("energy", "enstrophy"):
        assert r.invariants[name]["max_rel_drift"] <= drift_bound(r.stats["steps"]), (name, r.invariants[name])
    # the invariants hold at every returned state too, not only in the summary
    inv = M.ThreeWave().invariants(r.y)
    assert np.max(np.abs(inv["energy"] / inv["energy"][0] - 1.0)) <= drift_bound(r.stats["steps"])


@pytest.mark.parametrize("rtol", [1e-5, 1e-9])
@pytest.mark.parametrize("mode", ["auto", "dense"])
def test_python_fun_with_invariant_is_conserved_and_dense_output_too(rtol, mode):
    energy = lambda y: 0.5 * float(y @ y)  # noqa: E731
    t_eval = np.linspace(0.0, 30.0, 61)
    r = eci.solve(three_wave_fun, (0.0, 30.0), [1.0, 0.5, -0.3], rtol=rtol, atol=rtol, t_eval=t_eval,
                  invariants=[energy],
                  t_eval_mode=mode)
    assert r.method == "c-dp54"  # the default adaptive method
    assert np.array_equal(r.t, t_eval)
    if mode == "dense":
        # the conservative continuous extension: interpolated in xi = psi^2, so the invariants hold there too
        assert r.stats["dense_points"] > 0
    else:
        # on a plain system c-dp54's steps are more accurate than its interpolant near zeros: it lands them
        assert r.stats["landed_points"] > 0 and r.stats["dense_points"] == 0
    e = 0.5 * np.sum(r.y * r.y, axis=0)
    assert np.max(np.abs(e / e[0] - 1.0)) <= drift_bound(r.stats["steps"])


def test_lotka_volterra_transformed_pair_keeps_the_hamiltonian():
    r = eci.solve(M.LotkaVolterra(), (0.0, 100.0), method="c-dp54", rtol=1e-6, atol=1e-6)
    # H = x - ln x + mu (y - ln y) has logarithms: the transform's inverse (Newton) is good to a few ulps
    assert r.invariants["hamiltonian"]["max_rel_drift"] <= drift_bound(r.stats["steps"], k=100.0)


def test_error_is_proportional_to_the_tolerance():
    # y'' = -y, exact cos t: the global error of the conventional dp54 at t = 10 against rtol = atol
    tols = np.array([1e-5, 1e-6, 1e-7, 1e-8, 1e-9])
    errors = []
    for tol in tols:
        r = eci.solve(lambda t, y: np.array([y[1], -y[0]]), (0.0, 10.0), [1.0, 0.0], method="dp54", rtol=tol, atol=tol)
        errors.append(abs(r.y[0, -1] - math.cos(10.0)))
    slope = np.polyfit(np.log(tols), np.log(errors), 1)[0]
    # tolerance proportionality: error ~ tol^1 (the I controller aims at the local error per step)
    assert 0.8 <= slope <= 1.25, (slope, errors)


def cli_adaptive(cli, tmp_path, model, method, rtol, t_end, *options):
    csv, summary = tmp_path / "run.csv", tmp_path / "run.json"
    run_cli(cli, "run", model, "--method", method, "--rtol", repr(rtol), "--t-end", repr(t_end), "--output", csv,
            "--summary-json", summary, *options)
    header = csv.read_text().splitlines()[0].split(",")
    data = np.loadtxt(csv, delimiter=",", skiprows=1, ndmin=2)
    return {name: data[:, i] for i, name in enumerate(header)}, json.loads(summary.read_text())


def assert_same_adaptive_run(r, columns, summary, state_columns):
    assert np.array_equal(r.t, columns["t"])
    for i, name in enumerate(state_columns):
        assert np.array_equal(r.y[i], columns[name]), name
    assert r.stats["steps"] == summary["accepted_steps"]
    assert r.stats["rejected_steps"]["error_estimate"] == summary["rejected_error"]
    assert r.stats["rejected_steps"]["step_failed"] == summary["rejected_radicand"]
    assert r.stats["rhs_evals"] == summary["rhs_evals"]
    assert r.stats["dt_smallest"] == summary["dt_smallest"]
    assert r.stats["dt_largest"] == summary["dt_largest"]
    for name, record in summary["invariants"].items():
        for key in ("initial", "final", "max_abs_drift"):
            assert r.invariants[name][key] == record[key], (name, key)


@pytest.mark.parametrize("method", ["c-dp54", "dp54", "c-bs32", "f78"])
def test_three_wave_adaptive_matches_cli_bit_for_bit(cli, tmp_path, method):
    columns, summary = cli_adaptive(cli, tmp_path, "three-wave", method, 1e-8, 20.0)
    # first step: the model's dt, as the CLI
    r = eci.solve(M.ThreeWave(), (0.0, 20.0), method=method, rtol=1e-8, atol=1e-8)
    assert_same_adaptive_run(r, columns, summary, ["psi_K", "psi_P", "psi_Q"])


def test_python_fun_adaptive_matches_cli_bit_for_bit(cli, tmp_path):
    columns, summary = cli_adaptive(cli, tmp_path, "three-wave", "c-dp54", 1e-7, 20.0)
    model = M.ThreeWave()
    r = eci.solve(three_wave_fun, (0.0, 20.0), model.default_y0, method="c-dp54", rtol=1e-7, atol=1e-7,
                  first_step=model.default_dt)
    assert np.array_equal(r.t, columns["t"])
    for i, name in enumerate(["psi_K", "psi_P", "psi_Q"]):
        assert np.array_equal(r.y[i], columns[name]), name
    assert r.stats["rhs_evals"] == summary["rhs_evals"]


@pytest.mark.parametrize("model, make, method, columns", [
    ("three-wave", M.ThreeWave, "c-dp54", ["psi_K", "psi_P", "psi_Q"]),
    ("lotka-volterra", M.LotkaVolterra, "c-dp54", ["x", "y"]),
])
def test_t_eval_matches_cli_output_dt(cli, tmp_path, model, make, method, columns):
    cols, summary = cli_adaptive(cli, tmp_path, model, method, 1e-6, 10.0, "--output-dt", "0.5")
    r = eci.solve(make(), (0.0, 10.0), method=method, rtol=1e-6, atol=1e-6, t_eval=cols["t"])
    assert_same_adaptive_run(r, cols, summary, columns)
    assert r.stats["dense_points"] == summary["dense_outputs"]


def test_scipy_rk45_drifts_where_c_dp54_does_not():
    model = M.ThreeWave()
    t_end, tol = 500.0, 1e-6
    scipy = solve_ivp(model, (0.0, t_end), model.default_y0, method="RK45", rtol=tol, atol=tol)
    r = eci.solve(model, (0.0, t_end), method="c-dp54", rtol=tol, atol=tol)
    e_scipy = model.invariants(scipy.y)["energy"]
    scipy_drift = np.max(np.abs(e_scipy / e_scipy[0] - 1.0))
    ours = r.invariants["energy"]["max_rel_drift"]
    print(f"\nthree-wave t = {t_end}, rtol = atol = {tol}: RK45 energy drift {scipy_drift:.2e} "
          f"({scipy.nfev} evaluations), c-dp54 {ours:.2e} ({r.nfev})")
    assert ours <= drift_bound(r.stats["steps"])
    assert scipy_drift > 1e3 * drift_bound(r.stats["steps"])  # RK45 loses energy at the tolerance's scale


def test_stats_count_rejections_and_step_sizes():
    r = eci.solve(M.Kepler(), (0.0, 30.0), method="dp54", rtol=1e-9, atol=1e-9)
    s = r.stats
    assert s["steps"] == len(r.t) - 1
    assert s["rejected_steps"]["error_estimate"] > 0  # the pericentre passages force rejections
    assert 0.0 < s["dt_smallest"] < s["dt_largest"]
    # t + dt rounds: the times' differences are the steps to a few ulps of t
    ulps = 4 * EPS * r.t[-1]
    assert abs(np.min(np.diff(r.t)) - s["dt_smallest"]) <= ulps and abs(np.max(np.diff(r.t)) - s["dt_largest"]) <= ulps
    # every attempt of dp54 (FSAL) costs 6 evaluations, plus the first one
    attempts = s["steps"] + s["rejected_steps"]["error_estimate"] + s["rejected_steps"]["step_failed"]
    assert s["rhs_evals"] <= 7 * attempts + 1


def test_max_step_and_min_step_are_honoured():
    r = eci.solve(M.ThreeWave(), (0.0, 10.0), method="c-dp54", rtol=1e-4, atol=1e-4, max_step=0.05)
    assert r.stats["dt_largest"] <= 0.05
    err = failure_of(
        eci.solve(M.ThreeWave(), (0.0, 10.0), method="c-dp54", rtol=1e-12, atol=1e-12, min_step=0.1),
        eci.StepSizeUnderflow)
    assert isinstance(err, RuntimeError)
    assert 0.0 <= err.t < 10.0 and err.dt < 0.1
    assert err.cause == "error_estimate" and err.component_name in ("psi_K", "psi_P", "psi_Q")
    assert err.stats["rejected_steps"]["error_estimate"] >= 1
    assert "below the minimum" in str(err)


def test_too_many_steps_carries_the_statistics():
    err = failure_of(
        eci.solve(M.ThreeWave(), (0.0, 100.0), method="c-dp54", rtol=1e-10, atol=1e-10, max_steps=50),
        eci.TooManySteps)
    assert isinstance(err, RuntimeError)
    s = err.stats
    assert s["steps"] + s["rejected_steps"]["error_estimate"] + s["rejected_steps"]["step_failed"] == 50
    assert err.cause == "too_many_steps" and 0.0 < err.t < 100.0


def test_non_finite_fun_is_rejected_and_counted_then_underflows():
    # finite until t = 1, then nan: the controller cuts the step until it falls below the minimum just before 1
    def fun(t, y):
        return -y if t < 1.0 else np.full_like(y, np.nan)

    err = failure_of(
        eci.solve(fun, (0.0, 2.0), [1.0, 2.0], method="dp54", rtol=1e-6, atol=1e-6),
        eci.StepSizeUnderflow)
    assert err.cause == "non_finite_fun"
    assert err.stats["rejected_steps"]["non_finite_fun"] > 0
    assert err.t < 1.0 <= err.t + 1e-6
    # said as a fixed-step run says it (the message named only the minimum step and "tolerance too tight")
    assert ": fun(t, y) returned a non-finite value in component y[0] [component y[0]" in str(err), str(err)


def test_complex_and_transformed_functions_run_adaptively():
    z = eci.solve(lambda t, y: 1j * y, (0.0, 5.0), np.array([1.0 + 0.0j, 0.5j]), method="c-dp54", rtol=1e-9,
                  atol=1e-9)
    assert z.y.dtype == np.complex128
    assert np.max(np.abs(np.abs(z.y) - np.abs(z.y[:, :1]))) <= drift_bound(z.stats["steps"])
    # Lotka-Volterra by a user's transform, eq. (39): xi = (x - ln x, mu (y - ln y)) sums to H
    mu = 1.5
    lv = M.LotkaVolterra(mu=mu)

    def inverse(xi, hint):
        x = np.array(hint, dtype=float)
        for _ in range(60):  # Newton on each component of x - ln x = c, on the hint's side of 1
            scale = np.array([1.0, mu])
            g = scale * (x - np.log(x)) - xi
            x = x - g / (scale * (1.0 - 1.0 / x))
            if np.all(x <= 0):
                return None
        return x

    tr = eci.Transform(lambda x: np.array([x[0] - np.log(x[0]), mu * (x[1] - np.log(x[1]))]), inverse,
                       rate=lambda x, d: np.array([(1.0 - 1.0 / x[0]) * d[0], mu * (1.0 - 1.0 / x[1]) * d[1]]))
    r = eci.solve(lv, (0.0, 10.0), method="c-dp54", rtol=1e-7, atol=1e-7)
    u = eci.solve(lambda t, y: lv(t, y), (0.0, 10.0), lv.default_y0, method="c-dp54", rtol=1e-7, atol=1e-7,
                  transform=tr)
    h = lv.invariants(u.y)["hamiltonian"]
    assert np.max(np.abs(h / h[0] - 1.0)) <= drift_bound(u.stats["steps"], k=100.0)
    assert abs(u.y[0, -1] - r.y[0, -1]) < 1e-5  # the same orbit, within the tolerance's reach


@pytest.mark.parametrize("kwargs, error, pattern", [
    (dict(rtol=-1e-6), ValueError, "rtol must be a finite number >= 0, not -1e-06"),
    (dict(atol=float("nan")), ValueError, "atol must be a finite number >= 0, not nan"),
    (dict(rtol=1e-6, method="rk4"), ValueError,
     r"method rk4 has no error estimate for rtol/atol; adaptive methods for fun\(t, y\): bs32, "),
    (dict(rtol=1e-6, method="nope"), ValueError, "unknown method 'nope'"),
    (dict(atol=[1e-6, 1e-6, 1e-6]), ValueError,
     r"atol has shape \(3,\), expected a number or one value per component of y \(2,\)"),
    (dict(rtol=[1e-6, -1.0]), ValueError, r"rtol\[1\] must be a finite number >= 0, not -1"),
    (dict(rtol="tight"), TypeError, "rtol must be a real number or an array of them, not str"),
    (dict(rtol=1e-6, dt=0.1), ValueError, r"give either dt \(fixed steps\) or rtol/atol"),
    (dict(method="rk4"), ValueError, r"dt is required for method rk4 \(fixed steps\); or give rtol/atol"),
    (dict(dt=0.1, first_step=0.1), ValueError, "first_step is for adaptive step control"),
    (dict(dt=0.1, max_step=1.0), ValueError, "max_step is for adaptive step control"),
    (dict(rtol=1e-6, first_step=-1.0), ValueError, "first_step must be a positive finite number, not -1"),
    (dict(rtol=1e-6, min_step=1.0, max_step=0.5), ValueError, "min_step 1 is larger than max_step 0.5"),
    (dict(rtol=1e-6, max_steps=0), ValueError, "max_steps must be a whole number from 1 to 2\\*\\*63, not 0"),
    (dict(rtol=1e-6, max_steps=2 ** 64), ValueError, "max_steps must be a whole number from 1 to 2\\*\\*63, not 1844"),
    (dict(rtol=1e-6, t_eval_mode="cubic"), ValueError, "t_eval_mode must be one of auto, dense, landing"),
])
def test_bad_adaptive_arguments(kwargs, error, pattern):
    args = dict(fun=lambda t, y: -y, t_span=(0.0, 1.0), y0=[1.0, 2.0])
    args.update(kwargs)
    with pytest.raises(error, match=pattern):
        eci.solve(**args)


def test_model_rtol_with_fixed_step_method_names_the_adaptive_ones(cli):
    with pytest.raises(ValueError) as e:
        eci.solve(M.ThreeWave(), (0.0, 1.0), method="c-rk4", rtol=1e-6, atol=1e-6)
    cli_message = run_cli(cli, "run", "three-wave", "--method", "c-rk4", "--rtol", "1e-6", check=False).stderr
    assert "has no error estimate" in str(e.value) and "has no error estimate" in cli_message
    # the same list of adaptive methods as `eci run`
    assert str(e.value).split(": ")[-1] == cli_message.strip().split(": ")[-1]


def arenstorf(t, y, mu=0.012277471):
    """The restricted three-body problem (Hairer-Norsett-Wanner I, II.0): no quadratic invariant."""
    r1 = ((y[0] + mu) ** 2 + y[1] ** 2) ** 1.5
    r2 = ((y[0] - 1.0 + mu) ** 2 + y[1] ** 2) ** 1.5
    return np.array([y[2], y[3],
                     y[0] + 2.0 * y[3] - (1.0 - mu) * (y[0] + mu) / r1 - mu * (y[0] - 1.0 + mu) / r2,
                     y[1] - 2.0 * y[2] - (1.0 - mu) * y[1] / r1 - mu * y[1] / r2])


def test_default_adaptive_method_follows_what_fun_declares():
    # A fun that declares no invariant gets the conventional pair: nothing is conserved, and dp54 is the more
    # accurate at equal work (c-dp54's square roots lose accuracy wherever an unknown passes zero).
    y0, period = [0.994, 0.0, 0.0, -2.00158510637908252240537862224], 17.0652165601579625588917206249
    default = eci.solve(arenstorf, (0.0, period), y0, rtol=1e-8, atol=1e-8)
    explicit = eci.solve(arenstorf, (0.0, period), y0, method="dp54", rtol=1e-8, atol=1e-8)
    assert default.method == "dp54"
    assert np.array_equal(default.y, explicit.y) and default.nfev == explicit.nfev
    assert np.max(np.abs(default.y[:, -1] - y0)) < 1e-3  # one period of the orbit closes it
    # A fun that declares an invariant keeps the conservative pair, and with it the invariant.
    rot = lambda t, y: np.array([y[1], -y[0]])  # noqa: E731
    for declared in (dict(quadratic_invariants=[1.0, 1.0]), dict(invariants=lambda y: float(y @ y))):
        r = eci.solve(rot, (0.0, 5.0), [1.0, 0.0], rtol=1e-6, atol=1e-6, **declared)
        assert r.method == "c-dp54"
        n2 = np.sum(r.y * r.y, axis=0)
        assert np.max(np.abs(n2 - 1.0)) <= drift_bound(r.stats["steps"])
    assert eci.solve(rot, (0.0, 5.0), [1.0, 0.0]).method == "dp54"
    # a built-in model keeps the conservative pair
    assert eci.solve(M.ThreeWave(), (0.0, 1.0), rtol=1e-6, atol=1e-6).method == "c-dp54"


def test_per_component_tolerances_and_landing_mode():
    r = eci.solve(lambda t, y: np.array([y[1], -y[0]]), (0.0, 5.0), [1.0, 0.0], rtol=[1e-8, 1e-8],
                  atol=[1e-10, 1e-3], t_eval=[1.0, 2.5, 5.0], t_eval_mode="landing")
    assert r.stats["landed_points"] == 3 and r.stats["dense_points"] == 0
    assert np.array_equal(r.t, [1.0, 2.5, 5.0])


@pytest.mark.parametrize("make", [lambda: M.ThreeWave(), lambda: M.NWave(modes=9, triads_per_mode=2),
                                  lambda: M.NWave(modes=9, triads_per_mode=2, complex=True),
                                  lambda: M.LotkaVolterra(), lambda: M.Kepler()])
def test_every_adaptive_method_of_every_model(make):
    model = make()
    assert {"dp54", "c-dp54"} <= set(model.adaptive_methods) <= set(model.methods)
    for method in model.adaptive_methods:
        r = eci.solve(model, (0.0, 1.0), method=method, rtol=1e-8, atol=1e-8)
        assert r.t[-1] == 1.0 and r.stats["steps"] == len(r.t) - 1 and r.method == method
        if method.startswith("c-"):
            for name, record in r.invariants.items():  # Kepler's Runge-Lenz y starts at 0: absolute drift there
                scale = max(abs(record["initial"]), 1.0)
                assert record["max_abs_drift"] <= drift_bound(r.stats["steps"], k=100.0) * scale, (method, name)


def test_scipys_explicit_method_names_are_the_same_pairs():
    # a solve_ivp call moved to eci.solve keeps its method name: RK23, RK45 and DOP853 are bs32, dp54 and dp853,
    # bit for bit; SciPy's implicit solvers are refused by name (eci has none)
    f = lambda t, y: np.array([y[1], -y[0]])  # noqa: E731
    for scipy_name, name in (("RK23", "bs32"), ("RK45", "dp54"), ("DOP853", "dp853")):
        a = eci.solve(f, (0.0, 3.0), [1.0, 0.0], method=scipy_name, rtol=1e-8, atol=1e-10)
        b = eci.solve(f, (0.0, 3.0), [1.0, 0.0], method=name, rtol=1e-8, atol=1e-10)
        assert a.method == name and np.array_equal(a.t, b.t) and np.array_equal(a.y, b.y)
    with pytest.raises(ValueError, match="unknown method 'Radau'"):
        eci.solve(f, (0.0, 3.0), [1.0, 0.0], method="Radau")
    # a refusal names the method as it was given, with eci's name beside it
    with pytest.raises(ValueError, match=r"^method 'RK45' \(eci's dp54\) is not available for model navier-stokes-2d "):
        eci.solve(eci.models.NavierStokes2D(n=16), (0.0, 1.0), method="RK45", dt=0.1)
    with pytest.raises(ValueError, match=r"^method RK23 \(eci's bs32\) has no error estimate for rtol/atol; "):
        eci.solve(eci.models.NavierStokes2D(n=16), (0.0, 1.0), None, "RK23", rtol=1e-6)
