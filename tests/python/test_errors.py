# Bad input raises ValueError/TypeError with the CLI's one-line messages; a step that fails at every size raises
# eci.StepSizeUnderflow with the time, the component and the statistics so far; a fun that misbehaves (wrong
# shape or dtype, non-finite values, exceptions) gives a clear error and no crash; Ctrl-C stops a long run promptly.
import os
import re
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest

import eci
from conftest import BUILD, cli_error, failure_of

M = eci.models


def message(excinfo):
    return str(excinfo.value)


# --- the CLI's messages -----------------------------------------------------------------------------------------

@pytest.mark.parametrize("make, cli_args", [
    (lambda: M.ThreeWave(M=(1.0, 1.0, -1.0)), ["three-wave", "--M", "1,1,-1"]),
    (lambda: M.ThreeWave(K=1.0), ["three-wave", "--K", "1"]),
    (lambda: M.ThreeWave(P=float("inf")), ["three-wave", "--P", "inf"]),
    (lambda: M.LotkaVolterra(mu=-1.0), ["lotka-volterra", "--mu", "-1"]),
    (lambda: M.Kepler(ell=0.0), ["kepler", "--ell", "0"]),
    (lambda: M.Kepler(m=0.0), ["kepler", "--m", "0"]),
    (lambda: M.NWave(modes=2), ["n-wave", "--modes", "2"]),
    (lambda: M.NWave(modes=10, triads_per_mode=1), ["n-wave", "--modes", "10", "--triads-per-mode", "1"]),
])
def test_invalid_model_parameters_give_the_cli_message(cli, make, cli_args):
    with pytest.raises(ValueError) as e:
        make()
    assert message(e) == cli_error(cli, "run", *cli_args)


@pytest.mark.parametrize("model, y0, cli_args", [
    (M.LotkaVolterra(), [-1.0, 0.4], ["lotka-volterra", "--x", "-1"]),
    (M.LotkaVolterra(), [1.0, 0.0], ["lotka-volterra", "--y", "0"]),
    (M.Kepler(), [1.0, 5.0, 0.0], ["kepler", "--v-r", "5"]),
    (M.Kepler(), [-1.0, 0.0, 0.0], ["kepler", "--r", "-1"]),
    (M.ThreeWave(), [float("nan"), 0.0, 1.0], ["three-wave", "--psi", "nan,0,1"]),
])
def test_invalid_initial_conditions_give_the_cli_message(cli, model, y0, cli_args):
    with pytest.raises(ValueError) as e:
        eci.solve(model, (0.0, 1.0), y0)
    assert message(e) == cli_error(cli, "run", *cli_args)


def test_a_backward_span_of_a_model_needs_adaptive_control():
    # the CLI has no backward span (--t-end >= 0); a built-in model runs backward with rtol/atol only (a Python fun
    # also in fixed steps: test_solve_conventions.py)
    with pytest.raises(ValueError, match=r"t_span\[1\] = -1 is before t_span\[0\] = 0: fixed steps of a built-in "
                                         r"model run forward only"):
        eci.solve(M.ThreeWave(), (0.0, -1.0))
    assert eci.solve(M.ThreeWave(), (0.0, -1.0), rtol=1e-8, atol=1e-8).t[-1] == -1.0


@pytest.mark.parametrize("kwargs, cli_args, option, python_name", [
    (dict(method="rk5"), ["--method", "rk5"], None, None),
    (dict(method="kahan"), ["--method", "kahan"], None, None),
    (dict(dt=-1.0), ["--dt", "-1"], "--dt", "dt"),
    (dict(dt=0.0), ["--dt", "0"], "--dt", "dt"),
    (dict(dt=float("nan")), ["--dt", "nan"], "--dt", "dt"),
    (dict(t_span=(0.0, 1e10), dt=1e-10), ["--t-end", "1e10", "--dt", "1e-10"], "--t-end / --dt", "t_span / dt"),
])
def test_invalid_run_settings_give_the_cli_message(cli, kwargs, cli_args, option, python_name):
    kwargs = dict(kwargs)
    t_span = kwargs.pop("t_span", (0.0, 1.0))
    with pytest.raises(ValueError) as e:
        eci.solve(M.ThreeWave(), t_span, **kwargs)
    expected = cli_error(cli, "run", "three-wave", *cli_args)
    if option:
        expected = expected.replace(option, python_name, 1)
    assert message(e) == expected


