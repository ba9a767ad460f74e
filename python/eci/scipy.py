"""eci's embedded pairs as SciPy solvers: ``scipy.integrate.solve_ivp(fun, t_span, y0, method=eci.scipy.CDP54)``.

Every embedded pair of eci's registry (``eci.methods()``) is an ``scipy.integrate.OdeSolver`` subclass here, named
after it in capitals without the dash: ``BS32``, ``CBS32``, ``CK54``, ``CCK54``, ``DP54``, ``CDP54``, ``DP853``,
``CDP853``, ``F78``, ``CF78`` (``eci.scipy.solvers()`` lists them). ``DP853`` is SciPy's ``DOP853`` (the same
coefficients, error estimate and seventh-order dense output), ``DP54`` its ``RK45``. ``solve_ivp`` keeps all it does with any solver: events, t_eval,
dense output (``dense_output=True`` gives ``sol``), backward integration, ``args``, ``vectorized``, status and message.

What is eci's: each step is the C++ engine of ``include/eci/steppers/embedded_rk.hpp`` (stages, candidate, error
norm; the conservative pairs advance psi^2 with the tableau and keep every invariant sum_k w_k |psi_k|^2 that
``fun`` keeps, to round-off), and ``dense_output()`` is the engine's interpolant (for a conservative pair the one
that keeps the invariants at every point). What is SciPy's: the step-size controller, copied from its RungeKutta
class (safety 0.9, factors 0.2 to 10, the initial-step rule, the minimum step of 10 ulp of t), so that a pair
takes the steps SciPy would take with the same error estimates. A negative psi^2 (a conservative step across a
zero of psi that is too long) rejects the attempt and halves the step, as eci's own controller does.

The error norm is the engine's: the RMS over real unknowns of e_i / (atol + rtol max(|y_i|, |y_new_i|)), a complex
component's real and imaginary parts counted separately (SciPy takes the modulus of each complex component).
"""

import inspect

import numpy as np
from scipy.integrate import OdeSolver
from scipy.integrate._ivp.base import DenseOutput
from scipy.integrate._ivp.common import (select_initial_step, validate_first_step, validate_max_step, validate_tol,
                                         warn_extraneous)

from . import _eci

__all__ = ["EmbeddedPair", "solvers"]

# SciPy's RungeKutta controller constants (scipy/integrate/_ivp/rk.py), so that the steps are the ones SciPy takes.
SAFETY = 0.9
MIN_FACTOR = 0.2
MAX_FACTOR = 10
# eci's own controller shrinks a step that failed for a negative radicand by this factor (adaptive_options).
RADICAND_FACTOR = 0.5


class EciDenseOutput(DenseOutput):
    """The engine's interpolant over one accepted step (for a conservative pair, invariant-exact at every point)."""

    def __init__(self, t_old, t, step):
        super().__init__(t_old, t)
        self._step = step

    def _call_impl(self, t):
        return self._step(t)

    @property
    def landed(self):
        """Points where the conservative interpolant's psi^2 came out negative in some component (an interpolation
        error near a zero of psi): a step of the engine from the step's start landed on them instead (exactly
        conservative, as accurate as the steps; its calls of fun count in the solver's nfev)."""
        return self._step.landed

    @property
    def clamped(self):
        """Points where that landing step failed too (rare): psi = 0 where psi^2 < 0, off the invariants by that."""
        return self._step.clamped


