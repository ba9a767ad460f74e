# eci.solve(fun, ..., quadratic_invariants=W): a user's quadratic invariants sum_k W[j, k] |y_k|^2 handed to the
# conservative fixed-step engines' remedy of negative radicands (as the n-wave and spectral models give theirs),
# and reported in result.invariants; bad weights refused with one line naming the problem.
import math

import numpy as np
import pytest

import eci
import eci.models as M
from conftest import EPS


def rotations(pairs, seed):
    """`pairs` independent rotations u' = w v, v' = -w u (2 pairs unknowns) with random frequencies, amplitudes and
    phases: sum u^2 + v^2 is kept, and over a run every component passes through zero many times, where a
    conservative step's new psi^2 (its quadrature of d psi^2 / dt) can come out negative."""
    rng = np.random.default_rng(seed)
    w = rng.uniform(0.5, 2.0, pairs)
    amplitude, phase = rng.uniform(0.5, 1.5, pairs), rng.uniform(0.0, 2.0 * np.pi, pairs)
    y0 = np.concatenate([amplitude * np.cos(phase), amplitude * np.sin(phase)])

    def fun(t, y):
        return np.concatenate([w * y[pairs:], -w * y[:pairs]])

    return fun, y0


def test_weights_give_the_remedy_instead_of_halved_steps():
    pairs = 5000  # 10^4 unknowns
    fun, y0 = rotations(pairs, 3)
    W = np.ones(2 * pairs)
    span, dt = (0.0, 10.0), 0.1
    plain = eci.solve(fun, span, y0, method="c-rk4", dt=dt)
    told = eci.solve(fun, span, y0, method="c-rk4", dt=dt, quadratic_invariants=W)
    halvings = lambda r: r.stats["rejected_steps"]["step_failed"]  # noqa: E731
    # Without the weights a step with a negative radicand anywhere is halved (all 10^4 unknowns again); with them
    # the few failing unknowns take the conventional update and one rescale restores the invariant (and from 16
    # unknowns on the conditioned update avoids most failures in the first place).
    assert halvings(plain) > 0 and plain.stats["remedied_steps"] == 0
    assert halvings(told) < halvings(plain), (halvings(told), halvings(plain))
    assert told.stats["remedied_steps"] + told.stats["components_remedied"] > 0
    assert told.nfev < plain.nfev
    # The invariant is kept: each step rounds every psi^2 once and the rescale adds a rounding, a random walk of
    # a few eps per step relative to the sum (measured with compensation, so the measurement adds nothing).
    steps = told.stats["steps"]
    record = told.invariants["quadratic_0"]
    assert record["initial"] == pytest.approx(float(y0 @ y0), rel=4 * EPS)
    assert record["max_rel_drift"] <= 4 * EPS * math.sqrt(steps), record
    # The conventional method of the same tableau drifts by its error, far above that (so the bound can fail).
    rk4 = eci.solve(fun, span, y0, method="rk4", dt=dt, quadratic_invariants=W)
    assert rk4.invariants["quadratic_0"]["max_rel_drift"] > 1e3 * 4 * EPS * math.sqrt(steps)


def test_several_invariants_and_complex_states_and_backward_time():
    # A complex rotation within pairs of modes and a phase rotation: |a|^2 + |b|^2 (pair-wise) and the weighted
    # sum with weights k^2 are kept; both are reported, at the rounding of the steps.
    n = 40
    k = np.arange(1, n + 1, dtype=float)
    rng = np.random.default_rng(5)
    y0 = rng.normal(size=n) + 1j * rng.normal(size=n)

    def fun(t, y):
        return 1j * k * y  # each |y_k| is kept, so any weights are

    W = np.vstack([np.ones(n), k ** 2])
    r = eci.solve(fun, (0.0, 2.0), y0, method="c-rk4", dt=0.01, quadratic_invariants=W)
    assert set(r.invariants) == {"quadratic_0", "quadratic_1"}
    for j in range(2):
        assert r.invariants[f"quadratic_{j}"]["initial"] == pytest.approx(float(W[j] @ np.abs(y0) ** 2), rel=4 * EPS)
        assert r.invariants[f"quadratic_{j}"]["max_rel_drift"] <= 4 * EPS * math.sqrt(r.stats["steps"])
    b = eci.solve(fun, (2.0, 0.0), r.y[:, -1], method="c-rk4", dt=0.01, quadratic_invariants=W)
    assert b.invariants["quadratic_1"]["max_rel_drift"] <= 4 * EPS * math.sqrt(b.stats["steps"])
    # adaptive runs report them too, and keep them with the conditioned update (80 real unknowns: the default) as
    # with the paper's
    for update in ("conditioned", "paper"):
        a = eci.solve(fun, (0.0, 2.0), y0, method="c-dp54", rtol=1e-8, atol=1e-8, quadratic_invariants=W[1],
                      update=update)
        assert a.invariants["quadratic_0"]["max_rel_drift"] <= 4 * EPS * math.sqrt(a.stats["steps"])


def decay(t, y):
    return -y


def spin(t, y):
    return np.array([y[1], -y[0]])


@pytest.mark.parametrize("weights, error, pattern", [
    (np.ones(3), ValueError, r"quadratic_invariants has shape \(3,\), expected \(2,\) or \(m, 2\)"),
    (np.ones((2, 2, 1)), ValueError, r"quadratic_invariants has shape \(2, 2, 1\), expected \(2,\) or \(m, 2\)"),
    (np.ones((0, 2)), ValueError, r"quadratic_invariants has shape \(0, 2\)"),
    (np.ones((9, 2)), ValueError, "quadratic_invariants has 9 rows; at most 8 quadratic invariants"),
    ([1.0, math.nan], ValueError, r"quadratic_invariants\[0, 1\] is not finite"),
    (["a", "b"], TypeError, "quadratic_invariants must be real numbers, not dtype <U1"),
    ([1.0 + 1j, 1.0], TypeError, "quadratic_invariants must be real numbers, not dtype complex128"),
    ([1.0, 2.0], ValueError, r"fun does not keep quadratic invariant 0 \(row 0 of quadratic_invariants\) at "
                             r"\(t0, y0\): its rate is"),
])
def test_bad_weights_are_refused_with_one_line(weights, error, pattern):
    with pytest.raises(error, match=pattern) as e:
        eci.solve(spin, (0.0, 1.0), [1.0, 0.5], method="c-rk4", dt=0.1, quadratic_invariants=weights)
    assert "\n" not in str(e.value)


def test_weights_are_for_a_python_fun_without_a_transform():
    with pytest.raises(ValueError, match="quadratic_invariants is for a Python fun; model three-wave declares its own"):
        eci.solve(M.ThreeWave(), (0.0, 1.0), quadratic_invariants=np.ones(3))
    squares = eci.Transform(lambda x: x ** 2, lambda xi, hint: np.copysign(np.sqrt(xi), hint),
                            rate=lambda x, d: 2 * x * d)
    with pytest.raises(ValueError, match="quadratic_invariants and transform exclude each other"):
        eci.solve(decay, (0.0, 1.0), [1.0], method="c-rk4", dt=0.1, transform=squares, quadratic_invariants=[1.0])
    # the check of the weights is one call of fun, counted in nfev
    calls = [0]

    def counted(t, y):
        calls[0] += 1
        return spin(t, y)

    r = eci.solve(counted, (0.0, 1.0), [1.0, 0.5], method="c-rk4", dt=0.1, quadratic_invariants=[1.0, 1.0])
    assert r.nfev == calls[0] == 4 * 10 + 1
