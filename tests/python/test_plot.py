# SolveResult.plot (python/eci/_plot.py) and what it draws from: result.invariant_values (each invariant at each
# output, kept by the run's sink), NavierStokes2D's budget_residual_values, and the models' plot_plane,
# component_names and derived_columns. The curves drawn must be the result's own arrays, bit for bit.
import os
import subprocess
import sys

import numpy as np
import pytest

os.environ["MPLBACKEND"] = "Agg"  # (before matplotlib is imported: no display in the tests)

import eci  # noqa: E402
from conftest import BUILD, EPS  # noqa: E402

matplotlib = pytest.importorskip("matplotlib")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.collections import LineCollection  # noqa: E402


@pytest.fixture(autouse=True)
def close_figures():
    yield
    plt.close("all")


def panels(fig):
    """The figure's data axes (not the colorbar's), in the order drawn: state, [phase plane], invariants."""
    return [ax for ax in fig.axes if ax.get_label() != "<colorbar>"]


def phase_points(ax):
    """The phase plane's polyline: the points its coloured segments join."""
    (lines,) = [c for c in ax.collections if isinstance(c, LineCollection)]
    seg = lines.get_segments()
    return np.vstack([s[0] for s in seg] + [seg[-1][1]]), lines


def relative_change(v):
    v0 = v[0]
    return (v - v0) / abs(v0) if np.isfinite(v0) and v0 != 0 else v - v0


def test_state_phase_and_invariants_are_the_results_arrays():
    model = eci.models.ThreeWave()
    r = eci.solve(model, (0.0, 20.0), method="pc", dt=0.2)
    fig = r.plot()
    state, plane, inv = panels(fig)
    # the state: each component against t, the very arrays of the result, named as the model names them
    assert [ln.get_label() for ln in state.get_lines()] == list(model.component_names)
    for i, ln in enumerate(state.get_lines()):
        assert np.array_equal(ln.get_xdata(), r.t) and np.array_equal(ln.get_ydata(), r.y[i])
    assert state.get_ylabel() == "state"
    # the model's plane (psi_P, psi_Q): those rows, coloured by t (the segments' start times), the start marked
    assert model.plot_plane == ("psi_P", "psi_Q", False)
    names = list(model.component_names)
    points, lines = phase_points(plane)
    assert np.array_equal(points, np.column_stack((r.y[names.index("psi_P")], r.y[names.index("psi_Q")])))
    assert np.array_equal(lines.get_array(), r.t[:-1]) and lines.colorbar is not None
    (start,) = [ln for ln in plane.get_lines() if ln.get_label() == "start"]
    assert start.get_xydata().tolist() == [points[0].tolist()]
    assert plane.get_aspect() == "auto"  # (equal_axes False: each axis fitted to its range)
    # the invariants: (I - I0) / |I0| of the per-output values, which are the model's invariants at r.y
    assert [ln.get_label() for ln in inv.get_lines()] == ["energy", "enstrophy"]
    for ln, name in zip(inv.get_lines(), ["energy", "enstrophy"]):
        assert np.array_equal(ln.get_ydata(), relative_change(r.invariant_values[name]))
    at_states = model.invariants(r.y)
    for name, v in r.invariant_values.items():
        assert v.shape == r.t.shape
        # the same C++ function on the same state's bits, but compiled in another translation unit (the model's
        # runs at -O3, the binding at -O1), which may contract a multiply-add differently: a few roundings of the
        # sum of three squares, 4 eps relative
        assert np.max(np.abs(v - at_states[name])) <= 4 * EPS * np.max(np.abs(at_states[name]))
        # and they are the run's own measurements: every step is an output here, so the drift record's initial,
        # final and largest drift are these values' (bit for bit)
        rec = r.invariants[name]
        assert v[0] == rec["initial"] and v[-1] == rec["final"]
        assert np.max(np.abs(v - v[0])) == rec["max_abs_drift"]


