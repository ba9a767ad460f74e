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

import functools
import inspect
import math
import numbers
import os
import sys
import warnings
from collections import namedtuple

import numpy as np

from . import _eci, models
from ._errors import NonFiniteSolution, StepSizeUnderflow, TooManySteps
from .models import Model

__all__ = ["solve", "methods", "MethodInfo", "SolveResult", "DenseSolution", "Transform", "StepSizeUnderflow",
           "TooManySteps", "NonFiniteSolution", "models", "load_checkpoint", "restart", "Checkpoint"]
__version__ = _eci.__version__  # project(eci VERSION ...) in CMakeLists.txt


def __getattr__(name):  # eci.scipy (SciPy's solve_ivp with eci's pairs) is imported on first use: SciPy is heavy
    if name == "scipy":
        import importlib
        return importlib.import_module(".scipy", __name__)
    raise AttributeError(f"module 'eci' has no attribute {name!r}")


def __dir__():  # what eci offers (dir(), tab completion): not the modules it imports (math, np, warnings, ...)
    return sorted(set(__all__) | {"scipy", "Model", "__version__", "__doc__", "__name__", "__file__"})


MethodInfo = namedtuple("MethodInfo", "name order conservative description")
MethodInfo.__doc__ = "A method of the registry: its name, global order, whether it is exactly conservative, one line."


def methods():
    """Every method eci has, as MethodInfo(name, order, conservative, description), in the registry's order.

    A Python fun can use every method ("kahan" with its Jacobian, jac=); a built-in model lists the
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

    With transform=..., eci.solve accepts the methods c-pc, c-rk2 and c-rk4 at fixed steps, and the conservative
    pairs (c-bs32, c-ck54, c-dp54, c-dp853, c-f78) with rtol/atol, also with events and dense_output.
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

    t (m,), y (n, m) with y[:, i] at t[i]; stats: steps (on the dt grid; adaptive: accepted steps), t_eval_steps
    (extra steps to t_eval points between grid times), rejected_steps by cause (step_failed: negative radicand,
    non-invertible transform or unconverged implicit solve; non_finite_fun; error_estimate: adaptive control),
    rhs_evals, solver_solves, solver_iterations, solver_max_iterations, and with rtol/atol also adaptive (True),
    dt_smallest, dt_largest, dense_points, landed_points, dense_fallbacks; invariants: name -> initial, final,
    max_abs_drift, max_rel_drift (nan where it means nothing: moved from an initial 0 or subnormal value), measured
    after every step (adaptive with t_eval: at the t_eval times); method, order, conservative (the method's registry
    flag); keeps: for a built-in model, the names of its invariants the method keeps by construction (`eci run`'s
    summary: all for a conservative method, the first for relaxation, the independent ones for projection), None
    for a Python fun; time_lag (m,): for
    the relaxation methods (rrk-*, mrrk-*) at fixed steps, y[:, i] is the solution at t[i] + time_lag[i] (the CLI's
    time_lag column; a step's O(dt^p), never accumulated), else None; NavierStokes2D runs also budget (energy and
    enstrophy injection and dissipation); and SciPy's nfev, status, message, success.

    invariant_values: name -> (m,) array, each monitored invariant (the model's, then those given as invariants=)
    at each output t[i], the value the run measured there (the CLI's invariant columns); NavierStokes2D runs also
    budget_residual_values: name -> (m,) array, the largest budget residual per step (result.budget's rule) over
    the steps since the previous output (0 at the first).

    plot(file=None, phase=None) draws the run (matplotlib), as `eci run MODEL --plot` does.
    """

    def __getattr__(self, name):
        try:
            return self[name]
        except KeyError:
            raise AttributeError(name) from None

    def __dir__(self):
        return list(self.keys()) + ["plot"]

    def plot(self, file=None, phase=None):
        """The run as a matplotlib Figure, as `eci run MODEL --plot FILE` draws it; saved to `file` if given.

        Drawn: the state's first 6 components over t (named as the model names them; y[0], ... for a Python fun;
        a complex state's real and imaginary parts); beside them a phase plane, two columns against each other
        coloured by t, the start marked (a built-in model's own, model.plot_plane, with one scale on both axes
        where it says so; Kepler's is its derived x, y); below, each invariant's change relative to its initial
        value, (I - I0) / |I0| from invariant_values (absolute, "(abs.)", where I0 is 0 or not finite). A
        NavierStokes2D run: its invariants over t (log scale) and their budget residual per step.

        file: a path ending in .png, .svg or .pdf (ValueError for any other, nothing written).
        phase: (x, y) or (x, y, equal_axes), each a component's index (of the real columns) or name (a component's
        or a derived column's, model.derived_columns): the plane to draw instead of the model's; False: none.
        The figure is pyplot's when pyplot is in use (imported, or MPLBACKEND set, as in a notebook), so that
        plt.show() and notebooks show it; otherwise a figure of its own on the Agg canvas (no window, no backend
        chosen). Needs matplotlib (ImportError otherwise); eci imports it only here.
        """
        from . import _plot
        return _plot.plot(self, file, phase)

    def __repr__(self):
        drift = ", ".join(f"{k}: {v['max_rel_drift']:.3g}" for k, v in self["invariants"].items())
        return (f"SolveResult(method={self['method']!r}, {len(self['t'])} points, steps={self['stats']['steps']}, "
                f"nfev={self['nfev']}" + (f", max relative drift {{{drift}}})" if drift else ")"))


def _shortest(v):
    """v as the CLI quotes a number: the shortest text that reads back as v, without a trailing '.0'."""
    text = repr(float(v))
    return text[:-2] if text.endswith(".0") else text


def _number(value, what):
    if isinstance(value, np.ndarray) and value.ndim == 0 and value.dtype.kind in "iuf":
        value = value[()]  # a 0-d array (np.array(0.1), np.asarray of a number): its number, as SciPy takes it
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
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


def _check_invariant_names(names, reserved, whose):
    """ValueError for an invariants= name given twice or already the name of `whose` (result.invariants is by name)."""
    seen = set()
    for name in names:
        if name in reserved:
            raise ValueError(f"invariants: {name!r} is the name of {whose}, which result.invariants reports already; "
                             "give yours another name (a dict name -> callable)")
        if name in seen:
            raise ValueError(f"invariants: two are named {name!r}; give them different names (a dict name -> "
                             "callable)")
        seen.add(name)


