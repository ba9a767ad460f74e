"""eci: explicit, exactly conservative integrators (Shadwick, Bowman & Morrison 1995), from Python.

    import eci
    r = eci.solve(lambda t, y: ..., (0.0, 10.0), y0, method="c-rk4", dt=0.01,
                  invariants={"energy": lambda y: 0.5 * y @ y})
    r.t, r.y            # SciPy's layout: r.y[:, i] is the state at r.t[i]
    r.stats             # steps, rejected steps by cause, rhs evaluations, solver iterations
    r.invariants        # each invariant's initial and final value and maximum drift over every step

    r = eci.solve(eci.models.ThreeWave(), (0.0, 100.0))   # a built-in model: the whole run in C++

The numerics are the C++ library's: the same steps give the same bits as `eci run`. eci.methods() lists the methods.
"""

import math
import numbers
from collections import namedtuple

import numpy as np

from . import _eci, models
from ._errors import StepSizeUnderflow
from .models import Model

__all__ = ["solve", "methods", "MethodInfo", "SolveResult", "Transform", "StepSizeUnderflow", "models"]
__version__ = "0.1.0"

MethodInfo = namedtuple("MethodInfo", "name order conservative description")
MethodInfo.__doc__ = "A method of the registry: its name, global order, whether it is exactly conservative, one line."


def methods():
    """Every method eci has, as MethodInfo(name, order, conservative, description), in the registry's order.

    A Python fun can use every method except "kahan" (which needs a model's Jacobian); a built-in model lists the
    methods it accepts in model.methods."""
    return [MethodInfo(*m) for m in _eci._methods()]


class Transform:
    """A user's invariant-linearizing transform xi = T(x) for the transformation engine (paper §III.D, §IV, §V).

    forward(x) -> xi (a 1-D array; the invariants are sums of its components, so they are kept exactly);
    inverse(xi, hint) -> x: T's inverse on the branch of `hint` (the conventional update or the predictor), or None
    when xi cannot be inverted (the step is then retried smaller, like a negative radicand); it may also return
    (x, iterations) to count an iterative solve in result.stats;
    and the rate of xi along the flow, given either as jacobian(x) -> dxi/dx (shape (len(xi), len(x))) or as
    rate(x, dxdt) -> dxi/dt.

    With transform=..., eci.solve accepts the methods c-pc, c-rk2 and c-rk4.
    """

    def __init__(self, forward, inverse, jacobian=None, rate=None):
        for name, f in (("forward", forward), ("inverse", inverse)):
            if not callable(f):
                raise TypeError(f"Transform {name} must be callable")
        if (jacobian is None) == (rate is None):
            raise TypeError("Transform needs exactly one of jacobian(x) and rate(x, dxdt)")
        if not callable(jacobian if rate is None else rate):
            raise TypeError("Transform " + ("jacobian" if rate is None else "rate") + " must be callable")
        self.forward, self.inverse, self.jacobian, self.rate = forward, inverse, jacobian, rate

    def __repr__(self):
        return f"Transform(forward={self.forward!r}, inverse={self.inverse!r}, " + (
            f"jacobian={self.jacobian!r})" if self.rate is None else f"rate={self.rate!r})")


class SolveResult(dict):
    """What eci.solve returns; like SciPy's OdeResult, a dict whose keys are also attributes.

    t (m,), y (n, m) with y[:, i] at t[i]; stats: steps (on the dt grid), t_eval_steps (extra steps to t_eval points
    between grid times), rejected_steps by cause (step_failed: negative radicand, non-invertible transform or
    unconverged implicit solve; non_finite_fun; error_estimate: adaptive control), rhs_evals, solver_solves,
    solver_iterations, solver_max_iterations; invariants: name -> initial, final, max_abs_drift, max_rel_drift,
    measured after every step; method, order, conservative; and SciPy's nfev, status, message, success.
    """

    def __getattr__(self, name):
        try:
            return self[name]
        except KeyError:
            raise AttributeError(name) from None

    def __dir__(self):
        return list(self.keys())

    def __repr__(self):
        drift = ", ".join(f"{k}: {v['max_rel_drift']:.3g}" for k, v in self["invariants"].items())
        return (f"SolveResult(method={self['method']!r}, {len(self['t'])} points, steps={self['stats']['steps']}, "
                f"nfev={self['nfev']}" + (f", max relative drift {{{drift}}})" if drift else ")"))