def test_kepler_plane_is_the_derived_orbit_with_equal_axes():
    model = eci.models.Kepler()
    r = eci.solve(model, (0.0, 15.0), method="rk4", dt=0.05)
    fig = r.plot()
    _, plane, inv = panels(fig)
    assert model.plot_plane == ("x", "y", True)
    assert plane.get_aspect() == 1.0  # one scale on both axes (matplotlib's "equal")
    assert (plane.get_xlabel(), plane.get_ylabel()) == ("x", "y")
    points, _ = phase_points(plane)
    derived = model.derived_columns(r.y)
    assert np.array_equal(points, np.column_stack((derived["x"], derived["y"])))
    # the model's x, y are r cos(theta), r sin(theta): C++'s cos/sin and NumPy's each within an ulp of the true
    # value, and one rounding of the product: 3 ulp of r
    rr, theta = r.y[0], r.y[2]
    assert np.max(np.abs(points[:, 0] - rr * np.cos(theta)) / rr) <= 3 * EPS
    assert np.max(np.abs(points[:, 1] - rr * np.sin(theta)) / rr) <= 3 * EPS
    # runge_lenz_y starts at 0 (theta = 0): its change is absolute, and the key says so
    labels = [ln.get_label() for ln in inv.get_lines()]
    assert labels == ["hamiltonian", "runge_lenz_x", "runge_lenz_y (abs.)"]
    assert r.invariant_values["runge_lenz_y"][0] == 0.0
    for ln, name in zip(inv.get_lines(), model.invariant_names):
        assert np.array_equal(ln.get_ydata(), relative_change(r.invariant_values[name]))
    # H < 0: relative to |H0|, so a rising H is drawn rising
    h = r.invariant_values["hamiltonian"]
    assert h[0] < 0 and np.array_equal(inv.get_lines()[0].get_ydata(), (h - h[0]) / -h[0])
    assert "(abs.)" in inv.get_ylabel()


def test_adaptive_outputs_keep_the_invariants_at_their_states():
    # t_eval with rtol: the outputs are dense-output states, each measured where it is output
    model = eci.models.ThreeWave()
    r = eci.solve(model, (0.0, 10.0), rtol=1e-8, t_eval=np.linspace(0.0, 10.0, 41))
    at_states = model.invariants(r.y)
    for name, v in r.invariant_values.items():
        assert v.shape == (41,)
        # (as above: one function, two translation units)
        assert np.max(np.abs(v - at_states[name])) <= 4 * EPS * np.max(np.abs(at_states[name]))


def test_python_fun_names_phase_and_invariants():
    def f(t, y):
        return np.array([y[1], -y[0], 0.0])

    def energy(y):
        return y[0] * y[0] + y[1] * y[1]  # (elementwise: the same bits on a column of r.y as in the run)

    r = eci.solve(f, (0.0, 5.0), [1.0, 0.0, 0.5], method="rk2", dt=0.1, invariants={"E": energy})
    assert np.array_equal(r.invariant_values["E"], np.array([energy(r.y[:, i]) for i in range(r.t.size)]))
    fig = r.plot()
    assert len(panels(fig)) == 2  # no plane unless asked: a Python fun declares none
    state, inv = panels(fig)
    assert [ln.get_label() for ln in state.get_lines()] == ["y[0]", "y[1]", "y[2]"]
    assert np.array_equal(inv.get_lines()[0].get_ydata(), relative_change(r.invariant_values["E"]))
    fig = r.plot(phase=(0, 1, True))
    state, plane, inv = panels(fig)
    points, _ = phase_points(plane)
    assert np.array_equal(points, r.y[:2].T) and plane.get_aspect() == 1.0
    assert (plane.get_xlabel(), plane.get_ylabel()) == ("y[0]", "y[1]")
    assert panels(r.plot(phase=(2, 0)))[1].get_aspect() == "auto"
    with pytest.raises(ValueError, match="component 3 is not one of the 3"):
        r.plot(phase=(0, 3))
    with pytest.raises(ValueError, match="phase must be"):
        r.plot(phase="xy")