def test_kahan_needs_a_jacobian():
    with pytest.raises(ValueError, match=r"method kahan needs the Jacobian of fun: give jac=jac\(t, y\)"):
        eci.solve(lambda t, y: -y, (0.0, 1.0), [1.0], method="kahan", dt=0.1)


# --- arguments of eci.solve -------------------------------------------------------------------------------------

def decay(t, y):
    return -y


def decay_energy(y):
    return 0.5 * y @ y


@pytest.mark.parametrize("kwargs, error, pattern", [
    (dict(y0=[[1.0, 2.0]]), ValueError, r"y0 must be one-dimensional, got shape \(1, 2\)"),
    (dict(y0=["a"]), TypeError, "y0 must be real or complex numbers, not dtype <U1"),
    (dict(y0=[1.0, np.inf]), ValueError, r"initial condition y\[1\] is not finite"),
    (dict(y0=None), ValueError, "y0 is required for a Python fun"),
    (dict(dt=None, method="c-rk4"), ValueError, r"dt is required for method c-rk4 \(fixed steps\)"),
    (dict(rtol=1e-6), ValueError, "give either dt .* or rtol/atol"),
    (dict(dt="0.1"), TypeError, "dt must be a real number, not str"),
    (dict(t_span=(0.0,)), ValueError, r"t_span must be a pair \(t0, t1\)"),
    (dict(t_span=(float("nan"), 1.0)), ValueError, r"t_span\[0\] must be a finite number, not nan"),
    (dict(t_eval=[0.5, 0.2]), ValueError, "t_eval must be sorted in increasing order"),
    (dict(t_eval=[0.5, 2.0]), ValueError, r"t_eval values must lie within t_span \[0.0, 1.0\]"),
    (dict(method=3), TypeError, "method must be a string"),
    (dict(t_eval=[0.2, 0.5, 0.5]), ValueError, r"^t_eval has 0.5 twice: its times must be distinct$"),
    (dict(invariants=[1.0]), TypeError, "invariant 0 is not callable"),
    # result.invariants is by name: a name given twice, or one the run reports already, would replace a record
    (dict(invariants=[decay_energy, decay_energy]), ValueError,
     r"^invariants: two are named 'decay_energy'; give them different names \(a dict name -> callable\)$"),
    (dict(invariants=[lambda y: 1.0, decay_energy, lambda y: 2.0], t_eval=None), None, None),
    (dict(invariants={"invariant_1": decay_energy, "x": decay_energy, "invariant_0": lambda y: float(y[0])}), None,
     None),
    (dict(quadratic_invariants=[[1.0, 1.0]], invariants={"quadratic_0": decay_energy}), ValueError,
     r"^invariants: 'quadratic_0' is the name of one of quadratic_invariants, which result.invariants reports"),
    (dict(max_halvings=-1), ValueError, "max_halvings must be a whole number from 0 to 60"),
    (dict(transform="squares"), TypeError, "transform must be an eci.Transform"),
])
def test_bad_arguments(kwargs, error, pattern):
    args = dict(fun=decay, t_span=(0.0, 1.0), y0=[1.0, 2.0], dt=0.1)
    args.update(kwargs)
    if error is None:  # (the good neighbour of a refusal: it runs, every invariant reported under its own name)
        names = eci.solve(**args).invariants.keys()
        assert len(names) == len(args["invariants"]), names
        return
    with pytest.raises(error, match=pattern):
        eci.solve(**args)


