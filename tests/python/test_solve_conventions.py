# eci.solve with SciPy's conventions, on eci's own models: events located to round-off on the dense output,
# backward integration, the conservative dense output keeping the invariants at every point, and the conventions
# of SciPy's solve_ivp that are not numerical (status instead of exceptions, tolerance defaults, args, jac, ...).
import math
import warnings

import numpy as np
import pytest

import eci
import eci.models as M
from conftest import EPS


def drift_bound(steps, k=20.0):
    """k eps sqrt(steps): the round-off of an exactly conservative method's updates, a random walk over the steps
    (k covers the few roundings of each update of a three-term sum)."""
    return k * EPS * math.sqrt(max(steps, 1))


def changes_sign_across(g, sol, t, ulps=64):
    """Whether g(s, sol(s)) has opposite signs (or a zero) at t -+ ulps eps |t|: t is g's zero on the dense output
    to round-off. Brent stops within 4 eps |t| of it; 64 eps |t| of slope |g'| moves g by far more than the
    rounding of g's few operations on O(1) values here (a few eps)."""
    d = ulps * EPS * abs(t)
    a, b = g(t - d, sol(t - d)), g(t + d, sol(t + d))
    return a * b <= 0.0


def three_wave_turning(model, k):
    """d/dt psi_k^2 / 2 = psi_k dpsi_k/dt: zero where mode k's energy turns (the energy exchange's turning points)."""
    return lambda t, y: y[k] * model(t, y)[k]


@pytest.mark.parametrize("method", ["dp54", "c-dp54", "c-bs32", "dp853", "c-dp853", "c-f78"])
def test_three_wave_turning_points_are_located_to_round_off(method):
    model = M.ThreeWave()
    events = [three_wave_turning(model, k) for k in range(3)]
    r = eci.solve(model, (0.0, 40.0), method=method, rtol=1e-9, atol=1e-12, events=events, dense_output=True)
    assert r.status == 0 and r.success
    counts = [len(t) for t in r.t_events]
    assert min(counts) >= 3, counts  # the modes exchange energy several times over the span
    landed = 0
    for g, times, states in zip(events, r.t_events, r.y_events):
        assert np.all(np.diff(times) > 0)
        for t, y in zip(times, states):
            assert changes_sign_across(g, r.sol, t), (method, t)
            # y_events is the library's interpolant at t; sol rebuilds it from five points, each rounded, with
            # Lagrange weights of absolute sum below 3 on a step, so a few roundings of the largest component apart;
            # for a conservative pair in y**2 (the interpolated quantity: sqrt amplifies its rounding near a zero),
            # and without the sign, which flips at t
            # (except where the conservative interpolant needed sqrt of a negative xi near that zero and a step
            # landed on t instead: then within the run's tolerance of the interpolant, and counted in the stats)
            v = r.sol(t)
            a, b = (y * y, v * v) if r.conservative else (y, v)
            err = np.max(np.abs(a - b)) / np.max(np.abs(a))
            assert err <= 1e-9
            landed += err > 32 * EPS
    assert landed <= r.stats["dense_fallbacks"]
    # the turning points of mode 0 alternate between maxima and minima of its energy
    e0 = r.y_events[0][:, 0] ** 2
    assert np.all(np.diff(np.sign(np.diff(e0))) != 0)


