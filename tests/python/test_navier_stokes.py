# eci.models.NavierStokes2D: the FFTW vorticity model from Python, its diagnostics, and the inviscid conservative
# run keeping E and Z to round-off where RK4 drifts.
import math

import numpy as np
import pytest

import eci
from conftest import EPS

NS = getattr(eci.models, "NavierStokes2D", None)
pytestmark = pytest.mark.skipif(NS is None, reason="built without eci::spectral (FFTW3)")


def test_state_diagnostics_and_fields():
    m = NS(n=32)
    assert m.size == 21 * 11 and m.kmax == 10  # the retained modes: 2 kmax + 1 rows of kmax + 1 and m.invariant_names == ["energy", "enstrophy"]
    w = m.random_field(k_peak=3.0, energy=0.5, seed=11)
    assert w.dtype == np.complex128 and w.shape == (m.size,)
    assert abs(m.energy(w) - 0.5) <= 1e3 * EPS  # scaled to the energy asked for
    inv = m.invariants(w)
    assert inv["energy"] == m.energy(w) and inv["enstrophy"] == m.enstrophy(w)
    assert m.palinstrophy(w) > 0.0
    # E(k) sums to E; the field on the grid has Z = <omega^2> / 2
    assert abs(np.sum(m.energy_spectrum(w)) - m.energy(w)) <= 1e3 * EPS
    field = m.to_physical(w)
    assert field.shape == (32, 32)
    assert abs(0.5 * np.mean(field ** 2) - m.enstrophy(w)) <= 1e3 * EPS * m.enstrophy(w)
    assert np.max(np.abs(m.from_physical(field) - w)) <= 1e3 * EPS * np.max(np.abs(w))
    assert m.cfl_step(w) == pytest.approx(0.5 * (2 * math.pi / 32) / m.max_velocity(w), rel=1e-15)
    # the right-hand side as SciPy's fun(t, y) conserves E: sum over modes of conj(omega) N / |k|^2 = 0
    assert m(0.0, w).shape == w.shape


# from_physical takes a real, finite field: a complex one was cast to its real part (numpy's warning at most), a nan
# or inf made a state of nans, and a field near the largest double overflowed in the transform's sums ("initial
# condition is not finite" of a finite field). The last is transformed scaled by a power of two: its modes are
# exactly those of the field scaled down, scaled back; a field below the threshold is transformed as before.
def test_from_physical_takes_real_finite_fields_up_to_the_largest_double():
    m = NS(n=32, fftw_measure=False)
    field = m.to_physical(m.random_field(k_peak=3.0, seed=2))
    with pytest.raises(TypeError, match=r"^field must be real \(a field on the n x n grid\), not complex128$"):
        m.from_physical(field.astype(complex))
    for bad, text in ((np.nan, "nan"), (np.inf, "inf"), (-np.inf, "-inf")):
        f = field.copy()
        f[5, 3] = bad
        with pytest.raises(ValueError, match=rf"^field value at x = 3, y = 5 is {text}: a field must be finite$"):
            m.from_physical(f)
    big = field / np.max(np.abs(field)) * 1.5e308
    w = m.from_physical(big)
    scale = 2.0 ** -1024  # (a power of two: exact)
    assert np.all(np.isfinite(w)) and np.array_equal(w * scale, m.from_physical(big * scale))
    # the same in eci.solve's check: the field is finite, its energy (a sum of squares) is not
    with pytest.raises(ValueError, match="must be finite normal numbers"):
        eci.solve(m, (0.0, 1.0), w, dt=0.1)


def test_random_field_refuses_a_peak_beyond_the_retained_modes_as_the_cli_does():
    # eci run's --k-peak 6 at N = 16 says the same (tests/python/test_cli_run_files.py); the default peak 8 is kept
    # on a grid whose kmax is 5, and a peak at kmax is accepted
    m = NS(n=16)
    with pytest.raises(ValueError) as e:
        m.random_field(k_peak=6.0)
    assert str(e.value) == "k_peak 6 is beyond the retained modes (|k_x|, |k_y| <= kmax = 5 at N = 16)"
    w = m.random_field()
    assert w.shape == (m.size,) and abs(m.energy(w) - 0.5) <= 1e3 * EPS
    assert m.random_field(k_peak=5.0).shape == (m.size,)


def test_inviscid_c_rk4_keeps_energy_and_enstrophy_where_rk4_drifts():
    m = NS(n=32)
    w = m.random_field(k_peak=3.0, energy=0.5, seed=11)
    steps = 200
    dt = m.cfl_step(w)
    t_end = steps * dt
    r = eci.solve(m, (0.0, t_end), w, method="c-rk4", dt=dt, t_eval=[t_end])
    assert r.stats["steps"] == steps and r.y.shape == (m.size, 1)
    # as tests/spectral: each step rounds every sum once and the nonlinear transfer is zero to a few eps;
    # 8 eps sqrt(steps) relative, halvings counted as extra steps
    tol = 8.0 * EPS * math.sqrt(steps + 2 * r.stats["rejected_steps"]["step_failed"])
    for name in ("energy", "enstrophy"):
        assert r.invariants[name]["max_rel_drift"] <= tol, (name, r.invariants[name])
    rk4 = eci.solve(m, (0.0, t_end), w, method="rk4", dt=dt, t_eval=[t_end])
    assert max(rk4.invariants[n]["max_rel_drift"] for n in ("energy", "enstrophy")) > 1e3 * tol
    # the budget of an unforced inviscid run is zero, and each step kept to it (its residual: rounding alone)
    assert all(v == 0.0 for k, v in r.budget.items() if not k.startswith("max_")), r.budget
    assert all(r.budget[f"max_{n}_budget_residual_per_step"] <= 16 * EPS for n in ("energy", "enstrophy")), r.budget


