# The spectral core's other equations from Python: Charney-Hasegawa-Mima and surface QG keep both of their invariants
# under the conservative methods, report their budgets under their own names, agree with `eci run` bit for bit, and
# refuse bad parameters with the CLI's messages.
import json
import math

import numpy as np
import pytest

import eci
from conftest import EPS, cli_error, run_cli

CHM = getattr(eci.models, "CharneyHasegawaMima", None)
SQG = getattr(eci.models, "SurfaceQG", None)
pytestmark = pytest.mark.skipif(CHM is None, reason="built without eci::spectral (FFTW3)")


def models():
    return [("charney-hasegawa-mima", CHM(beta=10.0, deformation=1.0, n=32), ["energy", "enstrophy"]),
            ("surface-qg", SQG(n=32), ["energy", "variance"])]


@pytest.mark.parametrize("index", [0, 1])
def test_inviscid_conservative_methods_keep_both_invariants(index):
    name, m, names = models()[index]
    assert m.equation == name and m.invariant_names == names
    w = m.random_field(k_peak=3.0, energy=0.5, seed=5)
    steps = 200
    dt = m.cfl_step(w)
    for method in ("c-rk4", "c-pc"):
        r = eci.solve(m, (0.0, steps * dt), w, method=method, dt=dt, t_eval=[steps * dt])
        # each step rounds every sum once and the nonlinear transfer is zero to a few eps: 8 eps sqrt(steps)
        tol = 8.0 * EPS * math.sqrt(steps + 2 * r.stats["rejected_steps"]["step_failed"])
        for n in names:
            assert r.invariants[n]["max_rel_drift"] <= tol, (method, n, r.invariants[n])
    rk4 = eci.solve(m, (0.0, steps * dt), w, method="rk4", dt=dt, t_eval=[steps * dt])
    assert max(rk4.invariants[n]["max_rel_drift"] for n in names) > 1e3 * 8.0 * EPS * math.sqrt(steps)


@pytest.mark.parametrize("index", [0, 1])
def test_spectra_fluxes_and_budget_names(index):
    name, m, names = models()[index]
    w = m.random_field(k_peak=4.0, energy=0.5, seed=2)
    assert abs(np.sum(m.energy_spectrum(w)) - m.energy(w)) <= 64 * EPS * m.energy(w)
    assert abs(np.sum(m.enstrophy_spectrum(w)) - m.enstrophy(w)) <= 64 * EPS * m.enstrophy(w)
    pe, pz = m.fluxes(w)
    # the transfer conserves both invariants: no flux leaves the last shell
    assert abs(pe[-1]) <= 1e3 * EPS * np.max(np.abs(pe)) and abs(pz[-1]) <= 1e3 * EPS * np.max(np.abs(pz))
    r = eci.solve(m, (0.0, 0.05), w, method="c-rk4", dt=0.01)
    assert sorted(r.budget) == sorted([f"{n}_{k}" for n in names for k in ("injection", "dissipation")] +
                                      [f"max_{n}_budget_residual_per_step" for n in names])


def test_rossby_wave_frequency_from_python():
    m = CHM(beta=10.0, deformation=1.0, n=32)
    q = np.zeros(m.size, dtype=complex)
    kx, ky = m.kx, m.ky
    q[(kx == 3) & (ky == 4)] = 0.3 - 0.1j  # one Rossby wave of |k|^2 = 25
    dq = m(0.0, q)
    # dq/dt = -i omega q with omega = -beta k_x / (k^2 + F), to round-off
    omega = -10.0 * 3 / (25.0 + 1.0)
    i = np.flatnonzero((kx == 3) & (ky == 4))[0]
    assert abs(dq[i] - (-1j * omega) * q[i]) <= 64 * EPS * abs(omega * q[i])
    assert np.max(np.abs(np.delete(dq, i))) <= 64 * EPS * abs(omega * q[i])


@pytest.mark.parametrize("name,args", [("charney-hasegawa-mima", ["--beta", "10", "--deformation", "1"]),
                                       ("surface-qg", [])])
