// Tests of the pseudo-spectral 2-D Navier-Stokes model: half-plane weights against brute-force full-plane sums,
// exact dealiasing, the Taylor-Green decay, conservation, order of convergence and the exact discrete budget.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdio>
#include <cstdint>
#include <limits>
#include <numbers>
#include <vector>

#include <eci/eci.hpp>
#include <eci/models/navier_stokes_2d.hpp>

namespace {

using eci::navier_stokes_2d;
using state = navier_stokes_2d::state_type;
constexpr double eps = std::numeric_limits<double>::epsilon();

eci::ns2d_params small(int n) {
    eci::ns2d_params p;
    p.n = n;
    p.measure = false;  // FFTW_ESTIMATE: tests need no planning time, and plans identical from run to run
    return p;
}

// A random real field on the grid, every value uniform in [-1, 1].
std::vector<double> random_grid(int n, std::uint64_t seed) {
    std::vector<double> f(std::size_t(n) * std::size_t(n));
    std::uint64_t s = seed;
    for (double& v : f) {
        s = s * 6364136223846793005ull + 1442695040888963407ull;
        v = double(s >> 11) * 0x1.0p-53 * 2.0 - 1.0;
    }
    return f;
}

// sum_k w_k Re(conj(a_k) b_k) over the stored modes, weights w_k times `per_mode(i)`; and its magnitude scale
// sqrt(sum w |a|^2 f) sqrt(sum w |b|^2 f) (Cauchy-Schwarz bounds the sum by it).
template <class F>
std::pair<double, double> weighted_dot(const navier_stokes_2d& m, const state& a, const state& b, F per_mode) {
    double dot = 0.0, na = 0.0, nb = 0.0;
    for (std::size_t i = 0; i < m.size(); ++i) {
        const double w = m.weights()[i] * per_mode(i);
        dot += w * (a[i].real() * b[i].real() + a[i].imag() * b[i].imag());
        na += w * std::norm(a[i]);
        nb += w * std::norm(b[i]);
    }
    return {dot, std::sqrt(na * nb)};
}

double k2_of(const navier_stokes_2d& m, std::size_t i) { return double(m.kx(i)) * m.kx(i) + double(m.ky(i)) * m.ky(i); }

// The half plane's weights (2 for a mode standing for itself and its unstored conjugate, 1 on the k_x = 0 column)
// reproduce the sums over the full plane, computed by a brute-force 2-D DFT of a random real field.
TEST(NavierStokes2d, HalfPlaneWeightsReproduceFullPlaneSums) {
    for (int n : {8, 12, 18}) {
        navier_stokes_2d m(small(n));
        const auto f = random_grid(n, 7 + std::uint64_t(n));
        const state w = m.from_physical(f);
        double z_full = 0.0, e_full = 0.0, p_full = 0.0, count = 0.0;
        for (int ky = -n / 2 + 1; ky <= n / 2; ++ky)
            for (int kx = -n / 2 + 1; kx <= n / 2; ++kx) {
                if ((kx == 0 && ky == 0) || std::abs(kx) > m.kmax() || std::abs(ky) > m.kmax()) continue;
                std::complex<double> c{};
                for (int j = 0; j < n; ++j)
                    for (int i = 0; i < n; ++i)
                        c += f[std::size_t(j * n + i)] *
                             std::polar(1.0, -2.0 * std::numbers::pi * double(kx * i + ky * j) / n);
                c /= double(n * n);
                const double k2 = double(kx * kx + ky * ky);
                z_full += 0.5 * std::norm(c);
                e_full += 0.5 * std::norm(c) / k2;
                p_full += 0.5 * std::norm(c) * k2;
                count += 1.0;
            }
        double weight_sum = 0.0;
        for (double v : m.weights()) weight_sum += v;
        EXPECT_EQ(weight_sum, count) << "n = " << n;
        EXPECT_EQ(count, std::pow(2 * m.kmax() + 1, 2) - 1) << "n = " << n;
        // Each brute-force coefficient sums n^2 terms, each rounded once: relative error below n^2 eps.
        const double tol = double(n * n) * eps;
        EXPECT_NEAR(m.enstrophy(w), z_full, tol * z_full) << "n = " << n;
        EXPECT_NEAR(m.energy(w), e_full, tol * e_full) << "n = " << n;
        EXPECT_NEAR(m.palinstrophy(w), p_full, tol * p_full) << "n = " << n;
    }
}

// The stored modes on the k_x = 0 column are exact conjugate pairs, and the truncated modes and k = 0 are zero.
TEST(NavierStokes2d, StateIsHermitianAndTruncated) {
    navier_stokes_2d m(small(24));
    const state w = m.random_field(4.0, 0.5, 3);
    const std::size_t nc = std::size_t(m.columns());
    for (int row = 1; row < m.n() / 2; ++row)
        EXPECT_EQ(w[std::size_t(row) * nc], std::conj(w[std::size_t(m.n() - row) * nc]));
    for (std::size_t i = 0; i < m.size(); ++i)
        if (!m.retained(i)) {
            EXPECT_EQ(w[i], std::complex<double>{}) << i;
        }
    state nl;
    m.nonlinear(w, nl);
    for (int row = 1; row < m.n() / 2; ++row)
        EXPECT_EQ(nl[std::size_t(row) * nc], std::conj(nl[std::size_t(m.n() - row) * nc]));
}

// Dealiasing is exact: for random band-limited fields, sum w_k Re(conj(omega_k) N_k) vanishes to round-off for
// w = 1 (enstrophy) and w = 1/|k|^2 (energy), relative to the Cauchy-Schwarz scale of the sum.
TEST(NavierStokes2d, DealiasedNonlinearTermConservesEnergyAndEnstrophy) {
    for (int n : {16, 32, 64, 128}) {
        navier_stokes_2d m(small(n));
        for (std::uint64_t seed : {1u, 2u, 3u}) {
            // a peak at kmax / 2 fills the whole retained square with energetic modes
            const state w = m.random_field(0.5 * m.kmax(), 1.0, seed);
            state nl;
            m.nonlinear(w, nl);
            const auto [z, z_scale] = weighted_dot(m, w, nl, [](std::size_t) { return 1.0; });
            const auto [e, e_scale] = weighted_dot(m, w, nl, [&](std::size_t i) { return m.retained(i) ? 1.0 / k2_of(m, i) : 0.0; });
            ASSERT_GT(z_scale, 0.0);
            // N_k carries the transforms' rounding, normwise about eps log2(n^2) relative; 8 log2(n) eps has
            // margin for the pointwise products and the weighted sum itself.
            const double tol = 8.0 * std::log2(double(n)) * eps;
            std::printf("n %d seed %d: |sum|/scale = %.2f eps (Z), %.2f eps (E)\n", n, int(seed),
                        std::abs(z) / z_scale / eps, std::abs(e) / e_scale / eps);
            EXPECT_LE(std::abs(z), tol * z_scale) << "n = " << n << " seed " << seed;
            EXPECT_LE(std::abs(e), tol * e_scale) << "n = " << n << " seed " << seed;
        }
    }
}

// A control for the test above: paired with another field, the same sum is far from zero, so the identity is a
// property of the nonlinear term, not of the sums.
TEST(NavierStokes2d, ConservationIdentityIsNotVacuous) {
    navier_stokes_2d m(small(32));
    const state w = m.random_field(5.0, 1.0, 1), v = m.random_field(5.0, 1.0, 2);
    state nl;
    m.nonlinear(w, nl);
    const auto [z, scale] = weighted_dot(m, v, nl, [](std::size_t) { return 1.0; });
    EXPECT_GT(std::abs(z), 1e-3 * scale);
}

// The Taylor-Green vortex is a steady Euler flow (its nonlinear term vanishes), so with viscosity the state decays
// as exp(-2 nu t) exactly; C-RK4 reproduces it to 1e-12.
TEST(NavierStokes2d, TaylorGreenDecaysAsExpMinus2NuT) {
    auto p = small(16);
    p.nu = 0.05;
    navier_stokes_2d m(p);
    const state w0 = m.taylor_green(1.0);
    state w = w0, nl;
    m.nonlinear(w0, nl);
    double nl_max = 0.0;
    for (const auto& v : nl) nl_max = std::max(nl_max, std::abs(v));
    EXPECT_LE(nl_max, 16.0 * eps);
    EXPECT_NEAR(m.max_velocity(w0), 1.0, 16.0 * eps);
    eci::c_rk4<state> st;
    eci::ns2d_budget b;
    eci::run_stats stats;
    const double dt = 0.01;
    const int steps = 1000;
    for (int i = 0; i < steps; ++i) eci::ns2d_step(st, m, w, i * dt, dt, b, stats);
    const double decay = std::exp(-2.0 * p.nu * steps * dt);
    double worst = 0.0;
    for (std::size_t i = 0; i < m.size(); ++i)
        if (w0[i] != std::complex<double>{}) worst = std::max(worst, std::abs(w[i] - decay * w0[i]) / std::abs(w0[i]));
    EXPECT_LE(worst, 1e-12);
    EXPECT_EQ(stats.step_reductions, 0u);
}

}  // namespace