@pytest.mark.parametrize("method", ["dp54", "c-dp54"])
def test_kepler_pericentres_terminal_event_and_period(method):
    kepler = M.Kepler()

    def pericentre(t, y):  # the radial velocity v_r turns from negative to positive at a pericentre
        return y[1]

    pericentre.direction = 1
    r = eci.solve(kepler, (0.0, 60.0), method=method, rtol=1e-10, atol=1e-12, events=pericentre,
                  dense_output=True)
    times = r.t_events[0]
    assert len(times) >= 3
    # The check is on y_events, the library's interpolant at the root (c-dp54 on Kepler runs the transformed
    # engine, whose dense output is the interpolant of xi inverted, which sol only approximates). dp54: Brent stops
    # within 4 eps (|t| + 1) of the interpolant's zero, where v_r moves at its rate dv_r/dt, and the interpolant
    # rounds by a few eps of the largest v_r. c-dp54: the inverse takes v_r = sqrt(v_r^2) from xi, so at a
    # pericentre (v_r = 0) xi's rounding, a few eps of its O(1) terms, is a few sqrt(eps) in v_r.
    v_scale = np.max(np.abs(r.y[1]))
    for t, y in zip(times, r.y_events[0]):
        rate = kepler(t, y)[1]
        floor = 64 * EPS * v_scale if method == "dp54" else 8 * math.sqrt(EPS)
        assert abs(y[1]) <= abs(rate) * 8 * EPS * (abs(t) + 1) + floor, (t, y[1], rate)
    periods = np.diff(times)
    # The orbit is periodic: every interval between pericentres is the period, up to the run's error (rtol 1e-10
    # over a few orbits: far below 1e-6 of the period)
    assert np.max(np.abs(periods - periods[0])) <= 1e-6 * periods[0]
    # terminal: the same orbit started at t = 1 stops at its first pericentre, 1 later than the one above, with
    # status 1, the last state being it
    pericentre.terminal = True
    s = eci.solve(kepler, (1.0, 60.0), method=method, rtol=1e-10, atol=1e-12, events=pericentre)
    assert s.status == 1 and s.success and s.message == "A termination event occurred."
    first = 1.0 + times[0]
    assert s.t[-1] == s.t_events[0][0] and abs(s.t[-1] - first) <= 1e-8 * first
    np.testing.assert_array_equal(s.y[:, -1], s.y_events[0][0])


@pytest.mark.parametrize("method", ["dp54", "c-dp54", "c-dp853", "c-f78"])
def test_backward_integration_returns_to_the_initial_state(method):
    model = M.ThreeWave()
    tol = 1e-9
    fwd = eci.solve(model, (0.0, 20.0), method=method, rtol=tol, atol=tol)
    back = eci.solve(model, (20.0, 0.0), fwd.y[:, -1], method=method, rtol=tol, atol=tol)
    assert back.success and back.t[0] == 20.0 and back.t[-1] == 0.0 and np.all(np.diff(back.t) < 0)
    # the forward run's own error against a much tighter run measures what the tolerance buys on this span; the
    # way back is the same length with the same tolerance, so it errs by about as much again
    ref = eci.solve(model, (0.0, 20.0), method="dp54", rtol=1e-13, atol=1e-13)
    e_fwd = np.max(np.abs(fwd.y[:, -1] - ref.y[:, -1]))
    assert np.max(np.abs(back.y[:, -1] - model.default_y0)) <= 10 * e_fwd + 100 * tol
    if method.startswith("c-"):  # the conservative pairs keep both invariants backward too
        for name in ("energy", "enstrophy"):
            assert back.invariants[name]["max_rel_drift"] <= drift_bound(back.stats["steps"])


def test_backward_python_fun_with_t_eval_and_dense_output():
    fun = lambda t, y: np.array([y[1], -y[0]])  # noqa: E731  y = (sin t, cos t) backward from t = 3
    y3 = [math.sin(3.0), math.cos(3.0)]
    t_eval = np.linspace(3.0, -2.0, 11)
    r = eci.solve(fun, (3.0, -2.0), y3, method="c-dp54", rtol=1e-10, atol=1e-12, t_eval=t_eval, dense_output=True)
    np.testing.assert_array_equal(r.t, t_eval)
    exact = np.vstack((np.sin(t_eval), np.cos(t_eval)))
    assert np.max(np.abs(r.y - exact)) <= 1e-8
    tc = np.linspace(-2.0, 3.0, 101)
    assert np.max(np.abs(r.sol(tc) - np.vstack((np.sin(tc), np.cos(tc))))) <= 1e-8
    with pytest.raises(ValueError, match="sorted in decreasing order"):
        eci.solve(fun, (3.0, -2.0), y3, t_eval=[-1.0, 0.0])