def test_python_and_cli_run_the_same_steps(cli, tmp_path, name, args):
    summary = tmp_path / "s.json"
    run_cli(cli, "run", name, "--N", 32, "--steps", 20, "--fftw-wisdom", "none", "--fftw-estimate",
            "--summary-json", summary, *args)
    s = json.loads(summary.read_text())
    m = CHM(beta=10.0, deformation=1.0, n=32) if name == "charney-hasegawa-mima" else SQG(n=32)
    dt = m.default_dt
    r = eci.solve(m, (0.0, 20 * dt), method="c-rk4", dt=dt)
    assert sorted(s["invariants"]) == sorted(m.invariant_names)
    for n, inv in s["invariants"].items():
        assert r.invariants[n]["final"] == inv["final"], (n, inv)


def test_bad_parameters(cli):
    with pytest.raises(ValueError, match="deformation"):
        CHM(deformation=-1.0, n=16)
    with pytest.raises(ValueError, match="^surface-qg: grid size N must be at most 65536, not 4294967312$"):
        SQG(n=2 ** 32 + 16)
    assert "deformation" in cli_error(cli, "run", "charney-hasegawa-mima", "--N", 16, "--deformation", "-1",
                                      "--fftw-wisdom", "none")
    msg = cli_error(cli, "run", "surface-qg", "--N", 16, "--beta", "1", "--fftw-wisdom", "none")
    assert "beta" in msg


@pytest.mark.parametrize("attribute,value,needle", [
    ("dt", 0.0, "dt must be a positive number"),
    ("dt", -0.01, "dt must be a positive number"),
    ("energy0", float("nan"), "energy0 is not finite"),
    ("energy_injection", float("inf"), "energy_injection is not finite"),
    ("N", 2 ** 32 + 16, "N = 4294967312 is not in 8..65536"),
    ("threads", 0, "threads = 0 is not in 1..64"),
    ("forcing", "wind", "unknown forcing 'wind'"),
    ("t_end", 5.0, "t_end does not end total_steps steps of dt"),
])
def test_corrupt_checkpoint_fields_are_refused(cli, tmp_path, attribute, value, needle):
    """A checkpoint whose numbers a continued run would compute with is checked, not trusted."""
    import h5py

    ck = tmp_path / "ck.h5"
    run_cli(cli, "run", "surface-qg", "--N", 16, "--steps", 2, "--fftw-wisdom", "none", "--fftw-estimate",
            "--checkpoint", ck, "--checkpoint-every", 2)
    with h5py.File(ck, "r+") as f:
        if isinstance(value, str):
            del f.attrs[attribute]
            f.attrs.create(attribute, np.bytes_(value))
        else:
            dtype = f.attrs[attribute].dtype
            del f.attrs[attribute]
            f.attrs.create(attribute, value, dtype=dtype)
    before = ck.read_bytes()
    msg = cli_error(cli, "run", "surface-qg", "--restart", ck, "--fftw-wisdom", "none", "--steps", 4,
                    "--checkpoint", ck)
    assert needle in msg, msg
    assert ck.read_bytes() == before  # nothing replaced


# A keyword a flow's constructor does not take, or an argument of the wrong type, is one line naming it (pybind11's
# "incompatible constructor arguments" listed the signature over many lines).
def test_a_constructors_bad_argument_is_one_line():
    with pytest.raises(TypeError, match=r"^SurfaceQG\(\) got an unexpected keyword argument 'beta' \(it takes: n, nu, "):
        eci.models.SurfaceQG(n=16, beta=1.0)
    with pytest.raises(TypeError, match=r"^NavierStokes2D\(\): nu must be a real number, not str 'a'$"):
        eci.models.NavierStokes2D(nu="a")
    with pytest.raises(TypeError, match=r"^SurfaceQG\(\): hyper_p must be a whole number or None, not float 2.5$"):
        eci.models.SurfaceQG(16, 0.0, 1.0, 2.5)
    # ... and so is one of a method's arguments
    m = eci.models.NavierStokes2D(n=16, fftw_measure=False)
    with pytest.raises(TypeError, match=r"^NavierStokes2D.random_field\(\): seed must be a whole number, not float "
                                        r"1.5$"):
        m.random_field(seed=1.5)
    with pytest.raises(TypeError, match=r"^NavierStokes2D.vortex_pair\(\): separation must be a real number, not "
                                        r"str 'x'$"):
        m.vortex_pair(0.2, "x")
    with pytest.raises(TypeError, match=r"^ThreeWave\(t, y\): t must be a real number, not NoneType None$"):
        eci.models.ThreeWave()(None, [1.0, 2.0, 3.0])
    assert np.array_equal(m.random_field(np.float64(4.0), seed=np.int64(3)), m.random_field(4.0, seed=3))