class EmbeddedPair(OdeSolver):
    """Base class of eci's embedded pairs as SciPy solvers (use a subclass: ``eci.scipy.CDP54`` etc.).

    Parameters are those of ``scipy.integrate.RK45``: fun, t0, y0, t_bound, max_step=inf, rtol=1e-3, atol=1e-6,
    vectorized=False, first_step=None; and, for the conservative pairs, ``invariant_weights``: the quadratic
    invariants sum_k W[j, k] |y_k|^2 the user expects ``fun`` to keep, an (m, n) or (n,) array. The engine needs
    no weights (it keeps every such invariant ``fun`` keeps, whatever W); given, they are checked against
    ``fun(t0, y0)`` (ValueError if fun does not keep one) and ``solver.invariants(y)`` evaluates them. Default: the
    plain sum of squares, unchecked.
    """

    eci_method = None  # the registry name, set on each subclass
    conservative = False

    def __init__(self, fun, t0, y0, t_bound, max_step=np.inf, rtol=1e-3, atol=1e-6, vectorized=False,
                 first_step=None, invariant_weights=None, **extraneous):
        if self.eci_method is None:
            raise TypeError("EmbeddedPair is a base class: use one of eci.scipy.solvers()")
        warn_extraneous(extraneous)
        super().__init__(fun, t0, y0, t_bound, vectorized, support_complex=True)
        self.y_old = None
        self.max_step = validate_max_step(max_step)
        self.rtol, self.atol = validate_tol(rtol, atol, self.n)
        f0 = self.fun(self.t, self.y)
        if np.shape(f0) != self.y.shape:  # (before SciPy's initial-step rule, which failed on it with NumPy's words)
            raise ValueError(f"fun(t, y) returned an array of shape {np.shape(f0)}, expected {self.y.shape} like y0")
        self._weights = self._invariant_weights(invariant_weights, f0)
        # The engine calls fun itself (not through self.fun) and counts the calls: nfev adds them (property below).
        # Made before the first step is chosen: it refuses a state a conservative pair cannot step.
        engine_fun = self.fun_single if vectorized else fun
        self._engine = _eci._embedded_stepper(self.eci_method, engine_fun, float(self.t), self.y, f0, self.rtol,
                                              self.atol)
        if first_step is None:
            self.h_abs = self._initial_step(f0)
        else:
            self.h_abs = validate_first_step(first_step, t0, t_bound)
        self.error_exponent = -1 / (self.error_estimator_order + 1)
        self.h_previous = None

    def _initial_step(self, f0):
        """SciPy's initial-step rule, called as the installed SciPy defines it: newer versions also take the span's
        end and max_step, which bound the step (the older 8-argument call raised TypeError there)."""
        order = self.error_estimator_order
        with np.errstate(divide="ignore", invalid="ignore"):  # a zero error scale: said in _step_impl
            if "t_bound" in inspect.signature(select_initial_step).parameters:
                return select_initial_step(self.fun, self.t, self.y, self.t_bound, self.max_step, f0, self.direction,
                                           order, self.rtol, self.atol)
            return select_initial_step(self.fun, self.t, self.y, f0, self.direction, order, self.rtol, self.atol)

    # Every call of fun: SciPy's self.fun increments nfev (the initial-step rule), the engine counts its own
    # (steps, and dense outputs that land a step), also the ones made inside solve_ivp's event location.
    @property
    def nfev(self):
        engine = self.__dict__.get("_engine")
        return self._nfev_python + (engine.calls if engine is not None else 0)

    @nfev.setter
    def nfev(self, value):
        engine = self.__dict__.get("_engine")
        self._nfev_python = value - (engine.calls if engine is not None else 0)

    def _invariant_weights(self, weights, f0):
        if weights is None:
            return np.ones((1, self.n))
        if not self.conservative:
            raise TypeError(f"invariant_weights is for the conservative pairs; {self.eci_method} is conventional")
        w = np.asarray(weights, dtype=float)
        if w.ndim == 1:
            w = w[None, :]
        if w.ndim != 2 or w.shape[1] != self.n:
            raise ValueError(f"invariant_weights has shape {np.shape(weights)}, expected ({self.n},) or (m, {self.n})")
        if not np.all(np.isfinite(w)):
            raise ValueError("invariant_weights must be finite")
        # d/dt sum_k w_k |y_k|^2 = 2 sum_k w_k Re(conj(y_k) f_k): zero for an invariant of fun, up to the rounding
        # of the n products and their sum (each term's rounding below eps |term|, the sum's below n eps sum|term|).
        terms = 2.0 * w * np.real(np.conj(self.y) * f0)[None, :]
        rate, size = terms.sum(axis=1), np.abs(terms).sum(axis=1)
        bad = np.flatnonzero(np.abs(rate) > 4 * (self.n + 1) * np.finfo(float).eps * size)
        if bad.size:
            j = int(bad[0])
            raise ValueError(f"fun does not keep invariant {j} of invariant_weights at (t0, y0): its rate is "
                             f"{rate[j]:.17g}, not 0")
        return w

    def invariants(self, y):
        """The quadratic invariants sum_k W[j, k] |y_k|^2 at y (shape (n,): (m,); (n, p): (m, p))."""
        y = np.asarray(y)
        return self._weights @ (np.abs(y) ** 2)

    def _step_impl(self):
        # SciPy's RungeKutta._step_impl, the step itself being the engine's.
        t = self.t
        min_step = 10 * np.abs(np.nextafter(t, self.direction * np.inf) - t)
        if self.h_abs > self.max_step:
            h_abs = self.max_step
        elif self.h_abs < min_step:
            h_abs = min_step
        else:
            h_abs = self.h_abs

        if not h_abs >= 0:
            # SciPy's initial-step rule divides by the norm of fun(t0, y0) scaled by atol + rtol |y0|: a nan there, or
            # a zero scale, makes the step nan, which no comparison below stops (SciPy's RK45 loops for ever on it);
            # say what happened instead
            zero_scale = np.flatnonzero((np.broadcast_to(self.atol, self.y.shape) == 0) & (self.y == 0))
            if zero_scale.size:
                i = int(zero_scale[0])
                return False, (f"atol is 0 where y[{i}] = 0 at t = {t!r}: the error scale atol + rtol |y| is 0 "
                               "there, so no first step could be chosen (give atol > 0 or first_step)")
            return False, f"fun returned a non-finite value at t = {t!r}, so no first step could be chosen"
        step_accepted = False
        step_rejected = False
        why = None  # what rejected the last attempt, when it was not its error's size: said if the step runs out
        engine = self._engine
        while not step_accepted:
            if h_abs < min_step:
                return False, self.TOO_SMALL_STEP + (f" (at t = {t!r} {why})" if why else "")
            h = h_abs * self.direction
            t_new = t + h
            if self.direction * (t_new - self.t_bound) > 0:
                t_new = self.t_bound
            h = t_new - t
            h_abs = np.abs(h)

            ok, error_norm, _ = engine.attempt(t, h)
            if not ok:  # a negative psi^2: the conservative candidate does not exist
                h_abs *= RADICAND_FACTOR
                step_rejected = True
                why = "the last step size tried gave a negative psi^2 or a non-finite value"
            elif error_norm < 1:
                if error_norm == 0:
                    factor = MAX_FACTOR
                else:
                    factor = min(MAX_FACTOR, SAFETY * error_norm ** self.error_exponent)
                if step_rejected:
                    factor = min(1, factor)
                h_abs *= factor
                step_accepted = True
            else:
                h_abs *= max(MIN_FACTOR, SAFETY * error_norm ** self.error_exponent)  # (nan: MIN_FACTOR)
                step_rejected = True
                why = None if np.isfinite(error_norm) else "fun returned a non-finite value at every step size tried"

        self.h_previous = h
        self.y_old = self.y
        self.t = t_new
        self.y = engine.accept()
        self.h_abs = h_abs
        return True, None

    def _dense_output_impl(self):
        # (a pair without FSAL evaluates fun at the new state here, and its next step reuses it)
        return EciDenseOutput(self.t_old, self.t, self._engine.dense(self.t_old, self.t))


