// 2-D turbulence with eci::spectral: an inviscid truncated-Euler run keeps energy and enstrophy to round-off with
// C-RK4, then a forced, dissipative run closes its energy budget step by step. Exits non-zero if either fails.
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>

#include <eci/eci.hpp>
#include <eci/spectral/step.hpp>

int main() {
    using state = eci::navier_stokes_2d::state_type;
    constexpr double eps = std::numeric_limits<double>::epsilon();

    // Inviscid: N = 64, a random field peaked at k = 4, 200 steps at CFL 0.5.
    eci::ns2d_params p;
    p.n = 64;
    p.measure = false;  // FFTW_ESTIMATE: no planning time for a short run
    eci::navier_stokes_2d euler(p);
    state w = euler.random_field(4.0, 0.5, 42);
    const double dt = 0.5 * (2.0 * std::numbers::pi / p.n) / euler.max_velocity(w);
    const double e0 = euler.energy(w), z0 = euler.enstrophy(w);
    eci::c_rk4<state> stepper;
    eci::ns2d_budget budget;
    eci::run_stats stats;
    for (int i = 0; i < 200; ++i) eci::ns2d_step(stepper, euler, w, i * dt, dt, budget, stats);
    const double de = std::abs(euler.energy(w) - e0) / e0, dz = std::abs(euler.enstrophy(w) - z0) / z0;
    std::printf("inviscid: relative change of E %.2e, of Z %.2e after 200 steps (%llu halved)\n", de, dz,
                (unsigned long long)stats.step_reductions);

    // Forced (white-in-time band at k = 4) with viscosity and drag: E(t) - E(0) = injection - dissipation.
    p.nu = 1e-3;
    p.drag = 0.05;
    p.forcing = eci::ns2d_forcing::stochastic;
    p.injection_rate = 0.1;
    eci::navier_stokes_2d forced(p);
    state v = forced.random_field(4.0, 0.5, 7);
    const double f0 = forced.energy(v);
    eci::ns2d_budget total;
    for (int i = 0; i < 200; ++i) eci::ns2d_step(stepper, forced, v, i * dt, dt, total, stats);
    const double residual = forced.energy(v) - f0 - (total.energy_injection - total.energy_dissipation);
    std::printf("forced: E %.6f -> %.6f, injected %.6f, dissipated %.6f, budget residual %.2e\n", f0,
                forced.energy(v), total.energy_injection, total.energy_dissipation, residual);

    // Round-off bounds: a few eps per step, random-walk over 200 steps.
    const double tol = 16.0 * eps * std::sqrt(200.0);
    return de <= tol && dz <= tol && std::abs(residual) <= tol * forced.energy(v) ? 0 : 1;
}