_ADAPTIVE_MISSING = ("adaptive step control (rtol, atol) is not available in this version of eci; "
                     "give a fixed step dt")


def _shortest(v):
    """v as the CLI quotes a number: the shortest text that reads back as v, without a trailing '.0'."""
    text = repr(float(v))
    return text[:-2] if text.endswith(".0") else text


def _number(value, what):
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{what} must be a real number, not {type(value).__name__}")
    return float(value)


def _invariant_list(invariants):
    """Callables and their names from None, one callable, a sequence of callables, or a dict name -> callable."""
    if invariants is None:
        return [], []
    if callable(invariants):
        invariants = [invariants]
    if isinstance(invariants, dict):
        items = list(invariants.items())
    else:  # a function's own name where it has one (not a lambda's)
        items = [(getattr(f, "__name__", "").replace("<lambda>", ""), f) for f in invariants]
    names, functions = [], []
    for i, (name, f) in enumerate(items):
        if not callable(f):
            raise TypeError(f"invariant {name or i} is not callable")
        names.append(str(name) if name else f"invariant_{i}")
        functions.append(f)
    return functions, names


def _t_eval_array(t_eval, t0, t1):
    if t_eval is None:
        return None
    a = np.asarray(t_eval, dtype=float)
    if a.ndim != 1:
        raise ValueError(f"t_eval must be one-dimensional, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError("t_eval must be finite")
    if a.size and (a[0] < t0 or a[-1] > t1 or a.min() < t0 or a.max() > t1):
        raise ValueError(f"t_eval values must lie within t_span [{t0!r}, {t1!r}]")
    if np.any(np.diff(a) < 0):
        raise ValueError("t_eval must be sorted in increasing order")
    return [float(v) for v in a]


def _initial_state(y0):
    try:
        a = np.asarray(y0)
    except Exception as e:  # ragged lists and the like
        raise ValueError(f"y0 is not an array of numbers: {e}") from None
    if a.dtype.kind == "c":
        a = a.astype(np.complex128)
    elif a.dtype.kind in "biuf":
        a = a.astype(np.float64)
    else:
        raise TypeError(f"y0 must be real or complex numbers, not dtype {a.dtype}")
    if a.ndim != 1:
        raise ValueError(f"y0 must be one-dimensional, got shape {a.shape}")
    if a.size == 0:
        raise ValueError("y0 is empty")
    for i, v in enumerate(a):
        if not np.isfinite(v):
            raise ValueError(f"initial condition y[{i}] is not finite")
    return np.ascontiguousarray(a)


def solve(fun, t_span, y0=None, method="c-rk4", dt=None, rtol=None, atol=None, t_eval=None, invariants=None,
          transform=None, max_halvings=40):
    """Integrate dy/dt = fun(t, y) from t_span[0] to t_span[1], SciPy's solve_ivp conventions, eci's numerics.

    fun: a callable fun(t, y) -> dy/dt (y a real or complex 1-D array, as in SciPy), or a built-in model
        (eci.models.ThreeWave(), ...), which runs the whole integration in C++ without the GIL.
    t_span: (t0, t1), t1 >= t0.
    y0: the initial state; for a model, None means its default initial condition.
    method: a name from eci.methods(); "c-rk4" (conservative classical Runge-Kutta) by default.
    dt: the fixed step. Steps land on t0 + i dt, the last one shortened to end at t1, exactly as `eci run`, so the
        states are the CLI's bit for bit. For a model, None means its default step (model.default_dt).
    rtol, atol: adaptive step control, not available yet (NotImplementedError); dt is required meanwhile.
    t_eval: times at which to store the solution (sorted, within t_span); by default every step is stored. A time
        between two grid points is reached by one extra step from the earlier one, off the grid run.
    invariants: callables of y whose drift is measured after every step: one, a list, or a dict name -> callable.
        A model's own invariants are always measured.
    transform: an eci.Transform in which the invariants are linear (methods c-pc, c-rk2, c-rk4).
    max_halvings: how often a failed step may be halved before StepSizeUnderflow (default 40, as the CLI).

    Returns a SolveResult (t, y, stats, invariants, ...). Raises ValueError or TypeError for bad input (the CLI's
    messages), StepSizeUnderflow when a step fails at every size, and whatever fun raises; Ctrl-C interrupts.
    """
    is_model = isinstance(fun, Model)
    if not is_model and not callable(fun):
        raise TypeError(f"fun must be a callable fun(t, y) or an eci.models model, not {type(fun).__name__}")
    if not isinstance(method, str):
        raise TypeError(f"method must be a string (see eci.methods()), not {type(method).__name__}")
    try:
        t0, t1 = t_span
    except (TypeError, ValueError):
        raise ValueError(f"t_span must be a pair (t0, t1), not {t_span!r}") from None
    t0, t1 = _number(t0, "t_span[0]"), _number(t1, "t_span[1]")
    if not math.isfinite(t0):
        raise ValueError(f"t_span[0] must be a finite number, not {_shortest(t0)}")
    if not (t1 >= t0) or not math.isfinite(t1):
        raise ValueError(f"t_span[1] must be a finite number >= {_shortest(t0)}, not {_shortest(t1)}")
    if rtol is not None or atol is not None:
        if dt is not None:
            raise ValueError("give either dt (fixed steps) or rtol/atol (adaptive step control), not both")
        raise NotImplementedError(_ADAPTIVE_MISSING)
    if dt is None:
        if not is_model:
            raise ValueError("dt is required: " + _ADAPTIVE_MISSING.split(";")[0] + " yet")
        dt = fun.default_dt
    dt = _number(dt, "dt")
    if not (dt > 0.0) or not math.isfinite(dt):
        raise ValueError(f"dt must be a positive finite number, not {_shortest(dt)}")
    if (t1 - t0) / dt > 2.0 ** 53:  # beyond 2^53 steps the grid t0 + i dt is no longer exact
        raise ValueError(f"t_span / dt is {_shortest((t1 - t0) / dt)} steps, too many")
    if isinstance(max_halvings, bool) or not isinstance(max_halvings, numbers.Integral) or not 0 <= max_halvings <= 60:
        raise ValueError(f"max_halvings must be a whole number from 0 to 60, not {max_halvings!r}")
    times = _t_eval_array(t_eval, t0, t1)
    functions, names = _invariant_list(invariants)
    if transform is not None and not isinstance(transform, Transform):
        raise TypeError(f"transform must be an eci.Transform, not {type(transform).__name__}")

    if is_model:
        if transform is not None:
            raise ValueError(f"transform is for a Python fun; model {fun.name} uses its own")
        raw = fun._solve(t0, t1, y0, method, dt, times, functions, names, int(max_halvings))
    else:
        if y0 is None:
            raise ValueError("y0 is required for a Python fun")
        y = _initial_state(y0)
        if transform is not None:
            if y.dtype.kind == "c":
                raise ValueError("a transform needs a real y0")
            raw = _eci._solve_transformed(fun, transform.forward, transform.inverse, transform.jacobian,
                                          transform.rate, t0, t1, y, method, dt, times, functions, names,
                                          int(max_halvings))
        else:
            solver = _eci._solve_complex if y.dtype.kind == "c" else _eci._solve_real
            raw = solver(fun, t0, t1, y, method, dt, times, functions, names, int(max_halvings))
    result = SolveResult(raw)
    result["nfev"] = result["stats"]["rhs_evals"]
    result["status"] = 0
    result["success"] = True
    result["message"] = "The solver successfully reached the end of the integration interval."
    return result