# A spectral model's repr is the constructor call that makes it again (its class, n, and each setting that is not
# the default), and each keyword is a read-only property with the value the flow runs with.
@pytest.mark.parametrize("make", [
    lambda: eci.models.NavierStokes2D(n=16),
    lambda: eci.models.NavierStokes2D(n=32, nu=1e-3, hyper_nu=1e-10, hyper_p=4, forcing="stochastic",
                                      injection_rate=0.5, forcing_seed=7, fftw_measure=False),
    lambda: CHM(n=16, beta=10.0, deformation=1.0, full_transforms=True, drag=0.1, hypo_nu=0.01, hypo_p=2),
    lambda: SQG(n=16, forcing="deterministic", forcing_k=3.0, forcing_amplitude=2.0, threads=2)])
def test_a_spectral_models_repr_makes_it_again(make):
    m = make()
    r = repr(m)
    again = eval("eci.models." + r)
    assert repr(again) == r and type(again) is type(m)
    for k in ("n", "nu", "hyper_nu", "hyper_p", "hypo_nu", "hypo_p", "drag", "forcing", "forcing_k",
              "forcing_amplitude", "injection_rate", "forcing_seed", "threads", "fftw_measure", "full_transforms"):
        assert getattr(again, k) == getattr(m, k), k
        with pytest.raises(AttributeError):
            setattr(m, k, getattr(m, k))
    assert hasattr(m, "beta") == (type(m) is CHM)
    if type(m) is CHM:
        assert (m.beta, m.deformation) == (10.0, 1.0) and "beta=10.0, deformation=1.0" in r
    for part in r[r.index("(") + 1:-1].split(", "):  # each keyword shown is its property's value
        k, v = part.split("=")
        assert repr(getattr(m, k)) == v, (k, v)


# A state that is not a real field's (a k_x = 0 column that is not Hermitian, a nonzero mean) was run as given: its
# invariants count both halves of the column, and the run was no flow's. Beyond the round-off of a transform it is
# refused with the library's sentence; within it (numpy's rfft2 of a real field) it is taken and made exact.
@pytest.mark.parametrize("make", [lambda n: eci.models.NavierStokes2D(n=n, fftw_measure=False),
                                  lambda n: CHM(n=n, beta=2.0, deformation=1.0, fftw_measure=False),
                                  lambda n: SQG(n=n, fftw_measure=False)], ids=["ns", "chm", "sqg"])
def test_a_state_that_is_not_a_real_fields_is_refused(make):
    m = make(32)
    w = np.array(m.random_field(), dtype=complex)
    column = np.flatnonzero((m.kx == 0) & (m.ky == 3))[0]
    scale = np.linalg.norm(w)
    bad = w.copy()
    bad[column] += 1e-6 * scale  # its conjugate at k_y = -3 left as it was
    for r in (lambda y: eci.solve(m, (0.0, 0.01), y, dt=0.01), lambda y: m.cfl_step(y)):
        with pytest.raises(ValueError, match=r"^initial condition is not the state of a real field: its k_x = 0 "
                                             r"column is not Hermitian \(\|q\(0, -3\) - conj q\(0, 3\)\| = "):
            r(bad)
    mean = w.copy()
    mean[np.flatnonzero((m.kx == 0) & (m.ky == 0))[0]] = 1e-6 * scale
    with pytest.raises(ValueError, match=r"^initial condition has a mean: its k = 0 mode is .* subtract it$"):
        eci.solve(m, (0.0, 0.01), mean, dt=0.01)
    # round-off (the size of a transform's: a few eps of the norm) is taken, and the run is the exact state's
    near = w.copy()
    near[column] += 4 * EPS * scale
    near[np.flatnonzero((m.kx == 0) & (m.ky == 0))[0]] = 2 * EPS * scale
    a = eci.solve(m, (0.0, 0.02), near, dt=0.01)
    b = eci.solve(m, (0.0, 0.02), w, dt=0.01)
    assert a.success and b.success
    exact = w.copy()
    exact[column] = near[column]
    exact[np.flatnonzero((m.kx == 0) & (m.ky == -3))[0]] = np.conj(near[column])
    c = eci.solve(m, (0.0, 0.02), exact, dt=0.01)
    assert np.array_equal(a.y, c.y)  # the column made exact (k = 0 set to 0), not run as given
    assert not np.array_equal(a.y[:, -1], b.y[:, -1])  # (the perturbation was a change, seen by the run)


