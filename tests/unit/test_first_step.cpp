// The initial-step rule of adaptive runs (choose_first_step: Hairer, Norsett & Wanner, I, II.4; SciPy's
// select_initial_step), its edge cases and its evaluations, and solve() choosing the first step when dt is 0.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

#include <eci/eci.hpp>
#include <eci/models/three_wave.hpp>

#include "solve_tests.hpp"

namespace {

using vec = std::vector<double>;

// y0' = y1, y1' = -y0 + t/2, y2' = -3 y2 y0: a system whose rate depends on t and on every component.
struct test_system {
    void operator()(const vec& y, vec& d, double t) const {
        d[0] = y[1];
        d[1] = -y[0] + 0.5 * t;
        d[2] = -3.0 * y[2] * y[0];
    }
};

const vec start{1.0, -0.5, 2.0};

// SciPy 1.10's select_initial_step(fun, 0.25, start, fun(0.25, start), direction, order, rtol, atol) for test_system:
// the same rule without the cap at the span (the spans below are long enough not to cap it); its norms are
// np.linalg.norm / sqrt(n), so the steps agree to round-off, not to the bit.
constexpr double rel = 1e-14;

eci::adaptive_options tolerances(double rtol, double atol) {
    eci::adaptive_options o;
    o.rtol = rtol;
    o.atol = atol;
    return o;
}

// f counting its calls, optionally returning a non-finite rate from some time on, or throwing non_finite_rate.
struct scripted {
    int* calls;
    double bad_from = std::numeric_limits<double>::infinity();
    bool throws = false;
    void operator()(const vec& y, vec& d, double t) const {
        ++*calls;
        for (std::size_t i = 0; i < y.size(); ++i) d[i] = -y[i];
        if (t >= bad_from) {
            if (throws) throw eci::non_finite_rate{0, std::numeric_limits<double>::infinity()};
            d[0] = std::numeric_limits<double>::quiet_NaN();
        }
    }
};

}  // namespace

TEST(FirstStep, AgreesWithScipysSelectInitialStep) {
    const test_system f;
    const auto forward = eci::choose_first_step(f, start, 0.25, 10.0, 5, tolerances(1e-6, 1e-8));
    EXPECT_NEAR(forward.dt, 0.034296030797425325, rel * 0.034);
    EXPECT_EQ(forward.rhs_evals, 2u);
    // Backward: the Euler step goes backward, and the step is still a size.
    const auto backward = eci::choose_first_step(f, start, 0.25, -10.0, 5, tolerances(1e-6, 1e-8));
    EXPECT_NEAR(backward.dt, 0.034272896375246595, rel * 0.034);
    EXPECT_EQ(backward.rhs_evals, 2u);
    // Per-component absolute tolerances.
    eci::adaptive_options each = tolerances(1e-3, 0.0);
    each.atol_each = {1e-4, 1e-5, 1e-6};
    EXPECT_NEAR(eci::choose_first_step(f, start, 0.25, 10.0, 4, each).dt, 0.06949581608938354, rel * 0.07);
    EXPECT_NEAR(eci::choose_first_step(f, start, 0.25, 10.0, 8, tolerances(1e-10, 1e-12)).dt, 0.03793599352882486,
                rel * 0.038);
}

// The rule written out for one component, y' = -2 y from y = 3: scale s = atol + rtol 3, d0 = 3 / s, d1 = 6 / s,
// h0 = 0.01 d0 / d1 = 0.005, y1 = 3 - 0.03, d2 = |2 y1 - 6| / s / h0, h1 = (0.01 / max(d1, d2))^(1/(p+1)).
TEST(FirstStep, IsTheRuleWrittenOut) {
    const auto f = [](const vec& y, vec& d, double) { d[0] = -2.0 * y[0]; };
    const double s = 1e-7 + 1e-5 * 3.0;
    const double d0 = 3.0 / s, d1 = 6.0 / s, h0 = 0.01 * d0 / d1;
    const double y1 = 3.0 + h0 * -6.0;
    const double d2 = std::abs(-2.0 * y1 + 6.0) / s / h0;
    const double h1 = std::pow(0.01 / std::max(d1, d2), 1.0 / 5.0);
    const double expected = std::min(100.0 * h0, h1);
    const auto got = eci::choose_first_step(f, vec{3.0}, 0.0, 1.0, 4, tolerances(1e-5, 1e-7));
    EXPECT_EQ(got.dt, expected);
    EXPECT_EQ(got.rhs_evals, 2u);
    // Capped at the span.
    EXPECT_EQ(eci::choose_first_step(f, vec{3.0}, 0.0, 1e-4, 4, tolerances(1e-5, 1e-7)).dt, 1e-4);
}

