# The spectral equations' physics against small independent NumPy references (numpy's FFT, none of eci's code):
# the right-hand side dq/dt (inversion, exact Galerkin truncation of the nonlinear term, beta term, every dissipation
# term with its power, deterministic forcing), the spectra and the fluxes Pi_E(k), Pi_Z(k), the physical
# diagnostics, the per-step budgets against RK4's stages, the stochastic forcing's mean injection against a bound
# derived from its statistics, and single Rossby waves against their closed forms. Each test is a fraction of a
# second at N = 32 or 48.
import math

import numpy as np
import pytest

import eci
from conftest import EPS, run_cli

NS = getattr(eci.models, "NavierStokes2D", None)
pytestmark = pytest.mark.skipif(NS is None, reason="built without eci::spectral (FFTW3)")

NSE, CHME, SQGE = "navier-stokes-2d", "charney-hasegawa-mima", "surface-qg"


def make(eq, n, wave=None, **kw):
    cls = {NSE: eci.models.NavierStokes2D, CHME: eci.models.CharneyHasegawaMima, SQGE: eci.models.SurfaceQG}[eq]
    return cls(n=n, **(wave or {}), **kw)


# ---- the reference -------------------------------------------------------------------------------------------------

def full_plane(m, y):
    """The retained modes y as the full N x N spectrum Q[ky, kx] in numpy's fft2 order, q(x) = sum_k Q_k e^{ik.x}:
    a mode with k_x > 0 stands for itself and its conjugate at -k (docs/turbulence.md, "The model")."""
    n = m.n
    kx, ky = m.kx.astype(int), m.ky.astype(int)
    Q = np.zeros((n, n), complex)
    Q[ky % n, kx % n] = y
    pos = kx > 0
    Q[-ky[pos] % n, -kx[pos] % n] = np.conj(y[pos])
    return Q


def wavenumbers(n):
    k = np.fft.fftfreq(n, 1.0 / n)
    KY, KX = np.meshgrid(k, k, indexing="ij")
    return KX, KY


def inversion(eq, kx, ky, F=0.0):
    """a(k) of psi_k = a(k) q_k: omega = lap psi, q = lap psi - F psi, theta = (-lap)^(1/2) psi; 0 at k = 0."""
    k2 = np.asarray(kx * kx + ky * ky, float)
    safe = np.where(k2 == 0, 1.0, k2)
    a = {NSE: -1.0 / safe, CHME: -1.0 / (safe + F), SQGE: 1.0 / np.sqrt(safe)}[eq]
    return np.where(k2 == 0, 0.0, a)


def on_grid(S, M):
    """The field of the N x N spectrum S on an M x M grid (M >= N: zero padding)."""
    n = S.shape[0]
    k = np.fft.fftfreq(n, 1.0 / n).astype(int)
    P = np.zeros((M, M), complex)
    P[np.ix_(k % M, k % M)] = S
    return np.real(np.fft.ifft2(P)) * M * M


def nonlinear_ref(m, y, eq, F=0.0):
    """-u . grad q at the retained modes, u = (-psi_y, psi_x), its products formed on a 2N grid: with |k_x|, |k_y| <=
    kmax < N/2 no product reaches another retained mode there, so this is the exact Galerkin truncation, whatever
    dealiasing eci does on its N grid."""
    n, M = m.n, 2 * m.n
    KX, KY = wavenumbers(n)
    Q = full_plane(m, y)
    psi = inversion(eq, KX, KY, F) * Q
    u, v = on_grid(-1j * KY * psi, M), on_grid(1j * KX * psi, M)
    qx, qy = on_grid(1j * KX * Q, M), on_grid(1j * KY * Q, M)
    P = np.fft.fft2(u * qx + v * qy) / (M * M)
    kx, ky = m.kx.astype(int), m.ky.astype(int)
    out = -P[ky % M, kx % M]
    out[(kx == 0) & (ky == 0)] = 0.0
    return out


def damping_ref(kx, ky, nu=0.0, hyper_nu=0.0, hyper_p=2, hypo_nu=0.0, hypo_p=1, drag=0.0):
    """r(k) of -r q: nu |k|^2 + nu_h |k|^(2p) + nu_hypo |k|^(-2p') + mu (docs/turbulence.md)."""
    k2 = np.asarray(kx * kx + ky * ky, float)
    safe = np.where(k2 == 0, 1.0, k2)
    return nu * k2 + hyper_nu * k2 ** hyper_p + drag + (hypo_nu * safe ** (-float(hypo_p)) if hypo_nu else 0.0)


