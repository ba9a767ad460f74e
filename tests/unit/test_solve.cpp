// Unit tests of the one run, eci::solve (solve.hpp): it gives the drivers' bits for fixed and adaptive runs, side
// steps to output times between grid points, a failure report for every way a run can stop, and rates a system
// reports as non-finite counted apart. (Its settings, checks and cancellation: test_solve_settings.cpp; two files,
// so that the two halves of their template instantiations compile in parallel.)
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "solve_tests.hpp"

using namespace solve_tests;

namespace {

/// x' = -x, with a rate that turns NaN in component 1 for t >= 0.5 (a user's function that fails there).
struct nan_after_half {
    static constexpr bool reports_non_finite_rate = true;
    void operator()(const vec& x, vec& d, double t) const {
        for (std::size_t i = 0; i < x.size(); ++i) d[i] = -x[i];
        if (t >= 0.5) throw eci::non_finite_rate{1, std::numeric_limits<double>::quiet_NaN()};
    }
};

}  // namespace

TEST(Solve, FixedStepsGiveTheDriversBitsAndTheirReport) {
    const eci::three_wave model;
    tw_state a = fig5, b = fig5;
    eci::run_config cfg;
    cfg.t_end = 10.0;
    cfg.dt = 0.2;  // Fig. 2's step: C-PC halves some steps
    keep_all<tw_state> sink;
    const eci::solve_report r = eci::solve_model<eci::three_wave>(model, a, "c-pc", cfg, sink);
    // The reference is the driver itself (eci::run is solve_with too), with the drifts measured here.
    eci::c_pc<tw_state> st;
    std::vector<tw_state> seen;
    const double e0 = model.energy(fig5), z0 = model.enstrophy(fig5);
    double energy_drift = 0.0, enstrophy_drift = 0.0;
    const eci::run_stats ref = eci::integrate_to(st, model, b, 0.0, 10.0, 0.2, [&](const tw_state& s, double) {
        seen.push_back(s);
        energy_drift = std::max(energy_drift, std::abs(model.energy(s) - e0));
        enstrophy_drift = std::max(enstrophy_drift, std::abs(model.enstrophy(s) - z0));
    });
    ASSERT_TRUE(r.completed());
    EXPECT_EQ(a, b);
    EXPECT_EQ(sink.x, seen);
    EXPECT_EQ(sink.t.back(), 10.0);
    EXPECT_EQ(r.stats.steps, ref.steps);
    EXPECT_GT(r.stats.step_reductions, 0u);
    EXPECT_EQ(r.stats.step_reductions, ref.step_reductions);
    EXPECT_EQ(r.stats.rhs_evals, ref.rhs_evals);
    ASSERT_EQ(r.invariants.size(), 2u);
    EXPECT_EQ(r.invariants[0].max_abs_drift, energy_drift);
    EXPECT_EQ(r.invariants[1].max_abs_drift, enstrophy_drift);
    // eci::run, the observer's wrapper of the same run, gives the same bits.
    tw_state c = fig5;
    eci::c_pc<tw_state> st2;
    const eci::solve_report via_run = eci::run(st2, model, c, eci::run_span::until(10.0, 0.2));
    EXPECT_EQ(c, a);
    EXPECT_EQ(via_run.stats.rhs_evals, r.stats.rhs_evals);
    EXPECT_EQ(via_run.invariants[0].max_abs_drift, energy_drift);
    EXPECT_EQ(r.method.name, "c-pc");
    EXPECT_FALSE(r.adaptive);
}

TEST(Solve, EveryKStepsKeepsTheFirstAndTheLast) {
    const eci::three_wave model;
    tw_state x = fig5;
    eci::run_config cfg;
    cfg.steps = 10;
    cfg.dt = 0.01;
    cfg.every = 4;
    keep_all<tw_state> sink;
    const auto r = eci::solve_model<eci::three_wave>(model, x, "rk4", cfg, sink);
    ASSERT_TRUE(r.completed());
    EXPECT_EQ(sink.t, (std::vector<double>{0.0, 0.04, 0.08, 0.1}));
    EXPECT_EQ(sink.invariants[0].size(), 2u);  // energy and enstrophy at every output
}