# A run that fails returns what it reached, SciPy's way (status -1, result.failure, not raised), as every other model's
# run does; a run that does not has result.failure None. The sentence names the cause as the CLI does: a radicand
# only for the methods that take square roots.
@pytest.mark.parametrize("method, cause", [("rk4", "a non-finite state"),
                                           ("c-rk4", "a negative radicand or a non-finite state")])
def test_a_failed_spectral_run_returns_its_failure(method, cause):
    from conftest import failure_of
    m = eci.models.NavierStokes2D(n=16, drag=1e300, fftw_measure=False)
    w = m.random_field()
    r = eci.solve(m, (0.0, 0.03), w, dt=0.01, method=method)
    f = failure_of(r, eci.StepSizeUnderflow)
    assert str(f).startswith(f"step 1 failed at t = 0 even with the step halved 40 times (down to dt = ")
    assert f"): {cause}; the linear damping" in str(f), str(f)
    assert f.cause == "step_failed" and f.t == 0.0 and f.component_name.startswith("mode ")
    assert r.t.tolist() == [0.0] and np.array_equal(r.y[:, 0], w)  # what it reached: the initial state
    ok = eci.solve(eci.models.NavierStokes2D(n=16, fftw_measure=False), (0.0, 0.01), dt=0.01)
    assert ok.success and ok.status == 0 and ok.failure is None


# A run that blows up stops where the CLI's stops, for every equation: status -1, NonFiniteSolution, the outputs up to
# the last good step; a run that grows its energy less than the thousandfold bound goes on. (RK4 at CFL ~50 on an
# inviscid flow: its step multiplies the energy far beyond 1e3 at once.)
@pytest.mark.parametrize("make", [lambda: eci.models.NavierStokes2D(n=32, fftw_measure=False),
                                  lambda: CHM(n=32, beta=1.0, deformation=1.0, fftw_measure=False),
                                  lambda: SQG(n=32, fftw_measure=False)], ids=["ns", "chm", "sqg"])
def test_a_blow_up_stops_the_run(make):
    from conftest import failure_of
    m = make()
    w = m.random_field(k_peak=4)
    dt = 100 * m.cfl_step(w)
    r = eci.solve(m, (0.0, 10 * dt), w, dt=dt, method="rk4", t_eval=[0.0, dt, 2 * dt])
    f = failure_of(r, eci.NonFiniteSolution)
    name = m.invariant_names[0]
    assert str(f).startswith(f"blow-up at step ") and f"{name} " in str(f) and str(f).endswith("; reduce dt"), str(f)
    assert f.cause in ("blow_up", "invariant_overflow") and f.component_name in m.invariant_names
    step = int(str(f).split()[3].rstrip(","))
    assert f.t == step * dt and r.t.tolist() == [k * dt for k in range(min(step, 3))]
    assert all(math.isfinite(v["final"]) for v in r.invariants.values())
    assert r.stats["steps"] == step and r.nfev == 4 * step, r.stats
    # the same flow at its CFL step is no blow-up (the conservative method keeps E exactly at any step)
    assert eci.solve(m, (0.0, 10 * dt), w, dt=dt, method="c-rk4", t_eval=[]).success
    assert eci.solve(m, (0.0, 3 * dt / 100), w, dt=dt / 100, method="rk4", t_eval=[]).success


# A field whose nonlinear term overflows (surface QG of energy 1e307) is refused before the run in both front ends:
# every step of it fails, and the CLI's "a smaller --dt or --cfl may pass" (Python: a failed step) sent the user after
# a step that does not exist. One below it runs.
def test_a_field_whose_rate_overflows_is_refused(cli):
    message = ("initial condition: its rate dq/dt is not finite (the nonlinear term overflows double precision): no "
               "step of any size can take it")
    assert cli_error(cli, "run", "surface-qg", "--N", "32", "--energy", "1e307", "--steps", "2", "--fftw-estimate",
                     "--fftw-wisdom", "none") == message
    m = SQG(n=32, fftw_measure=False)
    big = m.random_field(energy=1e307)
    with pytest.raises(ValueError, match=r"^initial condition: its rate dq/dt is not finite"):
        eci.solve(m, (0.0, 1e-150), big, dt=1e-152)
    assert eci.solve(m, (0.0, 2e-152), m.random_field(energy=1e300), dt=1e-152).success