def wave_ref(eq, kx, ky, beta=0.0, F=0.0):
    """c(k) of dq_k/dt = i c q_k: the beta term -beta d psi/dx = -i beta k_x a(k) q_k, so q_k ~ e^{-i omega t} with
    omega = -beta k_x / (k^2 + F)."""
    if eq != CHME:
        return np.zeros_like(kx, dtype=float)
    return -beta * kx * inversion(eq, kx, ky, F)


def weights(m):
    w = np.where(m.kx > 0, 2.0, 1.0)
    w[(m.kx == 0) & (m.ky == 0)] = 0.0
    return w


def splitmix(s):
    s = (s + 0x9E3779B97F4A7C15) & 0xFFFFFFFFFFFFFFFF
    z = ((s ^ (s >> 30)) * 0xBF58476D1CE4E5B9) & 0xFFFFFFFFFFFFFFFF
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & 0xFFFFFFFFFFFFFFFF
    return s, z ^ (z >> 31)


def anisotropic_field(m, seed):
    """A rough field, white noise whose amplitude grows across x (not isotropic, not smooth), from_physical's."""
    n = m.n
    f = np.random.default_rng(seed).standard_normal((n, n)) * np.linspace(0.2, 3.0, n)[None, :]
    return m.from_physical(f)


CASES = [
    (NSE, None, dict(nu=1e-3, hyper_nu=1e-6, hyper_p=3, hypo_nu=0.05, hypo_p=2, drag=0.1)),
    (CHME, dict(beta=7.0, deformation=2.5), dict(nu=2e-3, hyper_nu=1e-5, hyper_p=2, hypo_nu=0.1, hypo_p=1, drag=0.05)),
    (CHME, dict(beta=-3.0, deformation=0.0), dict(hyper_nu=1e-9, hyper_p=5)),
    (SQGE, None, dict(nu=1e-3, hyper_nu=1e-7, hyper_p=4, drag=0.2, hypo_nu=0.3, hypo_p=3)),
]


# ---- 1. the right-hand side -----------------------------------------------------------------------------------------

# Each term of the reference is a few transforms and products of numbers of its own size, so eci and numpy agree to
# a few eps of each term's largest value (measured up to 3.6 eps of their sum over these cases; up to 6.6 eps of
# the largest |dq/dt| over N = 8 ... 64, both transform layouts, 1 and 2 threads); 16 eps of their sum is the
# bound. A sign, a power, a factor or an aliased product is off by O(1) of its term.
@pytest.mark.parametrize("n", [32, 48])
@pytest.mark.parametrize("full", [False, True])
@pytest.mark.parametrize("case", range(len(CASES)))
def test_right_hand_side_matches_an_independent_numpy_reference(case, full, n):
    eq, wave, diss = CASES[case]
    F, beta = (wave or {}).get("deformation", 0.0), (wave or {}).get("beta", 0.0)
    forced = make(eq, n, wave, **diss, forcing="deterministic", forcing_k=5, forcing_amplitude=3.0, forcing_seed=11,
                  full_transforms=full)
    m = make(eq, n, wave, **diss, full_transforms=full)
    kx, ky = m.kx, m.ky
    Fk = forced.forcing_term  # (checked against its definition below)
    assert np.array_equal(Fk, forced(0.0, np.zeros(m.size, complex))) and not np.any(m.forcing_term)
    for y in (m.random_field(k_peak=3.0, energy=0.7, seed=3), anisotropic_field(m, n)):
        parts = [nonlinear_ref(m, y, eq, F), -damping_ref(kx, ky, **diss) * y, 1j * wave_ref(eq, kx, ky, beta, F) * y]
        ref = sum(parts)
        ref[(kx == 0) & (ky == 0)] = 0.0
        scale = sum(np.max(np.abs(p)) for p in parts)
        assert np.max(np.abs(m(0.0, y) - ref)) <= 16 * EPS * scale
        assert np.max(np.abs(forced(0.0, y) - (ref + Fk))) <= 16 * EPS * (scale + np.max(np.abs(Fk)))