# A model's own invariants are reported by their names: one of invariants= of the same name would replace it.
@pytest.mark.parametrize("make", [lambda: M.ThreeWave(), lambda: M.NavierStokes2D(n=16, fftw_measure=False)])
def test_an_invariant_named_as_the_models_own_is_refused(make):
    m = make()
    for name in m.invariant_names:
        with pytest.raises(ValueError, match=rf"^invariants: '{name}' is the name of model {m.name}'s own invariant"):
            eci.solve(m, (0.0, 2 * m.default_dt), dt=m.default_dt, invariants={name: lambda y: 1.0})
    r = eci.solve(m, (0.0, 2 * m.default_dt), dt=m.default_dt, invariants={"mine": lambda y: 1.0})
    assert list(r.invariants) == list(m.invariant_names) + ["mine"]


def test_fun_must_be_callable():
    with pytest.raises(TypeError, match="fun must be a callable"):
        eci.solve(42, (0.0, 1.0), [1.0], dt=0.1)


def test_vectorized_is_for_functions():
    # a model's right-hand side takes one state: vectorized=True on it was silently ignored (args= and jac= refused)
    with pytest.raises(ValueError, match="vectorized is for a Python fun; model three-wave evaluates its own"):
        eci.solve(M.ThreeWave(), (0.0, 1.0), vectorized=True)
    assert eci.solve(M.ThreeWave(), (0.0, 1.0), vectorized=False).success


def test_transform_is_for_functions_and_conservative_methods():
    squares = eci.Transform(lambda x: x * x, lambda xi, hint: np.copysign(np.sqrt(xi), hint),
                            jacobian=lambda x: np.diag(2 * x))
    with pytest.raises(ValueError, match="transform is for a Python fun; model three-wave uses its own"):
        eci.solve(M.ThreeWave(), (0.0, 1.0), transform=squares)
    with pytest.raises(ValueError, match=r"method 'rk4' is not available for a transform \(available: c-pc, c-rk2, "
                                         r"c-rk4[,)]"):
        eci.solve(decay, (0.0, 1.0), [1.0], method="rk4", dt=0.1, transform=squares)
    with pytest.raises(ValueError, match="a transform needs a real y0"):
        eci.solve(decay, (0.0, 1.0), [1.0j], dt=0.1, transform=squares)
    with pytest.raises(TypeError, match="exactly one of jacobian"):
        eci.Transform(lambda x: x, lambda xi, hint: xi)


# --- a fun that misbehaves --------------------------------------------------------------------------------------

@pytest.mark.parametrize("fun, error, pattern", [
    (lambda t, y: y[:2], ValueError, r"fun\(t, y\) returned an array of shape \(2,\), expected \(3,\) like y0"),
    (lambda t, y: np.ones((3, 1)), ValueError, r"fun\(t, y\) returned an array of shape \(3, 1\), expected \(3,\)"),
    (lambda t, y: 1.0, ValueError, r"fun\(t, y\) returned an array of shape \(\), expected \(3,\)"),
    (lambda t, y: None, TypeError, r"fun\(t, y\) returned None, expected an array of 3 numbers"),
    (lambda t, y: ["a", "b", "c"], TypeError, r"fun\(t, y\) returned values of dtype <U1, expected real numbers"),
    (lambda t, y: 1j * y, TypeError, r"fun\(t, y\) returned complex values but y0 is real; pass a complex y0"),
])
def test_fun_returning_the_wrong_thing(fun, error, pattern):
    with pytest.raises(error, match=pattern):
        eci.solve(fun, (0.0, 1.0), [1.0, 2.0, 3.0], dt=0.1)


def test_fun_returning_a_list_or_integers_is_converted():
    r = eci.solve(lambda t, y: [0, 1, 2], (0.0, 1.0), [0.0, 0.0, 0.0], method="euler", dt=0.25)
    assert np.array_equal(r.y[:, -1], [0.0, 1.0, 2.0])
    r = eci.solve(lambda t, y: np.array([1.0, 2.0]), (0.0, 1.0), [1j, 0j], method="euler", dt=0.5)
    assert r.y.dtype == np.complex128 and np.array_equal(r.y[:, -1], [1 + 1j, 2 + 0j])