@pytest.mark.parametrize("method, order", [("c-rk4", 4), ("rk4", 4), ("c-pc", 2)])
def test_backward_fixed_steps_of_a_python_fun(method, order):
    # y' = (y1, -y0) + (cos t, 0) backward from t = 3 to -2: a time-dependent fun, so the stage times matter; the
    # order is measured against the run at dt / 8.
    fun = lambda t, y: np.array([y[1] + math.cos(t), -y[0]])  # noqa: E731
    y3 = np.array([math.sin(3.0), math.cos(3.0)])
    runs = [eci.solve(fun, (3.0, -2.0), y3, method=method, dt=0.1 / 2 ** k) for k in range(4)]
    for k, r in enumerate(runs):
        dt = 0.1 / 2 ** k
        assert r.status == 0 and r.t[0] == 3.0 and r.t[-1] == -2.0
        assert r.t[1] == 3.0 - dt and r.t[2] == 3.0 - 2 * dt  # the grid t0 - i dt, as stepping with -dt
        assert np.all(np.diff(r.t) < 0) and len(r.t) == round(5.0 / dt) + 1
    errors = [np.max(np.abs(r.y[:, -1] - runs[-1].y[:, -1])) for r in runs[:-1]]
    slopes = [math.log2(a / b) for a, b in zip(errors, errors[1:])]
    assert min(slopes) >= order - 0.3, (errors, slopes)
    # the same steps as a forward run of the time-reversed system, bit for bit (what stepping with -dt computes)
    mirror = eci.solve(lambda s, y: -fun(3.0 - s, y), (0.0, 5.0), y3, method=method, dt=0.1)
    np.testing.assert_array_equal(runs[0].y, mirror.y)
    # conservative methods keep |y|^2 backward too when the system keeps it (the rotation alone)
    rot = lambda t, y: np.array([y[1], -y[0]])  # noqa: E731
    r = eci.solve(rot, (3.0, -2.0), y3, method=method, dt=0.01, t_eval=np.linspace(3.0, -2.0, 6),
                  invariants={"E": lambda y: y @ y})
    np.testing.assert_array_equal(r.t, np.linspace(3.0, -2.0, 6))
    if method.startswith("c-"):
        assert r.invariants["E"]["max_rel_drift"] <= drift_bound(r.stats["steps"])


@pytest.mark.parametrize("method", ["c-bs32", "c-dp54", "c-dp853", "c-f78"])
def test_conservative_dense_output_keeps_the_invariants_at_every_point(method):
    model = M.ThreeWave()
    r = eci.solve(model, (0.0, 50.0), method=method, rtol=1e-6, atol=1e-6, dense_output=True)
    assert r.sol.n_segments == r.stats["steps"]
    tc = np.linspace(0.0, 50.0, 5001)
    inv = model.invariants(r.sol(tc))
    steps = r.stats["steps"]
    y = r.sol(tc)
    # Where the interpolated xi of a component dips below 0 between the stored points (near a zero of it: an
    # interpolation error), sol cannot land a step there as the library does, and sets that component to 0, off
    # the invariants by the dip (measured: c-dp853, whose long steps make the dip largest, at 3 of these 5001
    # points, 1.8e-7, below the tolerance; the others at none)
    clamped = np.any(y == 0.0, axis=0)
    assert np.count_nonzero(clamped) <= 5
    for name in ("energy", "enstrophy"):
        v0 = r.invariants[name]["initial"]
        # Each point is a combination of the stored states (5, or DP853's 8) whose weights sum to 1, each state
        # within the run's drift (k eps sqrt(steps)) of the initial value; the combination and the square root add
        # a few eps
        drift = np.abs(inv[name] / v0 - 1.0)
        assert np.max(drift[~clamped]) <= drift_bound(steps) + 16 * EPS, name
        assert np.max(drift, initial=0.0) <= 1e-6, name
    # the conventional pair's dense output does not keep them (the test can fail)
    c = eci.solve(model, (0.0, 50.0), method=method[2:], rtol=1e-6, atol=1e-6, dense_output=True)
    e = model.invariants(c.sol(tc))["energy"]
    assert np.max(np.abs(e / e[0] - 1.0)) > 1e3 * drift_bound(c.stats["steps"])
    # the dense output passes through the stored steps
    np.testing.assert_allclose(r.sol(r.t), r.y, rtol=1e-15, atol=1e-15)


