// Unit tests of the run layer (run.hpp, integrate.hpp): the invariant monitor, run() and its report (also for a
// run that underflows), step_with_reduction, odeint-style observers, and the reset contract for carried state.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <limits>
#include <vector>

#include <eci/eci.hpp>
#include <eci/models/invariant.hpp>
#include <eci/models/lotka_volterra.hpp>
#include <eci/models/three_wave.hpp>

namespace {

constexpr double eps = std::numeric_limits<double>::epsilon();
using tw_state = eci::three_wave::state_type;
const tw_state fig5{std::sqrt(1.5), 1.0, std::sqrt(1.5)};

// x2' = -sgn(x2) from t = 1 on (see unit/test_integrate.cpp): every conservative method underflows at t = 1,
// after 4 steps of 0.25. Its invariant x0^2 + x1^2 (the rotation of x0, x1) is conserved meanwhile.
struct sliding_model {
    using state_type = std::vector<double>;
    void operator()(const state_type& x, state_type& d, double t) const {
        d[0] = x[1], d[1] = -x[0];
        d[2] = t < 1.0 ? 0.0 : x[2] <= 0.0 ? 1.0 : -1.0;
    }
    double rotation(const state_type& x) const { return x[0] * x[0] + x[1] * x[1]; }
    static constexpr auto invariants() {
        return std::array<eci::named_invariant<sliding_model>, 1>{{{"rotation", &sliding_model::rotation}}};
    }
};

// An invariant that goes NaN: the monitor must keep the NaN, never report a clean run.
struct blow_up_model {
    using state_type = std::array<double, 1>;
    void operator()(const state_type& x, state_type& d, double) const { d[0] = x[0] * x[0]; }
    double value(const state_type& x) const { return x[0] * 0.0; }  // 0 while finite, NaN at infinity
    static constexpr auto invariants() {
        return std::array<eci::named_invariant<blow_up_model>, 1>{{{"value", &blow_up_model::value}}};
    }
};

// A user's model whose invariants() is not constexpr (a list built when called): the monitor evaluates it at run
// time instead of expanding it at compile time, with the same records.
struct runtime_list_model {
    using state_type = std::array<double, 2>;
    void operator()(const state_type& x, state_type& d, double) const { d[0] = x[1], d[1] = -x[0]; }
    double radius2(const state_type& x) const { return x[0] * x[0] + x[1] * x[1]; }
    double first(const state_type& x) const { return x[0]; }
    static auto invariants() {
        return std::vector<eci::named_invariant<runtime_list_model>>{{"radius2", &runtime_list_model::radius2},
                                                                     {"first", &runtime_list_model::first}};
    }
};
static_assert(eci::has_named_invariants<runtime_list_model> && !eci::constant_invariant_list<runtime_list_model>);
static_assert(eci::constant_invariant_list<eci::three_wave>);

}  // namespace

TEST(InvariantMonitor, ListsNotKnownAtCompileTimeAreRecordedAlike) {
    const runtime_list_model model;
    eci::invariant_monitor<runtime_list_model> mon(model);
    mon.record({1.0, 0.0});
    mon.record({0.0, 2.0});
    ASSERT_EQ(mon.records().size(), 2u);
    EXPECT_EQ(mon.records()[0].name, "radius2");
    EXPECT_EQ(mon.records()[0].initial, 1.0);
    EXPECT_EQ(mon.records()[0].final, 4.0);
    EXPECT_EQ(mon.records()[1].max_abs_drift, 1.0);
    EXPECT_EQ(mon.values()[1], 0.0);
}

TEST(InvariantMonitor, RecordsInitialFinalAndLargestDrift) {
    const eci::three_wave model;
    eci::invariant_monitor<eci::three_wave> mon(model);
    const tw_state a{1.0, 0.0, 0.0}, b{2.0, 0.0, 0.0}, c{1.5, 0.0, 0.0};
    mon.record(a);
    mon.record(b);
    mon.record(c);
    ASSERT_EQ(mon.records().size(), 2u);
    const eci::invariant_record& e = mon.records()[0];
    EXPECT_EQ(e.name, "energy");
    EXPECT_EQ(e.initial, 0.5);
    EXPECT_EQ(e.final, 1.125);
    EXPECT_EQ(e.max_abs_drift, 1.5);  // at b: 2 - 0.5
    EXPECT_EQ(e.max_rel_drift(), 3.0);
    EXPECT_EQ(mon.values()[0], 1.125);
    EXPECT_EQ(mon.worst_rel_drift(), 3.0);  // the enstrophy moved by the same factor (K^2 weighs both alike)
    mon.restart();
    mon.record(c);
    EXPECT_EQ(mon.records()[0].initial, 1.125);
    EXPECT_EQ(mon.records()[0].max_abs_drift, 0.0);
}