def test_fun_that_raises_propagates_its_exception():
    calls = []

    def fun(t, y):
        calls.append(t)
        if len(calls) == 7:
            raise ZeroDivisionError("user bug")
        return -y

    with pytest.raises(ZeroDivisionError, match="user bug"):
        eci.solve(fun, (0.0, 10.0), [1.0], method="rk4", dt=0.1)
    assert len(calls) == 7
    # the module is unharmed
    assert eci.solve(decay, (0.0, 1.0), [1.0], dt=0.5).success


def test_fun_returning_nan_everywhere_underflows_naming_it():
    err = failure_of(
        eci.solve(lambda t, y: np.array([0.0, np.nan]), (0.0, 1.0), [1.0, 1.0], method="c-rk4", dt=0.1),
        eci.StepSizeUnderflow)
    assert isinstance(err, RuntimeError)
    assert err.cause == "non_finite_fun" and err.component == 1 and err.component_name == "y[1]" and err.t == 0.0
    assert err.dt == 0.1 * 2.0 ** -40
    assert "fun(t, y) returned nan in component y[1]" in str(err)
    assert err.stats["rejected_steps"]["non_finite_fun"] == 40
    assert err.stats["rhs_evals"] == 41 and err.stats["steps"] == 0


def test_a_non_finite_value_fails_the_step_which_is_retried_smaller():
    calls = [0]

    def fun(t, y):
        calls[0] += 1
        return np.array([np.inf]) if calls[0] == 2 else -y

    r = eci.solve(fun, (0.0, 1.0), [1.0], method="c-rk4", dt=0.5)
    assert r.stats["rejected_steps"] == {"step_failed": 0, "non_finite_fun": 1, "error_estimate": 0}
    assert r.stats["steps"] == 2 and r.t[-1] == 1.0 and np.all(np.isfinite(r.y))


def test_invariant_returning_a_non_number():
    with pytest.raises(TypeError, match=r"invariant bad returned 'x', expected a real number"):
        eci.solve(decay, (0.0, 1.0), [1.0], dt=0.5, invariants={"bad": lambda y: "x"})


# --- step-size underflow ----------------------------------------------------------------------------------------

def test_step_size_underflow_carries_time_component_and_statistics():
    # Fig. 2's run (C-PC, dt = 0.2) needs step halvings; allowing none makes the first failure final.
    err = failure_of(
        eci.solve(M.ThreeWave(), (0.0, 100.0), method="c-pc", dt=0.2, max_halvings=0),
        eci.StepSizeUnderflow)
    assert err.cause == "step_failed" and err.dt == 0.2
    assert err.component_name in ("psi_K", "psi_P", "psi_Q") and err.component in (0, 1, 2)
    assert err.t > 0.0 and err.t == pytest.approx(0.2 * err.stats["steps"], rel=1e-12)
    assert err.stats["rhs_evals"] == 2 * err.stats["steps"] + 2
    assert str(err).startswith(f"step failed at t = {err.t:.17g} in component {err.component_name} even with the step "
                               "halved 0 times (dt = 0.20000000000000001): negative radicand")
    # with the CLI's 40 halvings the same run completes
    assert eci.solve(M.ThreeWave(), (0.0, 100.0), method="c-pc", dt=0.2).stats["rejected_steps"]["step_failed"] > 0


def test_transform_that_cannot_be_inverted_underflows():
    never = eci.Transform(lambda x: x * x, lambda xi, hint: None, rate=lambda x, f: 2 * x * f)
    err = failure_of(eci.solve(decay, (0.0, 1.0), [1.0], method="c-pc", dt=0.1, transform=never, max_halvings=3),
                     eci.StepSizeUnderflow)
    assert str(err).startswith("step failed at t = 0 in component y[0] even with the step halved 3 times")


