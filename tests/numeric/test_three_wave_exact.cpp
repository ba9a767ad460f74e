// The exact three-wave solution against a tiny-step classical RK4 integration, its invariants, its initial
// condition and its period, over the paper's initial conditions, random ones and degenerate cases.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <stdexcept>
#include <vector>

#include "eci/models/three_wave_exact.hpp"

namespace {

using eci::three_wave;
using eci::three_wave_exact;
using state = three_wave::state_type;

constexpr double eps = std::numeric_limits<double>::epsilon();

/// A model with M proportional to (P^2 - Q^2, Q^2 - K^2, K^2 - P^2), which satisfies eqs. (2) and (3).
three_wave make_model(double K, double P, double Q, double scale) {
    three_wave m;
    m.K = K, m.P = P, m.Q = Q;
    m.M = {scale * (P * P - Q * Q), scale * (Q * Q - K * K), scale * (K * K - P * P)};
    m.validate();
    return m;
}

double max_abs_diff(const state& a, const state& b) {
    return std::max({std::abs(a[0] - b[0]), std::abs(a[1] - b[1]), std::abs(a[2] - b[2])});
}

/// Max |exact - RK4| over every step of a classical RK4 run from 0 to t_end (t_end may be negative).
double rk4_max_error(const three_wave& model, const three_wave_exact& exact, state x, double t_end,
                     double dt = 1e-3) {
    const int steps = static_cast<int>(std::lround(std::abs(t_end) / dt));
    const double h = t_end / steps;
    auto add = [](const state& x, double c, const state& k) {
        return state{x[0] + c * k[0], x[1] + c * k[1], x[2] + c * k[2]};
    };
    double err = 0.0;
    state k1, k2, k3, k4;
    for (int n = 1; n <= steps; ++n) {
        model(x, k1, 0.0);
        model(add(x, h / 2, k1), k2, 0.0);
        model(add(x, h / 2, k2), k3, 0.0);
        model(add(x, h, k3), k4, 0.0);
        for (int i = 0; i < 3; ++i) x[i] += h / 6 * (k1[i] + 2 * k2[i] + 2 * k3[i] + k4[i]);
        err = std::max(err, max_abs_diff(x, exact(n * h)));
    }
    return err;
}

/// All the checks for one model and initial condition: IC, invariants on [-t_end, t_end], RK4 both ways.
void check(const three_wave& model, const state& psi0, double t_end = 15.0) {
    SCOPED_TRACE(testing::Message() << "psi0 = (" << psi0[0] << ", " << psi0[1] << ", " << psi0[2] << ")");
    const three_wave_exact exact(model, psi0);
    const double scale = std::max({std::abs(psi0[0]), std::abs(psi0[1]), std::abs(psi0[2])});
    EXPECT_LE(max_abs_diff(exact(0.0), psi0), 4 * eps * scale);

    const double E0 = model.energy(psi0), Z0 = model.enstrophy(psi0);
    double dE = 0.0, dZ = 0.0;
    for (double t = -t_end; t <= t_end; t += 0.01237) {
        const state x = exact(t);
        dE = std::max(dE, std::abs(model.energy(x) - E0) / E0);
        dZ = std::max(dZ, std::abs(model.enstrophy(x) - Z0) / Z0);
    }
    EXPECT_LE(dE, 1e-14);
    EXPECT_LE(dZ, 1e-14);

    const double fwd = rk4_max_error(model, exact, psi0, t_end), bwd = rk4_max_error(model, exact, psi0, -t_end);
    EXPECT_LE(fwd, 1e-10);
    EXPECT_LE(bwd, 1e-10);
    std::printf("  psi0 = (%+.4f, %+.4f, %+.4f)  T = %-8.4g  dE = %.1e  dZ = %.1e  RK4: %.1e (t>0) %.1e (t<0)\n",
                psi0[0], psi0[1], psi0[2], exact.period(), dE, dZ, fwd, bwd);
}

std::vector<state> random_states(unsigned seed, int count, double amplitude) {
    std::mt19937_64 gen(seed);
    std::uniform_real_distribution<double> u(-amplitude, amplitude);
    std::vector<state> out(count);
    for (auto& x : out) x = {u(gen), u(gen), u(gen)};
    return out;
}

const three_wave fig1_model{};  // K = sqrt 3, P = 3, Q = sqrt 6, M = (1, 1, -2)

TEST(ThreeWaveExact, Figure1InitialCondition) { check(fig1_model, {std::sqrt(1.5), 0.0, std::sqrt(1.5)}, 20.0); }

TEST(ThreeWaveExact, Figure5InitialCondition) { check(fig1_model, {std::sqrt(1.5), 1.0, std::sqrt(1.5)}, 20.0); }

TEST(ThreeWaveExact, ExactlyZeroModesWithEverySign) {
    for (double s : {1.0, -1.0})
        for (double r : {1.0, -1.0}) {
            check(fig1_model, {s * 1.1, r * 0.6, 0.0});  // the sn mode at zero
            check(fig1_model, {s * 0.6, 0.0, r * 1.1});  // the cn mode at zero
            check(fig1_model, {0.0, s * 0.6, r * 1.1});
        }
}

TEST(ThreeWaveExact, RandomInitialConditions) {
    for (const state& x : random_states(1, 12, 1.5)) check(fig1_model, x);
}

TEST(ThreeWaveExact, OtherCoefficientsOneNegativeM) {
    const three_wave model = make_model(1.3, 2.1, 2.9, -0.25);  // M = (+, -, +)
    ASSERT_LT(model.M[0] * model.M[1] * model.M[2], 0.0);
    for (const state& x : random_states(2, 8, 1.5)) check(model, x);
}

TEST(ThreeWaveExact, OtherCoefficientsTwoNegativeM) {  // the time-reversed branch
    const three_wave model = make_model(2.9, 1.3, 2.1, 0.3);
    ASSERT_GT(model.M[0] * model.M[1] * model.M[2], 0.0);
    for (const state& x : random_states(3, 8, 1.5)) check(model, x);
    check(model, {0.0, 0.8, -1.2});
    check(model, {1.0, 0.0, 0.7});
}

TEST(ThreeWaveExact, PeriodReturnsToInitialCondition) {
    for (const state& x : random_states(4, 6, 1.5)) {
        const three_wave_exact exact(fig1_model, x);
        const double T = exact.period();
        ASSERT_TRUE(std::isfinite(T));
        EXPECT_LE(max_abs_diff(exact(T), x), 1e-12);
        EXPECT_LE(max_abs_diff(exact(-3 * T + 0.4), exact(0.4)), 1e-12);
        EXPECT_GT(max_abs_diff(exact(T / 2), x), 1e-3);  // the fundamental period, not a multiple
    }
}

TEST(ThreeWaveExact, FixedPointsAreConstant) {
    for (const state& x : std::vector<state>{{0, 0, 0}, {1.2, 0, 0}, {0, -0.7, 0}, {0, 0, 1.5}}) {
        const three_wave_exact exact(fig1_model, x);
        EXPECT_EQ(exact.period(), std::numeric_limits<double>::infinity());
        for (double t : {-7.0, 0.0, 3.0, 100.0}) EXPECT_EQ(exact(t), x);
    }
}

TEST(ThreeWaveExact, SeparatrixConvergesToTheSaddle) {
    // psi_K^2 / M_K = psi_P^2 / M_P gives m = 1: psi -> (0, 0, +-amplitude) as t -> +-infinity.
    const state x{1.0, -1.0, 0.5};
    const three_wave_exact exact(fig1_model, x);
    EXPECT_EQ(exact.period(), std::numeric_limits<double>::infinity());
    check(fig1_model, x, 4.0);  // the saddle amplifies RK4's error like exp(w t); keep t short
    const double amp = std::sqrt(2 * fig1_model.energy(x));
    for (double t : {-30.0, 30.0}) {
        const state far = exact(t);
        EXPECT_NEAR(std::abs(far[2]), amp, 1e-12);
        EXPECT_NEAR(far[0], 0.0, 1e-10);
    }
}

TEST(ThreeWaveExact, ZeroCouplingCoefficientRotates) {
    three_wave model;  // M_K = 0 requires P = Q by eq. (3)
    model.K = 1.0, model.P = 2.0, model.Q = 2.0, model.M = {0.0, 0.7, -0.7};
    model.validate();
    for (const state& x : random_states(5, 4, 1.5)) check(model, x);
    EXPECT_NEAR(three_wave_exact(model, {0.5, 1, 1}).period(), 2 * std::acos(-1.0) / 0.35, 1e-12);
}

TEST(ThreeWaveExact, RejectsInvalidInput) {
    three_wave bad;
    bad.M = {1.0, 1.0, 1.0};
    EXPECT_THROW(three_wave_exact(bad, {1, 1, 1}), std::invalid_argument);
    EXPECT_THROW(three_wave_exact(fig1_model, {1, std::nan(""), 1}), std::invalid_argument);
    // 1 - m ~ 1e-18: m rounds to 1 although the motion is periodic.
    EXPECT_THROW(three_wave_exact(fig1_model, {1e-9, 0.0, 1.0}), std::invalid_argument);
}

}  // namespace