# The deterministic forcing is the documented band k_f - 1/2 <= |k| < k_f + 1/2 with fixed random phases drawn from
# SplitMix64 in the half plane's row order (k_y = 0 .. kmax, -kmax .. -1; k_x = 0 .. kmax), the k_x = 0 column made
# Hermitian, each mode of modulus amplitude / sqrt(modes of the full plane): the field's rms is the amplitude.
@pytest.mark.parametrize("eq,wave", [(NSE, None), (CHME, dict(beta=5.0, deformation=1.5)), (SQGE, None)])
def test_deterministic_forcing_is_the_documented_band_and_amplitude(eq, wave):
    m = make(eq, 48, wave, forcing="deterministic", forcing_k=5.3, forcing_amplitude=0.7, forcing_seed=11)
    Fk = m.forcing_term
    assert np.array_equal(Fk, m(0.0, np.zeros(m.size, complex)))
    kmax, index = m.kmax, {(int(a), int(b)): i for i, (a, b) in enumerate(zip(m.kx, m.ky))}
    s, count, draws = 11, 0, []
    for r in range(2 * kmax + 1):
        ky = r if r <= kmax else r - (2 * kmax + 1)
        for kx in range(kmax + 1):
            k = math.hypot(kx, ky)
            if (kx, ky) == (0, 0) or not 4.8 <= k < 5.8:
                continue
            count += 1 if kx == 0 else 2
            s, z = splitmix(s)
            draws.append((kx, ky, (z >> 11) * 2.0 ** -53))
    ref = np.zeros(m.size, complex)
    for kx, ky, u in draws:
        ref[index[kx, ky]] = 0.7 / math.sqrt(count) * np.exp(2j * math.pi * u)
    for kx, ky, _ in draws:
        if kx == 0 and ky > 0:
            ref[index[0, -ky]] = np.conj(ref[index[0, ky]])
    assert np.max(np.abs(Fk - ref)) <= 4 * EPS * 0.7
    assert abs(math.sqrt(np.mean(m.to_physical(Fk) ** 2)) - 0.7) <= 64 * EPS


# ---- 2. spectra and fluxes ------------------------------------------------------------------------------------------

# E(k), Z(k): sums over the shells round(|k|) = k of 1/2 |a_k| |q_k|^2 and 1/2 |q_k|^2 (full plane), summing to E and
# Z; Pi(k) = -sum_{k' <= k} T(k'), T the nonlinear term's transfer sum w Re(conj(q) N) (times |a| for E), positive
# towards small scales; the last shell's Pi is the total transfer, zero but for round-off. Errors are relative to
# sum_k |T(k)|, the scale of every partial sum (measured up to 7.9 eps; the last Pi up to 5.3 eps of it); 16 eps.
@pytest.mark.parametrize("eq,wave", [(NSE, None), (CHME, dict(beta=5.0, deformation=1.5)), (SQGE, None)])
@pytest.mark.parametrize("n", [32, 48])
def test_spectra_and_fluxes_match_an_independent_transfer(eq, wave, n):
    m = make(eq, n, wave)
    F = (wave or {}).get("deformation", 0.0)
    a, w = np.abs(inversion(eq, m.kx, m.ky, F)), weights(m)
    shell = np.rint(np.hypot(m.kx, m.ky)).astype(int)
    for y in (m.random_field(k_peak=3.0, energy=0.7, seed=3), anisotropic_field(m, 7)):
        E, Z = m.energy_spectrum(y), m.enstrophy_spectrum(y)
        L = len(E)
        e, z = 0.5 * w * a * np.abs(y) ** 2, 0.5 * w * np.abs(y) ** 2
        assert np.max(np.abs(E - np.bincount(shell, e, minlength=L))) <= 4 * EPS * np.sum(e)
        assert np.max(np.abs(Z - np.bincount(shell, z, minlength=L))) <= 4 * EPS * np.sum(z)
        assert abs(np.sum(E) - m.energy(y)) <= 8 * EPS * m.energy(y)  # shell sums, not shell averages
        assert abs(np.sum(Z) - m.enstrophy(y)) <= 8 * EPS * m.enstrophy(y)
        T = w * np.real(np.conj(y) * nonlinear_ref(m, y, eq, F))
        TE, TZ = np.bincount(shell, a * T, minlength=L), np.bincount(shell, T, minlength=L)
        pe, pz = m.fluxes(y)
        for got, t in ((pe, TE), (pz, TZ)):
            scale = np.sum(np.abs(t))
            assert np.max(np.abs(got - (-np.cumsum(t)))) <= 16 * EPS * scale
            assert abs(got[-1]) <= 16 * EPS * scale