# An array of a wider type than double (np.longdouble, np.clongdouble) from fun, a transform, or as a model's state:
# NumPy refuses the safe cast to double, pybind11's ensure() returned a null array, and reading it crashed the
# interpreter (SIGSEGV). It is now cast as SciPy's np.asarray(fun(t, y), dtype) casts it: the same run, bit for bit,
# as with the float64 values. Run in a child process, so that a crash fails this test and not the whole suite.
WIDE = textwrap.dedent("""
    import sys
    sys.path.insert(0, {path!r})
    import numpy as np
    import eci
    L, CL = np.longdouble, np.clongdouble
    rot = lambda t, y: np.array([-y[1], y[0]])
    for kw in ({{}}, {{"dt": 0.1}}, {{"method": "c-dp54"}}, {{"dt": 0.1, "method": "c-rk4"}}):
        wide = eci.solve(lambda t, y: rot(t, y).astype(L), (0.0, 1.0), [1.0, 0.0], **kw)
        assert wide.status == 0 and np.array_equal(wide.y, eci.solve(rot, (0.0, 1.0), [1.0, 0.0], **kw).y), kw
    wide = eci.solve(lambda t, y: (1j * y).astype(CL), (0.0, 1.0), [1.0 + 0j])
    assert np.array_equal(wide.y, eci.solve(lambda t, y: 1j * y, (0.0, 1.0), [1.0 + 0j]).y)
    m = eci.models.ThreeWave()
    y0 = np.asarray(m.default_y0)
    assert np.array_equal(eci.solve(m, (0.0, 1.0), y0.astype(L)).y, eci.solve(m, (0.0, 1.0), y0).y)
    assert m.invariants(y0.astype(L)) == m.invariants(y0)
    assert np.array_equal(m(0.0, y0.astype(L)), m(0.0, y0))
    square = eci.Transform(lambda x: (x * x).astype(L), lambda xi, hint: np.sqrt(xi), jacobian=lambda x: np.diag(2 * x))
    r = eci.solve(lambda t, y: y, (0.0, 1.0), [1.0], method="c-rk4", dt=0.1, transform=square)
    assert r.status == 0 and abs(r.y[0, -1] - np.e) < 1e-5
    print("ok")
""")


def test_wider_than_double_arrays_are_cast_not_a_crash(tmp_path):
    script = tmp_path / "wide.py"
    script.write_text(WIDE.format(path=str(BUILD / "python")))
    r = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0 and r.stdout.strip() == "ok", (r.returncode, r.stdout, r.stderr)


# --- Ctrl-C -----------------------------------------------------------------------------------------------------

INTERRUPTED = textwrap.dedent("""
    import signal, sys, time
    # Ctrl-C raises KeyboardInterrupt, as in a user's Python; a suite started in the background (`.ci/run &`)
    # hands its children SIGINT ignored, and Python then leaves it ignored
    signal.signal(signal.SIGINT, signal.default_int_handler)
    sys.path.insert(0, {path!r})
    import numpy as np
    import eci
    kind = sys.argv[1]
    print("ready", flush=True)
    start = time.monotonic()
    try:
        if kind == "model":   # the GIL is released: ~10^10 C++ steps, far longer than the test
            eci.solve(eci.models.ThreeWave(), (0.0, 1e8), method="c-rk4", dt=0.01, t_eval=[1e8])
        elif kind == "adaptive":   # adaptive, GIL released, one output time: checked between attempts
            eci.solve(eci.models.ThreeWave(), (0.0, 1e8), method="c-dp54", rtol=1e-12, t_eval=[1e8])
        elif kind == "thread":   # the GIL held (Python invariants, evaluated at the outputs) and the signal sent
            # by another Python thread of the process: the run lets the GIL go now and then, or that thread never runs
            import os, threading
            threading.Timer(1.0, lambda: os.kill(os.getpid(), signal.SIGINT)).start()
            eci.solve(eci.models.ThreeWave(), (0.0, 1e9), rtol=1e-12, output_dt=1e8, invariants=lambda y: y @ y)
        else:
            eci.solve(lambda t, y: -y, (0.0, 1e8), np.ones(3), method="rk4", dt=0.01, t_eval=[1e8])
    except KeyboardInterrupt:
        print(f"interrupted after {{time.monotonic() - start:.3f}} s", flush=True)
        sys.exit(0)
    sys.exit(3)
""")


