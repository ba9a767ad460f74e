// Example: the free rigid body (Euler's equations for the angular momentum L), a system written by the user as a
// plain lambda f(x, dxdt, t), integrated by C-RK4 and C-PC; |L|^2 and the kinetic energy are kept to round-off.
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>

#include <eci/eci.hpp>

int main() {
    using state = std::array<double, 3>;
    const double I1 = 1.0, I2 = 2.0, I3 = 3.0;  // principal moments of inertia

    // dL/dt = L x omega with omega_i = L_i / I_i. Both invariants are sums of w_i L_i^2 with
    // sum_i w_i L_i dL_i/dt = 0, the form every conservative method in eci keeps exactly.
    auto euler_top = [&](const state& L, state& dLdt, double /*t*/) {
        dLdt[0] = (1.0 / I3 - 1.0 / I2) * L[1] * L[2];
        dLdt[1] = (1.0 / I1 - 1.0 / I3) * L[2] * L[0];
        dLdt[2] = (1.0 / I2 - 1.0 / I1) * L[0] * L[1];
    };
    auto momentum2 = [](const state& L) { return L[0] * L[0] + L[1] * L[1] + L[2] * L[2]; };
    auto energy = [&](const state& L) { return 0.5 * (L[0] * L[0] / I1 + L[1] * L[1] / I2 + L[2] * L[2] / I3); };

    const state L0{1.0, 0.1, 0.9};  // precession about the axis of least inertia: L_2 and L_3 pass through zero
    const double dt = 0.05;
    const std::uint64_t steps = 100000;
    // Round-off only: a few eps per step, adding up as a random walk (see tests/numeric/test_conservation.cpp).
    const double tolerance = 4.0 * std::numeric_limits<double>::epsilon() * std::sqrt(double(steps));

    auto drift = [&](auto stepper, const char* name) {
        state L = L0;
        double worst = 0.0;
        auto watch = [&](const state& s, double, std::uint64_t) {
            worst = std::fmax(worst, std::fabs(momentum2(s) / momentum2(L0) - 1.0));
            worst = std::fmax(worst, std::fabs(energy(s) / energy(L0) - 1.0));
        };
        const eci::run_stats stats = eci::integrate_n_steps(stepper, euler_top, L, 0.0, dt, steps, watch);
        std::printf("%-6s %llu steps of %g: max relative drift of |L|^2 and energy %.2e (%llu step reductions)\n", name,
                    static_cast<unsigned long long>(stats.steps), dt, worst,
                    static_cast<unsigned long long>(stats.step_reductions));
        return worst;
    };

    const double c_rk4 = drift(eci::c_rk4<state>{}, "c-rk4");
    const double c_pc = drift(eci::c_pc<state>{}, "c-pc");
    const double rk4 = drift(eci::rk4<state>{}, "rk4");
    std::printf("tolerance (4 eps sqrt(steps)) %.2e\n", tolerance);

    // Non-zero exit if conservation failed, or if the comparison did not show RK4 drifting beyond it.
    if (!(c_rk4 <= tolerance) || !(c_pc <= tolerance)) {
        std::fprintf(stderr, "rigid_body: a conservative method drifted beyond round-off\n");
        return 1;
    }
    if (!(rk4 > tolerance)) {
        std::fprintf(stderr, "rigid_body: RK4 kept the invariants too; the example shows nothing\n");
        return 1;
    }
    return 0;
}