# The physical meaning of the diagnostics on the grid: E = 1/2 <|u|^2> + F/2 <psi^2> (Navier-Stokes, CHM) and
# 1/2 <psi theta> (SQG), Z = 1/2 <q^2>, P = 1/2 <|grad q|^2>, max|u| the grid's, to_physical q(x) = sum q_k e^{ik.x}
# with rows y; from the state by numpy's inverse FFT, each to a few eps.
@pytest.mark.parametrize("eq,wave", [(NSE, None), (CHME, dict(beta=5.0, deformation=1.5)), (SQGE, None)])
def test_diagnostics_are_the_physical_fields_means(eq, wave):
    n = 32
    m = make(eq, n, wave)
    F = (wave or {}).get("deformation", 0.0)
    y = m.random_field(k_peak=3.0, energy=0.5, seed=4)
    KX, KY = wavenumbers(n)
    Q = full_plane(m, y)
    psi = inversion(eq, KX, KY, F) * Q
    g = lambda S: np.real(np.fft.ifft2(S)) * n * n  # noqa: E731
    q, p, u, v = g(Q), g(psi), g(-1j * KY * psi), g(1j * KX * psi)
    x = 2 * np.pi * np.arange(n) / n
    assert np.max(np.abs(m.to_physical(y) - q)) <= 16 * EPS * np.max(np.abs(q))
    # mode (1, 0) alone is cos x: a row of the grid varies with x, its columns with y
    one = np.zeros(m.size, complex)
    one[(m.kx == 1) & (m.ky == 0)] = 0.5
    assert np.max(np.abs(m.to_physical(one) - np.cos(x)[None, :])) <= 16 * EPS
    E = 0.5 * np.mean(p * q) if eq == SQGE else 0.5 * np.mean(u * u + v * v) + 0.5 * F * np.mean(p * p)
    assert abs(m.energy(y) - E) <= 16 * EPS * E
    assert abs(m.enstrophy(y) - 0.5 * np.mean(q * q)) <= 16 * EPS * m.enstrophy(y)
    P = 0.5 * np.mean(g(1j * KX * Q) ** 2 + g(1j * KY * Q) ** 2)
    assert abs(m.palinstrophy(y) - P) <= 16 * EPS * P
    assert abs(m.max_velocity(y) - np.sqrt(np.max(u * u + v * v))) <= 16 * EPS * m.max_velocity(y)


# The CLI's snapshot spectrum CSV (k, E, Z, Pi_E, Pi_Z from k = 1) is the same shell sums and fluxes of the snapshot's
# own field (the HDF5 file's, taken back with from_physical: a few eps of each column's largest value, measured 1.7e-16
# to 1.4e-15), and its E(k) sums to the CSV row's energy at that step.
@pytest.mark.parametrize("eq,args,wave", [(CHME, ["--beta", 5, "--deformation", 1.5], dict(beta=5.0, deformation=1.5)),
                                          (SQGE, [], None)])
def test_the_clis_spectrum_csv_is_the_snapshots_spectra_and_fluxes(cli, tmp_path, eq, args, wave):
    h5py = pytest.importorskip("h5py")
    run_cli(cli, "run", eq, "--N", 32, *args, "--nu", 1e-3, "--forcing", "deterministic", "--steps", 4, "--dt", 0.01,
            "--snapshot-every", 2, "--snapshot-dir", tmp_path / "s", "--output", tmp_path / "o.csv", "--fftw-wisdom",
            "none", "--fftw-estimate")
    m = make(eq, 32, wave)
    field = "potential_vorticity" if eq == CHME else "buoyancy"
    with h5py.File(tmp_path / "s" / f"{field}_00000002.h5") as f:
        y = m.from_physical(np.array(f[f.attrs["field"]]))
    d = np.loadtxt(tmp_path / "s" / "spectrum_00000002.csv", delimiter=",", skiprows=1, ndmin=2)
    rows = np.loadtxt(tmp_path / "o.csv", delimiter=",", skiprows=1, ndmin=2)
    F = (wave or {}).get("deformation", 0.0)
    a, w = np.abs(inversion(eq, m.kx, m.ky, F)), weights(m)
    shell = np.rint(np.hypot(m.kx, m.ky)).astype(int)
    L = int(d[-1, 0]) + 1
    T = w * np.real(np.conj(y) * nonlinear_ref(m, y, eq, F))
    ref = [np.bincount(shell, 0.5 * w * a * np.abs(y) ** 2, minlength=L),
           np.bincount(shell, 0.5 * w * np.abs(y) ** 2, minlength=L),
           -np.cumsum(np.bincount(shell, a * T, minlength=L)), -np.cumsum(np.bincount(shell, T, minlength=L))]
    k = d[:, 0].astype(int)
    assert k[0] == 1 and np.all(np.diff(k) == 1)
    for col, r in enumerate(ref, start=1):
        assert np.max(np.abs(d[:, col] - r[k])) <= 32 * EPS * np.max(np.abs(r)), col
    assert abs(np.sum(d[:, 1]) - rows[rows[:, 0] == 2, 2][0]) <= 8 * EPS * np.sum(d[:, 1])


# ---- 3. budgets -----------------------------------------------------------------------------------------------------