def test_failure_is_a_status_not_an_exception():
    r = eci.solve(lambda t, y: y * y, (0.0, 2.0), [1.0], method="dp54", rtol=1e-6)  # blows up at t = 1
    assert r.status == -1 and not r.success
    assert isinstance(r.failure, eci.StepSizeUnderflow) and r.message == str(r.failure)
    assert abs(r.t[-1] - 1.0) <= 1e-3 and r.y.shape == (1, len(r.t)) and r.y[0, -1] > 1e3
    with pytest.raises(ValueError, match="rtol must be"):  # bad input is still an exception
        eci.solve(lambda t, y: y, (0.0, 1.0), [1.0], rtol=-1.0)


def test_tolerance_defaults_and_rtol_floor():
    fun = lambda t, y: -y  # noqa: E731
    only_rtol = eci.solve(fun, (0.0, 1.0), [1.0], method="dp54", rtol=1e-8)
    both = eci.solve(fun, (0.0, 1.0), [1.0], method="dp54", rtol=1e-8, atol=1e-6)
    np.testing.assert_array_equal(only_rtol.y, both.y)  # giving only rtol keeps SciPy's atol = 1e-6
    default = eci.solve(fun, (0.0, 1.0), [1.0], method="dp54")
    explicit = eci.solve(fun, (0.0, 1.0), [1.0], method="dp54", rtol=1e-3, atol=1e-6)
    np.testing.assert_array_equal(default.y, explicit.y)
    with pytest.warns(UserWarning, match="At least one element of `rtol` is too small"):
        low = eci.solve(fun, (0.0, 1.0), [1.0], method="dp54", rtol=1e-20, atol=1e-12)
    clipped = eci.solve(fun, (0.0, 1.0), [1.0], method="dp54", rtol=100 * EPS, atol=1e-12)
    np.testing.assert_array_equal(low.y, clipped.y)


@pytest.mark.parametrize("method", ["dp54", "c-dp54", "c-f78", "bs32"])
@pytest.mark.parametrize("y0", [[1.0, 0.0], [1e10, -3.0]])
def test_tolerances_near_the_smallest_double_do_not_blame_a_first_step_never_given(method, y0):
    # rtol is raised to 100 eps (SciPy's warning); atol 1e-300 makes y / (atol + rtol |y|) overflow in the first-step
    # rule, which used to give a step of 0 and "initial step must be a positive finite number"
    fun = lambda t, y: [y[1], -y[0]]  # noqa: E731
    with pytest.warns(UserWarning, match="`rtol` is too small"):
        r = eci.solve(fun, (0.0, 1.0), y0, method=method, rtol=1e-300, atol=1e-300)
    assert "initial step" not in r.message
    if r.success:  # a run that got there is as accurate as the tolerance floor allows
        c, s = math.cos(1.0), math.sin(1.0)
        exact = [y0[0] * c + y0[1] * s, y0[1] * c - y0[0] * s]
        assert np.allclose(r.y[:, -1], exact, rtol=1e-9, atol=1e-9 * max(map(abs, y0)))
    else:  # a failure names the tolerance (a conservative pair may stop at t0: y[1] = 0 there, atol 1e-300)
        assert r.status == -1 and "tolerance" in r.message, r.message


def test_scipy_arguments():
    fun = lambda t, y, a: a * y  # noqa: E731
    r = eci.solve(fun, (0.0, 1.0), [1.0], method="dp54", args=(-1.0,), rtol=1e-10, atol=1e-12)
    assert abs(r.y[0, -1] - math.exp(-1.0)) <= 1e-9
    with pytest.raises(TypeError, match="Supplied 'args' cannot be unpacked"):
        eci.solve(fun, (0.0, 1.0), [1.0], args=-1.0)
    v = eci.solve(lambda t, y: -y, (0.0, 1.0), [1.0, 2.0], method="dp54", vectorized=True)
    w = eci.solve(lambda t, y: -y, (0.0, 1.0), [1.0, 2.0], method="dp54")
    np.testing.assert_array_equal(v.y, w.y)
    with pytest.warns(UserWarning, match="no effect for a chosen solver: `jac`"):
        j = eci.solve(lambda t, y: -y, (0.0, 1.0), [1.0, 2.0], method="dp54", jac=lambda t, y: -np.eye(2))
    np.testing.assert_array_equal(j.y, w.y)
    e = eci.solve(lambda t, y: y, (0.0, 1.0), [], method="dp54")
    assert e.success and e.y.shape == (0, len(e.t)) and e.t[-1] == 1.0
    with pytest.raises(ValueError, match="first_step .* exceeds the span"):
        eci.solve(lambda t, y: -y, (0.0, 1.0), [1.0], first_step=2.0)
    with pytest.raises(ValueError, match=r"unknown method 'Radau' \(methods: .*dp54"):  # (RK45 is dp54)
        eci.solve(lambda t, y: -y, (0.0, 1.0), [1.0], method="Radau")


