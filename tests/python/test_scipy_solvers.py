# eci.scipy: eci's embedded pairs as scipy.integrate solvers. What SciPy's own suite (test_scipy_suite.py) does not
# check: that DP54 is RK45 (same pair, same controller), that the conservative pairs keep the invariants at every
# step, every dense-output point and every event, that backward time is stepped directly (bit for bit the
# time-reversed forward run), events on eci's models located to round-off, nfev counting every call, bad input.
import numpy as np
import pytest
from numpy.testing import assert_array_equal

scipy_integrate = pytest.importorskip("scipy.integrate")
from scipy.integrate import RK45, solve_ivp  # noqa: E402

import eci  # noqa: E402
import eci.scipy  # noqa: E402
from conftest import EPS  # noqa: E402

PAIRS = list(eci.scipy.solvers().values())
CONSERVATIVE = [c for c in PAIRS if c.conservative]


def rotation(t, y):
    """y' = A y, A antisymmetric: |y|^2 is kept (and only that, for this A)."""
    return np.array([y[1], -y[0] + 2.0 * y[2], -2.0 * y[1]])


Y0 = np.array([1.0, 0.5, -0.25])


def test_the_classes_are_the_registrys_embedded_pairs():
    pairs = {m.name for m in eci.methods() if m.name in {"bs32", "c-bs32", "ck54", "c-ck54", "dp54", "c-dp54", "dp853",
                                                        "c-dp853", "f78", "c-f78"}}
    assert set(eci.scipy.solvers()) == pairs
    assert {c.__name__ for c in PAIRS} == {"BS32", "CBS32", "CK54", "CCK54", "DP54", "CDP54", "DP853", "CDP853", "F78",
                                           "CF78"}
    info = {m.name: m for m in eci.methods()}
    for name, cls in eci.scipy.solvers().items():
        assert issubclass(cls, scipy_integrate.OdeSolver) and cls.order == info[name].order
        assert cls.conservative == info[name].conservative
        assert eci.scipy.__dict__[cls.__name__] is cls and getattr(eci, "scipy") is eci.scipy


def test_dp54_is_rk45():
    # The same pair (Dormand-Prince 5(4)) under the same controller: the same steps and calls. The step sizes are
    # the same up to the rounding of the error estimate, a sum of O(h |f|) terms cancelling to O(tol |y|), so
    # relatively eps / rtol per step, of which the controller takes the 1/5th power; summed over the steps in t.
    # Both runs are then tolerance-controlled solutions on the same steps, each within about rtol |y| per unit time
    # of the exact one on these non-growing problems: they differ by less than rtol |y| times the span.
    rtol = 1e-8
    for fun, t_span, y0 in ((rotation, (0.0, 20.0), Y0), (lambda t, y: -y * (1 + t), (0.0, 3.0), np.array([2.0]))):
        a = solve_ivp(fun, t_span, y0, method=RK45, rtol=rtol, atol=1e-10)
        b = solve_ivp(fun, t_span, y0, method=eci.scipy.DP54, rtol=rtol, atol=1e-10)
        assert a.nfev == b.nfev and a.t.size == b.t.size and b.t.size > 20
        steps = a.t.size - 1
        np.testing.assert_allclose(b.t, a.t, rtol=steps * EPS / rtol, atol=0)
        assert np.max(np.abs(b.y - a.y)) <= rtol * np.max(np.abs(a.y)) * (t_span[1] - t_span[0])


def test_dp853_is_dop853():
    # Dormand-Prince 8(5,3) with Hairer's DOP853 coefficients and its error estimate (the fifth- and third-order
    # estimates combined, |e5|^2 / sqrt(|e5|^2 + 0.01 |e3|^2)), under SciPy's controller: the steps and calls of
    # SciPy's DOP853: the same number of steps and calls. The step sizes agree up to the rounding of the estimate,
    # of which the controller takes the 1/8th power: where the estimate is itself at round-off (SciPy's first step
    # here is so short that its error is 1e-16, and the two sums of the same terms differ by 1e-4 of it) the next
    # step differs by 1e-5, and the times after it by as much (measured 1.2e-5 on y' = -y (1 + t)), hence 1e-4.
    # The states are then at slightly different times: each is compared with the other run's dense output at its
    # own time, and the dense outputs (DOP853's seventh-order one) with each other between the steps; both runs are
    # within about rtol |y| per unit time of the exact solution.
    rtol = 1e-8
    for fun, t_span, y0 in ((rotation, (0.0, 20.0), Y0), (lambda t, y: -y * (1 + t), (0.0, 3.0), np.array([2.0]))):
        a = solve_ivp(fun, t_span, y0, method="DOP853", rtol=rtol, atol=1e-10, dense_output=True)
        b = solve_ivp(fun, t_span, y0, method=eci.scipy.DP853, rtol=rtol, atol=1e-10, dense_output=True)
        assert a.nfev == b.nfev and a.t.size == b.t.size and b.t.size > 8
        np.testing.assert_allclose(b.t, a.t, rtol=1e-4, atol=0)
        reach = rtol * np.max(np.abs(a.y)) * (t_span[1] - t_span[0])
        assert np.max(np.abs(b.y - a.sol(b.t))) <= reach
        tt = np.linspace(*t_span, 997)
        assert np.max(np.abs(b.sol(tt) - a.sol(tt))) <= reach