TEST(InvariantMonitor, KeepsANaNOnceSeen) {
    const blow_up_model model;
    eci::invariant_monitor<blow_up_model> mon(model);
    mon.record({1.0});
    mon.record({std::numeric_limits<double>::infinity()});
    mon.record({1.0});
    EXPECT_TRUE(std::isnan(mon.records()[0].max_abs_drift));
    EXPECT_TRUE(std::isnan(mon.records()[0].max_rel_drift()));
    EXPECT_EQ(mon.worst_rel_drift(), std::numeric_limits<double>::infinity());
}

// One rule for the relative drift, which the CLI's summary, its JSON and Python all report: the quotient where
// I(t0) is a normal number and the quotient finite; 0 if I never moved; NaN (n/a, null, nan) where a relative
// drift means nothing: from I(t0) = 0 or a subnormal I(t0), an overflowing quotient, a NaN.
TEST(InvariantRecord, RelativeDriftOnlyWhereItMeansSomething) {
    const double tiny = std::numeric_limits<double>::min(), sub = tiny / 4.0;
    auto rel = [](double i0, double v) {
        eci::invariant_record r{"I"};
        r.record(i0, true);
        r.record(v, false);
        return r.max_rel_drift();
    };
    EXPECT_EQ(rel(2.0, 3.0), 0.5);
    EXPECT_EQ(rel(-2.0, -3.0), 0.5);
    EXPECT_EQ(rel(0.0, 0.0), 0.0);
    EXPECT_EQ(rel(sub, sub), 0.0);
    EXPECT_EQ(rel(tiny, 2.0 * tiny), 1.0);  // the smallest normal I(t0)
    EXPECT_TRUE(std::isnan(rel(0.0, 1.0)));
    EXPECT_TRUE(std::isnan(rel(sub, 2.0 * sub)));
    EXPECT_GT(rel(tiny, 1.0), 4e307);              // large, but from a normal I(t0)
    EXPECT_TRUE(std::isnan(rel(1e-300, 1e10)));  // the quotient overflows
    EXPECT_TRUE(std::isnan(rel(1.0, std::numeric_limits<double>::quiet_NaN())));
}

// run() watches every step whatever the observer's cadence: its drift equals the one seen by an observer of
// every step, bit for bit, and its state and statistics equal integrate_n_steps' own.
TEST(Run, MonitorsEveryStepAndMatchesTheDriver) {
    const eci::three_wave model;
    const std::uint64_t n = 2000;
    tw_state x = fig5, y = fig5;
    eci::c_pc<tw_state> st;
    std::vector<std::uint64_t> seen;
    const eci::solve_report rep = eci::run(st, model, x, eci::run_span::n_steps(n, 0.01),
                                           [&](const tw_state&, double, std::uint64_t i) { seen.push_back(i); },
                                           {.every = 500});
    EXPECT_TRUE(rep.completed());
    EXPECT_EQ(seen, (std::vector<std::uint64_t>{0, 500, 1000, 1500, 2000}));
    double worst = 0.0;
    const double e0 = model.energy(fig5);
    const auto ref = eci::integrate_n_steps(st, model, y, 0.0, 0.01, n, [&](const tw_state& s, double) {
        worst = std::max(worst, std::abs(model.energy(s) - e0));
    });
    EXPECT_EQ(x, y);
    EXPECT_EQ(rep.stats.steps, ref.steps);
    EXPECT_EQ(rep.stats.rhs_evals, ref.rhs_evals);
    EXPECT_EQ(rep.invariants[0].max_abs_drift, worst);
    EXPECT_EQ(rep.t, 0.01 * double(n));
    // C-PC: round-off only, 4 eps sqrt(n) relative (numeric/test_conservation.cpp).
    EXPECT_LE(rep.invariants[0].max_rel_drift(), 4.0 * eps * std::sqrt(double(n)));
    EXPECT_GT(rep.invariants[0].max_abs_drift, 0.0);  // it did measure something
}