def _class_name(method):
    return method.replace("-", "").upper()


def _make_classes():
    classes = {}
    for pair in _eci._embedded_pairs():
        name = _class_name(pair["name"])
        kind = "exactly conservative" if pair["conservative"] else "conventional"
        dense = ("continuous extension" if pair["continuous_extension"] else "cubic Hermite interpolant") + (
            " of psi^2, keeping the invariants at every point" if pair["conservative"] else "")
        doc = (f"eci's {pair['name']} as a SciPy solver: {pair['description']}.\n\n"
               f"{kind.capitalize()}, order {pair['order']} (error estimate of order {pair['error_estimator_order']}),"
               f" {pair['stages']} stages{', FSAL' if pair['fsal'] else ''}; dense output: {dense}.\n\n"
               + EmbeddedPair.__doc__.split("\n\n", 1)[1])
        classes[name] = type(name, (EmbeddedPair,), {
            "__doc__": doc, "__module__": __name__, "eci_method": pair["name"], "conservative": pair["conservative"],
            "order": pair["order"], "error_estimator_order": pair["error_estimator_order"],
            "n_stages": pair["stages"], "A": pair["A"], "B": pair["B"], "C": pair["C"], "E": pair["E"]})
    return classes


_classes = _make_classes()
globals().update(_classes)
__all__ += sorted(_classes)


def solvers():
    """eci's embedded pairs as SciPy solver classes, {registry name: class}, in the registry's order."""
    return {cls.eci_method: cls for cls in _classes.values()}
