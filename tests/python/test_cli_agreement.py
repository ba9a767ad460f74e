# The Python module runs the C++ library's numerics: the same integration through eci.solve and through `eci run`
# (CSV at 17 significant digits, which reads back as the same doubles) agrees bit for bit, state, time and drift.
import json
import math

import numpy as np
import pytest

import eci
from conftest import EPS, cli_error, failure_of, run_cli


def cli_run(cli, tmp_path, model, method, dt, t_end, *options):
    """Runs `eci run` and returns (t, columns by name, summary JSON)."""
    csv, summary = tmp_path / "run.csv", tmp_path / "run.json"
    run_cli(cli, "run", model, "--method", method, "--dt", repr(dt), "--t-end", repr(t_end), "--output", csv,
            "--summary-json", summary, *options)
    header = csv.read_text().splitlines()[0].split(",")
    data = np.loadtxt(csv, delimiter=",", skiprows=1, ndmin=2)
    columns = {name: data[:, i] for i, name in enumerate(header)}
    return columns["t"], columns, json.loads(summary.read_text())


def assert_same_run(r, t, columns, summary, state_columns, complex_state=False):
    assert np.array_equal(r.t, t)
    for i, name in enumerate(state_columns):
        y = r.y[i // 2].imag if complex_state and i % 2 else (r.y[i // 2].real if complex_state else r.y[i])
        assert np.array_equal(y, columns[name]), name
    assert r.stats["steps"] == summary["steps"]
    assert r.stats["rhs_evals"] == summary["rhs_evals"]
    assert r.stats["rejected_steps"]["step_failed"] == summary["step_reductions"]
    for name, record in summary["invariants"].items():
        assert r.invariants[name]["initial"] == record["initial"], name
        assert r.invariants[name]["final"] == record["final"], name
        assert r.invariants[name]["max_abs_drift"] == record["max_abs_drift"], name
        # the library's one rule: JSON null where Python has nan (a drift relative to 0 or a subnormal I(0))
        rel = r.invariants[name]["max_rel_drift"]
        assert (math.isnan(rel) and record["max_rel_drift"] is None) or rel == record["max_rel_drift"], name


@pytest.mark.parametrize("method", [m for m in eci.models.ThreeWave().methods])
def test_three_wave_model_matches_cli_for_every_method(cli, tmp_path, method):
    # dt = 0.03 does not divide t_end = 3: the last step is shortened exactly as `eci run` shortens it.
    t, columns, summary = cli_run(cli, tmp_path, "three-wave", method, 0.03, 3.0, "--psi", "1,0.5,-0.3")
    r = eci.solve(eci.models.ThreeWave(), (0.0, 3.0), [1.0, 0.5, -0.3], method=method, dt=0.03)
    assert_same_run(r, t, columns, summary, ["psi_K", "psi_P", "psi_Q"])


def three_wave_fun(t, y):
    """Eq. (1) with the default coefficients, written as the C++ model writes it (same operations, same order)."""
    return np.array([1.0 * y[1] * y[2], 1.0 * y[2] * y[0], -2.0 * y[0] * y[1]])


@pytest.mark.parametrize("method", ["c-pc", "c-rk4", "rk4", "c-euler", "implicit-midpoint"])
def test_python_fun_matches_cli(cli, tmp_path, method):
    # Step reductions included: dt = 0.2 makes C-PC halve steps (Fig. 2's run).
    t, columns, summary = cli_run(cli, tmp_path, "three-wave", method, 0.2, 20.0)
    y0 = eci.models.ThreeWave().default_y0
    # the C++ model's energy, term by term
    energy = lambda y: 0.5 * (y[0] * y[0] + y[1] * y[1] + y[2] * y[2])  # noqa: E731
    r = eci.solve(three_wave_fun, (0.0, 20.0), y0, method=method, dt=0.2, invariants={"energy": energy})
    assert np.array_equal(r.t, t)
    for i, name in enumerate(["psi_K", "psi_P", "psi_Q"]):
        assert np.array_equal(r.y[i], columns[name]), name
    assert r.stats["steps"] == summary["steps"]
    assert r.stats["rhs_evals"] == summary["rhs_evals"]
    assert r.stats["rejected_steps"]["step_failed"] == summary["step_reductions"]
    assert r.invariants["energy"]["max_abs_drift"] == summary["invariants"]["energy"]["max_abs_drift"]


@pytest.mark.parametrize("complex_modes", [False, True])
@pytest.mark.parametrize("method", ["c-pc", "c-rk4", "c-pc-compensated"])
def test_n_wave_matches_cli(cli, tmp_path, complex_modes, method):
    name = "n-wave-complex" if complex_modes else "n-wave"
    t, columns, summary = cli_run(cli, tmp_path, name, method, 0.05, 2.0, "--modes", 12, "--triads-per-mode", 3,
                                  "--seed", 7)
    model = eci.models.NWave(modes=12, triads_per_mode=3, seed=7, complex=complex_modes)
    r = eci.solve(model, (0.0, 2.0), method=method, dt=0.05)
    names = [f"{p}psi_{i}" for i in range(12) for p in (("re_", "im_") if complex_modes else ("",))]
    assert_same_run(r, t, columns, summary, names, complex_state=complex_modes)


@pytest.mark.parametrize("method", ["c-pc", "c-rk4", "kahan", "rk4"])
def test_lotka_volterra_matches_cli(cli, tmp_path, method):
    t, columns, summary = cli_run(cli, tmp_path, "lotka-volterra", method, 0.02, 20.0, "--mu", 1.25, "--x", 0.9)
    r = eci.solve(eci.models.LotkaVolterra(mu=1.25), (0.0, 20.0), [0.9, 0.4], method=method, dt=0.02)
    assert_same_run(r, t, columns, summary, ["x", "y"])
    assert r.stats["solver_iterations"] == summary.get("solver", {}).get("iterations", 0)


@pytest.mark.parametrize("method", ["c-pc", "c-rk4", "pc"])
def test_kepler_matches_cli(cli, tmp_path, method):
    t, columns, summary = cli_run(cli, tmp_path, "kepler", method, 0.105, 21.0, "--v-r", 0.2, "--theta", 0.1)
    model = eci.models.Kepler()
    r = eci.solve(model, (0.0, 21.0), [1.0, 0.2, 0.1], method=method, dt=0.105)
    assert_same_run(r, t, columns, summary, ["r", "v_r", "theta"])
    # the same angle from the same states; only the conversion to degrees may round differently
    turn = model.runge_lenz_turn(r.y[:, 0], r.y[:, -1]) * 180.0 / np.pi
    assert turn == pytest.approx(summary["runge_lenz_turn_degrees"], rel=4 * 2.0 ** -52, abs=1e-300)


def test_a_relative_drift_from_a_subnormal_invariant_is_nan_as_the_cli_says_n_a(cli, tmp_path):
    # theta = the smallest normal double: a Runge-Lenz component starts subnormal and moves (long CLI fuzz, seed
    # 1658050189): its relative drift was 6.7e307 or inf in Python while the CLI said n/a; one rule now
    theta = 2.2250738585072014e-308
    t, columns, summary = cli_run(cli, tmp_path, "kepler", "pc", 0.01, 2.0, "--theta", repr(theta))
    r = eci.solve(eci.models.Kepler(), (0.0, 2.0), [1.0, 0.0, theta], method="pc", dt=0.01)
    assert_same_run(r, t, columns, summary, ["r", "v_r", "theta"])
    undefined = [n for n, v in r.invariants.items() if math.isnan(v["max_rel_drift"])]
    assert undefined, r.invariants
    for name in undefined:
        assert r.invariants[name]["max_abs_drift"] > 0 and abs(r.invariants[name]["initial"]) < 2.3e-308
    assert all(math.isfinite(v["max_rel_drift"]) for n, v in r.invariants.items() if n not in undefined)


def test_t_eval_points_on_the_grid_are_the_grid_states(cli, tmp_path):
    t, columns, _ = cli_run(cli, tmp_path, "three-wave", "c-rk4", 0.01, 10.0)
    r = eci.solve(eci.models.ThreeWave(), (0.0, 10.0), method="c-rk4", dt=0.01, t_eval=t[::100])
    assert r.stats["t_eval_steps"] == 0
    assert np.array_equal(r.y[0], columns["psi_K"][::100])


def test_n_wave_remedy_matches_cli(cli, tmp_path):
    # 1000 modes at the CLI's default step: negative radicands are remedied inside the step (no halving), by the
    # same computation in both, so the runs still agree bit for bit.
    t, columns, summary = cli_run(cli, tmp_path, "n-wave", "c-pc", 0.01, 1.0, "--modes", 1000)
    r = eci.solve(eci.models.NWave(modes=1000), (0.0, 1.0), method="c-pc", dt=0.01)
    assert summary["remedied_steps"] > 0 and summary["step_reductions"] == 0
    assert r.stats["remedied_steps"] == summary["remedied_steps"]
    assert r.stats["components_remedied"] == summary["components_remedied"]
    assert_same_run(r, t, columns, summary, [f"psi_{i}" for i in range(1000)])


# The initial checks are the library's (eci::check_initial_state): the CLI and Python refuse the same initial states
# with the same one-line message, for every model (Python's models used to check finiteness and the domain only).
@pytest.mark.parametrize("model, option, values, y0", [
    ("three-wave", "--psi", "1e-310,1,1", None),             # subnormal
    ("three-wave", "--psi", "1e200,1,1", None),              # the energy overflows
    ("lotka-volterra", "--x", "-1", [-1.0, 0.4]),            # outside the model's domain
])
def test_cli_and_python_refuse_the_same_initial_states(cli, model, option, values, y0):
    from conftest import cli_error

    message = cli_error(cli, "run", model, option, values, "--t-end", 1)
    cls = {"three-wave": eci.models.ThreeWave, "lotka-volterra": eci.models.LotkaVolterra}[model]
    y = y0 if y0 is not None else [float(v) for v in values.split(",")]
    with pytest.raises(ValueError) as e:
        eci.solve(cls(), (0.0, 1.0), y, dt=0.1)
    assert str(e.value) == message


def test_cli_and_python_name_the_same_adaptive_methods(cli):
    from conftest import cli_error

    message = cli_error(cli, "run", "kepler", "--method", "c-rk4", "--rtol", "1e-8")
    with pytest.raises(ValueError) as e:
        eci.solve(eci.models.Kepler(), (0.0, 1.0), method="c-rk4", rtol=1e-8, atol=1e-8)
    assert str(e.value) == message


@pytest.mark.parametrize("rtol", [1e-6, 1e-9])
def test_adaptive_kepler_and_lotka_volterra_match_cli(cli, tmp_path, rtol):
    # adaptive runs through the same eci::solve: the same accepted steps, states and drifts
    t, columns, summary = cli_run(cli, tmp_path, "kepler", "c-dp54", 0.01, 20.0, "--rtol", rtol)
    r = eci.solve(eci.models.Kepler(), (0.0, 20.0), method="c-dp54", rtol=rtol, atol=rtol, first_step=0.01)
    assert_same_run(r, t, columns, summary, ["r", "v_r", "theta"])


# --output-dt and output_dt are one decision of the library (eci::resolve_output_dt): output times when adaptive, a
# row every k steps with fixed steps, and the same refusals in the same sentence, each front end naming its own
# settings (the CLI's options, Python's keywords).
CLI_NAMES_AS_PYTHONS = [("--t-end / --dt", "t_span / dt"), ("--output-dt", "output_dt"), ("--dt", "dt"),
                        ("--rtol/--atol", "rtol/atol")]


def as_python_names(message):
    for option, keyword in CLI_NAMES_AS_PYTHONS:
        message = message.replace(option, keyword)
    return message


@pytest.mark.parametrize("dt, t_end, output_dt, tolerance", [
    (0.03, 1.0, 0.25, None),     # not a multiple of dt with fixed steps
    (0.1, 1.0, 0.05, None),      # less than one step
    (0.01, 1.0, 0.0, None),      # not positive
    (0.01, 1.0, -1.0, 1e-6),
    (0.01, 1.0, float("inf"), None),
    (0.01, 10.0, 1e-7, 1e-6),    # more than 10^7 rows
    (0.01, 1e5, 1e-3, None),
])
def test_cli_and_python_refuse_the_same_output_dt(cli, dt, t_end, output_dt, tolerance):
    from conftest import cli_error

    method = "c-dp54" if tolerance else "c-rk4"
    adaptive = ["--rtol", repr(tolerance)] if tolerance else []
    message = cli_error(cli, "run", "three-wave", "--method", method, "--dt", repr(dt), "--t-end", repr(t_end),
                        "--output-dt", repr(output_dt), *adaptive)
    assert "--output-dt" in message
    step = {"rtol": tolerance, "atol": tolerance, "first_step": dt} if tolerance else {"dt": dt}
    with pytest.raises(ValueError) as e:
        eci.solve(eci.models.ThreeWave(), (0.0, t_end), method=method, output_dt=output_dt, **step)
    assert str(e.value) == as_python_names(message)


# A bad tolerance is named as the user gave it (atol alone is not reported as rtol, which takes its value), with the
# value, in the same sentence from both front ends: the CLI prefixes its options.
@pytest.mark.parametrize("options, keywords", [
    (["--atol", "nan"], {"atol": float("nan")}),
    (["--atol", "-1"], {"atol": -1.0}),
    (["--rtol", "-1e-06"], {"rtol": -1e-6}),
    (["--rtol", "1e-06", "--atol", "inf"], {"rtol": 1e-6, "atol": float("inf")}),
    (["--rtol", "nan", "--atol", "1e-06"], {"rtol": float("nan"), "atol": 1e-6}),
    # numbers laid out alike (as Python's repr: 0.0001, 1000000000000000; std::to_chars alone wrote 1e-04, 1e+15)
    (["--atol", "-0.0001"], {"atol": -0.0001}),
    (["--rtol", "-1e15"], {"rtol": -1e15}),
])
def test_cli_and_python_refuse_the_same_tolerances(cli, options, keywords):
    from conftest import cli_error

    message = cli_error(cli, "run", "three-wave", "--method", "c-dp54", "--t-end", "1", *options)
    assert message.startswith("--rtol/--atol: "), message
    with pytest.raises(ValueError) as e:
        eci.solve(eci.models.ThreeWave(), (0.0, 1.0), method="c-dp54", **keywords)
    assert str(e.value) == message.removeprefix("--rtol/--atol: ")


# Tolerances and a first step at their edges: an rtol below 100 eps is raised to it by both front ends (each with its
# warning) and the runs agree bit for bit; rtol = atol = 0 and a given first step beyond the span are refused by both
# in one sentence, each naming its own setting.
@pytest.mark.parametrize("rtol, atol", [(1e-30, 1e-30), (0.0, 1e-10)])
def test_cli_and_python_raise_a_tiny_rtol_alike(cli, tmp_path, rtol, atol):
    t, columns, summary = cli_run(cli, tmp_path, "three-wave", "c-dp54", 0.01, 1.0, "--rtol", repr(rtol),
                                  "--atol", repr(atol))
    assert summary["rtol"] == 100 * np.finfo(float).eps
    with pytest.warns(UserWarning, match="rtol"):
        r = eci.solve(eci.models.ThreeWave(), (0.0, 1.0), method="c-dp54", rtol=rtol, atol=atol, first_step=0.01)
    assert_same_run(r, t, columns, summary, ["psi_K", "psi_P", "psi_Q"])


def test_cli_and_python_refuse_zero_tolerances_and_a_first_step_beyond_the_span(cli):
    from conftest import cli_error

    message = cli_error(cli, "run", "three-wave", "--method", "c-dp54", "--t-end", "1", "--rtol", "0", "--atol", "0")
    with pytest.raises(ValueError) as e:
        eci.solve(eci.models.ThreeWave(), (0.0, 1.0), method="c-dp54", rtol=0.0, atol=0.0)
    assert str(e.value) == message.removeprefix("--rtol/--atol: ")
    with pytest.raises(ValueError) as e:
        eci.solve(eci.models.ThreeWave(), (0.0, 1.0), method="c-dp54", rtol=[0.0, 0.0, 0.0], atol=0.0)
    assert str(e.value) == message.removeprefix("--rtol/--atol: ")
    message = cli_error(cli, "run", "three-wave", "--method", "c-dp54", "--t-end", "1", "--rtol", "1e-06",
                        "--dt", "2")
    assert message == "--dt 2 exceeds the span of the run, 1"
    with pytest.raises(ValueError) as e:
        eci.solve(eci.models.ThreeWave(), (0.0, 1.0), method="c-dp54", rtol=1e-6, atol=1e-6, first_step=2.0)
    assert str(e.value) == message.replace("--dt", "first_step")


@pytest.mark.parametrize("method, dt, t_end, output_dt, tolerance", [
    ("c-rk4", 0.01, 10.0, 0.25, None),     # every 25 steps
    ("c-pc", 0.1, 3.0, 0.3, None),         # 0.3 / 0.1 = 2.9999999999999996: a multiple within round-off
    ("rk4", 0.03, 1.0, 0.03, None),        # every step; the last one shortened
    ("c-dp54", 0.01, 10.0, 0.5, 1e-7),     # adaptive: at 0, 0.5, ..., 10
    ("dp54", 0.01, 7.3, 0.5, 1e-6),        # adaptive: the end is not a multiple
])
def test_cli_and_python_accept_the_same_output_dt_with_the_same_rows(cli, tmp_path, method, dt, t_end, output_dt,
                                                                      tolerance):
    options = ["--output-dt", repr(output_dt)] + (["--rtol", repr(tolerance)] if tolerance else [])
    t, columns, summary = cli_run(cli, tmp_path, "three-wave", method, dt, t_end, *options)
    step = {"rtol": tolerance, "atol": tolerance, "first_step": dt} if tolerance else {"dt": dt}
    r = eci.solve(eci.models.ThreeWave(), (0.0, t_end), method=method, output_dt=output_dt, **step)
    assert t[0] == 0.0 and t[-1] == t_end
    if tolerance:  # the output times themselves
        k = np.arange(int(np.ceil(t_end / output_dt - 1e-9)))
        assert np.array_equal(t, np.append(k * output_dt, t_end))
    else:  # every k = output_dt / dt steps of the grid, and the last
        assert len(t) == int(np.ceil(summary["steps"] / round(output_dt / dt))) + 1
    assert_same_run(r, t, columns, summary, ["psi_K", "psi_P", "psi_Q"])


# --output-mode is Python's t_eval_mode: the conservative pairs of order above 3 land a step on each output time by
# default (output times closer than the tolerance's steps cost steps); "dense" takes them from the dense output,
# whose invariants are exact at every row. The same rows as Python's, bit for bit.
@pytest.mark.parametrize("mode", ["dense", "landing", "auto"])
def test_cli_output_mode_is_pythons_t_eval_mode(cli, tmp_path, mode):
    t, columns, summary = cli_run(cli, tmp_path, "three-wave", "c-dp853", 0.01, 5.0, "--output-dt", "0.01",
                                  "--rtol", "1e-8", "--output-mode", mode)
    r = eci.solve(eci.models.ThreeWave(), (0.0, 5.0), method="c-dp853", output_dt=0.01, rtol=1e-8, atol=1e-8,
                  first_step=0.01, t_eval_mode=mode)
    assert len(t) == 501 and t[-1] == 5.0
    assert_same_run(r, t, columns, summary, ["psi_K", "psi_P", "psi_Q"])
    landed = cli_run(cli, tmp_path, "three-wave", "c-dp853", 0.01, 5.0, "--output-dt", "0.01", "--rtol", "1e-8")[2]
    if mode == "dense":  # fewer evaluations than landing on 500 times; every row's energy at round-off
        assert summary["rhs_evals"] < landed["rhs_evals"] / 4
        e = columns["energy"]
        eps = np.finfo(float).eps  # (k eps sqrt(outputs): each row a few roundings from the last step)
        assert np.max(np.abs(e - e[0])) <= 8 * eps * abs(e[0]) * np.sqrt(len(e))
    else:
        assert summary["rhs_evals"] == landed["rhs_evals"]


def test_cli_output_mode_needs_an_adaptive_runs_output_dt(cli):
    from conftest import cli_error

    for extra in ([], ["--rtol", "1e-6"], ["--output-dt", "0.1"]):
        assert cli_error(cli, "run", "three-wave", "--output-mode", "dense", *extra) == (
            "--output-mode is for an adaptive run's --output-dt times: give --output-dt and --rtol/--atol")
    assert cli_error(cli, "run", "three-wave", "--output-mode", "smooth") == (
        "--output-mode must be auto, dense or landing, not 'smooth'")


@pytest.mark.skipif(not hasattr(eci.models, "NavierStokes2D"), reason="built without eci::spectral")
@pytest.mark.parametrize("method", ["c-rk4", "rk4"])
def test_navier_stokes_matches_cli_and_both_land_on_t_end(cli, tmp_path, method):
    # --t-end 0.1 is no multiple of --dt 0.03: both front ends take 3 steps of dt and one of 0.01 (the CLI went on
    # to the next multiple of dt before, t = 1.2 for --t-end 1 --dt 0.3, where Python stopped at 1), with the same
    # E and Z at every step, bit for bit: the same field (the default random one), plans (FFTW_ESTIMATE) and steps
    csv = tmp_path / "ns.csv"
    run_cli(cli, "run", "navier-stokes-2d", "--N", "16", "--nu", "1e-3", "--method", method, "--dt", "0.03",
            "--t-end", "0.1", "--fftw-estimate", "--fftw-wisdom", "none", "--output", csv)
    header = csv.read_text().splitlines()[0].split(",")
    data = np.loadtxt(csv, delimiter=",", skiprows=1, ndmin=2)
    columns = {name: data[:, i] for i, name in enumerate(header)}
    m = eci.models.NavierStokes2D(n=16, nu=1e-3, fftw_measure=False)
    r = eci.solve(m, (0.0, 0.1), m.default_y0, method=method, dt=0.03)
    assert list(columns["t"]) == list(r.t) == [0.0, 0.03, 0.06, 0.09, 0.1]
    assert [m.energy(r.y[:, i]) for i in range(len(r.t))] == list(columns["energy"])
    assert [m.enstrophy(r.y[:, i]) for i in range(len(r.t))] == list(columns["enstrophy"])


@pytest.mark.skipif(not hasattr(eci.models, "NavierStokes2D"), reason="built without eci::spectral")
@pytest.mark.parametrize("method", ["c-rk4", "c-pc", "rk4"])
def test_navier_stokes_counts_and_drifts_match_cli(cli, tmp_path, method):
    # the CFL 0.5 step of the default field, 20 steps: the conditioned update takes conventional elements in most
    # steps; both front ends count them alike (both reported 0 before), and give the same drifts and evaluations
    summary = tmp_path / "ns.json"
    run_cli(cli, "run", "navier-stokes-2d", "--N", "32", "--method", method, "--steps", "20", "--fftw-estimate",
            "--fftw-wisdom", "none", "--summary-json", summary)
    s = json.loads(summary.read_text())
    m = eci.models.NavierStokes2D(n=32, fftw_measure=False)
    dt = m.cfl_step(m.default_y0, 0.5)
    assert dt == s["dt"]
    r = eci.solve(m, (0.0, 20 * dt), m.default_y0, method=method, dt=dt)
    for key in ("steps", "rhs_evals", "remedied_steps", "components_remedied"):
        assert r.stats[key] == s[key], key
    assert r.stats["rejected_steps"]["step_failed"] == s["step_reductions"]
    assert (r.stats["remedied_steps"] > 0) == method.startswith("c-"), r.stats
    for name, record in s["invariants"].items():
        for key in ("initial", "final", "max_abs_drift", "max_rel_drift"):
            assert r.invariants[name][key] == record[key], (name, key)


@pytest.mark.skipif(not hasattr(eci.models, "NavierStokes2D"), reason="built without eci::spectral")
@pytest.mark.parametrize("options, keywords", [
    (["--method", "dp54", "--dt", "0.01"], {"method": "dp54", "dt": 0.01}),
    (["--method", "no-such", "--dt", "0.01"], {"method": "no-such", "dt": 0.01}),
    (["--dt", "-0.01"], {"method": "c-rk4", "dt": -0.01}),
    (["--method", "c-rk4", "--rtol", "1e-06"], {"method": "c-rk4", "rtol": 1e-6}),
    (["--dt", "1e-20"], {"method": "c-rk4", "dt": 1e-20}),  # the CLI took one step of the span (the count overflowed)
    (["--dt", "-0.0001"], {"method": "c-rk4", "dt": -0.0001}),  # (the CLI wrote -1e-04)
])
def test_navier_stokes_refuses_what_the_cli_refuses_in_one_sentence(cli, options, keywords):
    from conftest import cli_error

    message = cli_error(cli, "run", "navier-stokes-2d", "--N", "16", "--t-end", "0.1", "--fftw-estimate",
                        "--fftw-wisdom", "none", *options)
    with pytest.raises(ValueError) as e:
        eci.solve(eci.models.NavierStokes2D(n=16, fftw_measure=False), (0.0, 0.1), **keywords)
    assert str(e.value) == as_python_names(message).removeprefix("rtol/atol: ")


def test_output_dt_is_not_t_eval():
    with pytest.raises(ValueError, match="give t_eval or output_dt, not both"):
        eci.solve(eci.models.ThreeWave(), (0.0, 1.0), dt=0.1, t_eval=[0.0, 1.0], output_dt=0.5)
    with pytest.raises(TypeError, match="output_dt must be a real number"):
        eci.solve(eci.models.ThreeWave(), (0.0, 1.0), dt=0.1, output_dt="0.5")


def csv_columns(path):
    header = path.read_text().splitlines()[0].split(",")
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return {name: data[:, i] for i, name in enumerate(header)}


# --output-dt on a spectral equation (refused before): rows every k = H / dt steps. Given --dt, H must be a multiple
# of it; without, the CFL step is shortened to H / ceil(H / dt_CFL). Python's output_dt takes the same step and rows,
# bit for bit, and refuses what the CLI refuses in the same sentence.
@pytest.mark.skipif(not hasattr(eci.models, "NavierStokes2D"), reason="built without eci::spectral")
@pytest.mark.parametrize("dt", [None, 0.01])
def test_navier_stokes_output_dt_matches_cli(cli, tmp_path, dt):
    csv = tmp_path / "ns.csv"
    step = [] if dt is None else ["--dt", repr(dt)]
    run_cli(cli, "run", "navier-stokes-2d", "--N", "16", "--t-end", "0.25", "--output-dt", "0.05", *step,
            "--fftw-estimate", "--fftw-wisdom", "none", "--output", csv)
    columns = csv_columns(csv)
    m = eci.models.NavierStokes2D(n=16, fftw_measure=False)
    r = eci.solve(m, (0.0, 0.25), m.default_y0, dt=dt, output_dt=0.05)
    assert list(columns["t"]) == list(r.t)
    assert len(r.t) == 6  # 0, 0.05, ..., 0.25: each within round-off of a multiple of H
    assert np.max(np.abs(r.t - 0.05 * np.arange(6))) <= 8 * np.finfo(float).eps
    if dt is None:  # the CFL 0.5 step shortened to divide H: at most it, and no shorter than it needs
        cfl = m.cfl_step(m.default_y0)
        k = r.stats["steps"] // 5
        assert r.stats["steps"] == 5 * k and 0.05 / k <= cfl and (k == 1 or cfl < 0.05 / (k - 1))
    assert [m.energy(r.y[:, i]) for i in range(len(r.t))] == list(columns["energy"])
    assert [m.enstrophy(r.y[:, i]) for i in range(len(r.t))] == list(columns["enstrophy"])


@pytest.mark.skipif(not hasattr(eci.models, "NavierStokes2D"), reason="built without eci::spectral")
@pytest.mark.parametrize("dt, output_dt", [(0.03, 0.1), (0.01, 0.0), (0.01, -1.0), (1e-6, 1e-9), (0.01, float("nan"))])
def test_navier_stokes_refuses_the_same_output_dt(cli, dt, output_dt):
    from conftest import cli_error

    message = cli_error(cli, "run", "navier-stokes-2d", "--N", "16", "--t-end", "0.1", "--dt", repr(dt),
                        "--output-dt", repr(output_dt), "--fftw-estimate", "--fftw-wisdom", "none")
    assert "--output-dt" in message
    with pytest.raises(ValueError) as e:
        eci.solve(eci.models.NavierStokes2D(n=16, fftw_measure=False), (0.0, 0.1), dt=dt, output_dt=output_dt)
    assert str(e.value) == as_python_names(message)


# --- every model of the C++ model list (include/eci/models/list.hpp) --------------------------------------------

M = eci.models
EVERY_MODEL_AND_METHOD = [pytest.param(cls, method, id=f"{cls().name}-{method}")
                          for cls in M.ode_models for method in cls().methods]


def state_columns(header, model):
    """The CSV columns of the state: as many after t as the model has real unknowns."""
    real = len(model.default_y0) * (2 if np.iscomplexobj(model.default_y0) else 1)
    return header[1:1 + real]


def generated(cls):
    """A model drawn from a generator (n-wave): its settings make the system and its initial state."""
    return not cls._initial_condition()


def cli_options(model, y0):
    """The `eci run` options that give the model's parameters and the initial state y0 explicitly (a generated
    model's settings are not properties of the system drawn: its defaults on both sides)."""
    options = []
    for option, keyword, _ in ([] if generated(type(model)) else type(model)._parameters()):
        value = getattr(model, keyword)
        options += ["--" + option, ",".join(repr(float(v)) for v in np.atleast_1d(value))]
    for option, first, count in type(model)._initial_condition():
        options += ["--" + option, ",".join(repr(float(v)) for v in y0[first:first + count])]
    return options


def test_python_has_every_model_of_the_cli_in_its_order(cli):
    import re

    listing = run_cli(cli, "list").stdout
    listed = re.findall(r"^  (\S+) .*\n\s+methods: ", listing, re.M)
    names = [cls().name for cls in M.ode_models]
    assert listed[:len(names)] == names
    assert all(hasattr(M, cls.__name__) for cls in M.ode_models)
    for expected in ("ThreeWave", "NWave", "LotkaVolterra", "Kepler", "RigidBody", "KeplerCartesian",
                     "NonlinearOscillator", "ExpEntropy"):
        assert expected in M.__all__


@pytest.mark.parametrize("cls, method", EVERY_MODEL_AND_METHOD)
def test_every_model_matches_cli_for_every_method(cli, tmp_path, cls, method):
    # the parameters and the initial state given explicitly to the CLI (the keywords' options), 7.5 steps: the
    # last one shortened as `eci run` shortens it
    model = cls()
    y0, dt = model.default_y0, model.default_dt
    t_end = 7.5 * dt
    t, columns, summary = cli_run(cli, tmp_path, model.name, method, dt, t_end, *cli_options(model, y0))
    r = eci.solve(model, (0.0, t_end), y0, method=method, dt=dt)
    assert r.t[-1] == t[-1]  # the same end time (a relaxation method's may differ from t_end)
    header = list(columns)
    assert_same_run(r, t, columns, summary, state_columns(header, model), complex_state=np.iscomplexobj(y0))


@pytest.mark.parametrize("cls", M.ode_models, ids=lambda c: c().name)
def test_every_preset_matches_cli(cli, tmp_path, cls):
    for p in cls.presets():
        t_end = 5.5 * p.dt
        t, columns, summary = cli_run(cli, tmp_path, p.model.name, p.method, p.dt, t_end, "--preset", p.name)
        r = eci.solve(p.model, (0.0, t_end), p.y0, method=p.method, dt=p.dt)
        assert_same_run(r, t, columns, summary, state_columns(list(columns), p.model),
                        complex_state=np.iscomplexobj(p.y0))


@pytest.mark.parametrize("cls", M.ode_models, ids=lambda c: c().name)
def test_every_model_refuses_what_the_cli_refuses(cli, cls):
    from conftest import cli_error

    model = cls()
    refused = [m.name for m in eci.methods() if m.name not in model.methods] + ["no-such-method"]
    for method in refused:
        message = cli_error(cli, "run", model.name, "--method", method, "--t-end", 1)
        with pytest.raises(ValueError) as e:
            eci.solve(model, (0.0, 1.0), method=method, dt=0.1)
        assert str(e.value) == message, method
    # a non-finite initial state, through the option that sets its first component
    fields = cls._initial_condition()
    if fields:
        y0 = model.default_y0.copy()
        option, first, count = fields[0]
        y0[first] = np.nan
        values = ",".join(repr(float(v)) for v in y0[first:first + count])
        message = cli_error(cli, "run", model.name, "--" + option, values, "--t-end", 1)
        with pytest.raises(ValueError) as e:
            eci.solve(model, (0.0, 1.0), y0, dt=0.1)
        assert str(e.value) == message


@pytest.mark.parametrize("cls", [c for c in M.ode_models if not generated(c) and c._parameters()],
                         ids=lambda c: c().name)
def test_every_models_keywords_are_its_cli_parameters(cli, cls):
    # each keyword reads back what it was given, and the default is the CLI's --help default
    model = cls()
    help_text = run_cli(cli, "run", model.name, "--help").stdout
    for option, keyword, count in cls._parameters():
        default = getattr(model, keyword)
        line = next(l for l in help_text.splitlines() if l.startswith(f"  --{option} "))
        shown = line.rsplit("(default ", 1)[1].rstrip(")")
        assert [float(v) for v in shown.split(",")] == list(np.atleast_1d(default)), option
        assert getattr(cls(**{keyword: default}), keyword) == default


# The method of a run that names none is the library's one rule (eci::default_method_for) for both front ends: the
# model's default method (its first preset's), and with a tolerance the model's default adaptive method. Python
# used to run c-rk4 (refused on kepler-cartesian, c-pc elsewhere in the CLI) and c-dp54 (refused on kepler-cartesian),
# and the CLI refused --rtol without --method ("method c-pc has no error estimate").
@pytest.mark.parametrize("cls", M.ode_models, ids=lambda c: c().name)
@pytest.mark.parametrize("adaptive", [False, True], ids=["fixed", "rtol"])
def test_every_model_runs_the_clis_method_when_none_is_named(cli, tmp_path, cls, adaptive):
    model = cls()
    y0, dt = model.default_y0, model.default_dt
    t_end = 7.5 * dt
    csv, summary = tmp_path / "run.csv", tmp_path / "run.json"
    tolerance = ["--rtol", "1e-06"] if adaptive else ["--dt", repr(dt)]
    run_cli(cli, "run", model.name, "--t-end", repr(t_end), *tolerance, *cli_options(model, y0), "--output", csv,
            "--summary-json", summary)
    s = json.loads(summary.read_text())
    step = {"rtol": 1e-6, "atol": 1e-6} if adaptive else {"dt": dt}
    r = eci.solve(model, (0.0, t_end), y0, **step)
    assert r.method == s["method"] == model._default_method(adaptive)
    if adaptive:
        assert r.method in model.adaptive_methods
        assert r.method == ("c-dp54" if "c-dp54" in model.adaptive_methods else "dp54")
    else:
        assert r.method == model.default_method == cls.presets()[0].method
    columns = csv_columns(csv)
    assert_same_run(r, columns["t"], columns, s, state_columns(list(columns), model),
                    complex_state=np.iscomplexobj(y0))


def test_the_defaults_named_by_the_tester_run_in_python():
    # (raised "method 'c-rk4' is not available for model kepler-cartesian", and 'c-dp54' with rtol)
    assert eci.solve(M.KeplerCartesian(), (0.0, 1.0)).method == "rrk-rk4"
    assert eci.solve(M.KeplerCartesian(), (0.0, 1.0), rtol=1e-6).method == "dp54"
    assert eci.solve(M.ThreeWave(), (0.0, 10.0), dt=0.3).method == "c-pc"
    assert eci.solve(M.Kepler(), (0.0, 1.0)).method == "c-pc"
    assert eci.solve(M.NonlinearOscillator(), (0.0, 1.0)).method == "rrk-rk4"
    # a Python fun keeps its own defaults: c-rk4 at fixed steps; dp54, or c-dp54 with declared invariants
    f = lambda t, y: np.array([y[1], -y[0]])  # noqa: E731
    assert eci.solve(f, (0.0, 1.0), [1.0, 0.0], dt=0.1).method == "c-rk4"
    assert eci.solve(f, (0.0, 1.0), [1.0, 0.0]).method == "dp54"
    assert eci.solve(f, (0.0, 1.0), [1.0, 0.0], quadratic_invariants=[1.0, 1.0]).method == "c-dp54"


@pytest.mark.parametrize("cls", M.ode_models, ids=lambda c: c().name)
def test_every_preset_with_a_tolerance_runs_the_clis_method(cli, tmp_path, cls):
    # `eci run MODEL --preset NAME --rtol R` and Preset.solve(rtol=R): the model's default adaptive method for both
    for p in cls.presets():
        summary = tmp_path / "run.json"
        run_cli(cli, "run", p.model.name, "--preset", p.name, "--rtol", "1e-06", "--t-end", repr(5.5 * p.dt),
                "--summary-json", summary)
        # (the CLI's first step is the preset's --dt)
        r = eci.solve(p.model, (0.0, 5.5 * p.dt), p.y0, rtol=1e-6, atol=1e-6, first_step=p.dt)
        s = json.loads(summary.read_text())
        assert r.method == s["method"] == p.model._default_method(True)
        assert r.stats["steps"] == s["steps"] and r.stats["rhs_evals"] == s["rhs_evals"]
        assert p.solve(rtol=1e-6, atol=1e-6, t_eval=[0.0]).method == s["method"]


# Preset.solve(rtol=R, atol=R) is `eci run MODEL --preset NAME --rtol R`, bit for bit: the CLI's first step is the
# preset's --dt, and Preset.solve dropped it for the model's default step (three-wave fig2: 78 steps from 0.01
# where the CLI took 75 from 0.2).
@pytest.mark.parametrize("cls", M.ode_models, ids=lambda c: c().name)
def test_every_preset_with_a_tolerance_is_the_cli_run(cli, tmp_path, cls):
    for p in cls.presets():
        summary = tmp_path / "run.json"
        run_cli(cli, "run", p.model.name, "--preset", p.name, "--rtol", "1e-06", "--summary-json", summary)
        s = json.loads(summary.read_text())
        r = p.solve(rtol=1e-6, atol=1e-6, t_eval=[p.t_end])
        assert r.method == s["method"], p.name
        assert (r.stats["steps"], r.stats["rhs_evals"]) == (s["steps"], s["rhs_evals"]), p.name
        assert all(r.invariants[k]["final"] == v["final"] for k, v in s["invariants"].items()), p.name
    p = cls.presets()[0]  # first_step= still overrides the preset's step
    assert p.solve(rtol=1e-6, atol=1e-6, first_step=p.dt / 2).stats["steps"] > 0


def test_the_cli_help_names_both_default_methods(cli):
    for model in (M.ThreeWave(), M.KeplerCartesian()):
        help_text = run_cli(cli, "run", model.name, "--help").stdout
        line = " ".join(help_text.split("--method", 1)[1].split("\n  --", 1)[0].split())
        assert f"(default {model.default_method}; with --rtol/--atol {model._default_method(True)})" in line, line


@pytest.mark.skipif(not hasattr(eci.models, "NavierStokes2D"), reason="built without eci::spectral")
def test_navier_stokes_refuses_a_tolerance_without_a_method_as_the_cli(cli):
    from conftest import cli_error

    for options, keywords in ((["--rtol", "1e-06"], {"rtol": 1e-6}), (["--atol", "1e-06"], {"atol": 1e-6})):
        message = cli_error(cli, "run", "navier-stokes-2d", "--N", "16", "--fftw-estimate", "--fftw-wisdom",
                            "none", *options)
        assert message == "model navier-stokes-2d has no method with an error estimate for rtol/atol; it runs " \
                          "fixed steps only"
        with pytest.raises(ValueError) as e:
            eci.solve(eci.models.NavierStokes2D(n=16, fftw_measure=False), (0.0, 0.1), **keywords)
        assert str(e.value) == message


# The initial-state checks of the spectral models are the library's (flow2d::check_initial_state), made before the
# initial step (flow2d::initial_cfl_step): Python used to take the CFL step of an overflowing field first ("dt must
# be a positive finite number, not 0"), run it to a StepSizeUnderflow when given dt, and call a NaN field "the initial
# velocity is zero".
@pytest.mark.skipif(not hasattr(eci.models, "NavierStokes2D"), reason="built without eci::spectral")
@pytest.mark.parametrize("scale", [1e200, float("nan"), 0.0, 1e-160, 1e-300],
                         ids=["overflow", "nan", "zero", "subnormal", "underflow"])
@pytest.mark.parametrize("dt", [None, 0.01])
def test_navier_stokes_refuses_the_same_initial_states(cli, tmp_path, scale, dt):
    import h5py
    from conftest import cli_error

    m = eci.models.NavierStokes2D(n=32, fftw_measure=False)
    field = m.to_physical(m.random_field()) * scale
    ic = tmp_path / "ic.h5"
    with h5py.File(ic, "w") as f:
        f["vorticity"] = field
    step = ["--dt", "0.01"] if dt else []
    if scale == 0.0 and dt:  # a zero field is a state: it runs
        run_cli(cli, "run", "navier-stokes-2d", "--N", "32", "--ic", ic, "--t-end", "0.02", "--fftw-estimate",
                "--fftw-wisdom", "none", *step)
        assert eci.solve(m, (0.0, 0.02), m.from_physical(field), dt=dt).success
        return
    message = cli_error(cli, "run", "navier-stokes-2d", "--N", "32", "--ic", ic, "--t-end", "0.1",
                        "--fftw-estimate", "--fftw-wisdom", "none", *step)
    # (the CLI names the file the field came from; Python's state has none)
    assert message.startswith(f"--ic '{ic}': "), message
    message = message[len(f"--ic '{ic}': "):]
    with pytest.raises(ValueError) as e:
        eci.solve(m, (0.0, 0.1), m.from_physical(field), dt=dt)
    assert str(e.value) == as_python_names(message)
    if scale == 1e200:  # the tester's field, scaled as a state
        with pytest.raises(ValueError) as e:
            eci.solve(m, (0.0, 0.1), m.random_field() * 1e200, dt=dt)
        assert str(e.value) == "initial condition: energy inf and enstrophy inf must be finite normal numbers"
    if scale == 1e-300:  # not zero, but E = Z = 0: its squares underflowed whole (it ran, its drifts against 0)
        assert message.startswith("initial condition: energy 0 and enstrophy 0 must be finite normal numbers (its "
                                  "largest mode, "), message
    if scale != scale:
        with pytest.raises(ValueError, match="^initial condition is not finite$"):
            eci.solve(m, (0.0, 0.1), np.full(m.size, np.nan, dtype=complex), dt=dt)


# Parameters are checked by the library alone (flow_params::whole, validate), so both front ends refuse them in the
# same sentence, the CLI's: Python said "n must be in 8..65536, not 6".
@pytest.mark.skipif(not hasattr(eci.models, "NavierStokes2D"), reason="built without eci::spectral")
@pytest.mark.parametrize("option, value, keyword", [
    ("--N", 6, "n"), ("--N", 7, "n"), ("--N", 100000, "n"), ("--hyper-p", 17, "hyper_p"), ("--hyper-p", 0, "hyper_p"),
    ("--hypo-p", 40, "hypo_p"), ("--threads", 65, "threads"), ("--nu", -1, "nu"),
    # subnormal: ran as 0 (its products underflow), said as the ODE models say it
    ("--nu", 1e-320, "nu"), ("--drag", 1e-310, "drag"), ("--hyper-nu", 5e-324, "hyper_nu"),
])
def test_navier_stokes_refuses_the_same_parameters(cli, option, value, keyword):
    from conftest import cli_error

    message = cli_error(cli, "run", "navier-stokes-2d", option, value, "--fftw-estimate", "--fftw-wisdom", "none")
    assert message.startswith("navier-stokes-2d: "), message
    with pytest.raises(ValueError) as e:
        eci.models.NavierStokes2D(**{keyword: value}, fftw_measure=False)
    assert str(e.value) == message


# What cannot fit in memory is refused by the library's one guard (eci::check_fits_in_memory), for both front ends.
def test_n_wave_beyond_memory_is_refused_alike(cli):
    from conftest import cli_error

    message = cli_error(cli, "run", "n-wave", "--modes", str(10 ** 8))
    assert message.startswith("n-wave: the system needs about ") and "more than this machine's" in message
    with pytest.raises(ValueError) as e:  # (was a bare MemoryError, std::bad_alloc)
        eci.models.NWave(modes=10 ** 8)
    assert str(e.value) == message


def test_a_stored_solution_beyond_memory_is_refused_up_front():
    import os

    memory = os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    steps = 2 * memory // 32 + 1  # three doubles and the time per output: twice the memory
    with pytest.raises(ValueError) as e:
        eci.solve(M.ThreeWave(), (0.0, steps * 1e-5), dt=1e-5)
    message = str(e.value)
    assert message.startswith("storing the solution at ") and " GiB of memory, more than this machine's " in message
    assert "\n" not in message
    # what each output keeps: the state, its time and each invariant's value (result.invariant_values); the figure
    # is given to 3 digits
    needed = float(message[message.index(" needs about ") + 13:].split()[0])
    per_output = 8 * (3 + 1 + len(M.ThreeWave().invariant_names))
    assert abs(needed - (steps + 1) * per_output / 2 ** 30) <= 0.005 * needed, (needed, per_output)
    f = lambda t, y: -y  # noqa: E731  (a Python fun's arrays alike)
    with pytest.raises(ValueError, match="^storing the solution at "):
        eci.solve(f, (0.0, steps * 1e-5), [1.0, 2.0, 3.0], dt=1e-5)
    # what fits runs: t_eval stores two states; a short run all of them
    r = eci.solve(M.ThreeWave(), (0.0, 1.0), dt=1e-5, t_eval=[0.0, 1.0])
    assert r.success and r.y.shape == (3, 2)
    assert eci.solve(M.ThreeWave(), (0.0, 1.0), dt=1e-3).y.shape == (3, 1001)


# The ODE models' initial check (eci::check_initial_state) comes before any step rule for both front ends, whatever
# the step control: fixed steps of the default dt, or adaptive from the default first step.
@pytest.mark.parametrize("cls", [c for c in M.ode_models if c._initial_condition()], ids=lambda c: c().name)
@pytest.mark.parametrize("bad", [float("nan"), float("inf"), 1e-310], ids=["nan", "inf", "subnormal"])
def test_every_model_refuses_the_same_initial_state_under_any_step_control(cli, cls, bad):
    from conftest import cli_error

    model = cls()
    option, first, count = cls._initial_condition()[0]
    y0 = model.default_y0.copy()
    y0[first] = bad
    values = ",".join(repr(float(v)) for v in y0[first:first + count])
    for options, keywords in (([], {}), (["--rtol", "1e-06"], {"rtol": 1e-6, "atol": 1e-6})):
        message = cli_error(cli, "run", model.name, "--" + option, values, "--t-end", 1, *options)
        with pytest.raises(ValueError) as e:
            eci.solve(model, (0.0, 1.0), y0, **keywords)
        assert str(e.value) == message, options


# A spectral setting that cannot change the run is refused by both front ends in one sentence (the library's rule,
# flow_params::unused_setting), not ignored: a forgotten --forcing stochastic ran unforced with the --injection-rate
# typed. Python's keywords for these settings default to None ("not given"), so that both know what was given.
SPECTRAL = list(M.flow_models)  # every equation of the C++ list


def option_as_keyword(message):
    import re
    return re.sub(r"--([a-z][a-z-]*)", lambda m: m.group(1).replace("-", "_"), message)


@pytest.mark.parametrize("cls", SPECTRAL, ids=lambda c: c.__name__)
@pytest.mark.parametrize("options, keywords, expected", [
    (["--forcing-k", "3"], {"forcing_k": 3.0}, "forcing_k sets the forced band, and this run's forcing is none"),
    (["--forcing-seed", "2"], {"forcing_seed": 2},
     "forcing_seed sets the forcing's random numbers, and this run's forcing is none"),
    (["--injection-rate", "0.1"], {"injection_rate": 0.1},
     "injection_rate sets the stochastic forcing, and this run's forcing is none"),
    (["--forcing", "deterministic", "--injection-rate", "0.1"], {"forcing": "deterministic", "injection_rate": 0.1},
     "injection_rate sets the stochastic forcing, and this run's forcing is deterministic"),
    (["--forcing", "stochastic", "--forcing-amplitude", "2"], {"forcing": "stochastic", "forcing_amplitude": 2.0},
     "forcing_amplitude sets the deterministic forcing, and this run's forcing is stochastic"),
    (["--hyper-p", "3"], {"hyper_p": 3}, "hyper_p is the hyperviscosity's power, and hyper_nu is 0"),
    (["--hypo-nu", "0", "--hypo-p", "2"], {"hypo_nu": 0.0, "hypo_p": 2},
     "hypo_p is the hypoviscosity's power, and hypo_nu is 0"),
    (["--forcing", "bogus"], {"forcing": "bogus"}, "forcing must be none, deterministic or stochastic, not 'bogus'"),
    (["--forcing-seed", "-1"], {"forcing_seed": -1}, "forcing_seed: must be a whole number >= 0, not '-1'"),
    (["--threads", "0"], {"threads": 0}, "EQUATION: threads must be in 1..64, not 0"),
])
def test_spectral_settings_that_cannot_change_the_run_are_refused_alike(cli, cls, options, keywords, expected):
    from conftest import cli_error

    name = cls(n=16, fftw_measure=False).name
    message = cli_error(cli, "run", name, "--N", "16", "--t-end", "0.1", "--fftw-estimate", "--fftw-wisdom", "none",
                        *options)
    assert option_as_keyword(message) == expected.replace("EQUATION", name)
    with pytest.raises(ValueError) as e:
        cls(n=16, fftw_measure=False, **keywords)
    assert str(e.value) == expected.replace("EQUATION", name)


@pytest.mark.parametrize("cls", SPECTRAL, ids=lambda c: c.__name__)
def test_spectral_settings_that_change_the_run_are_taken_alike(cli, cls, tmp_path):
    # the same settings given with what they act on: both run, to the same bits
    keywords = {"nu": 1e-3, "hyper_nu": 1e-6, "hyper_p": 3, "hypo_nu": 1e-3, "hypo_p": 2, "forcing": "stochastic",
                "forcing_k": 3.0, "injection_rate": 0.1, "forcing_seed": 5}
    options = []
    for k, v in keywords.items():
        options += ["--" + k.replace("_", "-"), str(v)]
    m = cls(n=16, fftw_measure=False, **keywords)
    csv = tmp_path / "run.csv"
    summary = tmp_path / "run.json"
    run_cli(cli, "run", m.name, "--N", "16", "--dt", "0.01", "--t-end", "0.05", "--fftw-estimate", "--fftw-wisdom",
            "none", "--output", csv, "--summary-json", summary, *options)
    header = csv.read_text().splitlines()[0].split(",")
    data = np.loadtxt(csv, delimiter=",", skiprows=1, ndmin=2)
    columns = {name: data[:, i] for i, name in enumerate(header)}
    r = eci.solve(m, (0.0, 0.05), m.default_y0, dt=0.01)
    assert r.success and len(r.t) == 6
    first = m.invariant_names[0]
    assert [m.energy(r.y[:, i]) for i in range(len(r.t))] == list(columns[first])
    assert r.budget[first + "_injection"] > 0.0  # the forcing acted
    # each step's budget residual by the library's one rule (flow2d::budget_residual): the CLI's figures, bit for bit,
    # and a few eps (the rounding of E, Z and the budget's sums in a step)
    s = json.loads(summary.read_text())
    for name in m.invariant_names:
        key = f"max_{name}_budget_residual_per_step"
        assert r.budget[key] == s[key] and r.budget[key] <= 16 * EPS, (key, r.budget[key], s[key])


# update= / --update chooses a conservative method's update; with a method that has none it is refused in one
# sentence by the library (run_config::update_chosen), not ignored; not given, every method runs.
@pytest.mark.parametrize("model, extra, keywords", [
    ("three-wave", ["--dt", "0.01"], {"dt": 0.01}),
    ("n-wave", ["--dt", "0.01"], {"dt": 0.01}),
    ("navier-stokes-2d", ["--N", "16", "--fftw-estimate", "--fftw-wisdom", "none", "--dt", "0.01"], {"dt": 0.01}),
])
@pytest.mark.parametrize("method", ["rk4", "euler"])
def test_an_update_with_a_method_without_one_is_refused_alike(cli, model, extra, keywords, method):
    from conftest import cli_error

    message = cli_error(cli, "run", model, "--method", method, "--t-end", "0.02", "--update", "paper", *extra)
    assert message == ("update chooses the form of the conservative update on quadratic invariants (c-pc, c-rk2, "
                       f"c-rk4, a c- pair); method {method} has none on model {model}")
    m = {"three-wave": lambda: M.ThreeWave(), "n-wave": lambda: M.NWave(),
         "navier-stokes-2d": lambda: M.NavierStokes2D(n=16, fftw_measure=False)}[model]()
    with pytest.raises(ValueError) as e:
        eci.solve(m, (0.0, 0.02), method=method, update="paper", **keywords)
    assert str(e.value) == message
    assert eci.solve(m, (0.0, 0.02), method=method, **keywords).success
    assert eci.solve(m, (0.0, 0.02), method="c-rk4", update="paper", **keywords).success


# The default step of a beta-plane flow is bounded by its fastest Rossby wave too (a phase of CFL radians per
# step): beta = 1e10 took ~2^30 halvings per step of the velocity's CFL step, silently. Both front ends take it.
@pytest.mark.skipif(not hasattr(M, "CharneyHasegawaMima"), reason="built without eci::spectral")
@pytest.mark.parametrize("beta, deformation", [(0.0, 0.0), (20.0, 1.0), (1e6, 0.0), (1e10, 4.0)])
def test_the_default_step_follows_the_fastest_rossby_wave(cli, tmp_path, beta, deformation):
    m = M.CharneyHasegawaMima(n=32, beta=beta, deformation=deformation, fftw_measure=False)
    w = m.default_y0
    velocity_step = 0.5 * (2 * math.pi / 32) / m.max_velocity(w)
    # the fastest wave: omega = beta k_x / (k^2 + F), largest at k = (1, 0) for F <= 1 ... over the retained modes
    kx, ky = np.asarray(m.kx, dtype=float), np.asarray(m.ky, dtype=float)
    k2 = kx * kx + ky * ky
    omega = np.max(np.where(k2 > 0, np.abs(beta * kx) / np.where(k2 > 0, k2 + deformation, 1.0), 0.0))
    expected = velocity_step if omega == 0 else min(velocity_step, 0.5 / omega)
    assert m.cfl_step(w) == pytest.approx(expected, rel=1e-15)
    summary = tmp_path / "s.json"
    run_cli(cli, "run", "charney-hasegawa-mima", "--N", "32", "--beta", repr(beta), "--deformation",
            repr(deformation), "--steps", "3", "--fftw-estimate", "--fftw-wisdom", "none", "--summary-json", summary)
    s = json.loads(summary.read_text())
    assert s["dt"] == m.cfl_step(w)
    assert s["step_reductions"] == 0
    r = eci.solve(m, (0.0, 3 * s["dt"]), w)
    assert r.success and r.stats["rejected_steps"]["step_failed"] == 0


# The default step keeps within the stability of the linear damping too (at most 2 CFL e-folds per step, one at
# the default CFL 0.5): a stiff viscosity, hyperviscosity, drag or hypoviscosity failed the first step after 40
# halvings, or took 65536 sub-steps (--drag 1e10), or blew up under RK4. Both front ends take it.
@pytest.mark.skipif(not hasattr(M, "NavierStokes2D"), reason="built without eci::spectral")
@pytest.mark.parametrize("option, value", [("nu", 30.0), ("hyper_nu", 1e-3), ("drag", 1e4), ("hypo_nu", 1e5)])
def test_the_default_step_keeps_within_the_linear_dampings_stability(cli, tmp_path, option, value):
    m = M.NavierStokes2D(n=32, fftw_measure=False, **{option: value})
    w = m.default_y0
    velocity_step = 0.5 * (2 * math.pi / 32) / m.max_velocity(w)
    kx, ky = np.asarray(m.kx, dtype=float), np.asarray(m.ky, dtype=float)
    k2 = kx * kx + ky * ky
    kmax = (32 - 1) // 3
    kept = (np.abs(kx) <= kmax) & (np.abs(ky) <= kmax) & (k2 > 0)
    k2 = k2[kept]
    rate = np.max({"nu": value * k2, "hyper_nu": value * k2 ** 2, "drag": value + 0 * k2,
                   "hypo_nu": value / k2}[option])
    assert 1.0 / rate < velocity_step  # the damping's bound is the one that binds here
    assert m.cfl_step(w) == pytest.approx(1.0 / rate, rel=1e-15)
    summary = tmp_path / "s.json"
    run_cli(cli, "run", "navier-stokes-2d", "--N", "32", f"--{option.replace('_', '-')}", repr(value),
            "--method", "rk4", "--steps", "20", "--fftw-estimate", "--fftw-wisdom", "none", "--summary-json", summary)
    s = json.loads(summary.read_text())
    assert s["dt"] == m.cfl_step(w)
    assert s["step_reductions"] == 0
    r = eci.solve(m, (0.0, 20 * s["dt"]), w, method="rk4", dt=s["dt"])
    assert r.success and r.stats["rejected_steps"]["step_failed"] == 0
    # damped, not blown up: each invariant decays
    for name in ("energy", "enstrophy"):
        assert r.invariants[name]["final"] < r.invariants[name]["initial"], (name, r.invariants[name])


# A given step beyond the damping's stability fails, and both front ends name the cause (the rate and the dt that
# would do); a damping no step can take (--hypo-nu 1e308: even its default step is 1e-308) is refused as input.
@pytest.mark.skipif(not hasattr(M, "NavierStokes2D"), reason="built without eci::spectral")
def test_a_step_beyond_the_dampings_stability_names_it(cli):
    hint = ("the linear damping (viscosity, hyperviscosity, drag, hypoviscosity) decays at up to 1e+300 per unit "
            "time, so dt 0.01 is beyond an explicit step's stability; dt <= 2e-300 (the default step keeps within "
            "it) or a smaller coefficient")
    r = run_cli(cli, "run", "navier-stokes-2d", "--N", "16", "--drag", "1e300", "--dt", "0.01", "--steps", "1",
                "--method", "rk4", "--fftw-estimate", "--fftw-wisdom", "none", check=False)
    assert r.returncode == 1, r.stderr
    assert r.stderr.strip().splitlines()[-1].endswith("; " + hint), r.stderr
    m = M.NavierStokes2D(n=16, drag=1e300, fftw_measure=False)
    f = failure_of(eci.solve(m, (0.0, 0.01), dt=0.01, method="rk4"), eci.StepSizeUnderflow)
    assert str(f).endswith("; " + hint), str(f)
    # the CLI's sentence: the step, the time, the halvings, the cause (the CLI adds where the run was kept)
    assert str(f).split("; ")[0] in r.stderr, (str(f), r.stderr)
    # a blow-up (energy grown a thousandfold) names it too
    r = run_cli(cli, "run", "navier-stokes-2d", "--N", "16", "--drag", "1e4", "--dt", "0.01", "--steps", "3",
                "--method", "rk4", "--fftw-estimate", "--fftw-wisdom", "none", check=False)
    assert r.returncode == 1 and "blow-up at step 1" in r.stderr, r.stderr
    assert "decays at up to 10000 per unit time, so dt 0.01 is beyond an explicit step's stability" in r.stderr
    # ... and Python's run stops on it as the CLI's does (the library's rule and sentence), returning what it reached
    m = M.NavierStokes2D(n=16, drag=1e4, fftw_measure=False)
    b = eci.solve(m, (0.0, 0.03), dt=0.01, method="rk4")
    f = failure_of(b, eci.NonFiniteSolution)
    assert str(f).split("; ")[0] in r.stderr and str(f).startswith("blow-up at step 1, t = 0.01: energy "), str(f)
    assert "decays at up to 10000 per unit time, so dt 0.01 is beyond an explicit step's stability" in str(f)
    assert f.cause == "blow_up" and f.component_name == "energy" and f.t == 0.01
    assert b.t.tolist() == [0.0] and b.invariants["energy"]["final"] == b.invariants["energy"]["initial"]
    assert cli_error(cli, "run", "navier-stokes-2d", "--N", "16", "--hypo-nu", "1e308", "--fftw-estimate",
                     "--fftw-wisdom", "none") == (
        "--t-end / the default step 1e-308 is inf steps, too many (the step of the linear damping's stability: it "
        "decays at up to 1e+308 per unit time)")


# A field damped below double precision's normal range: the conservative step that fails there says so in both front
# ends (flow2d::decay_hint), not "a smaller dt may pass"; the conventional method takes it on to zero.
@pytest.mark.skipif(not hasattr(M, "NavierStokes2D"), reason="built without eci::spectral")
def test_a_field_damped_below_the_normal_range_is_said_so(cli):
    r = run_cli(cli, "run", "navier-stokes-2d", "--N", "32", "--drag", "1e10", "--steps", "400", "--fftw-estimate",
                "--fftw-wisdom", "none", check=False)
    assert r.returncode == 1, r.stderr
    hint = "the field has decayed below double precision's normal range (enstrophy "
    assert hint in r.stderr and "may pass" not in r.stderr, r.stderr
    m = M.NavierStokes2D(n=32, drag=1e10, fftw_measure=False)
    w = m.random_field()
    dt = m.cfl_step(w)
    b = eci.solve(m, (0.0, 400 * dt), w, dt=dt)
    f = failure_of(b, eci.StepSizeUnderflow)
    assert hint in str(f) and str(f).endswith("a conventional method (rk4) takes it on to zero"), str(f)
    assert str(f).split("; ")[0] in r.stderr, (str(f), r.stderr)
    assert b.invariants["enstrophy"]["final"] < 1e-300
    c = eci.solve(m, (0.0, 400 * dt), w, dt=dt, method="rk4")
    assert c.success and c.invariants["enstrophy"]["final"] == 0.0


# A fixed step far too long for the flow fails after the library's limit of sub-steps per grid step, with its
# sentence, in both front ends (it halved without end: no limit was set for the spectral models).
@pytest.mark.skipif(not hasattr(M, "CharneyHasegawaMima"), reason="built without eci::spectral")
def test_a_spectral_step_too_long_fails_after_the_sub_step_limit(cli):
    r = run_cli(cli, "run", "charney-hasegawa-mima", "--N", "16", "--beta", "1e12", "--dt", "0.01", "--steps", "1",
                "--fftw-estimate", "--fftw-wisdom", "none", check=False)
    assert r.returncode == 1, r.stderr
    assert "sub-steps" in r.stderr, r.stderr
    m = M.CharneyHasegawaMima(n=16, beta=1e12, fftw_measure=False)
    f = failure_of(eci.solve(m, (0.0, 0.01), dt=0.01), eci.StepSizeUnderflow)  # (returned, as every model's)
    assert "took more than 65536 sub-steps" in str(f) and f.cause == "work_exceeded"
    assert "took more than 65536 sub-steps" in r.stderr


# events=[] (no events) and t_eval=[] (no outputs), as SciPy takes them: eci.solve raised KeyError 'y_events' for
# the one and returned every step for the other. (SciPy 1.10 returns t = [] as a list there; eci an empty array.)
def test_empty_events_and_t_eval_are_scipys():
    from scipy.integrate import solve_ivp
    f = lambda t, y: -y  # noqa: E731
    for kw in ({"events": []}, {"t_eval": []}, {"t_eval": [], "events": []}):
        ref = solve_ivp(f, (0.0, 1.0), [1.0, 2.0], **kw)
        for extra in ({"rtol": 1e-6}, {"dt": 0.1}):
            r = eci.solve(f, (0.0, 1.0), [1.0, 2.0], **kw, **extra)
            assert r.success
            if "t_eval" in kw:
                assert np.shape(ref.t) == r.t.shape == (0,) and r.y.shape == (2, 0)
            else:
                assert len(r.t) > 2 and r.y.shape == (2, len(r.t))
            assert r.t_events == ref.t_events and r.y_events == ref.y_events
    m = M.ThreeWave()
    r = eci.solve(m, (0.0, 1.0), dt=0.1, t_eval=[])
    assert r.t.shape == (0,) and r.y.shape == (3, 0)


# A whole number beyond 64 bits is refused as the CLI refuses it (Python raised TypeError "seed must be a whole
# number, not int" for an int that did not fit a C++ long long, 2^63 included, which the CLI takes).
def test_whole_numbers_beyond_64_bits_are_refused_alike(cli):
    from conftest import cli_error

    for value in (2 ** 64, 2 ** 70):
        message = cli_error(cli, "run", "n-wave", "--seed", str(value), "--t-end", 1)
        with pytest.raises(ValueError) as e:
            M.NWave(seed=value)
        assert str(e.value) == message.replace("--seed", "seed")
    assert M.NWave(seed=2 ** 63).name == "n-wave"  # (the CLI takes it too)
    run_cli(cli, "run", "n-wave", "--seed", str(2 ** 63), "--steps", 1)


# The relaxation methods' states belong to t + time_lag (the CLI's time_lag column, docs/comparison.md): Python kept
# the times and dropped the lags, so that the default method of NonlinearOscillator and KeplerCartesian gave states
# compared against the wrong times.
def test_relaxation_time_lags_match_the_cli(cli, tmp_path):
    t, columns, summary = cli_run(cli, tmp_path, "nonlinear-oscillator", "rrk-rk4", 0.1, 10.0)
    r = eci.solve(M.NonlinearOscillator(), (0.0, 10.0), method="rrk-rk4", dt=0.1)
    assert np.array_equal(r.t, t)
    assert r.time_lag is not None and np.array_equal(r.time_lag, columns["time_lag"])
    assert np.count_nonzero(r.time_lag) > len(t) // 2
    assert r.time_lag[-1] == summary["time_lag"]
    assert eci.solve(M.NonlinearOscillator(), (0.0, 10.0), method="rk4", dt=0.1).time_lag is None
    # with t_eval: the grid points' lags, and the extra points' their own step's (a relaxed step from the grid state)
    r = eci.solve(M.KeplerCartesian(), (0.0, 1.0), dt=0.1, t_eval=[0.0, 0.25, 0.5, 1.0])
    assert r.method == "rrk-rk4" and r.time_lag.shape == (4,)
    assert r.time_lag[0] == 0.0 and r.time_lag[2] != 0.0


# A t_eval time between two grid times is reached by a relaxed step from the earlier grid state, whose state belongs
# to its time plus that step's lag, as on the grid; the lag was reported as 0 there, so y[:, i] was not the solution
# at t[i] + time_lag[i] as documented. The step from t = 0 to 0.01 is the whole run (0, 0.01) with dt = 0.01.
def test_relaxation_time_lag_at_t_eval_points_between_grid_times():
    side = eci.solve(M.KeplerCartesian(), (0.0, 1.0), t_eval=[0.01, 0.5])
    whole = eci.solve(M.KeplerCartesian(), (0.0, 0.01), dt=0.01)
    assert np.array_equal(side.y[:, 0], whole.y[:, -1])
    assert whole.time_lag[-1] != 0.0 and side.time_lag[0] == whole.time_lag[-1]
    # a point between later grid times: a step from the grid state continuing its lag, nonzero too
    r = eci.solve(M.KeplerCartesian(), (0.0, 1.0), dt=0.1, t_eval=[0.25, 0.55])
    assert np.all(r.time_lag != 0.0)


# result.keeps is what `eci run`'s summary says of the method on the model (JSON "keeps"): the invariants it keeps
# by construction. None for a Python fun, whose invariants the library cannot name.
@pytest.mark.parametrize("model, method", [("kepler", "projected-rk4"), ("kepler", "implicit-midpoint"),
                                           ("kepler", "c-pc"), ("three-wave", "rrk-rk4"), ("three-wave", "rk4"),
                                           ("kepler-cartesian", "mrrk-rk4")])
def test_result_keeps_what_the_cli_summary_says(cli, tmp_path, model, method):
    summary = cli_run(cli, tmp_path, model, method, 0.01, 0.1)[2]
    m = {"kepler": eci.models.Kepler, "three-wave": eci.models.ThreeWave,
         "kepler-cartesian": eci.models.KeplerCartesian}[model]()
    r = eci.solve(m, (0.0, 0.1), method=method, dt=0.01)
    assert r.keeps == summary["keeps"]
    assert summary["conservative"] == (len(r.keeps) == len(r.invariants))
    assert eci.solve(lambda t, y: -y, (0.0, 0.1), [1.0], method=method if method == "rk4" else "c-rk4",
                     dt=0.01).keeps is None
