// A user's program on the installed eci::spectral: 200 inviscid C-RK4 steps of 2-D turbulence at N = 32 and CFL 0.5.
// Exits non-zero if energy or enstrophy drift beyond round-off.
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>

#include <eci/eci.hpp>
#include <eci/spectral/step.hpp>

int main() {
    eci::ns2d_params p;
    p.n = 32;
    p.measure = false;
    eci::navier_stokes_2d model(p);
    auto w = model.random_field(3.0, 0.5, 1);
    const double dt = 0.5 * (2.0 * std::numbers::pi / p.n) / model.max_velocity(w);
    const double e0 = model.energy(w), z0 = model.enstrophy(w);
    eci::c_rk4<eci::navier_stokes_2d::state_type> stepper;
    eci::ns2d_budget budget;
    eci::run_stats stats;
    const int steps = 200;
    for (int i = 0; i < steps; ++i) eci::ns2d_step(stepper, model, w, i * dt, dt, budget, stats);
    // Each step rounds every sum once: a random walk of about eps sqrt(steps) relative; 8x margin.
    const double bound = 8.0 * std::numeric_limits<double>::epsilon() * std::sqrt(double(steps));
    const double de = std::abs(model.energy(w) - e0) / e0, dz = std::abs(model.enstrophy(w) - z0) / z0;
    std::printf("installed eci::spectral: %d C-RK4 steps, relative drift E %.3g, Z %.3g (bound %.3g)\n", steps, de, dz,
                bound);
    return de <= bound && dz <= bound ? 0 : 1;
}