TEST(FirstStep, EdgeCases) {
    int calls = 0;
    const scripted f{&calls};
    const eci::adaptive_options o = tolerances(1e-6, 1e-6);
    // An empty span: 1, and f is not called.
    auto c = eci::choose_first_step(f, vec{1.0, 2.0}, 3.0, 3.0, 5, o);
    EXPECT_EQ(c.dt, 1.0);
    EXPECT_EQ(c.rhs_evals, 0u);
    // An empty state: the span.
    c = eci::choose_first_step(f, vec{}, 1.0, -2.0, 5, o);
    EXPECT_EQ(c.dt, 3.0);
    EXPECT_EQ(c.rhs_evals, 0u);
    // A zero scale (atol 0 on a zero component): 1e-6 of the span, without calling f.
    c = eci::choose_first_step(f, vec{1.0, 0.0}, 0.0, 2.0, 5, tolerances(1e-6, 0.0));
    EXPECT_EQ(c.dt, 1e-6 * 2.0);
    EXPECT_EQ(c.rhs_evals, 0u);
    EXPECT_EQ(calls, 0);
    // A non-finite rate at the start, returned or thrown: 1e-6 of the span, after one call.
    for (const bool throws : {false, true}) {
        calls = 0;
        c = eci::choose_first_step(scripted{&calls, 0.0, throws}, vec{1.0, 2.0}, 0.0, 4.0, 5, o);
        EXPECT_EQ(c.dt, 4e-6);
        EXPECT_EQ(c.rhs_evals, 1u);
        EXPECT_EQ(calls, 1);
    }
    // A non-finite rate after the Euler step: that step's size h0 (here 0.01 d0 / d1 = 0.01, f = -y).
    for (const bool throws : {false, true}) {
        calls = 0;
        c = eci::choose_first_step(scripted{&calls, 1e-9, throws}, vec{1.0, 2.0}, 0.0, 4.0, 5, o);
        EXPECT_DOUBLE_EQ(c.dt, 0.01);
        EXPECT_EQ(c.rhs_evals, 2u);
        EXPECT_EQ(calls, 2);
    }
    // f / scale beyond the largest double (tolerance 1e-300, a fast rate): the step underflows to 0, and the
    // rule gives the smallest positive double (the run then says what is wrong).
    const auto fast = [](const vec& y, vec& d, double) { d[0] = -1e10 * y[0]; };
    c = eci::choose_first_step(fast, vec{1.0}, 0.0, 1.0, 5, tolerances(1e-300, 1e-300));
    EXPECT_EQ(c.dt, std::numeric_limits<double>::denorm_min());
    EXPECT_EQ(c.rhs_evals, 1u);
    // Bad tolerances: the settings' own message.
    EXPECT_THROW(eci::choose_first_step(f, vec{1.0}, 0.0, 1.0, 5, tolerances(0.0, 0.0)), std::invalid_argument);
    eci::adaptive_options wrong = o;
    wrong.atol_each = {1.0};
    EXPECT_THROW(eci::choose_first_step(f, vec{1.0, 2.0}, 0.0, 1.0, 5, wrong), std::invalid_argument);
}

// Squares that overflow (tolerance 1e-300 on values of order 1) do not make the rule's norms infinite: they are
// taken relative to the largest entry, and the step is the one the rule gives in exact arithmetic.
TEST(FirstStep, NormsAreOverflowSafe) {
    const auto decay = [](const vec& y, vec& d, double) { d[0] = -y[0]; };
    const double s = 1e-300 + 1e-300 * 1.0;
    const double d0 = 1.0 / s, d1 = d0, h0 = 0.01 * d0 / d1;
    const double y1 = 1.0 + h0 * -1.0;
    const double d2 = std::abs(-y1 + 1.0) / s / h0;
    const double expected = std::pow(0.01 / std::max(d1, d2), 1.0 / 6.0);
    ASSERT_TRUE(std::isinf(d1 * d1));
    const auto c = eci::choose_first_step(decay, vec{1.0}, 0.0, 1.0, 5, tolerances(1e-300, 1e-300));
    EXPECT_EQ(c.dt, expected);
    EXPECT_GT(c.dt, 0.0);
}

// solve() with an adaptive dt of 0 chooses the first step by the rule (the method's order) and counts its
// evaluations in the run's: the same bits as a run given that step.
TEST(FirstStep, SolveChoosesItWhenDtIsZero) {
    const eci::three_wave model;
    const eci::three_wave::state_type x0{1.0, 0.5, -0.8};
    // the compiled runs of the front ends (eci::solve_model, src/models), with a sink that keeps nothing
    solve_tests::discard<eci::three_wave::state_type> none;
    eci::run_config cfg;
    cfg.t_end = 2.0;
    cfg.adaptive = tolerances(1e-8, 1e-8);
    cfg.dt = 0.0;
    auto a = x0;
    const eci::solve_report chosen = eci::solve_model<eci::three_wave>(model, a, "dp54", cfg, none);
    ASSERT_TRUE(chosen.completed());
    const eci::first_step_choice c = eci::choose_first_step(model, x0, 0.0, 2.0, 5, *cfg.adaptive);
    EXPECT_EQ(c.rhs_evals, 2u);
    cfg.dt = c.dt;
    auto b = x0;
    const eci::solve_report given = eci::solve_model<eci::three_wave>(model, b, "dp54", cfg, none);
    EXPECT_EQ(a, b);
    EXPECT_EQ(chosen.stats.steps, given.stats.steps);
    EXPECT_EQ(chosen.stats.rhs_evals, given.stats.rhs_evals + 2);
    EXPECT_EQ(chosen.adaptive->rhs_evals, given.adaptive->rhs_evals + 2);
    // Negative or non-finite first steps are still refused with the same message.
    cfg.dt = -1.0;
    auto c2 = x0;
    try {
        eci::solve_model<eci::three_wave>(model, c2, "dp54", cfg, none);
        ADD_FAILURE() << "expected invalid_argument";
    } catch (const std::invalid_argument& e) {
        EXPECT_STREQ(e.what(), "initial step must be a positive finite number");
    }
}
