// Example: the free rigid body (Euler's equations for the angular momentum L), a model written by the user as a
// plain struct with named invariants, run by name through the registry (C-RK4, C-PC, RK4) with eci::run, whose
// report holds every invariant's drift; |L|^2 and the kinetic energy are kept to round-off.
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>

#include <eci/eci.hpp>

/// dL/dt = L x omega with omega_i = L_i / I_i. Both invariants are sums of w_i L_i^2 with
/// sum_i w_i L_i dL_i/dt = 0, the form every conservative method in eci keeps exactly.
struct free_rigid_body {
    using state_type = std::array<double, 3>;
    double I1 = 1.0, I2 = 2.0, I3 = 3.0;  // principal moments of inertia

    void operator()(const state_type& L, state_type& dLdt, double /*t*/) const {
        dLdt[0] = (1.0 / I3 - 1.0 / I2) * L[1] * L[2];
        dLdt[1] = (1.0 / I1 - 1.0 / I3) * L[2] * L[0];
        dLdt[2] = (1.0 / I2 - 1.0 / I1) * L[0] * L[1];
    }
    double momentum2(const state_type& L) const { return L[0] * L[0] + L[1] * L[1] + L[2] * L[2]; }
    double energy(const state_type& L) const { return 0.5 * (L[0] * L[0] / I1 + L[1] * L[1] / I2 + L[2] * L[2] / I3); }

    /// What eci::run monitors at every step.
    static constexpr auto invariants() {
        return std::array<eci::named_invariant<free_rigid_body>, 2>{
            {{"momentum2", &free_rigid_body::momentum2}, {"energy", &free_rigid_body::energy}}};
    }
};

int main() {
    using state = free_rigid_body::state_type;
    const free_rigid_body body;
    const state L0{1.0, 0.1, 0.9};  // precession about the axis of least inertia: L_2 and L_3 pass through zero
    const double dt = 0.05;
    const std::uint64_t steps = 100000;
    // Round-off only: a few eps per step, adding up as a random walk (see tests/numeric/test_conservation.cpp).
    const double tolerance = 4.0 * std::numeric_limits<double>::epsilon() * std::sqrt(double(steps));

    auto drift = [&](const char* method) {
        state L = L0;
        eci::solve_report report;
        // The registry builds the named method for this model (here: the conservative engine on L^2).
        eci::with_stepper<free_rigid_body>(method, [&](auto stepper) {
            report = eci::run(stepper, body, L, eci::run_span::n_steps(steps, dt));
        });
        double worst = 0.0;
        for (const eci::invariant_record& r : report.invariants) worst = std::fmax(worst, r.max_rel_drift());
        std::printf("%-6s %llu steps of %g: max relative drift of |L|^2 and energy %.2e (%llu step reductions)\n",
                    method, static_cast<unsigned long long>(report.stats.steps), dt, worst,
                    static_cast<unsigned long long>(report.stats.step_reductions));
        return report.completed() ? worst : std::numeric_limits<double>::infinity();
    };

    const double c_rk4 = drift("c-rk4");
    const double c_pc = drift("c-pc");
    const double rk4 = drift("rk4");
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