def test_nfev_counts_every_call_of_fun():
    calls = [0]

    def fun(t, y):
        calls[0] += 1
        return -y

    r = eci.solve(fun, (0.0, 5.0), [1.0, 0.5], method="c-dp54", t_eval=np.linspace(0, 5, 11))
    assert r.nfev == calls[0]
    calls[0] = 0
    r = eci.solve(fun, (0.0, 5.0), [1.0, 0.5], method="dp54", dense_output=True, events=lambda t, y: y[0] - 0.5)
    assert r.nfev == calls[0] and len(r.t_events[0]) == 1


def test_dp853_t_eval_costs_what_scipys_dop853_does():
    # dp853's seventh-order continuous extension is as accurate as its steps, so t_eval="auto" takes every output
    # time from it: 41 output times cost the three extra stages of each step they fall in, as with SciPy's DOP853
    # (which eci's dp853 is: the same pair, error estimate and first step; eci's own controller, not SciPy's, so
    # the steps differ a little), not landed steps (f78, which has no continuous extension, lands them).
    pytest.importorskip("scipy.integrate")
    from scipy.integrate import solve_ivp

    def fun(t, y):
        return np.array([y[1], -y[0] + 0.1 * math.sin(t)])

    span, y0 = (0.0, 20.0), [1.0, 0.0]
    t_eval = np.linspace(*span, 41)
    for rtol, atol in ((1e-3, 1e-6), (1e-8, 1e-10)):
        s0 = solve_ivp(fun, span, y0, method="DOP853", rtol=rtol, atol=atol)
        s = solve_ivp(fun, span, y0, method="DOP853", rtol=rtol, atol=atol, t_eval=t_eval)
        e0 = eci.solve(fun, span, y0, method="dp853", rtol=rtol, atol=atol)
        e = eci.solve(fun, span, y0, method="dp853", rtol=rtol, atol=atol, t_eval=t_eval)
        assert e.stats["dense_points"] >= 39 and e.stats["landed_points"] == 0
        assert e.stats["steps"] == e0.stats["steps"]  # the output times do not change the steps
        # the cost of the outputs: three calls per step that holds one, at most every step; as SciPy's (measured
        # +30 against +33 at rtol 1e-3, +105 against +114 at 1e-8), and the whole run's calls as SciPy's (213
        # against 191, 600 against 608: eci's controller takes one step more at 1e-3)
        assert e.nfev - e0.nfev <= 3 * e0.stats["steps"]
        assert abs((e.nfev - e0.nfev) - (s.nfev - s0.nfev)) <= 0.15 * (s.nfev - s0.nfev), (e.nfev, e0.nfev, s.nfev, s0.nfev)
        assert abs(e.nfev - s.nfev) <= 0.15 * s.nfev, (e.nfev, s.nfev)
        # and the outputs are as accurate as SciPy's: both within the tolerance's reach of each other
        assert np.max(np.abs(e.y - s.y)) <= 10 * (rtol + atol) * span[1]