def rk4_stages(m, y, eq, wave, diss, Fk, dt):
    F, beta = (wave or {}).get("deformation", 0.0), (wave or {}).get("beta", 0.0)
    lin = -damping_ref(m.kx, m.ky, **diss) + 1j * wave_ref(eq, m.kx, m.ky, beta, F)
    lin[(m.kx == 0) & (m.ky == 0)] = 0.0

    def f(x):
        return nonlinear_ref(m, x, eq, F) + lin * x + Fk

    Y2 = y + dt / 2 * f(y)
    Y3 = y + dt / 2 * f(Y2)
    return [y, Y2, Y3, y + dt * f(Y3)]


# Each C-RK4 step: E(t + dt) - E(t) (my sum over the state) = injection - dissipation as reported, and those are
# the xi tableau's tau sum_j b_j sum_k w |a| (Re(conj(Y_j) F_k), r_k |Y_j|^2) over RK4's stages Y_j from my right-hand
# side (docs/turbulence.md, "Exact budgets"); both to a few eps of E + |injection| + |dissipation| (measured 0.6-1.4
# eps and below 0.01 eps). The stochastic forcing of a step is the model's forcing_term after it.
@pytest.mark.parametrize("forcing", ["deterministic", "stochastic"])
@pytest.mark.parametrize("eq,wave", [(NSE, None), (CHME, dict(beta=5.0, deformation=1.5)), (SQGE, None)])
def test_each_steps_budget_is_the_energy_change_and_rk4s_stages(eq, wave, forcing):
    diss = dict(nu=2e-3, hyper_nu=1e-6, hyper_p=2, hypo_nu=0.05, hypo_p=1, drag=0.1)
    extra = dict(forcing_amplitude=2.0) if forcing == "deterministic" else dict(injection_rate=0.5)
    m = make(eq, 32, wave, **diss, forcing=forcing, forcing_k=4, **extra)
    a = np.abs(inversion(eq, m.kx, m.ky, (wave or {}).get("deformation", 0.0)))
    we, r = weights(m) * a, damping_ref(m.kx, m.ky, **diss)
    y = m.random_field(k_peak=3.0, energy=0.5, seed=2)
    dt = 0.5 * m.cfl_step(y)
    b = [1 / 6, 1 / 3, 1 / 3, 1 / 6]
    for _ in range(8):
        res = eci.solve(m, (0.0, dt), y, method="c-rk4", dt=dt)
        y1 = res.y[:, -1]
        Fk = m.forcing_term  # (the step's draw, for the stochastic forcing)
        if forcing == "deterministic":
            assert np.array_equal(Fk, m(0.0, np.zeros(m.size, complex)))
        Y = rk4_stages(m, y, eq, wave, diss, Fk, dt)
        for name, wt in zip(m.invariant_names, (we, weights(m))):  # E's weights w |a|, Z's w
            inj, dis = res.budget[name + "_injection"], res.budget[name + "_dissipation"]
            invariant = lambda x: 0.5 * np.sum(wt * np.abs(x) ** 2)  # noqa: E731
            scale = invariant(y) + abs(inj) + abs(dis)
            assert abs(invariant(y1) - invariant(y) - (inj - dis)) <= 8 * EPS * scale, name
            injection = dt * sum(bj * np.sum(wt * np.real(np.conj(Yj) * Fk)) for bj, Yj in zip(b, Y))
            dissipation = dt * sum(bj * np.sum(wt * r * np.abs(Yj) ** 2) for bj, Yj in zip(b, Y))
            assert abs(inj - injection) <= 8 * EPS * scale and abs(dis - dissipation) <= 8 * EPS * scale, name
        y = y1


