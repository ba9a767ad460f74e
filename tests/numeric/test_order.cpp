// Order of accuracy against the exact three-wave solution: the single-step error fit of Figure 5 (local error
// O(tau^(p+1))) and the global error at a fixed time as dt halves (O(dt^p)), for every method.
#include <gtest/gtest.h>

#include <cstdio>
#include <vector>

#include <eci/models/three_wave.hpp>
#include <eci/models/three_wave_exact.hpp>

#include "numeric/support.hpp"

namespace {

using namespace eci::test;
using state = eci::three_wave::state_type;

const eci::three_wave model{};
const state figure5_ic{std::sqrt(1.5), 1.0, std::sqrt(1.5)};

// Figure 5: the error in mode K after one step of tau, fitted to A tau^n by least squares in log-log. The range
// 1e-3..1e-1 keeps the smallest error (~1e-9 for a second-order method) far above round-off (~1e-16).
template <class Method>
double single_step_slope(double tau_lo, double tau_hi, std::size_t mode = 0) {
    const eci::three_wave_exact exact(model, figure5_ic);
    const std::vector<double> taus = log_space(tau_lo, tau_hi, 9);
    std::vector<double> errors;
    for (double tau : taus) {
        state x = figure5_ic;
        typename Method::template stepper<state> st;
        EXPECT_TRUE(st.step(model, x, 0.0, tau));
        const state e = exact(tau);
        errors.push_back(mode < 3 ? std::abs(x[mode] - e[mode])
                                  : std::max({std::abs(x[0] - e[0]), std::abs(x[1] - e[1]), std::abs(x[2] - e[2])}));
    }
    const double slope = log_log_slope(taus, errors);
    std::printf("  %-8s single-step error in %s: %.2e at tau = %g, %.2e at tau = %g, fitted n = %.3f\n", Method::name,
                mode < 3 ? eci::three_wave::component_names[mode] : "max |psi_k|", errors.front(), taus.front(), errors.back(), taus.back(), slope);
    return slope;
}

TEST(SingleStepErrorFigure5, PredictorCorrectorIsSecondOrder) {
    EXPECT_NEAR(single_step_slope<pc_m>(1e-3, 1e-1), 3.0, 0.1);
}
TEST(SingleStepErrorFigure5, ConservativePredictorCorrectorIsSecondOrder) {
    EXPECT_NEAR(single_step_slope<c_pc_m>(1e-3, 1e-1), 3.0, 0.1);
}
// The other methods, on every mode (mode 3 = the largest error of the three). Ranges: C-Euler's tau^2 and tau^3
// error terms partly cancel above tau ~ 1e-2, so the first-order methods are fitted one decade lower; fifth-order
// local error reaches round-off below tau ~ 1e-3, so RK4's range starts higher.
TEST(SingleStepErrorFigure5, OtherMethodsHaveLocalErrorOfOrderPPlusOne) {
    EXPECT_NEAR(single_step_slope<euler_m>(1e-4, 1e-2, 3), 2.0, 0.1);
    EXPECT_NEAR(single_step_slope<c_euler_m>(1e-4, 1e-2, 3), 2.0, 0.1);
    EXPECT_NEAR(single_step_slope<rk2_m>(1e-3, 1e-1, 3), 3.0, 0.1);
    EXPECT_NEAR(single_step_slope<c_rk2_m>(1e-3, 1e-1, 3), 3.0, 0.1);
    EXPECT_NEAR(single_step_slope<rk4_m>(4e-3, 8e-2, 3), 5.0, 0.15);
    EXPECT_NEAR(single_step_slope<c_rk4_m>(4e-3, 8e-2, 3), 5.0, 0.15);
}

// Global order: the largest error against the exact solution over [0, T] (every grid point, every mode), with
// dt halved from dt0; the fitted slope is the order. Ranges keep RK4's smallest error (~1e-7) far above round-off.
template <class Method>
double global_order(double dt0, int halvings = 3, double t_end = 10.0) {
    const eci::three_wave_exact exact(model, figure5_ic);
    std::vector<double> dts, errors;
    for (int h = 0; h <= halvings; ++h) {
        const double dt = dt0 / double(1 << h);
        state x = figure5_ic;
        typename Method::template stepper<state> st;
        double worst = 0.0;
        eci::integrate_to(st, model, x, 0.0, t_end, dt, [&](const state& s, double t, std::uint64_t) {
            const state e = exact(t);
            for (std::size_t k = 0; k < 3; ++k) worst = std::max(worst, std::abs(s[k] - e[k]));
        });
        dts.push_back(dt);
        errors.push_back(worst);
    }
    const double order = log_log_slope(dts, errors);
    std::printf("  %-8s max error on [0, %g]: %.2e (dt %g) .. %.2e (dt %g), ratios", Method::name, t_end,
                errors.front(), dts.front(), errors.back(), dts.back());
    for (std::size_t i = 1; i < errors.size(); ++i) std::printf(" %.2f", errors[i - 1] / errors[i]);
    std::printf(", fitted order %.3f\n", order);
    return order;
}

TEST(GlobalOrderAgainstExactSolution, ConservativeRk4IsFourthOrder) { EXPECT_NEAR(global_order<c_rk4_m>(0.1), 4.0, 0.15); }
TEST(GlobalOrderAgainstExactSolution, ConservativeRk2IsSecondOrder) { EXPECT_NEAR(global_order<c_rk2_m>(0.02), 2.0, 0.1); }
TEST(GlobalOrderAgainstExactSolution, ConservativePredictorCorrectorIsSecondOrder) {
    EXPECT_NEAR(global_order<c_pc_m>(0.02), 2.0, 0.1);
}
// C-Euler's error is O(dt) with a constant that jumps with dt: each zero crossing adds an O(dt) phase error whose
// size depends on where the last explicit step of eq. (16) lands relative to the zero (its local error there is
// O(dt), not O(dt^2)). Single halvings measure 0.4 to 4; four halvings fit close to 1.
TEST(GlobalOrderAgainstExactSolution, ConservativeEulerIsFirstOrder) {
    EXPECT_NEAR(global_order<c_euler_m>(0.02, 4), 1.0, 0.15);
}
TEST(GlobalOrderAgainstExactSolution, ConventionalMethodsHaveTheirOrder) {
    EXPECT_NEAR(global_order<euler_m>(0.02, 4), 1.0, 0.1);
    EXPECT_NEAR(global_order<pc_m>(0.02), 2.0, 0.1);
    EXPECT_NEAR(global_order<rk2_m>(0.02), 2.0, 0.1);
    EXPECT_NEAR(global_order<rk4_m>(0.1), 4.0, 0.15);
}

}  // namespace