def test_update_keyword_conditioned_by_default_and_paper_on_request():
    # c-rk4 takes the conditioned update by default (at RK4's error on random phases), update="paper" the
    # paper's; N = 32 inviscid, t = 0.05 in 32 steps against 512 RK4 steps. Both keep E and Z to 8 eps sqrt(steps)
    # (each step rounds every sum once, as in tests/spectral).
    m = NS(n=32)
    w = m.random_field(k_peak=4.0, energy=0.5, seed=3)
    t_end = 0.05

    def final(method, steps, **kw):
        r = eci.solve(m, (0.0, t_end), w, method=method, dt=t_end / steps, t_eval=[t_end], **kw)
        return r, r.y[:, -1]

    _, ref = final("rk4", 512)
    _, rk4 = final("rk4", 32)
    cond, crk4 = final("c-rk4", 32)
    paper, crk4_paper = final("c-rk4", 32, update="paper")
    err = lambda y: np.linalg.norm(y - ref)
    assert err(crk4) <= 1.5 * err(rk4), (err(crk4), err(rk4), err(crk4_paper))
    assert not np.array_equal(crk4, crk4_paper)  # the keyword reaches the stepper
    tol = 8.0 * EPS * math.sqrt(32)
    for r in (cond, paper):
        assert all(r.invariants[n]["max_rel_drift"] <= tol for n in ("energy", "enstrophy"))
    with pytest.raises(ValueError, match="update must be"):
        eci.solve(m, (0.0, t_end), w, method="c-rk4", dt=t_end / 32, update="fast")


def test_viscous_decay_budget_and_default_step():
    m = NS(n=32, nu=0.01)
    w = m.taylor_green(velocity=1.0)
    r = eci.solve(m, (0.0, 0.5), w, method="c-rk4", t_eval=[0.0, 0.5])  # dt: CFL 0.5 of w
    e0, e1 = r.invariants["energy"]["initial"], r.invariants["energy"]["final"]
    # Taylor-Green decays as exp(-2 nu t) in velocity, exp(-4 nu t) in energy (|k|^2 = 2)
    assert e1 / e0 == pytest.approx(math.exp(-4 * 0.01 * 0.5), rel=1e-6)
    # the discrete budget accounts for the loss to round-off
    assert abs(e0 - r.budget["energy_dissipation"] - e1) <= 1e3 * EPS * e0


def test_bad_input():
    with pytest.raises(ValueError, match="^navier-stokes-2d: grid size N must be even and at least 8, not 7$"):
        NS(n=7)
    with pytest.raises(ValueError, match="forcing must be none, deterministic or stochastic"):
        NS(n=32, forcing="wind")
    m = NS(n=16)
    with pytest.raises(ValueError, match=r"has shape \(3,\), expected \(66,\)"):
        m.energy(np.zeros(3, dtype=complex))
    with pytest.raises(ValueError, match="has no error estimate"):
        eci.solve(m, (0.0, 1.0), method="c-dp54", rtol=1e-6)
    with pytest.raises(ValueError, match=r"^t_eval time 0.15 is not on the step grid t0 \+ i dt of dt = 0.1; "
                                         r"navier-stokes-2d outputs whole steps: give output_dt= "):
        eci.solve(m, (0.0, 1.0), dt=0.1, t_eval=[0.15])
    # a step the user never chose is named as the CFL step, and the remedies work
    with pytest.raises(ValueError, match=rf"dt = {m.cfl_step(m.default_y0)!r} \(the CFL 0.5 step of y0: no dt was "
                                         r"given\); .* or a dt of which every t_eval time is a whole multiple"):
        eci.solve(m, (0.0, 1.0), t_eval=[0.5, 1.0])
    assert eci.solve(m, (0.0, 1.0), output_dt=0.5).t.tolist() == [0.0, 0.5, 1.0]
    assert eci.solve(m, (0.0, 1.0), dt=0.05, t_eval=[0.5, 1.0]).t.tolist() == [0.5, 1.0]


def test_full_transforms_give_the_same_run_to_round_off():
    # full_transforms=True (the CLI's --full-transforms): FFTW's 2-D plans instead of the default transforms of the
    # retained columns; the same steps to the transforms' round-off (measured 1e-15 of max|omega_k| here), not the
    # same bits, and each keeps E and Z exactly
    runs = []
    for full in (False, True):
        m = NS(n=32, fftw_measure=False, full_transforms=full)
        r = eci.solve(m, (0.0, 10 * m.cfl_step(m.default_y0)), m.default_y0, method="c-rk4",
                      dt=m.cfl_step(m.default_y0))
        for name in ("energy", "enstrophy"):
            assert r.invariants[name]["max_rel_drift"] <= 8 * EPS * math.sqrt(10), r.invariants[name]
        # (the default stores the state by columns, full transforms by rows: compared mode by mode)
        runs.append(r.y[np.lexsort((np.asarray(m.ky), np.asarray(m.kx))), -1])
    diff = np.max(np.abs(runs[0] - runs[1]))
    assert 0.0 < diff <= 1e-11 * np.max(np.abs(runs[1]))
