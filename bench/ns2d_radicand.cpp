// How often the conservative engines meet a negative radicand on 2-D turbulence at the step a user picks (CFL 0.5):
// halved steps per step, and E and Z drift of the inviscid runs. Usage: eci_bench_ns2d_radicand N STEPS [threads]
#include <chrono>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <numbers>
#include <string>

#include <eci/eci.hpp>
#include <eci/spectral/step.hpp>

namespace {

using state = eci::navier_stokes_2d::state_type;

template <class St>
void measure(const char* method, const char* label, const eci::ns2d_params& p, int steps) {
    eci::navier_stokes_2d m(p);
    state w = m.random_field(p.n / 16.0, 0.5, 1);
    const double dt = 0.5 * (2.0 * std::numbers::pi / p.n) / m.max_velocity(w);  // CFL 0.5
    St st;  // ns2d_step hands the model's invariant weights to the stepper (the negative-radicand remedy needs them)
    eci::run_stats stats;
    eci::ns2d_budget b;
    const double e0 = m.energy(w), z0 = m.enstrophy(w);
    double de = 0.0, dz = 0.0, budget_e = 0.0, budget_z = 0.0;
    const auto start = std::chrono::steady_clock::now();
    for (int i = 0; i < steps; ++i) {
        const double e1 = m.energy(w), z1 = m.enstrophy(w);
        eci::ns2d_budget bs;
        eci::ns2d_step(st, m, w, i * dt, dt, bs, stats);
        const double e2 = m.energy(w), z2 = m.enstrophy(w);
        budget_e = std::max(budget_e, std::abs(e2 - e1 - (bs.energy_injection - bs.energy_dissipation)) / e2);
        budget_z = std::max(budget_z, std::abs(z2 - z1 - (bs.enstrophy_injection - bs.enstrophy_dissipation)) / z2);
        de = std::max(de, std::abs(e2 - e0) / e0);
        dz = std::max(dz, std::abs(z2 - z0) / z0);
    }
    const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::uint64_t remedied = 0, components = 0;
    if constexpr (requires { st.remedy_statistics(); }) {
        remedied = st.remedy_statistics().remedied_steps;
        components = st.remedy_statistics().components_remedied;
    }
    std::printf("ns2d-radicand N=%d case=%s method=%s steps=%d dt=%.4g halvings=%" PRIu64
                " halvings_per_step=%.3f remedied_steps=%" PRIu64 " components_remedied=%" PRIu64
                " max_rel_dE=%.3g max_rel_dZ=%.3g budget_residual_E=%.3g budget_residual_Z=%.3g seconds=%.2f\n",
                p.n, label, method, steps, dt, stats.step_reductions, double(stats.step_reductions) / steps, remedied,
                components, de, dz, budget_e, budget_z, secs);
}

}  // namespace

int main(int argc, char** argv) {
    if (argc < 3) {
        std::fprintf(stderr, "usage: %s N STEPS [threads]\n", argv[0]);
        return 2;
    }
    eci::ns2d_params p;
    p.n = std::atoi(argv[1]);
    const int steps = std::atoi(argv[2]);
    p.threads = argc > 3 ? std::atoi(argv[3]) : 1;
    p.measure = false;
    // decaying, inviscid: E and Z must stay to round-off
    measure<eci::c_pc<state>>("c-pc", "inviscid", p, steps);
    measure<eci::c_rk4<state>>("c-rk4", "inviscid", p, steps);
    // forced (stochastic band at k = 4), hyperviscous and with drag: the budget must close
    p.hyper_nu = std::pow(2.0 / p.n, 4);  // damps the last retained shells at a rate ~ 1e-3..1 per unit time
    p.hyper_p = 2;
    p.drag = 0.05;
    p.forcing = eci::ns2d_forcing::stochastic;
    p.injection_rate = 0.1;
    measure<eci::c_pc<state>>("c-pc", "forced", p, steps);
    measure<eci::c_rk4<state>>("c-rk4", "forced", p, steps);
}