@pytest.mark.parametrize("cls", CONSERVATIVE, ids=lambda c: c.__name__)
def test_conservative_pairs_keep_the_invariant_at_steps_dense_points_and_events(cls):
    def level(t, y):
        return y[1] - 0.1  # y[1] oscillates about 0 with amplitude ~0.5

    r = solve_ivp(rotation, (0.0, 30.0), Y0, method=cls, rtol=1e-6, atol=1e-9, dense_output=True, events=level)
    assert r.success and r.t_events[0].size >= 10
    steps = r.t.size - 1
    e0 = Y0 @ Y0
    # |y|^2 after each step: psi^2 is advanced exactly-linearly, so each step adds a few roundings (the square
    # roots, the squares, the 3-term sum): relative drift below 8 eps per step, accumulated.
    assert np.max(np.abs(np.sum(r.y ** 2, axis=0) / e0 - 1)) <= 8 * EPS * steps
    # A dense point is the step's interpolant of psi^2 (its invariants are the step's ends'), or where that
    # interpolant is negative near a zero of a component, a step landed from the step's start: the same bound.
    tt = np.linspace(0.0, 30.0, 3001)
    assert np.max(np.abs(np.sum(r.sol(tt) ** 2, axis=0) / e0 - 1)) <= 8 * EPS * steps
    assert np.max(np.abs(np.sum(r.y_events[0] ** 2, axis=1) / e0 - 1)) <= 8 * EPS * steps
    assert sum(s.clamped for s in r.sol.interpolants) == 0
    # the conventional pair of the same tableau drifts by the tolerance, far above that
    conv = eci.scipy.solvers()[cls.eci_method[2:]]
    c = solve_ivp(rotation, (0.0, 30.0), Y0, method=conv, rtol=1e-6, atol=1e-9)
    assert np.max(np.abs(np.sum(c.y ** 2, axis=0) / e0 - 1)) > 1e3 * EPS * steps


def test_at_a_zero_of_a_component_psi_squared_can_only_be_clamped():
    # An event where a component vanishes (y[1] = 0) is located by SciPy on psi_1 = sign * sqrt(xi_1): where the
    # interpolated xi_1 dips below 0 (its interpolation error), psi_1 is 0 on a whole interval, and a step landed
    # there has xi_1 = O(its local error) of either sign too. Those points are psi_1 = 0 with the invariant off by
    # the dip: an interpolation error of xi, below the tolerance rtol |y|^2 (measured ~1e-8 |y|^2 at rtol 1e-6).
    def crossing(t, y):
        return y[1]

    rtol = 1e-6
    r = solve_ivp(rotation, (0.0, 30.0), Y0, method=eci.scipy.CDP54, rtol=rtol, atol=1e-9, dense_output=True,
                  events=crossing)
    assert r.t_events[0].size >= 10
    e0 = Y0 @ Y0
    drift = np.abs(np.sum(r.y_events[0] ** 2, axis=1) / e0 - 1)
    assert np.max(drift) <= rtol
    # the points off by more than rounding (8 eps per step, as above) are the clamped ones: psi_1 = 0 exactly
    off = drift > 8 * EPS * (r.t.size - 1)
    assert sum(s.clamped for s in r.sol.interpolants) > 0 and np.any(off) and np.all(r.y_events[0][off, 1] == 0)