def _t_eval_array(t_eval, t0, t1):
    if t_eval is None:
        return None
    a = np.asarray(t_eval, dtype=float)
    if a.ndim != 1:
        raise ValueError(f"t_eval must be one-dimensional, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError("t_eval must be finite")
    lo, hi = min(t0, t1), max(t0, t1)
    if a.size and (a.min() < lo or a.max() > hi):
        raise ValueError(f"t_eval values must lie within t_span [{t0!r}, {t1!r}]")
    if t1 >= t0 and np.any(np.diff(a) < 0):
        raise ValueError("t_eval must be sorted in increasing order")
    if t1 < t0 and np.any(np.diff(a) > 0):
        raise ValueError("t_eval must be sorted in decreasing order for a backward t_span (t1 < t0)")
    repeated = a[:-1][np.diff(a) == 0]
    if repeated.size:  # (SciPy's rule too: each time is one column of y)
        raise ValueError(f"t_eval has {float(repeated[0])!r} twice: its times must be distinct")
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
    for i, v in enumerate(a):
        if not np.isfinite(v):
            raise ValueError(f"initial condition y[{i}] is not finite")
    return np.ascontiguousarray(a)


# SciPy's solve_ivp defaults, used when a Python fun is given neither dt nor tolerances.
_SCIPY_RTOL, _SCIPY_ATOL = 1e-3, 1e-6
# The default adaptive method: the conservative pair for a model (every built-in one has invariants) or a fun that
# declares one (invariants=, quadratic_invariants=, transform=); the conventional pair for a fun that declares none,
# where nothing is conserved and dp54 is the more accurate of the two at equal work (docs/python.md).
_DEFAULT_ADAPTIVE = "c-dp54"
_DEFAULT_ADAPTIVE_PLAIN = "dp54"
_T_EVAL_MODES = ("auto", "dense", "landing")
# SciPy's explicit methods by the eci pairs of the same tableaux (solve_ivp's RK23, RK45, DOP853)
_SCIPY_METHODS = {"RK23": "bs32", "RK45": "dp54", "DOP853": "dp853"}


def _tolerance(value, name, n):
    """rtol or atol as (scalar, per-component list): a number >= 0 or one number >= 0 per component of y."""
    a = np.asarray(value)
    if a.dtype.kind not in "iuf":  # a bool (True read as 1.0) is a mistake, as in _number
        raise TypeError(f"{name} must be a real number or an array of them, not "
                        f"{'bool' if a.dtype.kind == 'b' else type(value).__name__}")
    if a.ndim == 0:
        v = float(a)
        if not (v >= 0.0) or not math.isfinite(v):
            raise ValueError(f"{name} must be a finite number >= 0, not {_shortest(v)}")
        return v, []
    if a.ndim != 1 or a.size != n:
        raise ValueError(f"{name} has shape {a.shape}, expected a number or one value per component of y ({n},)")
    for i, v in enumerate(a.astype(float)):
        if not (v >= 0.0) or not math.isfinite(v):
            raise ValueError(f"{name}[{i}] must be a finite number >= 0, not {_shortest(v)}")
    return 0.0, [float(v) for v in a]


class DenseSolution:
    """result.sol of eci.solve(..., dense_output=True): the solution between every two accepted steps, like SciPy's
    OdeSolution: sol(t) for a number gives y at t (shape (n,)), for an array of times y at each (shape (n, len(t))).

    Each step's dense output is the stepper's own interpolant (the continuous extension of DP54, degree 4, or of
    DP853, degree 7; else the cubic Hermite interpolant), stored as its values at degree + 1 points of the step,
    which determine it. For a conservative pair the interpolant is of xi = y**2 and each y takes the conventional
    interpolant's sign: every sum_k w_k y_k**2 the method keeps is kept at every t, to rounding (the stored points
    keep it, and the interpolant is a combination of them whose weights sum to 1); the sign is that of the
    conventional interpolant, stored at as many points, as the library takes it. Through a user's transform
    (transform=) the interpolant is of xi = forward(y) (forward of the stored points, which the library's
    interpolant of xi passes through), inverted by transform.inverse with the polynomial through the stored y as
    the hint: the invariants, sums of xi, are kept at every t as at the stored points. A built-in model the library
    integrates in its linearizing variables (Kepler, LotkaVolterra) has sol the polynomial through the stored
    points, not invariant-exact. Outside [t_min, t_max] the first or last step's interpolant is extrapolated, as
    OdeSolution does; it is then no solution: its error grows with the distance (dp853's degree-7 polynomial one
    step out: 2.8e-6 where SciPy's DOP853 extrapolates to 5.7e-8), and a conservative pair's xi, clamped at 0 where
    it turns negative, keeps no invariant there.
    """

    def __init__(self, t_start, t_end, nodes, samples, signs, sign_nodes, squared, y0, t0, transform=None):
        forward = len(t_start) == 0 or t_end[0] >= t_start[0]
        order = slice(None) if forward else slice(None, None, -1)
        self._t_start, self._t_end = np.asarray(t_start)[order], np.asarray(t_end)[order]
        self._samples = np.asarray(samples)[order]
        self._signs = np.asarray(signs)[order] if squared else None
        self._nodes = np.asarray(nodes, dtype=float)
        self._sign_nodes = np.asarray(sign_nodes, dtype=float)
        self._squared = squared
        self._y0 = np.asarray(y0)
        lo = np.minimum(self._t_start, self._t_end)
        self.ts = np.append(lo, max(self._t_start[-1], self._t_end[-1])) if len(lo) else np.array([t0])
        if not forward:
            self.ts = self.ts[::-1]
        self.t_min, self.t_max = (float(min(self.ts[0], self.ts[-1])), float(max(self.ts[0], self.ts[-1])))
        self.n_segments = len(self._t_start)
        self._transform = transform
        self._xi = {}  # per step: forward() of its stored points (transform=), computed when first needed

    def _end_at(self, t):
        """The run ended inside its last step (a terminal event at t): ts and the range end there, as SciPy's
        OdeSolution does; the last step's interpolant still serves beyond it (extrapolation)."""
        self.ts = self.ts.copy()
        self.ts[-1] = t
        self.t_min, self.t_max = (float(min(self.ts[0], self.ts[-1])), float(max(self.ts[0], self.ts[-1])))

    def __call__(self, t):
        t = np.asarray(t, dtype=float)
        tt = np.atleast_1d(t).ravel()
        n = self._y0.size
        if self.n_segments == 0:  # no step taken (t_span of length 0): the initial state everywhere
            y = np.repeat(self._y0[:, None], tt.size, axis=1)
            return y[:, 0] if t.ndim == 0 else y
        bounds = np.minimum(self._t_start, self._t_end)
        i = np.clip(np.searchsorted(bounds, tt, side="right") - 1, 0, self.n_segments - 1)
        a, b = self._t_start[i], self._t_end[i]
        theta = (tt - a) / (b - a)
        weights = self._lagrange(theta, self._nodes)
        samples = self._samples[i]  # (len(t), nodes, n)
        complex_state = samples.dtype.kind == "c"
        if complex_state:  # real and imaginary parts are unknowns of their own
            samples = samples.view(np.float64)
        psi = np.einsum("kj,kjn->kn", weights, samples)
        if self._transform is not None:
            psi = np.stack([self._through_transform(int(s), w, p) for s, w, p in zip(i, weights, psi)])
        elif self._squared:  # xi's interpolant, and the sign of the conventional one, as the library's interpolate
            xi = np.einsum("kj,kjn->kn", weights, samples * samples)
            signs = self._signs[i]
            conventional = np.einsum("kj,kjn->kn", self._lagrange(theta, self._sign_nodes),
                                     signs.view(np.float64) if complex_state else signs)
            psi = np.copysign(np.sqrt(np.maximum(xi, 0.0)), conventional)
        if complex_state:
            psi = np.ascontiguousarray(psi).view(np.complex128)
        y = psi.T.reshape(n, tt.size)
        return y[:, 0] if t.ndim == 0 else y

    def _through_transform(self, step, weights, hint):
        """y at one time of step `step`: xi interpolated from forward() of the stored points, inverted on the
        branch of `hint` (the polynomial through the stored points); that hint where xi cannot be inverted."""
        xi = self._xi.get(step)
        if xi is None:
            xi = self._xi[step] = np.array([np.asarray(self._transform.forward(y), dtype=float)
                                            for y in self._samples[step]])
        x = self._transform.inverse(weights @ xi, hint)
        if isinstance(x, tuple):
            x = x[0]
        return hint if x is None else np.asarray(x, dtype=float)

    @staticmethod
    def _lagrange(theta, x):
        """Lagrange's basis of the nodes x at each theta: exactly 1 and 0s at a node."""
        weights = np.ones((theta.size, x.size))
        for j in range(x.size):
            for m in range(x.size):
                if m != j:
                    weights[:, j] *= (theta - x[m]) / (x[j] - x[m])
        return weights

    def __repr__(self):
        return f"DenseSolution({self.n_segments} steps on [{self.t_min!r}, {self.t_max!r}])"


# The options SciPy's solve_ivp passes to its implicit solvers; an explicit method ignores them, with SciPy's warning.
_IMPLICIT_ONLY = ("jac_sparsity", "lband", "uband")
_SUCCESS = "The solver successfully reached the end of the integration interval."
_TERMINATED = "A termination event occurred."


def _no_effect(names):
    warnings.warn("The following arguments have no effect for a chosen solver: " +
                  ", ".join(f"`{n}`" for n in names) + ".", UserWarning, stacklevel=3)


def _event_list(events):
    """SciPy's events: one callable or a sequence, each with optional attributes terminal and direction."""
    if events is None:
        return None
    if callable(events):
        events = [events]
    out = []
    for i, e in enumerate(events):
        if not callable(e):
            raise TypeError(f"event {i} is not callable: events are functions event(t, y) -> float")
        terminal = getattr(e, "terminal", False)
        direction = getattr(e, "direction", 0)
        # SciPy's (1.11 on): True ends the run at the event's first zero, a whole number N at its N-th, False, 0 or
        # None never; the count is of the zeros found, each event's own (0 here: never)
        if terminal is None or isinstance(terminal, (bool, np.bool_)):
            count = int(bool(terminal))
        elif isinstance(terminal, numbers.Real) and math.isfinite(terminal) and terminal >= 0 and \
                terminal == int(terminal):
            count = int(terminal)
        else:
            raise ValueError(f"event {i}: terminal must be True, False or a whole number >= 0, not {terminal!r}")
        direction = _number(direction, f"event {i}'s direction")
        out.append((e, count, float(np.sign(direction))))
    return out


def _method_of_class(cls):
    """The eci method of a solver class given as solve_ivp's method: an eci.scipy class is its pair, SciPy's RK23,
    RK45 and DOP853 the pairs of the same tableaux (as their names); any other class is refused (eci.solve runs the
    library's own steppers, not a solver class's step)."""
    if isinstance(getattr(cls, "eci_method", None), str):
        return cls.eci_method
    if cls.__module__.startswith("scipy.integrate") and cls.__name__ in _SCIPY_METHODS:
        return cls.__name__
    raise TypeError(f"method {cls.__module__}.{cls.__qualname__} is a class eci.solve cannot run: give a method "
                    f"name (see eci.methods()), one of SciPy's explicit methods ({', '.join(_SCIPY_METHODS)}) or an "
                    f"eci.scipy class, or pass the class to scipy.integrate.solve_ivp")


def _said_as_given(solve):
    """A refusal of a method given by SciPy's name (RK45) names it as given, with eci's name beside it: the library
    speaks of the pair it was mapped to ("method 'dp54' is not available"), a name the user never typed."""
    @functools.wraps(solve)
    def call(*args, **kwargs):
        try:
            return solve(*args, **kwargs)
        except ValueError as e:
            try:  # (by solve's own signature: its parameters' order is not typed here)
                given = inspect.signature(solve).bind(*args, **kwargs).arguments.get("method")
            except TypeError:
                raise e from None
            ours = _SCIPY_METHODS.get(given) if isinstance(given, str) else None
            said = ours and str(e).replace(f"'{ours}'", f"'{given}' (eci's {ours})").replace(
                f"method {ours} ", f"method {given} (eci's {ours}) ")
            if not said or said == str(e):
                raise
            raise ValueError(said) from None
    return call


@_said_as_given
def solve(fun, t_span, y0=None, method=None, dt=None, rtol=None, atol=None, t_eval=None, invariants=None,
          transform=None, max_halvings=40, first_step=None, min_step=0.0, max_step=math.inf, max_steps=None,
          t_eval_mode="auto", jac=None, dense_output=False, events=None, vectorized=False, args=None,
          update=None, quadratic_invariants=None, output_dt=None, progress=None, checkpoint=None,
          checkpoint_every=None, **options):
    """Integrate dy/dt = fun(t, y) from t_span[0] to t_span[1], SciPy's solve_ivp conventions, eci's numerics.

    fun: a callable fun(t, y) -> dy/dt (y a real or complex 1-D array, as in SciPy), or a built-in model
        (eci.models.ThreeWave(), ...), which runs the whole integration in C++ without the GIL (unless Python
        invariants, events or dense output need it).
    t_span: (t0, t1). t1 < t0 integrates backward in time (a built-in model's fixed steps run forward only).
    y0: the initial state (may be empty); for a model, None means its default initial condition.
    method: a name from eci.methods(). Default for a built-in model: the CLI's, by the library's one rule
        (`eci run MODEL` without --method): model.default_method with fixed steps, and with rtol/atol the model's
        default adaptive method (c-dp54 where it runs, else dp54, else its first conservative pair); ValueError if
        it has none. For a Python fun: "c-rk4" (conservative classical Runge-Kutta) with fixed steps, "c-dp54"
        (conservative Dormand-Prince 5(4)) with adaptive control, but "dp54" (the conventional pair, SciPy's RK45)
        for a fun that declares no invariant (none of invariants=, quadratic_invariants=, transform=): nothing is
        conserved there, and the conventional pair is the more accurate at equal work. SciPy's explicit
        method names are taken for the same pairs: "RK23" is bs32, "RK45" dp54, "DOP853" dp853 (eci has no
        implicit solver: "Radau", "BDF" and "LSODA" are refused, naming its methods).
    dt: the fixed step. Steps land on t0 + i dt, the last one shortened to end at t1, exactly as `eci run`, so the
        states are the CLI's bit for bit. For a model, None means its default step (model.default_dt).
    rtol, atol: adaptive step control (an embedded pair: bs32, ck54, dp54, dp853, f78 and their c- versions), each a
        number or one number per component of y (a complex component's two parts share one). SciPy's defaults:
        one not given is rtol=1e-3 or atol=1e-6; an rtol below 100 eps is raised to it with SciPy's warning. A
        Python fun given neither dt nor tolerances is integrated adaptively with both defaults. dt and rtol/atol
        together are an error.
    t_eval: times at which to store the solution (sorted in the direction of t_span, within it); by default every
        step is stored. Fixed steps: a time between two grid points is reached by one extra step from the earlier
        one, off the grid run. Adaptive: t_eval_mode "auto" (dense output where it is as accurate as the steps:
        bs32, dp54, dp853, c-bs32, and c-dp54 and c-dp853 through a transform; c-dp54 and c-dp853 on a plain
        system land steps), "dense"
        (conservative dense output interpolates xi and keeps the invariants) or "landing" (a step lands on each
        time). With dense_output or events, t_eval comes from the dense output, as in SciPy.
    output_dt: store the solution every output_dt of time instead, as `eci run --output-dt` (the library decides
        both, with the same messages): adaptive, at t0, t0 + output_dt, ... and t1 (as t_eval); fixed steps, every
        k = output_dt / dt steps (and the last), output_dt being a whole number of dt, else ValueError (a spectral
        model given no dt takes its CFL 0.5 step shortened to divide output_dt); at most 10^7 outputs. Not with
        t_eval.
    dense_output: also return result.sol, a DenseSolution (callable like SciPy's OdeSolution) built from every
        step's dense output; for a conservative pair it keeps the invariants at every t. Adaptive runs only.
    events: a callable event(t, y) -> float, or a sequence of them, each optionally with attributes terminal
        (True: stop the run at its first zero; a whole number N: at its N-th, as SciPy 1.11 on) and direction
        (count only increasing (> 0) or decreasing (< 0) zeros), as SciPy's. Zeros are located to round-off on each
        step's dense output (Brent's method in C++, 4 eps); result.t_events[i] and result.y_events[i] hold event i's
        times and states; a terminal one ends the run with status 1. Adaptive runs only.
    args: extra arguments: fun(t, y, *args), and so jac and every event (SciPy's `args`).
    vectorized: fun accepts y of shape (n, k) and returns (n, k) (SciPy's `vectorized`); eci calls it with one
        column, as SciPy's explicit methods do.
    invariants: callables of y whose drift is measured after every step (adaptive with t_eval: at every t_eval
        time, as `eci run --rtol --output-dt`): one, a list, or a dict name -> callable. A model's own invariants
        are always measured. Names must differ from each other and from those reported already (ValueError).
    quadratic_invariants: the weights W of quadratic invariants sum_k W[j, k] |y_k|^2 that fun keeps, an (m, n)
        array (or (n,) for one) for y0 of n components, m <= 8. The conservative methods keep every such invariant
        whether told or not; told, the fixed-step ones (c-rk4, c-pc, c-euler, ...) remedy isolated negative
        radicands (the conventional update for those few unknowns, then one rescale restoring every W invariant)
        instead of halving the whole step, and from 16 real unknowns on take the conditioned update (update=).
        result.invariants reports each as quadratic_0, quadratic_1, ... (summed with compensation). fun is
        checked to keep them at (t0, y0) (one call, counted in nfev); a Python fun only, not with transform=.
    transform: an eci.Transform in which the invariants are linear (methods c-pc, c-rk2, c-rk4; adaptive: the c-
        pairs).
    max_halvings: fixed steps: how often a failed step may be halved before the run stops (default 40).
    update: c-pc, c-rk2 or c-rk4 at fixed steps, or an adaptive c- pair, on a system of
        16 or more real unknowns with declared invariants (the n-wave and spectral models, a fun with
        quadratic_invariants=): "conditioned" (default; at the conventional method's error and, adaptive, its
        evaluations, docs/methods.md) or "paper" (the paper's update, bit for bit as before the conditioned update).
        Given with a method that has no update to choose (rk4, a relaxation method, ...): ValueError, as the CLI's
        --update.
    first_step, min_step, max_step, max_steps: adaptive control: the first step (no larger than the span;
        default: the model's default dt, as `eci run --rtol`; for a Python fun, the library's rule
        (choose_first_step: Hairer, Norsett & Wanner's, SciPy's) from two evaluations of fun, counted in nfev and
        stats["rhs_evals"]), the smallest step (default 0: 64 eps |t|), the largest (default inf) and the most
        attempts, accepted and rejected (default 50 000 000).
    progress: a progress line on sys.stderr while the run goes on, as `eci run`'s: "[####....]  45.0%  t = 4.5
        12 s left", from a second into the run (short runs show nothing), erased at its end. None (default): when
        sys.stderr is a terminal; True: always (a notebook's stream too); False: never.
    checkpoint: a spectral model's run kept in a file (eci run's checkpoint format, HDF5: `eci run EQUATION
        --restart FILE` continues it, and eci.restart(FILE)): written at the end of the run (a run whose last step
        is shortened to land on t_span[1] keeps the step before it, on the grid t = i dt), every checkpoint_every
        steps, and on Ctrl-C (the step reached; then the KeyboardInterrupt is raised), each time replacing the file
        whole (a temporary renamed over it), never left half written. A run that fails keeps the last one written.
        t_span must start at 0 (a checkpoint's time is step * dt). The file is checked before the first step
        (OSError: a missing directory, a read-only file).
    checkpoint_every: also write the checkpoint every this many steps (a whole number >= 1; with checkpoint=).
    jac: the Jacobian of a Python fun for method "kahan" (Kahan's linearly implicit method, for quadratic fields):
        jac(t, y) -> (n, n) array, rows the components of fun (SciPy's convention), or a constant (n, n) array;
        real y of up to 8 unknowns. Every other method is explicit and ignores it, with SciPy's warning, as it
        does jac_sparsity, lband and uband.

    Returns a SolveResult (t, y, stats, invariants, nfev, njev, nlu, status, message, success, sol, t_events,
    y_events, ...). As SciPy: a run that cannot go on (a step that fails at every size, the step budget, a state
    that blows up) is no exception but status -1, success False and a message, with the solution up to there and
    result.failure, the exception that describes it (StepSizeUnderflow, TooManySteps or NonFiniteSolution, with
    t, component, component_name, dt, cause and stats), not raised; result.failure is None otherwise; a terminal event
    gives status 1. Bad input raises ValueError or TypeError (the CLI's messages); whatever fun raises propagates;
    Ctrl-C interrupts.
    """
    is_model = isinstance(fun, Model)
    if not is_model and not callable(fun):
        raise TypeError(f"fun must be a callable fun(t, y) or an eci.models model, not {type(fun).__name__}")
    if isinstance(method, type):  # a solver class, as solve_ivp takes one: SciPy's explicit ones or eci.scipy's
        method = _method_of_class(method)
    if method is not None and not isinstance(method, str):
        raise TypeError(f"method must be a string (see eci.methods()), not {type(method).__name__}")
    names = [m.name for m in methods()]
    method = _SCIPY_METHODS.get(method, method)  # (a string or None here)
    if method is not None and method not in names:
        raise ValueError(f"unknown method '{method}' (methods: {', '.join(names)})")  # the library's, as the CLI
    restart_from = options.pop("_restart", None)  # (eci.restart: the checkpoint the run continues)
    unknown = [k for k in options if k not in _IMPLICIT_ONLY]
    if unknown:
        raise TypeError(f"solve() got an unexpected keyword argument {unknown[0]!r}")
    ignored = [k for k in _IMPLICIT_ONLY if k in options]
    try:
        t0, t1 = t_span
    except (TypeError, ValueError):
        raise ValueError(f"t_span must be a pair (t0, t1), not {t_span!r}") from None
    t0, t1 = _number(t0, "t_span[0]"), _number(t1, "t_span[1]")
    if not math.isfinite(t0):
        raise ValueError(f"t_span[0] must be a finite number, not {_shortest(t0)}")
    if not math.isfinite(t1):
        raise ValueError(f"t_span[1] must be a finite number, not {_shortest(t1)}")
    event_list = _event_list(events)
    if args is not None:
        try:
            args = tuple(args)
        except TypeError:
            raise TypeError("Supplied 'args' cannot be unpacked. Please supply `args` as a tuple "
                            "(e.g. `args=(arg,)`)") from None
        if is_model:
            raise ValueError(f"args is for a Python fun; model {fun.name} takes its parameters when built")
        fun = (lambda f: lambda t, y: f(t, y, *args))(fun)
        if callable(jac):
            jac = (lambda j: lambda t, y: j(t, y, *args))(jac)
        if event_list:
            event_list = [((lambda e: lambda t, y: e(t, y, *args))(e), term, d) for e, term, d in event_list]
    if vectorized and is_model:  # (it was ignored: the model's own right-hand side takes one state)
        raise ValueError(f"vectorized is for a Python fun; model {fun.name} evaluates its own right-hand side")
    if vectorized and not is_model:  # SciPy's explicit methods call a vectorized fun with one column
        fun = (lambda f: lambda t, y: np.asarray(f(t, y[:, None])).reshape(-1))(fun)
    if jac is not None and is_model:
        raise ValueError(f"jac is for a Python fun; model {fun.name} has its own Jacobian")
    if jac is not None and method != "kahan":
        ignored.insert(0, "jac")
        jac = None
    if ignored:
        _no_effect(ignored)
    adaptive = rtol is not None or atol is not None
    if adaptive and dt is not None:
        raise ValueError("give either dt (fixed steps) or rtol/atol (adaptive step control; first_step sets the "
                         "first step), not both")
    if not adaptive and dt is None and not is_model:
        if method is None or method in _eci._adaptive_methods_real():
            adaptive = True
        else:
            raise ValueError(f"dt is required for method {method} (fixed steps); or give rtol/atol with an adaptive "
                             f"method ({', '.join(_eci._adaptive_methods_real())})")
    if adaptive:  # SciPy's defaults for the one not given
        rtol = _SCIPY_RTOL if rtol is None else rtol
        atol = _SCIPY_ATOL if atol is None else atol
    if method is None and not is_model:  # (a model's default is the library's rule, the CLI's: below)
        declares = invariants is not None or quadratic_invariants is not None or transform is not None
        method = ("c-rk4" if not adaptive else _DEFAULT_ADAPTIVE if declares else _DEFAULT_ADAPTIVE_PLAIN)
    if not adaptive:
        for name, value, default in (("first_step", first_step, None), ("min_step", min_step, 0.0),
                                     ("max_step", max_step, math.inf), ("max_steps", max_steps, None),
                                     ("t_eval_mode", t_eval_mode, "auto"), ("dense_output", dense_output, False),
                                     ("events", event_list or None, None)):  # (events=[]: none)
            if value != default:
                raise ValueError(f"{name} is for adaptive step control: give rtol/atol (and no dt)")
        if t1 < t0 and is_model:
            # (a spectral model has no method with an error estimate: it runs forward only)
            how = ("; a spectral model runs forward only" if hasattr(fun, "cfl_step") else
                   "; backward time needs adaptive control (rtol/atol, no dt)")
            raise ValueError(f"t_span[1] = {_shortest(t1)} is before t_span[0] = {_shortest(t0)}: fixed steps of a "
                             f"built-in model run forward only{how}")
        dt_given = dt is not None
        if dt is None:  # a spectral model: the CFL 0.5 step of the initial state, as `eci run navier-stokes-2d`
            dt = fun.cfl_step(y0) if y0 is not None and hasattr(fun, "cfl_step") else fun.default_dt
            if hasattr(fun, "cfl_step") and output_dt is not None:  # shortened to divide output_dt, as the CLI's
                dt = _eci._step_dividing(_number(output_dt, "output_dt"), dt)
        dt = _number(dt, "dt")
        if not (dt > 0.0) or not math.isfinite(dt):
            raise ValueError(f"dt must be a positive finite number, not {_shortest(dt)}")
        if (t1 - t0) / dt > _eci._max_grid_steps:  # beyond 2^53 steps the grid t0 + i dt is no longer exact
            raise ValueError(f"t_span / dt is {_shortest((t1 - t0) / dt)} steps, too many")
    if isinstance(max_halvings, bool) or not isinstance(max_halvings, numbers.Integral) or not 0 <= max_halvings <= 60:
        raise ValueError(f"max_halvings must be a whole number from 0 to 60, not {max_halvings!r}")
    times = _t_eval_array(t_eval, t0, t1)
    if output_dt is not None:  # checked and resolved by the library (eci::resolve_output_dt), as the CLI's
        if times is not None:
            raise ValueError("give t_eval or output_dt, not both")
        output_dt = _number(output_dt, "output_dt")
    functions, inv_names = _invariant_list(invariants)
    if transform is not None and not isinstance(transform, Transform):
        raise TypeError(f"transform must be an eci.Transform, not {type(transform).__name__}")
    if is_model and transform is not None:
        raise ValueError(f"transform is for a Python fun; model {fun.name} uses its own")
    if is_model:
        y = None if y0 is None else np.asarray(y0)
        n = len(fun.default_y0) if y is None or y.ndim != 1 else len(y)
    else:
        if y0 is None:
            raise ValueError("y0 is required for a Python fun")
        y = _initial_state(y0)
        if transform is not None and y.dtype.kind == "c":
            raise ValueError("a transform needs a real y0")
        n = len(y)
    weights = None
    kahan_calls, jac_given = [0], None  # (method kahan: its calls of jac, and jac as given)
    if quadratic_invariants is not None:
        if is_model:
            raise ValueError(f"quadratic_invariants is for a Python fun; model {fun.name} declares its own")
        if transform is not None:
            raise ValueError("quadratic_invariants and transform exclude each other: through a transform the "
                             "invariants are those the transform makes linear")
        weights = _quadratic_weights(quadratic_invariants, y)
    # result.invariants is a dict by name: a name given twice, or one the run reports already, would replace a record
    reserved = (list(fun.invariant_names) if is_model
                else [f"quadratic_{j}" for j in range(0 if weights is None else len(weights))])
    _check_invariant_names(inv_names, reserved, f"model {fun.name}'s own invariant" if is_model
                           else "one of quadratic_invariants")

    if update not in (None, "conditioned", "paper"):
        raise ValueError(f"update must be 'conditioned' or 'paper', not {update!r}")
    if progress is None:  # (a stream without isatty, or None where there is none: no line)
        progress = bool(getattr(sys.stderr, "isatty", lambda: False)())
    elif not isinstance(progress, (bool, np.bool_)):
        raise TypeError(f"progress must be True, False or None, not {type(progress).__name__}")
    if checkpoint is not None or checkpoint_every is not None:
        if not (is_model and hasattr(fun, "cfl_step")):
            what = f"model {fun.name}" if is_model else "a Python fun"
            raise ValueError(f"checkpoint is for the spectral models (eci.models.NavierStokes2D, ...); {what} keeps "
                             "none (its result holds the states)")
        if checkpoint is None:
            raise ValueError("checkpoint_every needs checkpoint=FILE, the file it writes")
        if not isinstance(checkpoint, (str, os.PathLike)):
            raise TypeError(f"checkpoint must be a file name, not {type(checkpoint).__name__}")
        checkpoint = os.fspath(checkpoint)
        if checkpoint_every is not None and (isinstance(checkpoint_every, (bool, np.bool_)) or
                                             not isinstance(checkpoint_every, numbers.Integral) or
                                             checkpoint_every < 1):
            raise ValueError(f"checkpoint_every must be a whole number of steps >= 1, not {checkpoint_every!r}")
    settings = {"t_eval": times, "max_halvings": int(max_halvings), "adaptive": None, "update": update,
                "dense_output": bool(dense_output), "events": event_list, "output_dt": output_dt,
                "dt_given": adaptive or dt_given, "progress": bool(progress), "checkpoint": checkpoint,
                "checkpoint_every": None if checkpoint_every is None else int(checkpoint_every),
                "restart": restart_from}
    extra_calls = 0
    if weights is not None:
        _check_quadratic_invariants(fun, t0, y, weights)
        extra_calls += 1
    if adaptive:
        settings["adaptive"] = _adaptive_settings(rtol, atol, n, first_step, min_step, max_step, max_steps,
                                                  t_eval_mode, t0, t1)
        h = settings["adaptive"]["first_step"]
        if h is None and is_model:
            h = fun.default_dt
        elif h is None:  # the library's rule (choose_first_step, Hairer, Norsett & Wanner), counted in rhs_evals
            h = 0.0
        dt = h
    if is_model:
        if method is None:  # the model's default method, with rtol/atol its default adaptive one: as `eci run`
            method = fun._default_method(adaptive)
        raw = fun._solve(t0, t1, y0, method, dt, settings, functions, inv_names)
    else:
        if method == "kahan":
            if transform is not None:
                raise ValueError("method kahan does not take a transform")
            jac_given = jac

            def jac(t, x, j=_jacobian(jac, y)):  # counted: SciPy's njev and nlu (one solve per attempted step)
                kahan_calls[0] += 1
                return j(t, x)
        parts = None if transform is None else (transform.forward, transform.inverse, transform.jacobian,
                                                transform.rate)
        if t1 < t0 and not adaptive:  # fixed steps backward (adaptive runs step backward in the library)
            raw = _solve_backward_fixed(fun, t0, t1, y, method, dt, settings, functions, inv_names, parts, jac,
                                        weights)
        else:
            raw = _eci._solve_function(fun, t0, t1, y, method, dt, settings, functions, inv_names, parts, jac,
                                       weights)
    result = SolveResult(raw)
    result._model = fun if is_model else None  # (for plot: the model's names, phase plane and derived columns)
    result["nfev"] = result["stats"]["rhs_evals"] + extra_calls
    # explicit methods evaluate no Jacobian and solve nothing; Kahan's linearly implicit method evaluates jac (a
    # constant matrix: no evaluation) and factors one matrix per attempted step
    result["njev"] = kahan_calls[0] if callable(jac_given) else 0
    result["nlu"] = kahan_calls[0]
    failure = result.get("failure")
    if failure is not None:  # the exception that describes it, not raised: result.failure (raise it if you like)
        from . import _errors
        f = failure
        result["failure"] = getattr(_errors, f["kind"])(f["message"], f["t"], f["component"], f["component_name"],
                                                         f["dt"], f["cause"], result["stats"])
        result["status"], result["message"] = -1, f["message"]
    elif result.get("stopped_at") is not None:
        result["status"], result["message"] = 1, _TERMINATED
    else:
        result["status"], result["message"] = 0, _SUCCESS
    result["success"] = result["status"] >= 0
    if event_list is None:
        result["t_events"] = result["y_events"] = None
    else:  # as SciPy: an event that never occurred has y_events of shape (0,)
        result["y_events"] = [ye if len(ye) else np.asarray([]) for ye in result.get("y_events", [])]
        result.setdefault("t_events", [])
    result["sol"] = None
    if dense_output:
        d = result.pop("dense")
        start = y if y is not None else (result["y"][:, 0] if result["y"].shape[1] else np.asarray(fun.default_y0))
        result["sol"] = DenseSolution(d["t_start"], d["t_end"], d["nodes"], d["samples"], d["signs"], d["sign_nodes"],
                                      d["squared"], start, t0, transform)
        if result.get("stopped_at") is not None and result["sol"].n_segments:
            result["sol"]._end_at(float(result["stopped_at"]))
    return result


def _solve_backward_fixed(fun, t0, t1, y, method, dt, settings, functions, inv_names, parts, jac, weights=None):
    """Fixed steps of dt from t0 back to t1 < t0: the forward run of g(s, y) = -fun(t0 - s, y) over s in [0, t0 - t1].
    A Runge-Kutta step of g with step dt computes exactly what a step of fun with step -dt computes (negation is
    exact; the stage times t0 - (s + c dt) differ from t + c (-dt) only in their rounding), and the transforms,
    invariants and radicands see the same states, so the conservative methods keep their invariants backward too.
    The result's times are t0 - s, with t_eval's own values and t1 itself where the run reached them."""
    def backward(s, x):
        return np.negative(np.asarray(fun(t0 - s, x)))

    back_jac = None
    if jac is not None:  # kahan: d(-fun)/dy
        back_jac = lambda s, x: np.negative(np.asarray(jac(t0 - s, x)))  # noqa: E731
    times = settings["t_eval"]
    settings = dict(settings, t_eval=None if times is None else [t0 - t for t in times])
    raw = _eci._solve_function(backward, 0.0, t0 - t1, y, method, dt, settings, functions, inv_names, parts,
                               back_jac, weights)
    t = t0 - np.asarray(raw["t"], dtype=float)
    if times is not None and len(t) == len(times):
        t = np.asarray(times, dtype=float)
    elif len(t) and raw.get("failure") is None and raw.get("stopped_at") is None:
        t[-1] = t1
    raw["t"] = t
    if raw.get("failure") is not None:
        f = raw["failure"]
        # the message was written by the forward run, at its time s: said at t0 - s, as f["t"] (with 17 digits, or
        # the shortest text, as the library writes times)
        message, s, t = f["message"], f["t"], t0 - f["t"]
        for text in (lambda v: f"{v:.17g}", lambda v: repr(float(v)).removesuffix(".0")):
            if f"t = {text(s)}" in message:
                message = message.replace(f"t = {text(s)}", f"t = {text(t)}", 1)
                break
        raw["failure"] = dict(f, t=t, message=message)
    return raw


_MAX_QUADRATIC_INVARIANTS = 8  # the remedy's limit (radicand_remedy::max_invariants)


def _quadratic_weights(weights, y):
    """quadratic_invariants= as a float64 (m, n) array, checked: real finite numbers, n per row, 1 <= m <= 8."""
    n = len(y)
    try:
        w = np.asarray(weights)
    except Exception as e:  # ragged lists and the like
        raise ValueError(f"quadratic_invariants is not an array of numbers: {e}") from None
    if w.dtype.kind not in "iuf":
        raise TypeError(f"quadratic_invariants must be real numbers, not dtype {w.dtype}")
    if w.ndim == 1:
        w = w[None, :]
    if w.ndim != 2 or w.shape[1] != n or w.shape[0] == 0:
        raise ValueError(f"quadratic_invariants has shape {np.shape(weights)}, expected ({n},) or (m, {n}): one "
                         f"weight per component of y0")
    if w.shape[0] > _MAX_QUADRATIC_INVARIANTS:
        raise ValueError(f"quadratic_invariants has {w.shape[0]} rows; at most {_MAX_QUADRATIC_INVARIANTS} "
                         f"quadratic invariants")
    w = np.ascontiguousarray(w, dtype=np.float64)
    if not np.all(np.isfinite(w)):
        j, k = np.argwhere(~np.isfinite(w))[0]
        raise ValueError(f"quadratic_invariants[{j}, {k}] is not finite")
    return w


def _check_quadratic_invariants(fun, t0, y, w):
    """ValueError if fun does not keep sum_k W[j, k] |y_k|^2 at (t0, y0): its rate 2 sum_k W[j, k] Re(conj(y_k)
    f_k) must vanish up to the rounding of the products and their sum, each product below a few eps of
    |W[j, k]| |y_k| |f_k| (a complex product's real part is itself a difference of two), the sum below n eps of
    the sum of those."""
    f = np.asarray(fun(t0, y.copy()))
    if f.shape != y.shape or f.dtype.kind not in "biufc" or not np.all(np.isfinite(f)):
        return  # the run itself reports a fun that returns something unusable
    rate = (2.0 * w * np.real(np.conj(y) * f)[None, :]).sum(axis=1)
    size = (2.0 * np.abs(w) * (np.abs(y) * np.abs(f))[None, :]).sum(axis=1)
    bad = np.flatnonzero(np.abs(rate) > 4 * (len(y) + 1) * np.finfo(float).eps * size)
    if bad.size:
        j = int(bad[0])
        raise ValueError(f"fun does not keep quadratic invariant {j} (row {j} of quadratic_invariants) at (t0, y0): "
                         f"its rate is {rate[j]:.17g}, not 0")


def _jacobian(jac, y):
    """jac for Kahan's method as a callable jac(t, y): the user's, or a constant matrix's."""
    if jac is None:
        raise ValueError("method kahan needs the Jacobian of fun: give jac=jac(t, y) (an (n, n) array, as "
                         "solve_ivp's jac)")
    if y.dtype.kind == "c":
        raise ValueError("method kahan needs a real y0")
    if callable(jac):
        return jac
    J = np.asarray(jac)
    if J.dtype.kind not in "biuf" or J.shape != (len(y), len(y)):
        raise ValueError(f"jac must be callable jac(t, y) or an array of shape ({len(y)}, {len(y)}), got "
                         f"{J.dtype} array of shape {J.shape}")
    J = J.astype(float)
    return lambda t, y: J


def _adaptive_settings(rtol, atol, n, first_step, min_step, max_step, max_steps, t_eval_mode, t0, t1):
    """The checked adaptive settings, as the dict the compiled solvers read (solve has filled in SciPy's
    defaults for a tolerance not given). An rtol below 100 eps is raised to it with SciPy's warning: below it the
    error estimate is round-off."""
    r, r_each = _tolerance(rtol, "rtol", n)
    a, a_each = _tolerance(atol, "atol", n)
    # both zero is refused before rtol is raised (as the CLI refuses it), which would otherwise hide it
    if not r_each and not a_each and r == 0.0 and a == 0.0:
        raise ValueError("rtol and atol cannot both be zero")
    if r_each or a_each:  # the library takes per-component vectors for both or a scalar: expand the scalar
        r_each = r_each or [r] * n
        a_each = a_each or [a] * n
        if not any(x + y > 0.0 for x, y in zip(r_each, a_each)):
            raise ValueError("rtol and atol cannot both be zero")
    floor = 100 * np.finfo(float).eps  # eci::min_rtol, which the CLI raises its rtol to alike
    if (r_each and min(r_each) < floor) or (not r_each and r < floor):
        warnings.warn(f"At least one element of `rtol` is too small. Setting `rtol = np.maximum(rtol, {floor})`.",
                      UserWarning, stacklevel=3)
        r = max(r, floor)
        r_each = [max(v, floor) for v in r_each]
    if first_step is not None:
        first_step = _number(first_step, "first_step")
        if not (first_step > 0.0) or not math.isfinite(first_step):
            raise ValueError(f"first_step must be a positive finite number, not {_shortest(first_step)}")
        if first_step > abs(t1 - t0):
            raise ValueError(f"first_step {_shortest(first_step)} exceeds the span of the run, "
                             f"{_shortest(abs(t1 - t0))}")
    min_step = _number(min_step, "min_step")
    if not (min_step >= 0.0) or not math.isfinite(min_step):
        raise ValueError(f"min_step must be a finite number >= 0, not {_shortest(min_step)}")
    max_step = _number(max_step, "max_step")
    if not (max_step > 0.0):
        raise ValueError(f"max_step must be positive, not {_shortest(max_step)}")
    if min_step > max_step:
        raise ValueError(f"min_step {_shortest(min_step)} is larger than max_step {_shortest(max_step)}")
    if max_steps is None:
        max_steps = 50_000_000
    if (isinstance(max_steps, bool) or not isinstance(max_steps, numbers.Integral) or max_steps < 1
            or max_steps > 2 ** 63):  # (beyond it the C++ count could not hold it: pybind's cast error leaked)
        raise ValueError(f"max_steps must be a whole number from 1 to 2**63, not {max_steps!r}")
    if t_eval_mode not in _T_EVAL_MODES:
        raise ValueError(f"t_eval_mode must be one of {', '.join(_T_EVAL_MODES)}, not {t_eval_mode!r}")
    return {"rtol": r, "atol": a, "rtol_each": r_each, "atol_each": a_each, "first_step": first_step,
            "min_step": min_step, "max_step": max_step, "max_steps": int(max_steps), "t_eval_mode": t_eval_mode}


class Checkpoint:
    """A spectral run's checkpoint (`eci run EQUATION --checkpoint` or eci.solve(..., checkpoint=)), as
    eci.load_checkpoint reads it.

    model: a new model of the checkpoint's equation with its settings (n, viscosities, forcing, threads, plans) and
        its stochastic forcing's generator where the run left it; y: the state, in the model's layout; t: its time,
        step * dt; step, dt, method, update: the run's; t_end: the end time the run was asked for; equation.
    initial: the first two invariants at step 0; budget: (E injection, E dissipation, Z injection, Z dissipation)
        since step 0; max_drift, max_budget_residual: the run's so far; rhs_evals, halvings.
    """

    def __init__(self, path, model, y, header):
        self.path, self.model, self.y, self._header = path, model, y, header
        self.step, self.dt, self.method, self.update = header.step, header.dt, header.method, header.update
        self.t = header.step * header.dt
        self.t_end = header.t_end if math.isfinite(header.t_end) else header.total_steps * header.dt
        self.equation = header.equation
        self.initial, self.budget = header.initial, header.budget
        self.max_drift, self.max_budget_residual = header.max_drift, header.max_budget_residual
        self.rhs_evals, self.halvings = header.rhs_evals, header.halvings

    def __repr__(self):
        return (f"Checkpoint({self.path!r}: {self.model!r} at step {self.step}, t = {_shortest(self.t)} of "
                f"{_shortest(self.t_end)}, {self.method}, dt {_shortest(self.dt)})")


def load_checkpoint(path):
    """The checkpoint at `path` (eci run's or eci.solve's checkpoint=) as an eci.Checkpoint: its model (a new one,
    with the run's settings, plans and forcing generator), state y at time t, and the run's settings and statistics.
    The state is checked against the checksum the file holds. FileNotFoundError (no such file), ValueError (not an
    eci checkpoint, damaged, an unknown equation)."""
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"path must be a file name, not {type(path).__name__}")
    path = os.fspath(path)
    if not hasattr(_eci, "_load_checkpoint"):
        raise ValueError("this eci was built without the spectral equations (FFTW): it has no checkpoints")
    with open(path, "rb"):  # (FileNotFoundError, PermissionError, IsADirectoryError: Python's own)
        pass
    model, y, header = _eci._load_checkpoint(path)
    return Checkpoint(path, model, y, header)


