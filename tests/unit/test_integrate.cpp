// Unit tests of the drivers (integrate.hpp): landing on t_end, the observer's cadence and times, step reduction
// and its statistics, step_size_underflow with time and component, and argument checks.
#include <gtest/gtest.h>

#include <array>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <eci/eci.hpp>

#include "numeric/support.hpp"

namespace {

using namespace eci::test;
using state = std::array<double, 1>;

// x' = 1 with Euler: x is the time actually stepped, and the system records when it was called.
struct clock_system {
    std::vector<double>* calls;
    void operator()(const state&, state& d, double t) const {
        calls->push_back(t);
        d[0] = 1.0;
    }
};

struct observation {
    double t;
    std::uint64_t i;
};

TEST(IntegrateTo, LandsExactlyOnTheEndTimeWithAShortenedLastStep) {
    std::vector<double> calls;
    std::vector<observation> seen;
    state x{0.0};
    eci::euler<state> st;
    const auto stats = eci::integrate_to(st, clock_system{&calls}, x, 0.0, 1.0, 0.3,
                                         [&](const state&, double t, std::uint64_t i) { seen.push_back({t, i}); });
    EXPECT_EQ(stats.steps, 4u);
    EXPECT_EQ(calls, (std::vector<double>{0.0, 0.3, 0.6, 0.3 * 3.0}));  // step starts t0 + i dt, not accumulated
    EXPECT_NEAR(x[0] - 0.9, 0.1, 4 * eps) << "the last step is 0.1 long";
    ASSERT_FALSE(seen.empty());
    EXPECT_EQ(seen.back().t, 1.0);
    EXPECT_EQ(seen.back().i, 4u);
}

TEST(IntegrateTo, EndTimeThatIsAMultipleOfDtUpToRoundOffTakesNoExtraStep) {
    // 0.3 / 0.1 = 2.9999999999999996 and 3 * 0.1 = 0.30000000000000004: three steps, no sliver of a fourth,
    // and the observer still reports the requested end time itself.
    std::vector<double> calls;
    std::vector<observation> seen;
    state x{0.0};
    eci::euler<state> st;
    const auto stats = eci::integrate_to(st, clock_system{&calls}, x, 0.0, 0.3, 0.1,
                                         [&](const state&, double t, std::uint64_t i) { seen.push_back({t, i}); });
    EXPECT_EQ(stats.steps, 3u);
    EXPECT_EQ(calls.size(), 3u);
    ASSERT_EQ(seen.size(), 4u);
    EXPECT_EQ(seen.back().t, 0.3);
    EXPECT_EQ(seen.back().i, 3u);
}

TEST(IntegrateTo, EndTimeEqualToStartObservesOnce) {
    std::vector<double> calls;
    std::vector<observation> seen;
    state x{2.0};
    eci::rk4<state> st;
    const auto stats = eci::integrate_to(st, clock_system{&calls}, x, 1.5, 1.5, 0.1,
                                         [&](const state&, double t, std::uint64_t i) { seen.push_back({t, i}); });
    EXPECT_EQ(stats.steps, 0u);
    EXPECT_TRUE(calls.empty());
    ASSERT_EQ(seen.size(), 1u);
    EXPECT_EQ(seen[0].t, 1.5);
    EXPECT_EQ(x[0], 2.0);
}

TEST(Observer, SeesTheStartEveryKStepsAndTheEnd) {
    std::vector<double> calls;
    std::vector<observation> seen;
    state x{0.0};
    eci::pc<state> st;
    eci::integrate_n_steps(st, clock_system{&calls}, x, 2.0, 0.25, 10,
                           [&](const state&, double t, std::uint64_t i) { seen.push_back({t, i}); }, {.every = 3});
    const std::vector<std::uint64_t> expected{0, 3, 6, 9, 10};
    ASSERT_EQ(seen.size(), expected.size());
    for (std::size_t j = 0; j < seen.size(); ++j) {
        EXPECT_EQ(seen[j].i, expected[j]);
        EXPECT_EQ(seen[j].t, 2.0 + double(expected[j]) * 0.25);
    }
}

TEST(Observer, CadenceHoldsWithAShortenedLastStep) {
    std::vector<double> calls;
    std::vector<observation> seen;
    state x{0.0};
    eci::rk2<state> st;
    eci::integrate_to(st, clock_system{&calls}, x, 0.0, 1.05, 0.1,
                      [&](const state&, double t, std::uint64_t i) { seen.push_back({t, i}); }, {.every = 4});
    const std::vector<std::uint64_t> expected{0, 4, 8, 11};
    ASSERT_EQ(seen.size(), expected.size());
    for (std::size_t j = 0; j < seen.size(); ++j) EXPECT_EQ(seen[j].i, expected[j]);
    EXPECT_EQ(seen[1].t, 0.4);
    EXPECT_EQ(seen.back().t, 1.05);
}

// A run continued from step 7 (a restart) observes its first state, then the multiples of `every` on the grid's
// indices, then its end: the cadence is counted, not divided, at every step (detail::multiples_of).
TEST(Observer, CadenceIsOnTheGridsIndicesAfterARestart) {
    std::vector<double> calls;
    std::vector<observation> seen;
    state x{0.0};
    eci::rk4<state> st;
    eci::integrate_n_steps(st, clock_system{&calls}, x, 0.0, 0.5, 10,
                           [&](const state&, double, std::uint64_t i) { seen.push_back({0.0, i}); },
                           {.every = 3, .first_step = 7});
    const std::vector<std::uint64_t> expected{7, 9, 12, 15, 17};
    ASSERT_EQ(seen.size(), expected.size());
    for (std::size_t j = 0; j < seen.size(); ++j) EXPECT_EQ(seen[j].i, expected[j]);
}

// The grid t0 + k dt is exact up to k = 2^53 (the step index converts exactly): a run beyond it is refused before
// any step, the count compared as an integer (2^53 + 1 as a double is 2^53; first_step + n could wrap around).
// The last step of the 2^53 is taken, on the grid, from a restart at 2^53 - 1.
TEST(Observer, TheGridEndsAtStepTwoToThe53) {
    constexpr std::uint64_t most = std::uint64_t(1) << 53;
    std::vector<double> calls;
    std::vector<observation> seen;
    state x{0.0};
    eci::rk4<state> st;
    auto observe = [&](const state&, double t, std::uint64_t i) { seen.push_back({t, i}); };
    eci::integrate_n_steps(st, clock_system{&calls}, x, 0.0, 1.0, 1, observe, {.first_step = most - 1});
    ASSERT_EQ(seen.size(), 2u);
    EXPECT_EQ(seen.back().i, most);
    EXPECT_EQ(seen.back().t, 0x1p53);
    EXPECT_EQ(calls.front(), 0x1p53 - 1);  // the step's first stage, at the grid time of step 2^53 - 1
    const std::uint64_t top = std::numeric_limits<std::uint64_t>::max();
    for (const auto& [n, first] : {std::pair{most + 1, std::uint64_t{0}}, std::pair{std::uint64_t{1}, most},
                                   std::pair{top, std::uint64_t{2}}}) {
        calls.clear();
        EXPECT_THROW(eci::integrate_n_steps(st, clock_system{&calls}, x, 0.0, 1.0, n, eci::no_observer{},
                                            {.first_step = first}),
                     std::invalid_argument)
            << n << " from " << first;
        EXPECT_TRUE(calls.empty());
    }
    // integrate_to's count of steps beyond the integers saturates, and is refused alike
    EXPECT_THROW(eci::integrate_to(st, clock_system{&calls}, x, 0.0, 1.0, 1e-300), std::invalid_argument);
    EXPECT_TRUE(calls.empty());
}

TEST(Observer, MultiplesOfEveryAskedInTurn) {
    for (const std::uint64_t every : {std::uint64_t{1}, std::uint64_t{3}, std::uint64_t{7}}) {
        for (const std::uint64_t from : {std::uint64_t{0}, std::uint64_t{1}, std::uint64_t{5}, std::uint64_t{21}}) {
            eci::detail::multiples_of m(every, from);
            for (std::uint64_t i = from; i < from + 50; ++i) EXPECT_EQ(m.due(i), i % every == 0) << every << " " << i;
        }
    }
    // no multiple left below 2^64: never due (not a wrapped-around small index)
    const std::uint64_t top = std::numeric_limits<std::uint64_t>::max();
    eci::detail::multiples_of m(top / 2 + 1, top / 2 + 2);
    for (std::uint64_t i = top / 2 + 2; i < top / 2 + 100; ++i) EXPECT_FALSE(m.due(i));
    EXPECT_FALSE(eci::detail::multiples_of(top / 2 + 1, 1).due(1));
}

// A stepper that fails every attempt longer than `limit` and counts its attempts: with dt = 1 and limit 0.3,
// each step is tried at 1 (fails), twice at 0.5 (fail), four times at 0.25: 3 reductions and 7 attempts.
struct failing_above {
    static constexpr int order = 1;
    double limit;
    int attempts = 0;
    template <class F>
    eci::step_result step(F& f, state& x, double t, double dt) {
        ++attempts;
        state d{};
        f(x, d, t);
        if (dt > limit) return eci::step_result::failure(0);
        x[0] += dt * d[0];
        return eci::step_result::success();
    }
};

TEST(RunStats, CountsStepsReductionsAndEvaluations) {
    std::vector<double> calls;
    failing_above st{0.3};
    state x{0.0};
    const auto stats = eci::integrate_n_steps(st, clock_system{&calls}, x, 0.0, 1.0, 5);
    EXPECT_EQ(stats.steps, 5u);
    EXPECT_EQ(stats.step_reductions, 15u);
    EXPECT_EQ(stats.rhs_evals, 35u) << "failed attempts count too";
    EXPECT_EQ(st.attempts, 35);
    EXPECT_NEAR(x[0], 5.0, 64 * eps) << "the reduced steps still cover the whole interval";
    // The attempts of the first step: 1 at t = 0, 0.5 at 0, 0.25 at 0 and 0.25, 0.5 at 0.5, 0.25 at 0.5 and 0.75.
    EXPECT_EQ(std::vector<double>(calls.begin(), calls.begin() + 7),
              (std::vector<double>{0.0, 0.0, 0.0, 0.25, 0.5, 0.5, 0.75}));
    EXPECT_EQ(calls[7], 1.0);
}

TEST(RunStats, CountsEvaluationsOfRealSteppersAndImplicitSolves) {
    std::vector<double> calls;
    state x{0.0};
    eci::c_rk4<state> rk;
    EXPECT_EQ(eci::integrate_n_steps(rk, clock_system{&calls}, x, 0.0, 0.1, 7).rhs_evals, 28u);
    // C-Euler: one evaluation per explicit step, plus one per fixed-point iteration of each implicit step; a
    // rotation starting with a zero component needs implicit steps at every crossing.
    const auto rotation = [](const std::vector<double>& v, std::vector<double>& d, double) {
        d[0] = v[1];
        d[1] = -v[0];
    };
    std::vector<double> y{1.0, 0.0};
    eci::c_euler<std::vector<double>> ce;
    const auto s = eci::integrate_n_steps(ce, rotation, y, 0.0, 0.01, 1000);
    EXPECT_GT(s.solver.solves, 2u);
    EXPECT_EQ(s.rhs_evals, s.steps + s.step_reductions + s.solver.iterations);
    EXPECT_LE(s.solver.max_iterations, ce.max_iterations);
}

// x2' = -sgn(x2) (sign of 0 taken as -1) switched on at t = 1: from x2 = 0 every conservative method then asks
// for psi_2^2 < 0 at any step size, so the driver halves down to dt 2^-max_halvings and gives up at t = 1 exactly.
// (Before t = 1, x2 = 0 with rate 0 is a valid state, and a stage at t = 1 alone only makes a zero radicand.)
struct sliding_after_one {
    void operator()(const std::vector<double>& x, std::vector<double>& d, double t) const {
        d[0] = x[1], d[1] = -x[0];
        d[2] = t < 1.0 ? 0.0 : x[2] <= 0.0 ? 1.0 : -1.0;
    }
};

template <class Method>
void expect_underflow() {
    std::vector<double> x{0.8, -0.6, 0.0};
    typename Method::template stepper<std::vector<double>> st;
    try {
        eci::integrate_n_steps(st, sliding_after_one{}, x, 0.0, 0.25, 8, eci::no_observer{}, {.max_halvings = 12});
        ADD_FAILURE() << Method::name << ": expected step_size_underflow";
    } catch (const eci::step_size_underflow& e) {
        EXPECT_EQ(e.time, 1.0) << Method::name;
        EXPECT_EQ(e.component, 2u) << Method::name;
        EXPECT_EQ(e.dt, 0.25 * std::ldexp(1.0, -12)) << Method::name;
        const std::string what = e.what();
        EXPECT_NE(what.find("t = 1 "), std::string::npos) << what;
        EXPECT_NE(what.find("component 2"), std::string::npos) << what;
    }
}

TEST(StepSizeUnderflow, ThrownWithTimeAndComponentAfterMaxHalvings) {
    expect_underflow<c_euler_m>();
    expect_underflow<c_pc_m>();
    expect_underflow<c_rk2_m>();
    expect_underflow<c_rk4_m>();
}

TEST(StepSizeUnderflow, DefaultAllowsFortyHalvings) {
    std::vector<double> x{0.8, -0.6, 0.0};
    eci::c_pc<std::vector<double>> st;
    try {
        eci::integrate_n_steps(st, sliding_after_one{}, x, 0.0, 0.25, 8);
        ADD_FAILURE() << "expected step_size_underflow";
    } catch (const eci::step_size_underflow& e) {
        EXPECT_EQ(e.dt, 0.25 * std::ldexp(1.0, -40));
    }
}

// A conventional stepper keeps a few real unknowns (std::array<double, n>) in registers through a fixed-step run:
// the run steps a copy held by its loop and writes it back after every accepted attempt. The run must be the
// general engine's bit for bit, through halvings, observations and a cancellation: the same system on a
// std::vector is stepped by the general engine.
struct fails_at_call {  // the coupled triad x0' = x1 x2, x1' = -2 x2 x0, x2' = x0 x1; evaluation `bad` gives inf
    int* calls;
    int bad;
    std::atomic<bool>* cancel_at_200 = nullptr;
    template <class S>
    void operator()(const S& x, S& d, double) const {
        d[0] = x[1] * x[2];
        d[1] = -2.0 * x[2] * x[0];
        d[2] = x[0] * x[1];
        if (++*calls == bad) d[1] = std::numeric_limits<double>::infinity();
        if (cancel_at_200 && *calls == 200) cancel_at_200->store(true);
    }
};

template <template <class> class Stepper>
void expect_registers_match_the_general_engine() {
    using arr = std::array<double, 3>;
    using vec = std::vector<double>;
    static_assert(Stepper<arr>::template in_registers<const eci::detail::counting_system<fails_at_call>>);
    static_assert(!Stepper<vec>::template in_registers<const eci::detail::counting_system<fails_at_call>>);
    int ca = 0, cv = 0;
    arr a{0.9, -0.4, 0.3};
    vec v(a.begin(), a.end());
    std::vector<arr> seen_a;
    std::vector<vec> seen_v;
    Stepper<arr> sa;
    Stepper<vec> sv;
    // evaluation 30 fails a step: it is taken as two halves, whose pieces are observed as one step
    const auto ra = eci::integrate_n_steps(sa, fails_at_call{&ca, 30}, a, 0.0, 0.05, 40,
                                           [&](const arr& x, double, std::uint64_t) { seen_a.push_back(x); });
    const auto rv = eci::integrate_n_steps(sv, fails_at_call{&cv, 30}, v, 0.0, 0.05, 40,
                                           [&](const vec& x, double, std::uint64_t) { seen_v.push_back(x); });
    EXPECT_GE(ra.step_reductions, 1u);
    EXPECT_EQ(ra.step_reductions, rv.step_reductions);
    EXPECT_EQ(ra.rhs_evals, rv.rhs_evals);
    ASSERT_EQ(seen_a.size(), 41u);
    ASSERT_EQ(seen_a.size(), seen_v.size());
    for (std::size_t k = 0; k < seen_a.size(); ++k)
        for (std::size_t i = 0; i < 3; ++i) ASSERT_EQ(seen_a[k][i], seen_v[k][i]) << "step " << k << " element " << i;
    EXPECT_EQ(vec(a.begin(), a.end()), v) << "the run's state is the last one observed";

    // Cancelled inside a step: the state is the last one completed, as with the general engine.
    std::atomic<bool> stop_a{false}, stop_v{false};
    ca = cv = 0;
    a = {0.9, -0.4, 0.3};
    v.assign(a.begin(), a.end());
    EXPECT_THROW(eci::integrate_n_steps(sa, fails_at_call{&ca, -1, &stop_a}, a, 0.0, 0.05, 1000, eci::no_observer{},
                                        {.cancel = &stop_a}),
                 eci::interrupted);
    EXPECT_THROW(eci::integrate_n_steps(sv, fails_at_call{&cv, -1, &stop_v}, v, 0.0, 0.05, 1000, eci::no_observer{},
                                        {.cancel = &stop_v}),
                 eci::interrupted);
    EXPECT_EQ(ca, cv);
    EXPECT_EQ(vec(a.begin(), a.end()), v);
    EXPECT_NE(v, vec({0.9, -0.4, 0.3})) << "steps were taken before the cancellation";
}

TEST(Integrate, ASmallRealStateInRegistersRunsAsTheGeneralEngine) {
    expect_registers_match_the_general_engine<eci::euler>();
    expect_registers_match_the_general_engine<eci::pc>();
    expect_registers_match_the_general_engine<eci::rk2>();
    expect_registers_match_the_general_engine<eci::rk4>();
    // the conservative engine: its paper's update in registers, a failed update finished by the general engine
    expect_registers_match_the_general_engine<eci::c_pc>();
    expect_registers_match_the_general_engine<eci::c_rk2>();
    expect_registers_match_the_general_engine<eci::c_rk4>();
}

// The conservative engine's register path hands a step with a negative radicand to the general finish (its remedy
// when the model's quadratic invariants allow one, else a failed step that is halved): the same bits, reductions
// and remedy counts as a std::vector run.
struct rotating_pair {  // x0' = x1, x1' = -x0 (and x2' = 0): the amplitudes cross zero, invariant x0^2 + x1^2
    int* calls;
    template <class S>
    void operator()(const S& x, S& d, double) const {
        ++*calls;
        d[0] = x[1];
        d[1] = -x[0];
        d[2] = 0.0;
    }
    eci::quadratic_weights quadratic_invariant_weights() const { return {{1.0, 1.0, 0.0}, {0.0, 0.0, 1.0}}; }
};

template <template <class> class Stepper>
void expect_negative_radicands_as_the_general_engine() {
    for (double dt : {0.5, 0.7}) {
        int ca = 0, cv = 0;
        std::array<double, 3> a{1.0, 0.0, 0.5};
        std::vector<double> v(a.begin(), a.end());
        Stepper<std::array<double, 3>> sa;
        Stepper<std::vector<double>> sv;
        const auto ra = eci::integrate_n_steps(sa, rotating_pair{&ca}, a, 0.0, dt, 100);
        const auto rv = eci::integrate_n_steps(sv, rotating_pair{&cv}, v, 0.0, dt, 100);
        EXPECT_GT(ra.step_reductions + ra.remedied_steps, 0u) << "negative radicands were met, dt " << dt;
        EXPECT_EQ(ra.remedied_steps, rv.remedied_steps);
        EXPECT_EQ(ra.components_remedied, rv.components_remedied);
        EXPECT_EQ(ra.step_reductions, rv.step_reductions);
        EXPECT_EQ(ra.rhs_evals, rv.rhs_evals);
        EXPECT_EQ(ca, cv);
        EXPECT_EQ(std::vector<double>(a.begin(), a.end()), v) << "dt " << dt;
    }
}

TEST(Integrate, ANegativeRadicandInRegistersIsTheGeneralEnginesStep) {
    expect_negative_radicands_as_the_general_engine<eci::c_pc>();
    expect_negative_radicands_as_the_general_engine<eci::c_rk2>();
    expect_negative_radicands_as_the_general_engine<eci::c_rk4>();
}

TEST(Integrate, RejectsBadArguments) {
    std::vector<double> calls;
    state x{0.0};
    eci::euler<state> st;
    const clock_system f{&calls};
    const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
    for (double dt : {0.0, -0.1, nan, inf}) {
        EXPECT_THROW(eci::integrate_n_steps(st, f, x, 0.0, dt, 3), std::invalid_argument) << dt;
        EXPECT_THROW(eci::integrate_to(st, f, x, 0.0, 1.0, dt), std::invalid_argument) << dt;
    }
    EXPECT_THROW(eci::integrate_to(st, f, x, 1.0, 0.5, 0.1), std::invalid_argument);
    EXPECT_THROW(eci::integrate_to(st, f, x, 0.0, nan, 0.1), std::invalid_argument);
    EXPECT_THROW(eci::integrate_n_steps(st, f, x, 0.0, 0.1, 3, eci::no_observer{}, {.every = 0}), std::invalid_argument);
    EXPECT_TRUE(calls.empty());
    EXPECT_EQ(x[0], 0.0);
}

}  // namespace