// run() with opt.first_step continues the grid t0 + i dt (a restart): its observer sees steps first .. first + n at
// their grid times, and its state equals the driver's continuation, bit for bit; an end-time span continues it to
// its end, the last step shortened as the whole run's, and refuses a first step beyond the end's.
TEST(Run, FirstStepContinuesTheGrid) {
    const eci::three_wave model;
    tw_state x = fig5, y = fig5;
    eci::c_rk4<tw_state> st;
    std::vector<std::uint64_t> seen;
    std::vector<double> times;
    const auto rep = eci::run(st, model, x, eci::run_span::n_steps(6, 0.1),
                              [&](const tw_state&, double t, std::uint64_t i) { seen.push_back(i), times.push_back(t); },
                              {.every = 2, .first_step = 5});
    EXPECT_TRUE(rep.completed());
    EXPECT_EQ(seen, (std::vector<std::uint64_t>{5, 6, 8, 10, 11}));
    EXPECT_EQ(times.front(), 0.1 * 5.0);
    EXPECT_EQ(times.back(), 0.1 * 11.0);
    EXPECT_EQ(rep.stats.steps, 6u);
    eci::integrate_n_steps(st, model, y, 0.0, 0.1, 6, eci::no_observer{}, {.first_step = 5});
    EXPECT_EQ(x, y);
    // to t = 1.05 in one run, and in two: 5 steps, then a restart at step 5 to the end time (steps 6 .. 11, the
    // last of 0.05)
    tw_state whole = fig5, part = fig5;
    eci::integrate_to(st, model, whole, 0.0, 1.05, 0.1);
    eci::integrate_n_steps(st, model, part, 0.0, 0.1, 5);
    seen.clear(), times.clear();
    const auto rest = eci::run(st, model, part, eci::run_span::until(1.05, 0.1),
                               [&](const tw_state&, double t, std::uint64_t i) { seen.push_back(i), times.push_back(t); },
                               {.first_step = 5});
    EXPECT_EQ(part, whole);
    EXPECT_EQ(seen, (std::vector<std::uint64_t>{5, 6, 7, 8, 9, 10, 11}));
    EXPECT_EQ(times.front(), 0.1 * 5.0);
    EXPECT_EQ(times.back(), 1.05);
    EXPECT_EQ(rest.stats.steps, 6u);
    EXPECT_EQ(rest.t, 1.05);
    tw_state z = fig5;
    EXPECT_THROW(eci::run(st, model, z, eci::run_span::until(1.0, 0.1), eci::no_observer{}, {.first_step = 11}),
                 std::invalid_argument);
    // a restart at the end itself: nothing to take, the state stays
    const auto none = eci::run(st, model, z, eci::run_span::until(1.0, 0.1), eci::no_observer{}, {.first_step = 10});
    EXPECT_EQ(z, fig5);
    EXPECT_EQ(none.stats.steps, 0u);
    EXPECT_EQ(none.t, 1.0);
}

TEST(Run, ObserverMaySeeTheMonitor) {
    const eci::three_wave model;
    tw_state x = fig5;
    eci::pc<tw_state> st;
    double last_energy = 0.0;
    const auto rep = eci::run(st, model, x, eci::run_span::until(1.0, 0.3),
                              [&](const tw_state&, double, std::uint64_t,
                                  const eci::invariant_monitor<eci::three_wave>& m) { last_energy = m.values()[0]; });
    EXPECT_EQ(last_energy, model.energy(x));
    EXPECT_EQ(rep.invariants[0].final, model.energy(x));
    EXPECT_EQ(rep.t, 1.0);
    EXPECT_EQ(rep.stats.steps, 4u);
}