def restart(checkpoint, t_end=None, *, output_dt=None, invariants=None, max_halvings=40, progress=None,
            keep_checkpoint=True, checkpoint_every=None):
    """Continue a spectral run from its checkpoint, bit for bit as the run that was not stopped would have gone on
    (as `eci run EQUATION --restart FILE`): the checkpoint's model, state, method, dt and update.

    checkpoint: a file name (eci run's or eci.solve's checkpoint) or an eci.Checkpoint.
    t_end: where to go; default the end its run was asked for. A later end goes on along the grid t = i dt.
    keep_checkpoint: True (default) continues the checkpoint in place (written as eci.solve's checkpoint=, every
        checkpoint_every steps, at the end, on Ctrl-C); a file name writes another one; False none.
    output_dt, invariants, max_halvings, progress: as eci.solve's.
    Returns eci.solve's SolveResult for the run from the checkpoint's step on (its t starts at the checkpoint's t;
    its budget and drifts are this part's; the checkpoint written holds the totals since step 0)."""
    ck = checkpoint if isinstance(checkpoint, Checkpoint) else load_checkpoint(checkpoint)
    ck.model._rng_state = ck._header.rng_state  # (a Checkpoint restarted twice: its model's generator has moved)
    t_end = ck.t_end if t_end is None else _number(t_end, "t_end")
    if not math.isfinite(t_end):
        raise ValueError(f"t_end must be a finite number, not {_shortest(t_end)}")
    if not t_end >= ck.t:
        raise ValueError(f"t_end {_shortest(t_end)} is before the checkpoint's t = {_shortest(ck.t)} (step "
                         f"{ck.step}): a restart goes forward from it")
    if keep_checkpoint is True:
        path = ck.path
    elif keep_checkpoint is False or keep_checkpoint is None:
        path = None
        if checkpoint_every is not None:
            raise ValueError("checkpoint_every needs a checkpoint to write: keep_checkpoint=False writes none")
    else:
        path = keep_checkpoint
    return solve(ck.model, (0.0, t_end), ck.y, method=ck.method, dt=ck.dt,
                 update="paper" if ck.update == "paper" else None, output_dt=output_dt, invariants=invariants,
                 max_halvings=max_halvings, progress=progress, checkpoint=path, checkpoint_every=checkpoint_every,
                 _restart=ck._header)