# (test_conservation.py's Newton for the inverse divides by v - 1 = 0 where xi is 0 to rounding, y = 1: it then
# returns None, and sol keeps the hint there)
@pytest.mark.filterwarnings("ignore:invalid value encountered in scalar divide:RuntimeWarning")
@pytest.mark.parametrize("method", ["c-dp54", "c-dp853"])
def test_events_and_dense_output_through_a_users_transform(method):
    # Lotka-Volterra through a user's transform, xi = ((x - 1) - log x, mu ((y - 1) - log y)), whose sum is H
    # (test_conservation.py's): events located on the engine's dense output (xi interpolated and inverted), and
    # sol, xi interpolated from forward() of the stored points and inverted, keeping H at every point.
    from test_conservation import LV_TRANSFORM, MU, lv_fun

    model = M.LotkaVolterra(mu=MU)

    def H(s):
        return model.invariants(np.asarray(s))["hamiltonian"]

    def predator_level(t, y):  # away from y = 1, where the inverse of (y - 1) - log y is ill-conditioned
        return y[1] - 0.6

    y0 = np.array([1.0, 0.4])
    r = eci.solve(lv_fun, (0.0, 30.0), y0, method=method, rtol=1e-10, atol=1e-12, transform=LV_TRANSFORM,
                  events=predator_level, dense_output=True, invariants={"H": H})
    assert r.success and len(r.t_events[0]) >= 4
    steps = r.stats["steps"]
    # H has logarithms: each inverse (Newton to 4 eps) is good to a few ulps of the state, H to as many of its
    # terms (test_adaptive.py's bound for the same transform)
    bound = drift_bound(steps, k=100.0)
    h0 = H(y0)
    for t, y in zip(r.t_events[0], r.y_events[0]):
        # located to round-off on the dense output: the event changes sign across t within 64 eps |t|, and the
        # state there is the engine's dense output: y[1] = 0.6 to its rounding
        assert changes_sign_across(predator_level, r.sol, t), t
        assert abs(y[1] - 0.6) <= 64 * EPS * (1.0 + abs(lv_fun(t, y)[1]) * (abs(t) + 1.0)), (t, y)
        assert abs(H(y) / h0 - 1.0) <= bound
    tt = np.linspace(0.0, 30.0, 1501)
    assert np.max(np.abs(H(r.sol(tt)) / h0 - 1.0)) <= bound
    np.testing.assert_allclose(r.sol(r.t), r.y, rtol=64 * EPS, atol=0)
    # the polynomial through the same stored points, which the built-in models' sol is, does not keep H so well
    poly = eci.DenseSolution(r.sol._t_start, r.sol._t_end, r.sol._nodes, r.sol._samples, None, r.sol._sign_nodes,
                             False, y0, 0.0)
    assert np.max(np.abs(H(poly(tt)) / h0 - 1.0)) > bound


# An event's terminal may be a count, as in SciPy 1.11 on: the run ends at that event's N-th zero (it was refused
# unless True or False). Zeros of cos t at pi/2 + k pi.
@pytest.mark.parametrize("method", ["dp54", "c-dp54"])
def test_a_terminal_count_ends_the_run_at_that_zero(method):
    f = lambda t, y: np.array([-y[1], y[0]])  # noqa: E731  y = (cos t, sin t)

    def first(t, y):
        return y[0]

    for terminal, zeros in ((3, 3), (True, 1), (1, 1), (0, 6), (False, 6), (2.0, 2)):
        first.terminal = terminal
        r = eci.solve(f, (0.0, 19.0), [1.0, 0.0], method=method, rtol=1e-10, atol=1e-10, events=first)
        assert len(r.t_events[0]) == zeros, (terminal, r.t_events[0])
        np.testing.assert_allclose(r.t_events[0], np.pi / 2 + np.pi * np.arange(zeros), rtol=1e-8)
        assert r.status == (1 if zeros < 6 else 0)
        assert r.t[-1] == (r.t_events[0][-1] if zeros < 6 else 19.0)
    for bad in (-1, 1.5, "2", math.inf, math.nan):
        first.terminal = bad
        with pytest.raises(ValueError, match="terminal must be True, False or a whole number >= 0"):
            eci.solve(f, (0.0, 19.0), [1.0, 0.0], method=method, rtol=1e-10, events=first)


# Kahan's method evaluates jac once and solves one linear system per step: SciPy's njev and nlu count them (they
# were 0); a constant Jacobian matrix is no evaluation.
def test_kahan_counts_its_jacobians_and_solves():
    calls = []

    def f(t, y):
        return np.array([y[0] * y[1], -y[0] * y[1]])

    def jac(t, y):
        calls.append(t)
        return np.array([[y[1], y[0]], [-y[1], -y[0]]])

    r = eci.solve(f, (0.0, 1.0), [1.0, 2.0], method="kahan", dt=0.1, jac=jac)
    assert r.success and len(calls) == 10
    assert r.njev == 10 and r.nlu == 10
    r = eci.solve(lambda t, y: -y, (0.0, 1.0), [1.0, 2.0], method="kahan", dt=0.1, jac=-np.eye(2))
    assert r.njev == 0 and r.nlu == 10
    r = eci.solve(f, (0.0, 1.0), [1.0, 2.0], method="rk4", dt=0.1)
    assert r.njev == 0 and r.nlu == 0
    # an update chosen for it is refused, as for every method without one (it was ignored on this path)
    with pytest.raises(ValueError, match="; method kahan has none on "):
        eci.solve(f, (0.0, 1.0), [1.0, 2.0], method="kahan", dt=0.1, jac=jac, update="paper")


