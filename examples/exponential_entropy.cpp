// Example: a user's own system with a non-quadratic invariant, ARKODE's u' = -e^v, v' = e^u with e^u + e^v kept,
// three ways: a user-written transform xi = (e^u, e^v) for eci's C-RK4, relaxation RK4 and projection from lambdas.
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>

#include <eci/eci.hpp>
#include <eci/invariants.hpp>
#include <eci/steppers/projection.hpp>
#include <eci/steppers/relaxation_rk.hpp>

using state = std::array<double, 2>;

// The transform in which the invariant is a sum: xi = (e^u, e^v), d xi / dt = (-e^(u+v), e^(u+v)), exact negatives.
struct exp_transform {
    using state_type = state;
    using xi_type = state;
    void to_xi(const state& s, state& xi) const { xi = {std::exp(s[0]), std::exp(s[1])}; }
    void xi_rate(const state& s, const state& /*dsdt*/, state& rate) const {
        const double r = std::exp(s[0] + s[1]);
        rate = {-r, r};
    }
    // The inverse; a non-positive xi (a step too large) fails the step and the driver halves it.
    eci::step_result from_xi(const state& xi, const state& /*hint*/, state& s, eci::solver_stats&) const {
        if (!(xi[0] > 0.0) || !(xi[1] > 0.0)) return eci::step_result::failure(xi[0] > 0.0 ? 1 : 0);
        s = {std::log(xi[0]), std::log(xi[1])};
        return eci::step_result::success();
    }
};

int main() {
    auto f = [](const state& s, state& d, double) { d = {-std::exp(s[1]), std::exp(s[0])}; };
    auto entropy = [](const state& s) { return std::exp(s[0]) + std::exp(s[1]); };
    // The same invariant as relaxation and projection need it: value and gradient.
    const auto invariant = eci::make_invariants<state>(
        1, [&](const state& s, std::size_t) { return entropy(s); },
        [](const state& s, std::size_t, state& g) { g = {std::exp(s[0]), std::exp(s[1])}; });

    const state s0{1.0, 0.5};
    const double dt = 0.01;
    const std::uint64_t steps = 500;  // to t = 5
    // Round-off only: a few eps of the entropy (~4.4) per step, adding up as a random walk.
    const double tolerance = 8.0 * std::numeric_limits<double>::epsilon() * entropy(s0) * std::sqrt(double(steps));

    auto drift = [&](auto stepper, const char* name) {
        state s = s0;
        double worst = 0.0;
        auto watch = [&](const state& x, double, std::uint64_t) {
            worst = std::fmax(worst, std::fabs(entropy(x) - entropy(s0)));
        };
        const eci::run_stats r = eci::integrate_n_steps(stepper, f, s, 0.0, dt, steps, watch);
        std::printf("%-16s u(5) = %.12f, max |change of e^u + e^v| %.2e, %llu solver iterations\n", name, s[0], worst,
                    static_cast<unsigned long long>(r.solver.iterations));
        return worst;
    };

    const double transformed = drift(eci::transformed_rk4<exp_transform>{}, "C-RK4 (transform)");
    const double relaxed = drift(eci::rrk4<state, decltype(invariant)>(invariant), "RRK4");
    const double projected = drift(eci::orthogonal_projection<eci::rk4<state>, state, decltype(invariant)>(invariant),
                                   "RK4 + projection");
    const double plain = drift(eci::rk4<state>{}, "RK4");
    std::printf("tolerance (8 eps |I| sqrt(steps)) %.2e\n", tolerance);
    if (!(transformed <= tolerance) || !(relaxed <= tolerance) || !(projected <= tolerance)) {
        std::fprintf(stderr, "exponential_entropy: a conserving method drifted beyond round-off\n");
        return 1;
    }
    if (!(plain > tolerance)) {
        std::fprintf(stderr, "exponential_entropy: RK4 kept the invariant too; the example shows nothing\n");
        return 1;
    }
    return 0;
}