// A run whose step underflows still reports its work: statistics and drifts up to the failure.
TEST(Run, UnderflowKeepsTheStatisticsOfThePartialRun) {
    const sliding_model model;
    std::vector<double> x{0.8, -0.6, 0.0};
    eci::c_pc<std::vector<double>> st;
    const auto rep = eci::run(st, model, x, eci::run_span::n_steps(8, 0.25), eci::no_observer{}, {.max_halvings = 12});
    ASSERT_FALSE(rep.completed());
    EXPECT_EQ(rep.failure->kind, eci::run_failure_kind::step_failed);
    EXPECT_EQ(rep.failure->t, 1.0);
    EXPECT_EQ(rep.failure->component, 2u);
    EXPECT_EQ(rep.failure->message.rfind("step failed at t = 1 in component x[2] even with the step halved 12 times",
                                         0),
              0u)
        << rep.failure->message;
    EXPECT_EQ(rep.stats.steps, 4u);            // t = 0.25 ... 1
    EXPECT_EQ(rep.stats.step_reductions, 12u);  // one failed attempt per halving level before giving up
    EXPECT_GE(rep.stats.rhs_evals, 2u * (4u + 13u));
    EXPECT_EQ(rep.t, 1.0);
    EXPECT_LE(rep.invariants[0].max_rel_drift(), 4.0 * eps * 2.0);  // 4 steps of round-off
    // The exception of the drivers carries the same statistics.
    std::vector<double> y{0.8, -0.6, 0.0};
    try {
        eci::integrate_n_steps(st, model, y, 0.0, 0.25, 8, eci::no_observer{}, {.max_halvings = 12});
        ADD_FAILURE() << "expected step_size_underflow";
    } catch (const eci::step_size_underflow& e) {
        EXPECT_EQ(e.stats.steps, rep.stats.steps);
        EXPECT_EQ(e.stats.step_reductions, rep.stats.step_reductions);
        EXPECT_EQ(e.stats.rhs_evals, rep.stats.rhs_evals);
        EXPECT_EQ(e.time, rep.failure->t);
        EXPECT_EQ(e.dt, rep.failure->dt);
        EXPECT_EQ(e.non_finite_rate_value, rep.failure->non_finite_rate_value);
    }
}

TEST(Run, SpanRejectsBadArguments) {
    EXPECT_THROW(eci::run_span::n_steps(3, 0.0), std::invalid_argument);
    EXPECT_THROW(eci::run_span::until(1.0, -0.1), std::invalid_argument);
    EXPECT_THROW(eci::run_span::until(-1.0, 0.1), std::invalid_argument);
    EXPECT_THROW(eci::run_span::until(std::numeric_limits<double>::infinity(), 0.1), std::invalid_argument);
    EXPECT_EQ(eci::run_span::until(0.3, 0.1).steps, 3u);
}

// step_with_reduction is the drivers' step: the same state and counts as integrate_n_steps, step by step.
TEST(StepWithReduction, IsTheDriversStep) {
    const eci::three_wave model;
    const tw_state start{std::sqrt(1.5), 0.0, std::sqrt(1.5)};  // psi_P = 0: C-PC reduces its first steps
    tw_state x = start, y = start;
    eci::c_pc<tw_state> a, b;
    eci::run_stats mine;
    for (int i = 0; i < 50; ++i) eci::step_with_reduction(a, model, x, 0.2 * i, 0.2, mine);
    const auto ref = eci::integrate_n_steps(b, model, y, 0.0, 0.2, 50);
    EXPECT_EQ(x, y);
    EXPECT_EQ(mine.steps, 50u);
    EXPECT_EQ(mine.step_reductions, ref.step_reductions);
    EXPECT_GT(mine.step_reductions, 0u);
    EXPECT_EQ(mine.rhs_evals, ref.rhs_evals);
}

// A failed whole step is handed to the controller from that failure (detail::attempt_whole_step, then
// fixed_control::run_after_failed): halved as the driver halves it, its failed attempts' evaluations counted once,
// a non-finite rate counted apart, and a bound of halvings kept. x' = -x with a rate that is NaN where an unknown is
// not positive (a logarithm's domain): an RK4 step of 2.5 from x > 0 reaches x (1 - 1.25) < 0 at its second stage,
// its halves of 1.25 stay positive.
namespace {
struct positive_decay {
    static constexpr bool reports_non_finite_rate = true;
    void operator()(const std::vector<double>& x, std::vector<double>& d, double) const {
        for (std::size_t i = 0; i < x.size(); ++i) {
            if (!(x[i] > 0.0)) throw eci::non_finite_rate{i, std::numeric_limits<double>::quiet_NaN()};
            d[i] = -x[i];
        }
    }
};
}  // namespace