# The stochastic forcing F_k = sigma g_k / sqrt(tau), g_k complex Gaussians with E|g|^2 = 1, one per independent mode
# j of the band (a k_x = 0 pair is one), held over the step, sigma^2 = 2 eps / sum_band w |a| = eps / sum_j c_j with
# c_j = |a_j|. Over n steps:
#  - A = tau^2/2 sum_k w |a| |F_k|^2 = tau sigma^2 sum_j c_j |g_j|^2, the forcing's own energy per step, has mean
#    tau eps and, |g|^2 being exponential (variance 1) and independent, variance (tau eps rho)^2 with
#    rho^2 = sum c_j^2 / (sum c_j)^2: its mean over n steps is tau eps within 4.5 tau eps rho / sqrt(n) (a 4.5 sigma
#    bound; rho ~ 0.25, so 1.1 % at n = 4000: a sigma or a weight off by 2 % fails).
#  - the recorded injection I = tau sum_j b_j sum_k w |a| Re(conj(Y_j) F_k) of RK4's stages Y_j is A times
#    2 sum_j b_j (coefficient of tau F in Y_j) = 1 + z/3 + z^2/12 (z = lambda tau, lambda = -r + i c the mode's
#    linear coefficient: the work of a force held over the step on a damped, rotating mode), plus
#    tau sum w |a| Re(conj(q) F), of mean 0 and variance 2 tau sigma^2 sum_j c_j^2 |q_j|^2 given the state, which
#    is summed from the run; the nonlinear term adds no mean at this order (E[conj(F_k) (J F)_k] = 0 for circular
#    g, the Jacobian J having no diagonal). So mean(I) = tau eps <Re(1 + z/3 + z^2/12)>_c within 4.5 of its
#    standard deviation, and with damping r tau = 0.25 at the band it is 8 % below tau eps, far outside that bound.
@pytest.mark.parametrize("eq,wave", [(NSE, None), (CHME, dict(beta=5.0, deformation=1.5)), (SQGE, None)])
@pytest.mark.parametrize("drag,dt", [(0.2, 0.01), (5.0, 0.05)])
def test_stochastic_forcing_injects_epsilon_on_average(eq, wave, drag, dt):
    eps_in, n = 0.5, 4000
    m = make(eq, 32, wave, drag=drag, forcing="stochastic", forcing_k=4, injection_rate=eps_in, forcing_seed=7)
    F, beta = (wave or {}).get("deformation", 0.0), (wave or {}).get("beta", 0.0)
    kx, ky = m.kx, m.ky
    a, w = np.abs(inversion(eq, kx, ky, F)), weights(m)
    k = np.hypot(kx, ky)
    band = (k >= 3.5) & (k < 4.5)
    indep = band & ((kx > 0) | (ky > 0))
    c = a[indep]
    sigma2 = eps_in / np.sum(c)
    rho = math.sqrt(np.sum(c ** 2)) / np.sum(c)
    z = (-damping_ref(kx, ky, drag=drag) + 1j * wave_ref(eq, kx, ky, beta, F))[indep] * dt
    expected = dt * eps_in * np.sum(c * np.real(1 + z / 3 + z * z / 12)) / np.sum(c)
    y = np.zeros(m.size, complex)
    A, inj, var_m = 0.0, 0.0, 0.0
    for _ in range(n):
        var_m += 2 * dt * sigma2 * np.sum(c ** 2 * np.abs(y[indep]) ** 2)
        r = eci.solve(m, (0.0, dt), y, method="c-rk4", dt=dt)
        Fk = m.forcing_term
        assert np.all(Fk[~band] == 0)
        A += 0.5 * dt * dt * np.sum(w * a * np.abs(Fk) ** 2)
        inj += r.budget["energy_injection"]
        y = r.y[:, -1]
    assert abs(A / n - dt * eps_in) <= 4.5 * dt * eps_in * rho / math.sqrt(n)
    sd = math.sqrt(n * (dt * eps_in * rho) ** 2 + var_m) / n
    assert abs(inj / n - expected) <= 4.5 * sd
    if drag * dt > 0.1:  # the bias is real: mean(I) is not tau eps
        assert abs(inj / n - dt * eps_in) > 4.5 * sd


# ---- 4. linear exact solutions --------------------------------------------------------------------------------------

def amplification(method, z, r, dt):
    """One step's factor on a mode dq/dt = lambda q (z = lambda dt, r = -Re lambda): RK4's polynomial; C-RK4's
    conditioned update, RK4's step rescaled to the modulus that the xi tableau gives, |q|^2 (1 - 2 r dt sum_j b_j
    |Y_j|^2) over RK4's stages Y_j; C-PC's, Heun's phase with the modulus of its xi tableau (b = 1/2, 1/2)."""
    R = 1 + z + z * z / 2 + z ** 3 / 6 + z ** 4 / 24
    if method == "rk4":
        return R
    if method == "c-rk4":
        Y = np.array([1, 1 + z / 2, 1 + z / 2 + z * z / 4, 1 + z + z * z / 2 + z ** 3 / 4])
        return math.sqrt(1 - 2 * r * dt * np.sum(np.array([1, 2, 2, 1]) / 6 * np.abs(Y) ** 2)) * R / abs(R)
    H = 1 + z + z * z / 2
    return math.sqrt(1 - r * dt * (1 + abs(1 + z) ** 2)) * H / abs(H)


WAVES = [
    (CHME, dict(beta=6.0, deformation=1.7), dict(), (3, -2)),
    (CHME, dict(beta=6.0, deformation=1.7), dict(nu=0.02, hyper_nu=1e-4, hyper_p=2, hypo_nu=0.3, hypo_p=1, drag=0.1),
     (1, 4)),
    (CHME, dict(beta=-4.0, deformation=0.0), dict(hyper_nu=1e-6, hyper_p=3, hypo_nu=0.5, hypo_p=2), (2, 1)),
    (CHME, dict(beta=3.0, deformation=0.5), dict(nu=0.01), (0, 3)),  # k_x = 0: no wave, decay alone
    (SQGE, None, dict(nu=0.01, drag=0.2, hyper_nu=1e-5, hyper_p=2), (2, -3)),
]