def test_three_wave_energy_exchange_keeps_energy_and_enstrophy():
    # eci's three-wave model: E and Z are sums of squares. The times where mode 2's energy psi_2^2 passes 0.2 (it
    # swings between 0 and 0.41 as energy moves between the modes) are located by SciPy on the conservative dense
    # output; there E and Z are the initial ones to round-off, and the event function is zero to round-off.
    model = eci.models.ThreeWave()
    y0 = np.array([1.0, 0.3, 0.8])
    w = np.array([[0.5, 0.5, 0.5], [0.5 * model.K ** 2, 0.5 * model.P ** 2, 0.5 * model.Q ** 2]])

    def exchange(t, y):
        return y[1] ** 2 - 0.2

    r = solve_ivp(model, (0.0, 40.0), y0, method=eci.scipy.CDP54, rtol=1e-9, atol=1e-12, events=exchange,
                  invariant_weights=w)
    assert r.success and r.t_events[0].size >= 4
    steps = r.t.size - 1
    inv = model.invariants(y0)
    inv0 = np.array([inv["energy"], inv["enstrophy"]])
    at_events = np.array([[model.invariants(y)["energy"], model.invariants(y)["enstrophy"]] for y in r.y_events[0]])
    assert np.max(np.abs(at_events / inv0 - 1)) <= 8 * EPS * steps
    # located to round-off: SciPy's brentq stops within 4 eps (1 + |t|) of the interpolant's root, where the event
    # function moves by |2 psi_2 f_2| <= 2 |psi| max|M| |psi|^2 per unit time (|psi|^2 = 2E), plus the rounding of
    # its own square and difference.
    e2 = 2 * inv0[0]
    rate = 2 * np.sqrt(e2) * np.max(np.abs(model.M)) * e2
    for t, y in zip(r.t_events[0], r.y_events[0]):
        assert abs(exchange(t, y)) <= rate * 8 * EPS * (1 + abs(t)) + 4 * EPS * e2


def kepler(t, y):
    x, yy, vx, vy = y
    r3 = (x * x + yy * yy) ** 1.5
    return np.array([vx, vy, -x / r3, -yy / r3])


@pytest.mark.parametrize("cls", [eci.scipy.DP54, eci.scipy.CDP54, eci.scipy.F78], ids=lambda c: c.__name__)
def test_kepler_pericentres(cls):
    # e = 0.5, a = 1, from the apocentre at t = 0: the pericentre (r . v = 0, r turning from falling to rising)
    # at t = pi + 2 pi k.
    e = 0.5
    y0 = np.array([-(1 + e), 0.0, 0.0, -np.sqrt((1 - e) / (1 + e))])

    def radial(t, y):
        return y[0] * y[2] + y[1] * y[3]

    radial.direction = 1
    rtol = 1e-11
    r = solve_ivp(kepler, (0.0, 6 * np.pi), y0, method=cls, rtol=rtol, atol=1e-13, events=radial)
    assert r.success and r.t_events[0].size == 3
    # the pericentres of the computed orbit are the exact ones to within its phase error, proportional to the
    # tolerance and growing with the periods: 1e4 rtol per period (measured up to 2e3 rtol, F78) catches a
    # wrong event (a step or a period away) and the rest is the integration's accuracy, not the event's.
    assert np.all(np.abs(r.t_events[0] - (np.pi + 2 * np.pi * np.arange(3))) <= 1e4 * rtol * np.arange(1, 4))
    for t, y in zip(r.t_events[0], r.y_events[0]):
        # located to round-off: d/dt (r . v) = v^2 - 1/r = 3 - 2 = 1 at this pericentre, so brentq's 4 eps (1 + t)
        # in time is that in value; with the rounding of the two products, 16 eps (1 + t)
        assert abs(radial(t, y)) <= 16 * EPS * (1 + t)


@pytest.mark.parametrize("cls", PAIRS, ids=lambda c: c.__name__)
def test_backward_time_is_stepped_directly(cls):
    # SciPy passes direction -1; the C++ engine takes the negative step itself. Its arithmetic is then the
    # time-mirrored forward run's (y + (-h) a k = y + h a (-k) and -t + c (-h) = -(t + c h), both exact), so the
    # backward run over (10, 0) of fun equals, bit for bit, the forward run over (-10, 0) of -fun(-t, y).
    back = solve_ivp(rotation, (10.0, 0.0), Y0, method=cls, rtol=1e-8, atol=1e-10)
    mirrored = solve_ivp(lambda s, y: -rotation(-s, y), (-10.0, 0.0), Y0, method=cls, rtol=1e-8, atol=1e-10)
    assert back.success and back.t.size > 5
    assert_array_equal(back.t, -mirrored.t)
    assert_array_equal(back.y, mirrored.y)
    # and there and back returns to the start within the tolerance: each leg's global error is at most a few
    # times rtol per unit time of this non-growing rotation (10 units, 1e-8) -> 2e-7 with a factor 2 margin
    fwd = solve_ivp(rotation, (0.0, 10.0), Y0, method=cls, rtol=1e-10, atol=1e-12)
    ret = solve_ivp(rotation, (10.0, 0.0), fwd.y[:, -1], method=cls, rtol=1e-10, atol=1e-12)
    assert np.max(np.abs(ret.y[:, -1] - Y0)) <= 2 * 10 * 1e-10 * 10