TEST(StepWithReduction, AFailedStepIsHalvedAsTheDriverHalvesIt) {
    const positive_decay f;
    std::vector<double> x{1.0, 2.0}, y = x;
    eci::rk4<std::vector<double>> a, b;
    eci::run_stats mine;
    for (int i = 0; i < 4; ++i) eci::step_with_reduction(a, f, x, 2.5 * i, 2.5, mine);
    const auto ref = eci::integrate_n_steps(b, f, y, 0.0, 2.5, 4);
    EXPECT_EQ(x, y);
    EXPECT_EQ(ref.step_reductions, 4u);  // every step once
    EXPECT_EQ(mine.step_reductions, ref.step_reductions);
    EXPECT_EQ(mine.non_finite_rate_reductions, ref.non_finite_rate_reductions);
    EXPECT_EQ(mine.non_finite_rate_reductions, 4u);
    EXPECT_EQ(mine.rhs_evals, ref.rhs_evals);
    EXPECT_EQ(mine.rhs_evals, 4u * (2u + 4u + 4u));  // per step: the failed whole attempt's 2, the halves' 4 + 4
    // A step of 5 with one halving allowed: the whole step and its first half (2.5) fail at their second stage.
    // The underflow reports the half, and the statistics hold the reduction and the 2 + 2 evaluations.
    std::vector<double> z{1.0, 2.0};
    eci::run_stats bounded;
    try {
        eci::step_with_reduction(a, f, z, 0.0, 5.0, bounded, 1);
        ADD_FAILURE() << "the step of 5 with one halving should underflow";
    } catch (const eci::step_size_underflow& e) {
        ASSERT_TRUE(e.non_finite_rate_value);
        EXPECT_TRUE(std::isnan(*e.non_finite_rate_value));
        EXPECT_EQ(e.dt, 2.5);
        EXPECT_EQ(e.component, 0u);
        EXPECT_EQ(bounded.step_reductions, 1u);
        EXPECT_EQ(bounded.non_finite_rate_reductions, 1u);
        EXPECT_EQ(bounded.rhs_evals, 4u);
        EXPECT_EQ(e.stats.rhs_evals, 4u);
    }
    EXPECT_EQ(z, (std::vector<double>{1.0, 2.0}));  // no piece completed
}

// Carried state follows one contract: a run starts afresh (the driver calls reset()), a resumed run continues.
TEST(ResetContract, ReusedStepperEqualsAFreshOneAndSegmentsEqualOneRun) {
    const eci::three_wave model;
    eci::c_pc_compensated<tw_state> reused;
    tw_state other{1.0, -0.5, 0.25};
    eci::integrate_n_steps(reused, model, other, 0.0, 0.01, 1000);  // leaves residuals of another orbit
    tw_state x = fig5, y = fig5;
    eci::c_pc_compensated<tw_state> fresh;
    eci::integrate_n_steps(reused, model, x, 0.0, 0.01, 1000);
    eci::integrate_n_steps(fresh, model, y, 0.0, 0.01, 1000);
    EXPECT_EQ(x, y);
    // In segments with resume: the same bits as one run (the residual is carried across the segments).
    tw_state z = fig5;
    eci::c_pc_compensated<tw_state> seg;
    for (int k = 0; k < 4; ++k)
        eci::integrate_n_steps(seg, model, z, 2.5 * k, 0.01, 250, eci::no_observer{}, {.resume = k > 0});
    EXPECT_EQ(z, y);
    // The transformed engine follows the same contract.
    const eci::lotka_volterra lv;
    eci::transformed_pc<eci::lotka_volterra::transform> t1, t2;
    eci::lotka_volterra::state_type p{1.0, 0.4}, q{1.0, 0.4}, r{2.0, 0.7};
    eci::integrate_n_steps(t1, lv, r, 0.0, 0.02, 100);
    eci::integrate_n_steps(t1, lv, p, 0.0, 0.02, 100);
    eci::integrate_n_steps(t2, lv, q, 0.0, 0.02, 100);
    EXPECT_EQ(p, q);
}

// Odeint-style observers (x, t) work with both drivers.
TEST(Observers, TwoArgumentObserversAreAccepted) {
    const eci::three_wave model;
    tw_state x = fig5;
    eci::rk4<tw_state> st;
    std::vector<double> times;
    eci::integrate_to(st, model, x, 0.0, 0.25, 0.1, [&](const tw_state&, double t) { times.push_back(t); });
    EXPECT_EQ(times, (std::vector<double>{0.0, 0.1, 0.2, 0.25}));
    times.clear();
    eci::integrate_n_steps(st, model, x, 0.0, 0.1, 2, [&](const tw_state&, double t) { times.push_back(t); });
    EXPECT_EQ(times.size(), 3u);
}