@pytest.mark.parametrize("kind", ["model", "adaptive", "function", "thread"])
def test_ctrl_c_interrupts_a_long_run(kind, tmp_path):
    script = tmp_path / "long_run.py"
    script.write_text(INTERRUPTED.format(path=str(BUILD / "python")))
    p = subprocess.Popen([sys.executable, str(script), kind], stdout=subprocess.PIPE, text=True)
    try:
        assert p.stdout.readline().strip() == "ready"
        time.sleep(1.0)  # well inside eci.solve
        sent = time.monotonic()
        if kind != "thread":  # (that one signals itself, from its own timer thread, 1 s in)
            p.send_signal(signal.SIGINT)
        out, _ = p.communicate(timeout=20)
        latency = time.monotonic() - sent
    finally:
        if p.poll() is None:
            p.kill()
    assert p.returncode == 0, out
    ran = float(out.split()[2])
    assert ran >= 0.9  # it was interrupted inside the integration, not before it
    # prompt: checked between steps (every 1-10 ms of run time with the GIL released); generous for a loaded CI
    assert latency < 2.0, latency


@pytest.mark.parametrize("make", [
    lambda: eci.solve(lambda t, y: -y, (0.0, 1.0), [1.0], rtol=True),
    lambda: eci.solve(lambda t, y: -y, (0.0, 1.0), [1.0], atol=[np.True_]),
    lambda: M.ThreeWave(K=True),
    lambda: M.Kepler(ell=False),
    lambda: M.NWave(modes=True),
])
def test_a_bool_is_not_a_number(make):
    # True read as 1 (a tolerance of 1.0, one mode) is a mistake, refused by name
    with pytest.raises(TypeError, match="not bool"):
        make()


@pytest.mark.skipif(not hasattr(M, "NavierStokes2D"), reason="built without eci::spectral")
def test_a_bool_is_not_a_spectral_parameter_but_flags_are_bools():
    for kwargs in ({"nu": True}, {"threads": True}, {"hyper_p": np.True_}):
        with pytest.raises(TypeError, match="not bool"):
            M.NavierStokes2D(n=16, **kwargs)
    assert M.NavierStokes2D(n=16, fftw_measure=False).n == 16
    assert M.NavierStokes2D(n=16, full_transforms=np.True_).n == 16
    # and a flag is True or False, not anything with a truth value (1.5 and "no" were taken as True)
    for kwargs in ({"fftw_measure": 1.5}, {"full_transforms": "no"}, {"full_transforms": 1}):
        with pytest.raises(TypeError, match="must be True or False"):
            M.NavierStokes2D(n=16, **kwargs)


# A conservative method steps squares: a state whose every component's square under- or overflows is refused with
# one line (1e-170 ran to a state of 0 with status 0 and drift 0; 1e160 stored inf and ended on a step-size failure).
# A single tiny component beside larger ones is not refused, and conventional methods take any finite state.
@pytest.mark.parametrize("y0, method, word", [([1e-170, 1e-170], "c-rk4", "underflows"),
                                              ([1e-170, -1e-171], "c-dp54", "underflows"),
                                              ([1e160, 0.0], "c-dp54", "overflows"),
                                              ([0.0, -1e155], "c-pc", "overflows")])
def test_a_state_beyond_the_squares_range_is_refused(y0, method, word):
    rot = lambda t, y: np.array([y[1], -y[0]])  # noqa: E731
    kw = {} if "dp" in method else {"dt": 0.01}
    with pytest.raises(ValueError) as e:
        eci.solve(rot, (0.0, 1.0), y0, method=method, invariants=lambda y: y @ y, **kw)
    big = max(abs(v) for v in y0)
    assert str(e.value) == (f"the initial state's largest component is {big!r}: its square {word}, and method "
                            f"{method} steps squares (|psi| from 1.5e-154 to 6.7e153); rescale the variables or use "
                            "a conventional method")
    assert eci.solve(rot, (0.0, 1.0), [1e-170, 1.0], method=method, **kw).status == 0
    r = eci.solve(rot, (0.0, 1.0), y0, method="rk4", dt=0.01)
    assert r.status == 0 and np.all(np.isfinite(r.y)) and np.max(np.abs(r.y[:, -1])) > 0.5 * big