@pytest.mark.parametrize("cls", PAIRS, ids=lambda c: c.__name__)
@pytest.mark.parametrize("dense", [False, True])
def test_nfev_counts_every_call(cls, dense):
    calls = []

    def fun(t, y):
        calls.append(t)
        return rotation(t, y)

    r = solve_ivp(fun, (0.0, 5.0), Y0, method=cls, rtol=1e-6, atol=1e-9, dense_output=dense)
    assert r.nfev == len(calls) > 0


def test_unitary_complex_system_keeps_the_norm():
    # y' = i H y with H Hermitian: sum |y_k|^2 is kept; eci advances the squares of the real and imaginary parts.
    h = np.array([[1.0, 0.5 - 0.2j, 0.0], [0.5 + 0.2j, -0.3, 0.7j], [0.0, -0.7j, 0.2]])
    y0 = np.array([1.0, 0.3j, -0.2 + 0.1j])
    r = solve_ivp(lambda t, y: 1j * (h @ y), (0.0, 20.0), y0, method=eci.scipy.CDP54, rtol=1e-7, atol=1e-10,
                  dense_output=True)
    n0 = np.sum(np.abs(y0) ** 2)
    steps = r.t.size - 1
    assert np.max(np.abs(np.sum(np.abs(r.y) ** 2, axis=0) / n0 - 1)) <= 16 * EPS * steps
    tt = np.linspace(0, 20, 501)
    assert np.max(np.abs(np.sum(np.abs(r.sol(tt)) ** 2, axis=0) / n0 - 1)) <= 16 * EPS * steps


def test_bad_input():
    with pytest.raises(ValueError, match=r"^fun does not keep invariant 1 of invariant_weights at \(t0, y0\)"):
        eci.scipy.CDP54(rotation, 0.0, Y0, 1.0, invariant_weights=[[1, 1, 1], [1, 2, 3]])
    with pytest.raises(ValueError, match=r"invariant_weights has shape \(2,\), expected \(3,\) or \(m, 3\)"):
        eci.scipy.CDP54(rotation, 0.0, Y0, 1.0, invariant_weights=[1, 1])
    with pytest.raises(TypeError, match="invariant_weights is for the conservative pairs; dp54 is conventional"):
        eci.scipy.DP54(rotation, 0.0, Y0, 1.0, invariant_weights=[1, 1, 1])
    with pytest.raises(TypeError, match="EmbeddedPair is a base class"):
        eci.scipy.EmbeddedPair(rotation, 0.0, Y0, 1.0)

    def later(bad):  # fun that goes wrong once the engine calls it (SciPy's own first two calls check nothing)
        calls = []

        def fun(t, y):
            calls.append(t)
            return bad(y) if len(calls) > 2 else y
        return fun

    with pytest.raises(ValueError, match=r"fun\(t, y\) returned an array of shape \(2,\), expected \(3,\) like y0"):
        solve_ivp(later(lambda y: y[:2]), (0.0, 1.0), Y0, method=eci.scipy.DP54)
    with pytest.raises(TypeError, match="fun\\(t, y\\) returned None"):
        solve_ivp(later(lambda y: None), (0.0, 1.0), Y0, method=eci.scipy.CDP54)
    with pytest.raises(TypeError, match="returned complex values but y0 is real"):
        solve_ivp(later(lambda y: 1j * y), (0.0, 1.0), Y0, method=eci.scipy.F78)
    with pytest.raises(TypeError, match="returned values of dtype <U1, expected numbers"):
        solve_ivp(later(lambda y: ["a", "b", "c"]), (0.0, 1.0), Y0, method=eci.scipy.BS32)
    with pytest.raises(ValueError, match="unknown embedded pair 'rk4'"):
        eci._eci._embedded_stepper("rk4", rotation, 0.0, Y0, None, 1e-3, 1e-6)
    s = eci.scipy.CDP54(rotation, 0.0, Y0, 1.0, invariant_weights=[2, 2, 2])
    np.testing.assert_allclose(s.invariants(Y0), [2 * Y0 @ Y0], rtol=4 * EPS)