TEST(Solve, OutputTimesBetweenGridPointsAreSideStepsFromTheEarlierOne) {
    const eci::three_wave model;
    tw_state x = fig5;
    eci::run_config cfg;
    cfg.t_end = 1.0;
    cfg.dt = 0.25;
    cfg.times = {0.0, 0.25, 0.3, 1.0};
    keep_all<tw_state> sink;
    const auto r = eci::solve_model<eci::three_wave>(model, x, "rk4", cfg, sink);
    ASSERT_TRUE(r.completed());
    EXPECT_EQ(sink.t, cfg.times);
    EXPECT_EQ(r.side_steps, 1u);
    // The point at 0.3: one step of 0.05 from the grid state at 0.25.
    tw_state g = fig5;
    eci::rk4<tw_state> st;
    eci::integrate_n_steps(st, model, g, 0.0, 0.25, 1);
    tw_state side = g;
    eci::rk4<tw_state> st2;
    eci::integrate_n_steps(st2, model, side, 0.25, 0.3 - 0.25, 1);
    EXPECT_EQ(sink.x[1], g);
    EXPECT_EQ(sink.x[2], side);
    // The grid run is untouched by the side step: 4 steps, 16 + 4 evaluations.
    EXPECT_EQ(r.stats.steps, 4u);
    EXPECT_EQ(r.stats.rhs_evals, 20u);
}

// GCC 12 at -O2 reports the payload of cfg.adaptive, a disengaged optional, as maybe used uninitialized when it is
// assigned below (a false positive, depending on how much of solve() it inlines here).
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
TEST(Solve, AdaptiveRunsGiveRunAdaptivesBits) {
    const eci::three_wave model;
    tw_state a = fig5, b = fig5;
    eci::run_config cfg;
    cfg.t_end = 5.0;
    cfg.dt = 0.01;
    cfg.adaptive = eci::adaptive_options{.rtol = 1e-8, .atol = 1e-8};
    cfg.times = {0.0, 1.0, 2.5};  // stops short of t_end: the run still goes there
    keep_all<tw_state> sink;
    const auto r = eci::solve_model<eci::three_wave>(model, a, "c-dp54", cfg, sink);
    ASSERT_TRUE(r.completed());
    ASSERT_TRUE(r.adaptive);
    std::vector<tw_state> seen;
    std::vector<double> times = cfg.times;
    times.push_back(5.0);
    // The reference is the driver itself (eci::run_adaptive is solve_with too).
    eci::adaptive_stats ref;
    eci::with_adaptive_stepper<eci::three_wave>("c-dp54", [&](auto st) {
        ref = eci::integrate_adaptive_at(st, model, b, 0.0, times, 0.01, *cfg.adaptive,
                                         [&](const tw_state& s, double, std::uint64_t) { seen.push_back(s); });
    });
    EXPECT_EQ(a, b);
    EXPECT_EQ(sink.t, cfg.times);
    ASSERT_EQ(sink.x.size(), 3u);
    for (std::size_t i = 0; i < 3; ++i) EXPECT_EQ(sink.x[i], seen[i]);
    EXPECT_EQ(r.adaptive->accepted, ref.accepted);
    EXPECT_EQ(r.stats.steps, ref.accepted);
    EXPECT_EQ(r.stats.rhs_evals, ref.rhs_evals);
    // eci::run_adaptive with the same times gives the same bits.
    tw_state c = fig5;
    std::vector<tw_state> seen_run;
    eci::with_adaptive_stepper<eci::three_wave>("c-dp54", [&](auto st) {
        const eci::solve_report via = eci::run_adaptive(st, model, c, 0.0, 5.0, 0.01, *cfg.adaptive, times,
                                                        [&](const tw_state& s, double) { seen_run.push_back(s); });
        EXPECT_TRUE(via.completed());
        EXPECT_EQ(via.adaptive->rhs_evals, ref.rhs_evals);
    });
    EXPECT_EQ(c, a);
    EXPECT_EQ(seen_run, seen);
}

#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic pop
#endif

TEST(Solve, ANonFiniteRateFailsTheAttemptAndIsCountedApart) {
    // dt = 0.3: the step from 0.3 evaluates at t >= 0.5 and fails at every size down to 2^-3 dt.
    vec x{1.0, 2.0};
    eci::run_config cfg;
    cfg.t_end = 1.0;
    cfg.dt = 0.3;
    cfg.max_halvings = 3;
    eci::rk4<vec> rk4;  // the run of solve(..., "rk4", ...) on its stepper: every method of a plain system not compiled
    const auto r = eci::solve_with(rk4, nan_after_half{}, x, cfg, eci::no_sink{});
    ASSERT_FALSE(r.completed());
    EXPECT_EQ(r.failure->kind, eci::run_failure_kind::step_failed);
    ASSERT_TRUE(r.failure->non_finite_rate_value);
    EXPECT_TRUE(std::isnan(*r.failure->non_finite_rate_value));
    EXPECT_EQ(r.failure->component, 1u);
    EXPECT_EQ(r.stats.steps, 1u);
    EXPECT_GT(r.stats.non_finite_rate_reductions, 0u);
    EXPECT_EQ(r.stats.non_finite_rate_reductions, r.stats.step_reductions);
    EXPECT_NE(r.failure->message.find("in component x[1] even with the step halved 3 times"), std::string::npos)
        << r.failure->message;
    // x is the last state reached: after the one step, finite.
    EXPECT_TRUE(std::isfinite(x[0]) && std::isfinite(x[1]));
}