# A long span waiting for a terminal event (SciPy's idiom with t_bound = inf, which eci refuses): the step floor
# near t = 0 is set by the first step, not by the span (a span of 1e30 made it 1e7, and the first rejected step
# ended the run).
def test_a_long_span_with_a_terminal_event_runs_to_the_event():
    mu = 5.0
    vdp = lambda t, y: np.array([y[1], mu * (1 - y[0] ** 2) * y[1] - y[0]])  # noqa: E731
    ev = lambda t, y: y[0]  # noqa: E731
    ev.terminal = 3
    short = eci.solve(vdp, (0.0, 100.0), [2.0, 0.0], events=ev)
    for end in (1e20, 1e30, 1e300):
        r = eci.solve(vdp, (0.0, end), [2.0, 0.0], events=ev)
        assert r.status == 1, (end, r.message)
        assert len(r.t_events[0]) == 3
        np.testing.assert_allclose(r.t_events[0], short.t_events[0], rtol=1e-6)


# Far from t = 0 the doubles are far apart. Fixed steps whose grid times round by more than 2^-10 of a step are
# refused (t0 = 1e16, dt = 0.5 integrated y' = 1 over 159.5 of 160 with status 0); an adaptive step below the spacing
# stops the run saying so (at t = 1e17 five steps were "accepted" without moving t, then "tolerance too tight, a
# singularity, ...").
def test_times_far_from_zero_that_cannot_hold_the_steps():
    one = lambda t, y: np.ones(1)  # noqa: E731
    for t0, dt in [(1e15, 0.1), (1e16, 0.5), (1e17, 1.0)]:
        with pytest.raises(ValueError, match=rf"^the step {dt:g} is too small for times near .*, where doubles are .* "
                                             r"apart: the grid's times would be off by more than 2\^-10 of a step "
                                             r"\(count time from 0: a start time nearer 0\)$"):
            eci.solve(one, (t0, t0 + 160), [0.0], method="rk4", dt=dt)
    r = eci.solve(one, (1e9, 1e9 + 160), [0.0], method="rk4", dt=0.5)  # doubles 1.2e-7 apart: taken
    assert r.status == 0 and abs(r.y[0, -1] - 160.0) < 1e-6
    r = eci.solve(one, (2.0 ** 60, 2.0 ** 60 + 4096), [0.0], method="rk4", dt=256.0)  # every grid time a double
    assert r.status == 0 and r.y[0, -1] == 4096.0
    rotation = lambda t, y: np.array([-y[1], y[0]])  # noqa: E731
    for method in ["dp54", "c-dp54"]:
        r = eci.solve(rotation, (1e17, 1e17 + 1000), [1.0, 0.0], method=method, rtol=1e-6, atol=1e-9)
        f = failure_of(r, eci.StepSizeUnderflow)
        assert re.match(r"adaptive step fell below the spacing of doubles at t = 1e\+17 \(dt = .*\): time cannot "
                        r"advance there \(count time from 0: a start time nearer 0\)", str(f)), str(f)
        assert r.stats["steps"] == 0


def test_a_backward_runs_failure_is_said_at_its_own_time():
    # a backward fixed-step run is a forward run of s = t0 - t: its message named s (0.12 for t = 0.88), and a NaN
    # through the negated fun as "-nan"
    with np.errstate(over="ignore"):  # y' = -y^2 backward from y(1) = 10 blows up at t = 0.9
        r = eci.solve(lambda t, y: -y ** 2, (1.0, 0.0), [10.0], dt=0.01)
    assert r.status == -1 and 0.85 < r.failure.t < 0.95
    assert r.message.startswith(f"step failed at t = {r.failure.t:.17g} in component y[0]"), r.message
    nan_below = lambda t, y: np.array([np.nan]) if t < 0.55 else -y  # noqa: E731
    r = eci.solve(nan_below, (1.0, 0.0), [1.0], dt=0.01)
    assert r.message.startswith(f"step failed at t = {r.failure.t:.17g} in component y[0]"), r.message
    assert r.message.endswith("fun(t, y) returned nan in component y[0]"), r.message