# A single Rossby wave q_k e^{ik.x} + c.c. is an exact nonlinear solution (psi is a multiple of q, J(psi, q) = 0),
# q_k(t) = q_k(0) e^{(-i omega - r) t} with omega = -beta k_x / (k^2 + F) and r the damping at |k|. Each method
# multiplies the mode by its amplification factor (above) every step, to round-off: 4 eps a step of the mode's
# modulus (measured <= 0.75 eps a step over 400-800 steps); every other mode stays round-off (the nonlinear term of
# one |k| is a few eps). Against the closed form e^{lambda t} at t = 20 the error is the method's: halving dt divides
# it by 2^p within 10 % (p = 4 for RK4 and C-RK4, 2 for C-PC).
@pytest.mark.parametrize("method,order", [("rk4", 4), ("c-rk4", 4), ("c-pc", 2)])
@pytest.mark.parametrize("case", range(len(WAVES)))
def test_a_single_rossby_wave_follows_its_closed_form(case, method, order):
    eq, wave, diss, (a, b) = WAVES[case]
    m = make(eq, 32, wave, **diss)
    F, beta = (wave or {}).get("deformation", 0.0), (wave or {}).get("beta", 0.0)
    q0 = np.zeros(m.size, complex)
    i = np.flatnonzero((m.kx == a) & (m.ky == b))[0]
    q0[i] = 0.4 - 0.3j
    if a == 0:
        q0[(m.kx == 0) & (m.ky == -b)] = np.conj(q0[i])
    r = float(damping_ref(np.array(a), np.array(b), **diss))
    omega = beta * a / (a * a + b * b + F) * -1.0
    lam = -1j * omega - r
    assert lam == pytest.approx(-r + 1j * float(wave_ref(eq, np.array(a), np.array(b), beta, F)), rel=1e-15)
    errors = []
    for dt in (0.05, 0.025):
        n = int(round(20.0 / dt))
        t = np.arange(n + 1) * dt
        res = eci.solve(m, (0.0, n * dt), q0, method=method, dt=dt, t_eval=t)
        closed = q0[i] * amplification(method, lam * dt, r, dt) ** np.arange(n + 1)
        assert np.max(np.abs(res.y[i] - closed) / np.abs(closed)) <= 4 * n * EPS
        others = np.delete(res.y, np.flatnonzero(q0), axis=0)
        assert np.max(np.abs(others)) <= 64 * EPS * abs(q0[i])
        exact = q0[i] * np.exp(lam * t)
        errors.append(np.max(np.abs(res.y[i] - exact) / np.abs(exact)))
    if omega != 0.0:  # (a wave; decay alone is also checked, but its error can be too small to measure an order)
        assert 0.9 * 2 ** order <= errors[0] / errors[1] <= 1.1 * 2 ** order, errors


# taylor_green's q = 2U sin x sin y is the modes (+-1, +-1), one |k|: with beta both Rossby waves of k_x = 1 have
# the phase speed omega / k_x = -beta / (2 + F), so the pattern travels west rigidly, q = 2U sin(x + beta t/(2 + F))
# sin y (it is no standing wave), to the RK4 error of a phase beta dt / (2 + F) per step.
def test_taylor_green_with_beta_travels_west_at_the_rossby_phase_speed():
    U, beta, F, dt, n = 0.5, 4.0, 1.0, 0.01, 300
    m = eci.models.CharneyHasegawaMima(n=32, beta=beta, deformation=F)
    y0 = m.taylor_green(U)
    x = 2 * np.pi * np.arange(32) / 32
    X, Y = np.meshgrid(x, x)
    assert np.max(np.abs(m.to_physical(y0) - 2 * U * np.sin(X) * np.sin(Y))) <= 16 * EPS
    r = eci.solve(m, (0.0, n * dt), y0, method="c-rk4", dt=dt, t_eval=[n * dt])
    T, phase = n * dt, beta * dt / (2 + F)
    q = m.to_physical(r.y[:, -1])
    assert np.max(np.abs(q - 2 * U * np.sin(X + beta * T / (2 + F)) * np.sin(Y))) <= 2 * U * n * phase ** 5 / 120 * 2


# ---- 5. what a user would be surprised by ---------------------------------------------------------------------------