# After a terminal event the dense solution ends where the run did, as SciPy's OdeSolution (t_max was the end of the
# step the event fell in).
@pytest.mark.parametrize("span", [(0.0, 19.0), (19.0, 0.0)])
def test_the_dense_solution_ends_at_a_terminal_event(span):
    from scipy.integrate import solve_ivp
    f = lambda t, y: np.array([-y[1], y[0]])  # noqa: E731

    def first(t, y):
        return y[0]
    first.terminal = True
    y0 = [math.cos(span[0]), math.sin(span[0])]
    r = eci.solve(f, span, y0, method="dp54", rtol=1e-8, atol=1e-8, events=first, dense_output=True)
    ref = solve_ivp(f, span, y0, method="RK45", rtol=1e-8, atol=1e-8, events=first, dense_output=True)
    assert r.status == ref.status == 1
    assert r.sol.ts[-1] == r.t[-1] == r.t_events[0][0]
    assert (r.sol.t_min, r.sol.t_max) == (min(span[0], r.t[-1]), max(span[0], r.t[-1]))
    assert ref.sol.ts[-1] == ref.t[-1]
    # one interpolant evaluated two ways (the run's C++ form at the event, sol's samples in Python): a few ulps of 1
    np.testing.assert_allclose(r.sol(r.t[-1]), r.y[:, -1], rtol=0, atol=16 * EPS)


# Numbers given as 0-d arrays (np.array(0.1), np.asarray of a number) are numbers, as SciPy's solve_ivp takes them
# (they were a TypeError: "first_step must be a real number, not ndarray"); a 1-element array or a bool is not one.
def test_zero_dimensional_arrays_are_numbers_as_in_scipy():
    f = lambda t, y: np.array([y[1], -y[0]])  # noqa: E731
    a = eci.solve(f, (np.array(0.0), np.array(10)), [1.0, 0.0], first_step=np.array(0.1), max_step=np.array(0.5))
    b = eci.solve(f, (0.0, 10.0), [1.0, 0.0], first_step=0.1, max_step=0.5)
    np.testing.assert_array_equal(a.t, b.t)
    np.testing.assert_array_equal(a.y, b.y)
    for bad in (np.array(True), np.array([0.1]), np.array(1j)):
        with pytest.raises(TypeError, match="first_step must be a real number, not ndarray"):
            eci.solve(f, (0.0, 10.0), [1.0, 0.0], first_step=bad)


# solve_ivp takes a solver class as method: SciPy's explicit ones run as the pairs of their names (RK45 is dp54),
# eci.scipy's as their pair; any other class is refused saying so (it was "method must be a string ..., not type").
def test_a_solver_class_as_method():
    import scipy.integrate as si
    import eci.scipy
    f = lambda t, y: np.array([y[1], -y[0]])  # noqa: E731
    for cls, name in ((si.RK23, "RK23"), (si.RK45, "RK45"), (si.DOP853, "DOP853"), (eci.scipy.CDP54, "c-dp54"),
                      (eci.scipy.F78, "f78")):
        a = eci.solve(f, (0.0, 10.0), [1.0, 0.0], method=cls)
        b = eci.solve(f, (0.0, 10.0), [1.0, 0.0], method=name)
        assert a.method == b.method
        np.testing.assert_array_equal(a.y, b.y)
    for cls in (si.Radau, eci.scipy.EmbeddedPair, int):
        with pytest.raises(TypeError, match=r"is a class eci.solve cannot run: .* pass the class to "
                                            r"scipy.integrate.solve_ivp"):
            eci.solve(f, (0.0, 10.0), [1.0, 0.0], method=cls)