def test_model_plane_chosen_by_name_or_turned_off():
    model = eci.models.ThreeWave()
    r = eci.solve(model, (0.0, 2.0), method="c-rk4", dt=0.1)
    _, plane, _ = panels(r.plot(phase=("psi_K", "psi_Q", True)))
    points, _ = phase_points(plane)
    assert np.array_equal(points, r.y[[0, 2]].T) and plane.get_aspect() == 1.0
    assert len(panels(r.plot(phase=False))) == 2
    with pytest.raises(ValueError, match="no component or derived column named 'q'"):
        r.plot(phase=("psi_K", "q"))


def test_first_six_of_many_components_and_complex_parts():
    model = eci.models.NWave(complex=True)
    r = eci.solve(model, (0.0, 1.0), dt=0.1)
    state = panels(r.plot())[0]
    n_real = 2 * r.y.shape[0]
    assert state.get_ylabel() == f"state (first 6 of {n_real} components)"
    lines = state.get_lines()
    assert [ln.get_label() for ln in lines] == list(model.component_names[:6])
    for k, ln in enumerate(lines):  # re_psi_0, im_psi_0, re_psi_1, ...
        part = r.y[k // 2].real if k % 2 == 0 else r.y[k // 2].imag
        assert np.array_equal(ln.get_ydata(), part)


def test_spectral_flow_plots_its_invariants_and_budget_residuals():
    model = eci.models.NavierStokes2D(n=16, nu=1e-3)
    r = eci.solve(model, (0.0, 0.08), dt=0.01, output_dt=0.02)
    assert r.t.size == 5
    top, bottom, field = panels(r.plot())
    assert top.get_yscale() == "log" and bottom.get_yscale() == "log"
    # beside them the field at the last output, the model's own physical field, on a colour scale symmetric about 0
    (image,) = field.get_images()
    expected = model.to_physical(r.y[:, -1])
    assert np.array_equal(np.asarray(image.get_array()), expected)
    lo, hi = image.get_clim()
    assert hi == np.max(np.abs(expected)) and lo == -hi > -np.inf
    assert field.get_title() == f"vorticity at t = {r.t[-1]:.6g}" and model.field == "vorticity"
    # (each equation's field and symbol, from its C++ module: the snapshots' names)
    assert [(c(n=16).field, c(n=16).symbol) for c in eci.models.flow_models] == [
        ("vorticity", "omega"), ("potential vorticity", "q"), ("buoyancy", "theta")]
    for ln, name in zip(top.get_lines(), model.invariant_names):
        assert np.array_equal(ln.get_xdata(), r.t) and np.array_equal(ln.get_ydata(), r.invariant_values[name])
    for ln, name in zip(bottom.get_lines(), model.invariant_names):
        assert np.array_equal(ln.get_ydata(), r.budget_residual_values[name])
    for name in model.invariant_names:
        v = r.invariant_values[name]
        # E and Z at the outputs: the model's own functions on r.y (as above: the same functions, other units)
        at_states = np.array([getattr(model, name)(r.y[:, i]) for i in range(r.t.size)])
        assert np.max(np.abs(v - at_states)) <= 4 * EPS * np.max(v)
        assert v[0] == r.invariants[name]["initial"] and v[-1] == r.invariants[name]["final"]
        # each output's largest per-step residual since the previous one: their maximum is the run's
        res = r.budget_residual_values[name]
        assert res[0] == 0.0 and res.max() == r.budget[f"max_{name}_budget_residual_per_step"]


MAGIC = {"png": (b"\x89PNG\r\n\x1a\n", b"IEND\xaeB`\x82"), "svg": (b"<?xml", b"</svg>\n"),
         "pdf": (b"%PDF-", b"%%EOF\n")}


@pytest.mark.parametrize("ext", sorted(MAGIC))
def test_file_is_written_whole(tmp_path, ext):
    r = eci.solve(eci.models.Kepler(), (0.0, 2.0), dt=0.1)
    path = tmp_path / f"run.{ext}"
    fig = r.plot(file=path)
    assert fig is not None
    data = path.read_bytes()
    head, tail = MAGIC[ext]
    assert data.startswith(head) and data.endswith(tail), (data[:16], data[-16:])


def test_bad_extension_is_refused_and_nothing_written(tmp_path):
    r = eci.solve(eci.models.Kepler(), (0.0, 1.0), dt=0.1)
    for name in ("run.jpg", "run", "run.png.txt"):
        with pytest.raises(ValueError, match=r"must end in \.png, \.svg or \.pdf") as e:
            r.plot(file=tmp_path / name)
        assert name in str(e.value) and len(str(e.value).splitlines()) == 1
    assert list(tmp_path.iterdir()) == []


def test_without_matplotlib_plot_says_what_to_install(monkeypatch):
    r = eci.solve(eci.models.Kepler(), (0.0, 1.0), dt=0.1)
    monkeypatch.setitem(sys.modules, "matplotlib", None)  # `import matplotlib` now fails
    with pytest.raises(ImportError, match="python3-matplotlib"):
        r.plot()


def test_importing_eci_does_not_import_matplotlib():
    code = ("import sys, eci, eci.models\n"
            "r = eci.solve(eci.models.Kepler(), (0.0, 1.0), dt=0.1)\n"
            "assert 'invariant_values' in r and 'plot' in dir(r)\n"
            "print(sorted(m for m in sys.modules if m.split('.')[0] == 'matplotlib'))\n")
    env = dict(os.environ, PYTHONPATH=str(BUILD / "python"))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"


def test_without_pyplot_a_figure_of_its_own(tmp_path):
    # no backend chosen and pyplot not imported: an Agg figure, pyplot never imported (no window, nothing global)
    code = ("import os, sys, eci\n"
            "r = eci.solve(eci.models.ThreeWave(), (0.0, 1.0), dt=0.1)\n"
            f"fig = r.plot({str(tmp_path / 'a.png')!r})\n"
            "print(type(fig.canvas).__name__, 'matplotlib.pyplot' in sys.modules)\n")
    env = {k: v for k, v in os.environ.items() if k != "MPLBACKEND"}
    env["PYTHONPATH"] = str(BUILD / "python")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["FigureCanvasAgg", "False"]
    assert (tmp_path / "a.png").read_bytes().startswith(MAGIC["png"][0])


def test_budget_residual_values_are_each_outputs_steps():
    # inviscid, unforced: no injection or dissipation, so a step's residual is |I_after - I_before| / I_after
    # (the library's budget_residual with both terms 0), computed here from the invariants at every step, bit for
    # bit; then the same run output every 3rd step holds the largest of those 3 steps' residuals
    model = eci.models.NavierStokes2D(n=16)
    every = eci.solve(model, (0.0, 0.12), dt=0.01, method="c-rk4")
    third = eci.solve(model, (0.0, 0.12), dt=0.01, method="c-rk4", output_dt=0.03)
    assert every.t.size == 13 and third.t.size == 5
    for name in model.invariant_names:
        v, res = every.invariant_values[name], every.budget_residual_values[name]
        assert res[0] == 0.0 and np.array_equal(res[1:], np.abs(v[1:] - v[:-1]) / v[1:])
        assert np.array_equal(third.invariant_values[name], v[::3])
        assert np.array_equal(third.budget_residual_values[name][1:], res[1:].reshape(4, 3).max(axis=1))
    # (round-off residuals whose 3-step maxima are not monotone: a running maximum instead would differ)
    assert any(np.any(np.diff(third.budget_residual_values[n][1:]) < 0) for n in model.invariant_names)


def test_a_spectral_runs_own_invariants_are_drawn_in_a_panel_of_their_own():
    model = eci.models.NavierStokes2D(n=16, nu=1e-3)
    r = eci.solve(model, (0.0, 0.08), dt=0.01, output_dt=0.02,
                  invariants={"P": model.palinstrophy, "zero": lambda w: 0.0})
    top, bottom, user, field = panels(r.plot())
    assert len(top.get_lines()) == 2  # E and Z alone on the log scale
    (p, zero) = user.get_lines()
    v = r.invariant_values["P"]
    assert p.get_label() == "P" and np.array_equal(p.get_ydata(), (v - v[0]) / abs(v[0]))
    assert zero.get_label() == "zero (abs.)" and not np.any(zero.get_ydata())
    assert field.get_images()
