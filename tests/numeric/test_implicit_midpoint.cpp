// The implicit midpoint rule (the work-precision benchmark's implicit reference): second order against the exact
// three-wave solution, quadratic invariants kept to round-off, and a failed solve leaving the state untouched.
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <vector>

#include <eci/models/n_wave.hpp>
#include <eci/models/three_wave.hpp>
#include <eci/models/three_wave_exact.hpp>
#include <eci/steppers/implicit_midpoint.hpp>

#include "numeric/support.hpp"

namespace {

using namespace eci::test;
using tw_state = eci::three_wave::state_type;

using implicit_midpoint_m = method_tag<eci::method_entries::implicit_midpoint>;

double error_at(double t_end, std::uint64_t steps) {
    const eci::three_wave model{};
    const tw_state x0{std::sqrt(1.5), 1.0, std::sqrt(1.5)};
    tw_state x = x0;
    eci::implicit_midpoint<tw_state> st;
    eci::integrate_n_steps(st, model, x, 0.0, t_end / double(steps), steps);
    const tw_state exact = eci::three_wave_exact(model, x0)(t_end);
    double e = 0;
    for (int i = 0; i < 3; ++i) e = std::max(e, std::abs(x[i] - exact[i]));
    return e;
}

TEST(ImplicitMidpoint, IsSecondOrderAgainstTheExactThreeWaveSolution) {
    std::vector<double> dts, errs;
    for (std::uint64_t steps : {200u, 400u, 800u, 1600u}) {
        dts.push_back(5.0 / double(steps));
        errs.push_back(error_at(5.0, steps));
    }
    // A second-order method: the fitted slope is 2 up to the O(dt) correction of the leading error term.
    EXPECT_NEAR(log_log_slope(dts, errs), 2.0, 0.05);
}

TEST(ImplicitMidpoint, KeepsThreeWaveInvariantsToRoundOff) {
    const eci::three_wave model{};
    constexpr std::uint64_t steps = 20000;
    const drift_result r = measure_drift<implicit_midpoint_m>(model, {std::sqrt(1.5), 0.0, std::sqrt(1.5)}, 0.01, steps);
    // Each solve stops within 2 eps of its fixed point, which changes a quadratic invariant by a few eps
    // relative, with no preferred sign: a random walk c eps sqrt(n), c of order 1; k = 4 as for the C- methods.
    EXPECT_LE(r.worst(), 4.0 * eps * std::sqrt(double(steps)));
    EXPECT_EQ(r.stats.solver.solves, steps);
    EXPECT_EQ(r.stats.rhs_evals, steps + r.stats.solver.iterations);  // f(x) once, then one per iteration
    // dt |J| / 2 ~ 0.01 contracts the error about 100x per iteration: from the Euler guess (dt^2) to eps takes ~6.
    EXPECT_LE(r.stats.solver.mean_iterations(), 10.0);
}

TEST(ImplicitMidpoint, KeepsComplexNWaveEnergyToRoundOff) {
    const auto model = eci::n_wave<std::complex<double>>::random(30, 6, 3);
    auto x = model.random_state(4);
    const double e0 = model.energy(x), z0 = model.enstrophy(x);
    eci::implicit_midpoint<std::vector<std::complex<double>>> st;
    constexpr std::uint64_t steps = 2000;
    eci::integrate_n_steps(st, model, x, 0.0, 0.005, steps);
    // as above, over 60 real unknowns whose roundings also add up in the invariant's sum: k = 4 sqrt(60)
    const double tol = 4.0 * std::sqrt(60.0) * eps * std::sqrt(double(steps));
    EXPECT_LE(std::abs(model.energy(x) - e0) / e0, tol);
    EXPECT_LE(std::abs(model.enstrophy(x) - z0) / z0, tol);
}

TEST(ImplicitMidpoint, AFailedSolveLeavesTheStateUntouched) {
    const eci::three_wave model{};
    tw_state x{std::sqrt(1.5), 1.0, std::sqrt(1.5)};
    const tw_state before = x;
    eci::implicit_midpoint<tw_state> st;
    st.max_iterations = 2;  // far too few for round-off at dt = 0.1
    const eci::three_wave& f = model;
    EXPECT_FALSE(st.step(f, x, 0.0, 0.1));
    EXPECT_EQ(x, before);
    EXPECT_EQ(st.solver_statistics().solves, 1u);
    EXPECT_EQ(st.solver_statistics().max_iterations, 2);
}

}  // namespace