# fun returning nan or inf, from the start or later: every pair ends with status -1 and a message that says so, in a
# bounded number of calls. SciPy's own RK45 loops for ever on a nan f(t0, y0) (its initial step comes out nan), and
# DP853 stepped to t_bound on nan states with status 0 (its two-estimate error norm read a nan sum as zero).
@pytest.mark.parametrize("cls", PAIRS, ids=lambda c: c.__name__)
@pytest.mark.parametrize("bad", [np.nan, np.inf])
@pytest.mark.parametrize("start", [0.0, 0.5])
@pytest.mark.parametrize("first_step", [None, 0.1])
def test_a_non_finite_fun_ends_the_run_with_a_reason(cls, bad, start, first_step):
    calls = []

    def fun(t, y):
        calls.append(t)
        return rotation(t, y) if t < start else np.array([bad, 0.0, 0.0])

    with np.errstate(all="ignore"):  # (SciPy's initial-step rule computes with the bad values)
        r = solve_ivp(fun, (0.0, 1.0), Y0, method=cls, first_step=first_step)
    assert r.status == -1 and not r.success, (r.status, r.message)
    assert "non-finite" in r.message, r.message
    assert len(calls) < 20000
    assert r.t[-1] <= start + 1e-12 and np.all(np.isfinite(r.y))


# SciPy's initial-step rule is private and changed its signature (newer versions take the span's end and max_step):
# eci's solvers call it as the installed SciPy defines it. Here a rule of the newer signature stands in (the 8-argument
# call raised TypeError on it), and gets the span's end and max_step; the first step is the same.
@pytest.mark.parametrize("cls", PAIRS, ids=lambda c: c.__name__)
def test_the_initial_step_rule_is_called_as_scipy_defines_it(cls, monkeypatch):
    old_rule = eci.scipy.select_initial_step
    seen = []

    def new_rule(fun, t0, y0, t_bound, max_step, f0, direction, order, rtol, atol):
        seen.append((t_bound, max_step))
        return old_rule(fun, t0, y0, f0, direction, order, rtol, atol)

    before = cls(rotation, 0.0, Y0, 2.0, max_step=5.0).h_abs
    monkeypatch.setattr(eci.scipy, "select_initial_step", new_rule)
    assert cls(rotation, 0.0, Y0, 2.0, max_step=5.0).h_abs == before
    assert seen == [(2.0, 5.0)]
    r = solve_ivp(rotation, (0.0, 1.0), Y0, method=cls)
    assert r.success, r.message


# atol = 0 where a component is 0 leaves the initial-step rule no error scale there: the message says so (it blamed
# fun for a non-finite value; SciPy's RK45 loops for ever), with no NumPy warning.
@pytest.mark.parametrize("cls", PAIRS, ids=lambda c: c.__name__)
def test_a_zero_error_scale_is_named(cls):
    y0 = np.array([0.0, 1.0, 0.5])
    with np.errstate(divide="raise", invalid="raise"):
        r = solve_ivp(rotation, (0.0, 1.0), y0, method=cls, atol=0.0, rtol=1e-6)
    assert r.status == -1, r.message
    assert r.message.startswith("atol is 0 where y[0] = 0 at t = 0.0: the error scale atol + rtol |y| is 0 there"), \
        r.message


# A conservative pair steps squares: from a state whose squares overflow (or underflow) every step failed with "a
# negative psi^2 or a non-finite value" after thousands of calls; refused at once, in eci.solve's words.
@pytest.mark.parametrize("cls", [c for c in eci.scipy.solvers().values() if c.conservative])
def test_a_state_whose_squares_overflow_is_refused_by_the_conservative_pairs(cls):
    rotation = lambda t, y: np.array([-y[1], y[0]])  # noqa: E731
    for y0, what in [([1e200, 1e200], "overflows"), ([1e-170, 0.0], "underflows")]:
        with pytest.raises(ValueError, match=f"largest component is .*: its square {what}, and method "
                                             f"{cls.eci_method} steps squares"):
            solve_ivp(rotation, (0, 1), y0, method=cls)
    assert solve_ivp(rotation, (0, 1), [1e150, 0.0], method=cls).success


# fun returning the wrong shape: one line before SciPy's initial-step rule (it failed there with NumPy's broadcast
# error); None is an array of shape () after SciPy's conversion.
@pytest.mark.parametrize("cls", [eci.scipy.DP54, eci.scipy.CDP54])
def test_fun_of_the_wrong_shape_is_named_before_the_first_step(cls):
    for value, shape in [(np.array([1.0, 2.0, 3.0]), r"\(3,\)"), (None, r"\(\)")]:
        with pytest.raises(ValueError, match=rf"^fun\(t, y\) returned an array of shape {shape}, expected \(2,\) like "
                                             r"y0$"):
            solve_ivp(lambda t, y, v=value: v, (0, 1), [1.0, 0.0], method=cls)