# A stochastic model's right-hand side outside eci's steps has no forcing of its own: the forcing is drawn by each
# step of eci.solve and held over it. model(t, y) added F = 0 before any solve and the last step's draw after one, so
# SciPy's solve_ivp(model, ...) ran unforced (or with one draw held for the whole run, its injection growing like
# t^2), silently; it is refused, and forcing_term gives the last step's draw.
@pytest.mark.parametrize("eq", [NSE, CHME, SQGE])
def test_a_stochastic_models_right_hand_side_is_refused_outside_eci_solve(eq):
    scipy_integrate = pytest.importorskip("scipy.integrate")
    m = make(eq, 16, forcing="stochastic", injection_rate=0.5)
    y = m.random_field(k_peak=2.0, energy=0.5, seed=1)
    with pytest.raises(ValueError, match=r"\(t, y\): the stochastic forcing is white in time"):
        m(0.0, y)
    with pytest.raises(ValueError, match="white in time"):
        scipy_integrate.solve_ivp(m, (0.0, 0.1), y)
    with pytest.raises(ValueError, match="white in time"):
        eci.solve(lambda t, x: m(t, x), (0.0, 0.1), y, method="rk4", dt=0.01)
    assert not np.any(m.forcing_term)  # nothing drawn yet
    r = eci.solve(m, (0.0, 0.01), y, method="c-rk4", dt=0.01)  # eci.solve draws it
    assert r.success and r.budget["energy_injection"] != 0.0 and np.any(m.forcing_term)
    assert not np.any(make(eq, 16).forcing_term)  # unforced: zero


# Any superposition of Rossby waves of one |k| is an exact nonlinear solution (q = -(k^2 + F) psi pointwise, so J(psi,
# q) = 0) at any amplitude, each wave at its own omega: at amplitudes 10^-3 to 10^3, the right-hand side is the linear
# one to 16 eps of the largest linear term |lambda q| plus the scale of the products that cancel, |k| max|u| max|q| on
# the grid (measured 0.05-0.4 eps of their sum; at amplitude 10^3 the products are 5 10^4 times the linear term); and
# 200 RK4 steps follow R(z_k)^n per mode to 4 eps a step plus that round-off. (At amplitude 10^3 the waves' own
# instability would grow the round-off by e^(k |u| t), so the run is at 10^-3 and 1.)
@pytest.mark.parametrize("amplitude", [1e-3, 1.0, 1e3])
def test_rossby_waves_of_one_wavenumber_superpose_exactly(amplitude):
    beta, F, nu = 6.0, 0.7, 0.01
    m = eci.models.CharneyHasegawaMima(n=32, beta=beta, deformation=F, nu=nu)
    rng = np.random.default_rng(3)
    q0 = np.zeros(m.size, complex)
    for kx, ky in [(3, 4), (5, 0), (4, -3), (3, -4), (0, 5)]:  # |k| = 5
        i = np.flatnonzero((m.kx == kx) & (m.ky == ky))[0]
        q0[i] = amplitude * np.exp(2j * np.pi * rng.random())
        if kx == 0:
            q0[(m.kx == 0) & (m.ky == -ky)] = np.conj(q0[i])
    lam = -damping_ref(m.kx, m.ky, nu=nu) + 1j * wave_ref(CHME, m.kx, m.ky, beta, F)
    products = 5.0 * m.max_velocity(q0) * np.max(np.abs(m.to_physical(q0)))
    assert np.max(np.abs(m(0.0, q0) - lam * q0)) <= 16 * EPS * (np.max(np.abs(lam * q0)) + products)
    if amplitude > 1.0:
        return
    dt, n = 0.02, 200
    r = eci.solve(m, (0.0, n * dt), q0, method="rk4", dt=dt, t_eval=[n * dt])
    z = lam * dt
    closed = q0 * (1 + z + z * z / 2 + z ** 3 / 6 + z ** 4 / 24) ** n
    assert np.max(np.abs(r.y[:, -1] - closed)) <= n * (4 * EPS * np.max(np.abs(closed)) + 16 * EPS * dt * products)


# taylor_green(U) (--ic taylor-green, --vortex-peak U) is q = 2U sin x sin y for every equation, so U is the peak
# velocity of Navier-Stokes only: psi = -q/(2 + F) gives 2U/(2 + F) for CHM, psi = q/sqrt(2) gives sqrt(2) U for SQG
# (as the help and docs now say; they called U the velocity of every equation).
@pytest.mark.parametrize("eq,wave,peak", [(NSE, None, 1.0), (CHME, dict(deformation=2.5), 2.0 / 4.5),
                                          (SQGE, None, math.sqrt(2.0))])
def test_taylor_greens_u_is_the_peak_velocity_of_navier_stokes_alone(eq, wave, peak):
    m = make(eq, 32, wave)
    assert abs(m.max_velocity(m.taylor_green(0.75)) - 0.75 * peak) <= 8 * EPS * peak