TEST(Solve, AdaptiveRejectsANonFiniteRateAndNamesItTheLastRejection) {
    vec x{1.0, 2.0};
    eci::run_config cfg;
    cfg.t_end = 1.0;
    cfg.dt = 0.01;
    cfg.adaptive = eci::adaptive_options{.rtol = 1e-6, .atol = 1e-6};
    eci::dp54<vec> dp54;
    const auto r = eci::solve_with(dp54, nan_after_half{}, x, cfg, eci::no_sink{});
    ASSERT_FALSE(r.completed());
    EXPECT_EQ(r.failure->kind, eci::run_failure_kind::step_too_small);
    EXPECT_EQ(r.failure->last_rejection, eci::rejection::non_finite_rate);
    EXPECT_GT(r.adaptive->rejected_non_finite_rate, 0u);
    EXPECT_LT(r.failure->t, 0.5);
}

TEST(Solve, AnInvariantThatOverflowsEndsTheRun) {
    // x' = x^2 from x = 1 blows up at t = 1; its "energy" x^2 overflows before the state does.
    struct blow_up {
        using state_type = std::array<double, 1>;
        void operator()(const state_type& x, state_type& d, double) const { d[0] = x[0] * x[0]; }
        double energy(const state_type& x) const { return x[0] * x[0] * x[0] * x[0] * x[0] * x[0] * x[0] * x[0]; }
        static constexpr auto invariants() {
            return std::array<eci::named_invariant<blow_up>, 1>{{{"energy", &blow_up::energy}}};
        }
    };
    blow_up::state_type x{1.0};
    eci::run_config cfg;
    cfg.t_end = 2.0;
    cfg.dt = 1e-3;
    eci::rk4<blow_up::state_type> rk4;
    const auto r = eci::solve_with(rk4, blow_up{}, x, cfg, eci::no_sink{});
    ASSERT_FALSE(r.completed());
    EXPECT_EQ(r.failure->kind, eci::run_failure_kind::invariant_overflow);
    EXPECT_EQ(r.failure->message.rfind("the invariant energy overflowed at t = ", 0), 0u) << r.failure->message;
    EXPECT_LT(r.failure->t, 1.01);     // at the blow-up time 1 (RK4 overshoots it by a few steps)
    EXPECT_TRUE(std::isfinite(x[0]));  // before the state itself overflowed
}

// (cfg.adaptive assigned below: the same GCC 12 false positive as above.)
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
// A dynamic sink that observes steps sees every accepted step of an adaptive run through eci::step_view: contiguous
// steps from t0, the stepper's dense output (of squares for a conservative pair, of its degree), and a stop time it
// returns ends the run there, at the dense output's state.
TEST(Solve, ADynamicSinkSeesEveryAcceptedStepAndStopsTheRun) {
    struct steps_seen final : eci::dynamic_sink<tw_state> {
        std::vector<double> starts, ends;
        tw_state at_stop{};
        bool squares = false, ends_match = true;
        int degree = 0;
        void output(const tw_state&, const eci::output_point&) override {}
        bool observes_steps() const override { return true; }
        std::optional<double> accepted(eci::step_view<tw_state>& s) override {
            starts.push_back(s.t_start());
            ends.push_back(s.t_end());
            squares = s.dense_of_squares();
            degree = s.dense_degree();
            tw_state end{};
            s.at(s.t_end(), end);
            ends_match = ends_match && end == s.end_state();
            if (s.t_end() < 1.0) return std::nullopt;
            s.at(1.0, at_stop);
            return 1.0;
        }
    };
    const eci::three_wave model;
    eci::run_config cfg;
    cfg.t_end = 5.0;
    cfg.dt = 0.01;
    cfg.adaptive = eci::adaptive_options{.rtol = 1e-8, .atol = 1e-8};
    for (const char* method : {"c-dp54", "dp54"}) {
        tw_state x = fig5;
        steps_seen sink;
        const eci::solve_report r = eci::solve_model<eci::three_wave>(model, x, method, cfg, sink);
        ASSERT_TRUE(r.stopped_at.has_value()) << method;
        EXPECT_EQ(*r.stopped_at, 1.0);
        EXPECT_EQ(x, sink.at_stop);
        ASSERT_GT(sink.starts.size(), 2u);
        EXPECT_EQ(sink.starts.front(), 0.0);
        for (std::size_t i = 1; i < sink.starts.size(); ++i) EXPECT_EQ(sink.starts[i], sink.ends[i - 1]);
        EXPECT_GE(sink.ends.back(), 1.0);
        EXPECT_TRUE(sink.ends_match);
        EXPECT_EQ(sink.squares, std::string(method) == "c-dp54") << method;
        EXPECT_EQ(sink.degree, 4) << method;  // DP54's continuous extension
    }
}
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic pop
#endif
