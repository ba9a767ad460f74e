// Unit tests of eci::solve's settings (solve.hpp): bad settings refused before any step with the front ends'
// messages, initial states beyond double precision, the method resolver's messages, cancellation between steps,
// output_dt and the tolerance defaults. (Its runs and failures: test_solve.cpp.)
#include <gtest/gtest.h>

#include <array>
#include <atomic>
#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

#include <eci/memory.hpp>
#include <eci/models/kepler.hpp>
#include <eci/models/kepler_cartesian.hpp>
#include <eci/models/n_wave.hpp>

#include "solve_tests.hpp"

using namespace solve_tests;

TEST(Solve, BadSettingsAreRefusedBeforeAnyStep) {
    const eci::three_wave model;
    tw_state x = fig5;
    auto message = [&](eci::run_config cfg, const char* method = "rk4") {
        tw_state y = x;
        discard<tw_state> none;
        try {
            eci::solve_model<eci::three_wave>(model, y, method, cfg, none, {}, "model three-wave");
        } catch (const std::invalid_argument& e) {
            return std::string(e.what());
        }
        return std::string("accepted");
    };
    eci::run_config ok;
    ok.t_end = 1.0;
    ok.dt = 0.1;
    EXPECT_EQ(message(ok), "accepted");
    EXPECT_EQ(message(ok, "rk5").rfind("unknown method 'rk5' (methods: ", 0), 0u);
    EXPECT_EQ(message(ok, "kahan").rfind("method 'kahan' is not available for model three-wave (available: euler, ", 0),
              0u);
    eci::run_config a = ok;
    a.adaptive = eci::adaptive_options{};
    EXPECT_EQ(message(a, "c-rk4").rfind("method c-rk4 has no error estimate for rtol/atol; adaptive methods for "
                                        "model three-wave: ", 0),
              0u);
    eci::run_config zero = ok;
    zero.dt = 0.0;
    EXPECT_EQ(message(zero), "time step must be a positive finite number");
    eci::run_config times = ok;
    times.times = {0.5, 0.2};
    EXPECT_EQ(message(times), "output times must be finite, sorted in the direction of the run and within the span");
    EXPECT_EQ(x, fig5);
}

// Whoever calls the run (a C++ user, not only the CLI and Python, which check first in their own words), the model's
// parameters, a finite state and the model's domain and size are checked before any step: a state of 5 elements
// for an n-wave model of 8 modes corrupted the heap, a three-wave M violating eq. (2) ran 133 steps to energy 7e142,
// Kepler's r = -1 and a NaN component ran 40 halvings to a "step failed" naming another component. The run's
// settings likewise: dt_min above dt_max, max_halvings out of range, max_substeps 0.
TEST(Solve, TheModelAndTheInitialStateAreCheckedBeforeAnyStep) {
    eci::run_config cfg;
    cfg.t_end = 1.0;
    cfg.dt = 0.1;
    const auto refusal = [](auto&& run) {
        try {
            run();
        } catch (const std::invalid_argument& e) {
            return std::string(e.what());
        }
        return std::string("accepted");
    };
    eci::three_wave bad;
    bad.M = {1.0, 1.0, 1.0};
    tw_state y = fig5;
    EXPECT_EQ(refusal([&] {
                  discard<tw_state> none;
                  eci::solve_model<eci::three_wave>(bad, y, "c-pc", cfg, none, {}, "model three-wave");
              }).rfind("invalid model three-wave: M_K + M_P + M_Q (eq. 2)", 0),
              0u);
    EXPECT_EQ(y, fig5);
    const auto waves = eci::n_wave<double>::random(8, 2, 1);
    vec short_state(5, 0.1);
    EXPECT_EQ(refusal([&] {
                  discard<vec> none;
                  eci::solve_model<eci::n_wave<double>>(waves, short_state, "c-rk4", cfg, none, {}, "model n-wave");
              }),
              "invalid initial condition: the state has 5 elements and the n-wave model 8 modes");
    eci::kepler orbit;
    eci::kepler::state_type inside_out{-1.0, 0.0, 0.0};
    eci::rk4<eci::kepler::state_type> rk4k;
    EXPECT_EQ(refusal([&] { eci::run(rk4k, orbit, inside_out, eci::run_span::n_steps(10, 0.01)); }),
              "invalid initial condition: Kepler r must be positive, got -1");
    const auto decay = [](const vec& x, vec& d, double) {
        for (std::size_t i = 0; i < x.size(); ++i) d[i] = -x[i];
    };
    vec z{1.0, std::numeric_limits<double>::quiet_NaN(), 0.25};
    eci::rk4<vec> rk4v;
    EXPECT_EQ(refusal([&] { eci::solve_with(rk4v, decay, z, cfg, eci::no_sink{}); }),
              "initial condition x[1] is not finite");
    vec w{1.0, 0.5};
    eci::run_config adaptive = cfg;
    adaptive.adaptive = eci::adaptive_options{};
    adaptive.adaptive->dt_min = 1.0;
    adaptive.adaptive->dt_max = 0.1;
    eci::dp54<vec> dp;
    EXPECT_EQ(refusal([&] { eci::solve_with(dp, decay, w, adaptive, eci::no_sink{}); }),
              "dt_min 1 exceeds dt_max 0.1");
    for (const int halvings : {-1, 1075}) {
        eci::run_config h = cfg;
        h.max_halvings = halvings;
        EXPECT_EQ(refusal([&] { eci::solve_with(rk4v, decay, w, h, eci::no_sink{}); }),
                  "max_halvings must be from 0 to 1074, not " + std::to_string(halvings));
    }
    eci::run_config sub = cfg;
    sub.max_substeps = 0;
    EXPECT_EQ(refusal([&] { eci::solve_with(rk4v, decay, w, sub, eci::no_sink{}); }),
              "max_substeps must be at least 1");
    EXPECT_EQ(w, (vec{1.0, 0.5}));
}

TEST(Solve, InitialStatesBeyondDoublePrecisionAreRefusedNamingTheComponent) {
    // A model with no domain check of its own (three-wave's validate_state catches subnormal values first).
    struct product {
        using state_type = std::array<double, 2>;
        void operator()(const state_type& x, state_type& d, double) const { d[0] = x[1] * x[1] * x[1], d[1] = -x[0]; }
        double energy(const state_type& x) const { return x[0] * x[0] + x[1] * x[1]; }
        static constexpr auto invariants() {
            return std::array<eci::named_invariant<product>, 1>{{{"energy", &product::energy}}};
        }
    };
    auto message = [&](product::state_type x) {
        try {
            eci::check_initial_state(product{}, x, [](std::size_t i) {
                std::string name = "u";  // appended: GCC 12 warns falsely (-Wrestrict) on "u" + std::to_string(i)
                return name.append(std::to_string(i));
            });
        } catch (const std::invalid_argument& e) {
            return std::string(e.what());
        }
        return std::string("accepted");
    };
    EXPECT_EQ(message({1.0, 2.0}), "accepted");
    EXPECT_EQ(message({1.0, std::nan("")}), "initial condition u1 is not finite");
    const std::string subnormal = message({1.0, 1e-310});
    EXPECT_EQ(subnormal.rfind("initial condition u1 = ", 0), 0u) << subnormal;
    EXPECT_NE(subnormal.find(" is subnormal (below 2.2e-308)"), std::string::npos) << subnormal;
    EXPECT_EQ(message({1e200, 1.0}).rfind("the initial energy is inf", 0), 0u);
    // the energy is finite, the rate u1^3 is not
    EXPECT_EQ(message({1.0, 1e103}).rfind("the rate of u0 overflows at the initial condition", 0), 0u)
        << message({1.0, 1e103});
    // without names: x[i]
    EXPECT_THROW(eci::check_initial_state(product{}, product::state_type{1.0, 1e-310}, {}), std::invalid_argument);
}

TEST(Solve, ACancelFlagStopsTheRunBetweenSteps) {
    const eci::three_wave model;
    tw_state x = fig5;
    std::atomic<bool> cancel{false};
    eci::run_config cfg;
    cfg.t_end = 100.0;
    cfg.dt = 0.01;
    cfg.cancel = &cancel;
    struct stop_after_10 final : eci::dynamic_sink<tw_state> {
        explicit stop_after_10(std::atomic<bool>* f) : flag(f) {}
        std::atomic<bool>* flag;
        void output(const tw_state&, const eci::output_point&) override {}
        void progress(double, std::uint64_t i) override {
            if (i == 10) flag->store(true);
        }
    } sink(&cancel);
    EXPECT_THROW(eci::solve_model<eci::three_wave>(model, x, "rk4", cfg, sink), eci::interrupted);
}

// The default minimum step is the resolution of time where the run is, not at its end: a tight
// tolerance over a long horizon runs (here until its attempt budget) instead of stopping at the start.
TEST(Solve, ALongHorizonDoesNotRaiseTheMinimumStep) {
    vec x{1.0, 0.0};
    auto rotation = [](const vec& y, vec& d, double) { d[0] = y[1], d[1] = -y[0]; };
    eci::run_config cfg;
    cfg.t_end = 1e13;  // 64 eps 1e13 = 0.14: the old floor, far above the steps (~0.02) rtol 1e-12 needs
    cfg.dt = 1e-3;
    cfg.adaptive = eci::adaptive_options{.rtol = 1e-12, .atol = 1e-12, .max_attempts = 2000};
    eci::dp54<vec> dp54;  // the run of solve(..., "dp54", ...) on its stepper
    const auto r = eci::solve_with(dp54, rotation, x, cfg, eci::no_sink{});
    ASSERT_FALSE(r.completed());
    EXPECT_EQ(r.failure->kind, eci::run_failure_kind::too_many_steps) << r.failure->message;
    EXPECT_GT(r.failure->t, 1.0);
    EXPECT_LT(r.adaptive->dt_largest, 0.14);
}

// --output-dt is the library's decision (resolve_output_dt), for the CLI and Python alike: output times for an
// adaptive run, every k steps for fixed steps, and one-line refusals naming the settings as the front end does.
TEST(Solve, OutputDtIsOutputTimesWhenAdaptiveAndEveryKStepsWhenFixed) {
    eci::run_config fixed;
    fixed.t_end = 1.0;
    fixed.dt = 0.01;
    fixed.output_dt = 0.25;
    eci::resolve_output_dt(fixed);
    EXPECT_EQ(fixed.every, 25u);
    EXPECT_TRUE(fixed.times.empty());
    EXPECT_FALSE(fixed.output_dt.has_value());

    eci::run_config adaptive;
    adaptive.t_end = 1.1;
    adaptive.dt = 0.01;
    adaptive.adaptive = eci::adaptive_options{};
    adaptive.output_dt = 0.25;
    eci::resolve_output_dt(adaptive);
    EXPECT_EQ(adaptive.times, (vec{0.0, 0.25, 0.5, 0.75, 1.0, 1.1}));
    EXPECT_EQ(adaptive.every, 1u);

    // a time within 1e-12 of the span before the end is the end, written once
    eci::run_config near = adaptive;
    near.times.clear();
    near.t_end = 1.0 + 1e-14;
    near.output_dt = 0.5;
    eci::resolve_output_dt(near);
    EXPECT_EQ(near.times, (vec{0.0, 0.5, 1.0 + 1e-14}));

    // backward in time (adaptive only), from t0 = 2
    eci::run_config back = adaptive;
    back.times.clear();
    back.t0 = 2.0;
    back.t_end = 1.0;
    back.output_dt = 0.5;
    eci::resolve_output_dt(back);
    EXPECT_EQ(back.times, (vec{2.0, 1.5, 1.0}));

    // a step count: the span is steps * dt
    eci::run_config counted;
    counted.steps = 500;
    counted.dt = 0.02;
    counted.output_dt = 0.1;
    eci::resolve_output_dt(counted);
    EXPECT_EQ(counted.every, 5u);

    // solve resolves it too: the outputs of a fixed-step run are those of every = 25
    const eci::three_wave model;
    tw_state a = fig5, b = fig5;
    fixed.output_dt = 0.25;
    fixed.every = 1;
    keep_all<tw_state> by_dt, by_every;
    eci::solve_model<eci::three_wave>(model, a, "c-rk4", fixed, by_dt);
    fixed.output_dt.reset();
    fixed.every = 25;
    eci::solve_model<eci::three_wave>(model, b, "c-rk4", fixed, by_every);
    EXPECT_EQ(by_dt.t, (vec{0.0, 0.25, 0.5, 0.75, 1.0}));
    EXPECT_EQ(by_dt.t, by_every.t);
    EXPECT_EQ(by_dt.x, by_every.x);
}

TEST(Solve, OutputDtRefusalsNameTheSettingsAsTheFrontEndDoes) {
    auto message = [](eci::run_config c, const eci::setting_names& names) {
        try {
            eci::resolve_output_dt(c, names);
        } catch (const std::invalid_argument& e) {
            return std::string(e.what());
        }
        return std::string("accepted");
    };
    const eci::setting_names cli{.output_dt = "--output-dt", .dt = "--dt", .tolerances = "--rtol/--atol"};
    eci::run_config c;
    c.t_end = 1.0;
    c.dt = 0.03;
    c.output_dt = 0.25;
    EXPECT_EQ(message(c, cli), "--output-dt 0.25 is not a multiple of --dt 0.03 (with fixed steps; --rtol/--atol "
                               "lifts that)");
    EXPECT_EQ(message(c, {}), "output_dt 0.25 is not a multiple of dt 0.03 (with fixed steps; rtol/atol lifts that)");
    c.adaptive = eci::adaptive_options{};
    EXPECT_EQ(message(c, cli), "accepted");  // adaptive control lifts it
    c.output_dt = 1e-7;
    c.t_end = 10.0;
    EXPECT_EQ(message(c, cli), "--output-dt 1e-07 to t = 10 asks for 100000000 rows, more than 10^7: give a "
                               "larger --output-dt");  // (numbers as Python's repr lays them out: eci/format.hpp)
    for (double bad : {0.0, -1.0, std::numeric_limits<double>::infinity(), std::nan("")}) {
        c.output_dt = bad;
        EXPECT_EQ(message(c, cli).rfind("--output-dt must be a positive finite number, not ", 0), 0u) << bad;
    }
    c.output_dt = 0.5;
    c.times = {0.0, 1.0};
    EXPECT_EQ(message(c, {}), "output_dt and output times exclude each other: give one of them");
    // a multiple within 1e-9 k of a whole number of steps: 0.3 / 0.1 is 2.9999999999999996
    eci::run_config f;
    f.t_end = 1.0;
    f.dt = 0.1;
    f.output_dt = 0.3;
    EXPECT_EQ(message(f, {}), "accepted");
    f.output_dt = 0.3 + 1e-6;
    EXPECT_NE(message(f, {}), "accepted");
    f.output_dt = 0.05;  // less than one step
    EXPECT_NE(message(f, {}), "accepted");
    // solve refuses with the default (Python's) names before any step
    const eci::three_wave model;
    tw_state x = fig5;
    f.output_dt = 0.25;
    discard<tw_state> none;
    try {
        eci::solve_model<eci::three_wave>(model, x, "c-rk4", f, none);
        ADD_FAILURE() << "accepted";
    } catch (const std::invalid_argument& e) {
        EXPECT_STREQ(e.what(), "output_dt 0.25 is not a multiple of dt 0.1 (with fixed steps; rtol/atol lifts that)");
    }
    EXPECT_EQ(x, fig5);
}

TEST(Solve, AToleranceNotGivenTakesTheOthersValue) {
    EXPECT_FALSE(eci::tolerances_from(std::nullopt, std::nullopt).has_value());
    const auto r = eci::tolerances_from(1e-8, std::nullopt);
    ASSERT_TRUE(r.has_value());
    EXPECT_EQ(r->rtol, 1e-8);
    EXPECT_EQ(r->atol, 1e-8);
    const auto a = eci::tolerances_from(std::nullopt, 1e-5);
    EXPECT_EQ(a->rtol, 1e-5);
    EXPECT_EQ(a->atol, 1e-5);
    const auto both = eci::tolerances_from(1e-6, 1e-9);
    EXPECT_EQ(both->rtol, 1e-6);
    EXPECT_EQ(both->atol, 1e-9);
}

TEST(Solve, ABadToleranceIsNamedAsGivenWithItsValue) {
    // atol alone: rtol takes its value, but the message names atol, the setting the user gave
    const std::vector<std::tuple<std::optional<double>, std::optional<double>, std::string>> cases{
        {std::nullopt, std::numeric_limits<double>::quiet_NaN(), "atol must be a finite number >= 0, not nan"},
        {std::nullopt, -1.0, "atol must be a finite number >= 0, not -1"},
        {-1e-6, std::nullopt, "rtol must be a finite number >= 0, not -1e-06"},
        {1e-6, std::numeric_limits<double>::infinity(), "atol must be a finite number >= 0, not inf"},
    };
    for (const auto& [rtol, atol, message] : cases) {
        try {
            (void)eci::tolerances_from(rtol, atol);
            ADD_FAILURE() << "accepted " << message;
        } catch (const std::invalid_argument& e) {
            EXPECT_EQ(e.what(), message);
        }
    }
    eci::adaptive_options o;
    o.atol = -2.0;
    try {
        eci::check_adaptive_options(o, 3);
        ADD_FAILURE() << "accepted atol -2";
    } catch (const std::invalid_argument& e) {
        EXPECT_STREQ(e.what(), "atol must be a finite number >= 0, not -2");
    }
}

// An rtol below 100 eps (the error estimate's round-off) is raised to it, scalar and per component, as SciPy's
// solve_ivp does; the front ends warn when raise_rtol says it raised one.
TEST(Solve, AnRtolBelowHundredEpsIsRaisedToIt) {
    const double eps = std::numeric_limits<double>::epsilon();
    EXPECT_EQ(eci::min_rtol, 100 * eps);
    eci::adaptive_options o;
    o.rtol = 1e-30;
    EXPECT_TRUE(eci::raise_rtol(o));
    EXPECT_EQ(o.rtol, 100 * eps);
    EXPECT_FALSE(eci::raise_rtol(o));  // at the floor: kept, nothing to say
    o.rtol = 0.0;
    EXPECT_TRUE(eci::raise_rtol(o));
    EXPECT_EQ(o.rtol, 100 * eps);
    o.rtol = 1e-9;
    o.rtol_each = {1e-6, 0.0, 3e-15};
    EXPECT_TRUE(eci::raise_rtol(o));
    EXPECT_EQ(o.rtol, 1e-9);
    EXPECT_EQ(o.rtol_each, (std::vector<double>{1e-6, 100 * eps, 100 * eps}));
    o.rtol_each = {1e-6, 1e-8};
    EXPECT_FALSE(eci::raise_rtol(o));
    EXPECT_EQ(o.rtol_each, (std::vector<double>{1e-6, 1e-8}));
}

// A first step the user gives is positive, finite and within the span, in either direction, named as the front end
// names it.
TEST(Solve, AGivenFirstStepLiesWithinTheSpan) {
    EXPECT_NO_THROW(eci::check_first_step(1.0, 0.0, 1.0, "first_step"));
    EXPECT_NO_THROW(eci::check_first_step(0.5, 2.0, 1.0, "first_step"));
    const std::vector<std::tuple<double, double, double, std::string>> cases{
        {10.0, 0.0, 1.0, "--dt 10 exceeds the span of the run, 1"},
        {1.5, 2.0, 1.0, "--dt 1.5 exceeds the span of the run, 1"},
        {0.01, 0.0, 0.0, "--dt 0.01 exceeds the span of the run, 0"},
        {0.0, 0.0, 1.0, "--dt must be a positive finite number, not 0"},
        {std::numeric_limits<double>::quiet_NaN(), 0.0, 1.0, "--dt must be a positive finite number, not nan"},
    };
    for (const auto& [h, t0, t1, message] : cases) {
        try {
            eci::check_first_step(h, t0, t1, "--dt");
            ADD_FAILURE() << "accepted " << message;
        } catch (const std::invalid_argument& e) {
            EXPECT_EQ(e.what(), message);
        }
    }
}

// Beyond 2^53 fixed steps the grid t0 + i dt is no longer exact: refused, the count compared as an integer (as a
// double 2^53 + 1 reads as 2^53, and a restart's first step plus its steps could wrap around). The accepted edges
// take one step: the last of the 2^53, from a restart at step 2^53 - 1.
TEST(Solve, MoreThanTwoToThe53StepsAreRefused) {
    const eci::three_wave model;
    constexpr std::uint64_t most = std::uint64_t(1) << 53;
    auto message = [&](eci::run_config cfg) {
        tw_state y = fig5;
        discard<tw_state> none;
        try {
            eci::solve_model<eci::three_wave>(model, y, "rk4", cfg, none);
        } catch (const std::invalid_argument& e) {
            return std::string(e.what());
        }
        return std::string("accepted");
    };
    auto by_steps = [](std::uint64_t steps, std::uint64_t first) {
        eci::run_config c;
        c.dt = 1.0;  // (every grid time a double up to 2^53: see GridTimesThatRoundAwayFromTheStepsAreRefused)
        c.steps = steps;
        c.first_step = first;
        return c;
    };
    EXPECT_EQ(message(by_steps(1, most - 1)), "accepted");
    EXPECT_EQ(message(by_steps(most + 1, 0)), "steps 9007199254740993 is too many (at most 2^53)");
    EXPECT_EQ(message(by_steps(1, most)), "steps 1 from step 9007199254740992 is too many (at most 2^53)");
    EXPECT_EQ(message(by_steps(std::numeric_limits<std::uint64_t>::max(), 2)),  // (the sum wraps around to 1)
              "steps 18446744073709551615 from step 2 is too many (at most 2^53)");
    auto by_end = [](double t_end, double dt, std::uint64_t first) {
        eci::run_config c;
        c.t_end = t_end;
        c.dt = dt;
        c.first_step = first;
        return c;
    };
    EXPECT_EQ(message(by_end(0x1p53, 1.0, most - 1)), "accepted");
    EXPECT_EQ(message(by_end(0x1p53 + 2, 1.0, most - 1)), "(t_end - t0) / dt is 9007199254740994 steps, too many (at "
                                                          "most 2^53)");
    EXPECT_EQ(message(by_end(1.0, 1e-20, 0)), "(t_end - t0) / dt is 1e+20 steps, too many (at most 2^53)");
    // the count itself saturates where it exceeds the integers (converting it would be undefined)
    EXPECT_EQ(eci::steps_to_reach(0.0, 1.0, 1e-300), std::numeric_limits<std::uint64_t>::max());
    EXPECT_EQ(eci::steps_to_reach(0.0, 0x1p53, 1.0), most);
    EXPECT_EQ(eci::steps_to_reach(0.0, 1e15, 1.0), std::uint64_t(1e15));  // (not one fewer, its last step 2 long)
    EXPECT_EQ(eci::last_step_to_reach(0.0, 1e15, 1.0, std::uint64_t(1e15)), 1.0);
    EXPECT_EQ(eci::steps_to_reach(0.0, 0.3, 0.1), 3u);  // a remainder at round-off is no step of its own
}

// Far from t = 0 the doubles are far apart, and the times t0 + i dt of a fixed-step grid round to them: the times
// the system sees and the last step, shortened to land on t_end, come out wrong (t0 = 1e16, dt = 0.5 integrated
// y' = 1 over 159.5 of the 160 asked, status 0). Refused where the rounding exceeds 2^-10 of a step and 2^-30 of the
// span, unless every grid time is a double.
TEST(Solve, GridTimesThatRoundAwayFromTheStepsAreRefused) {
    auto message = [](double t0, double t_end, double dt) {
        eci::run_config c;
        c.t0 = t0, c.t_end = t_end, c.dt = dt;
        try {
            eci::detail::check_config(c);
        } catch (const std::invalid_argument& e) {
            return std::string(e.what());
        }
        return std::string("accepted");
    };
    EXPECT_EQ(message(1e16, 1e16 + 160, 0.5), "the step 0.5 is too small for times near 1.000000000000016e+16, where "
                                              "doubles are 2 apart: the grid's times would be off by more than 2^-10 "
                                              "of a step (count time from 0: a start time nearer 0)");
    EXPECT_EQ(message(-1e16 - 160, -1e16, 0.5).substr(0, 46), "the step 0.5 is too small for times near 1.000");
    EXPECT_EQ(message(1e12, 1e12 + 1, 1e-3).substr(0, 30), "the step 0.001 is too small fo");
    EXPECT_EQ(message(1e9, 1e9 + 1, 1e-3), "accepted");      // doubles 1.2e-7 apart: 1.2e-4 of a step
    EXPECT_EQ(message(0x1p60, 0x1p60 + 0x1p12, 256.0), "accepted");  // every grid time a double
    EXPECT_EQ(message(0.0, 1e6, 1e-6), "accepted");
    EXPECT_EQ(message(0.0, 1e12, 0.01), "accepted");  // (a run to be stopped: doubles 1e-4 apart only after 1e14 steps)
    // the run refused, end to end, where it had ended short with status 0
    const eci::three_wave model;
    tw_state y = fig5;
    discard<tw_state> none;
    eci::run_config c;
    c.t0 = 1e16, c.t_end = 1e16 + 160, c.dt = 0.5;
    EXPECT_THROW(eci::solve_model<eci::three_wave>(model, y, "rk4", c, none), std::invalid_argument);
}

// The one rule of the front ends for a run that names no method (eci::default_method_for): the model's own method at
// fixed steps; with a tolerance c-dp54, else dp54, else the first conservative pair; a refusal where none has an
// error estimate.
TEST(Solve, TheDefaultMethodIsTheModelsAndWithATolerancePrefersDormandPrince) {
    EXPECT_EQ(eci::default_method_for<eci::three_wave>("c-pc", false, "model three-wave"), "c-pc");
    EXPECT_EQ(eci::default_method_for<eci::three_wave>("c-pc", true, "model three-wave"), "c-dp54");
    EXPECT_EQ(eci::default_method_for<eci::kepler>("c-pc", true, "model kepler"), "c-dp54");  // (transformed)
    // H is not quadratic: no conservative pair runs on it, the conventional one does
    EXPECT_EQ(eci::default_method_for<eci::kepler_cartesian>("rrk-rk4", true, "model kepler-cartesian"), "dp54");
    EXPECT_EQ(eci::default_method_for<eci::kepler_cartesian>("rrk-rk4", false, "model kepler-cartesian"), "rrk-rk4");
}

// A sink that keeps every output in memory says how much per output; a fixed-step run whose outputs cannot fit is
// refused before its first step, in one line naming the size, and one that fits is not.
TEST(Solve, StoredOutputsBeyondMemoryAreRefusedBeforeAnyStep) {
    const eci::three_wave model;
    eci::run_config cfg;
    cfg.dt = 1e-5;
    cfg.t_end = 2.0 * eci::physical_memory() / 32.0 * cfg.dt;
    cfg.output_bytes = 32;
    tw_state y = fig5;
    discard<tw_state> none;
    try {
        eci::solve_model<eci::three_wave>(model, y, "rk4", cfg, none, {}, "model three-wave");
        ADD_FAILURE() << "accepted";
    } catch (const std::invalid_argument& e) {
        const std::string m = e.what();
        EXPECT_EQ(m.rfind("storing the solution at ", 0), 0u) << m;
        EXPECT_NE(m.find(" GiB of memory, more than this machine's "), std::string::npos) << m;
    }
    EXPECT_EQ(y, fig5);
    cfg.times = {0.0, cfg.t_end};  // two outputs fit: not refused up front (the run itself is not taken here)
    EXPECT_NO_THROW(eci::detail::check_stored_outputs(cfg));
    cfg.times.clear();
    cfg.output_bytes = 0;  // a sink that keeps nothing
    EXPECT_NO_THROW(eci::detail::check_stored_outputs(cfg));
}

// Projection stops its Newton iteration at the rounding of each invariant's evaluation, a scale taken over the
// unknowns the invariant depends on: over the whole state, Kepler's unwrapped angle (2e4 after 10^5 steps) made the
// energy's tolerance grow with the run, and H drifted 2.8e-11 by t = 10500 (3.1e-13 by t = 105). Now it stays at
// the round-off of the steps taken (C-RK4's own drift there: 1e-14).
TEST(Solve, ProjectionKeepsKeplersEnergyToRoundOffOverALongRun) {
    const eci::kepler orbit;
    eci::kepler::state_type x{1.0, 0.0, 0.0};
    eci::run_config cfg;
    cfg.dt = 0.105;
    cfg.steps = 100000;
    discard<eci::kepler::state_type> none;
    const eci::solve_report r = eci::solve_model<eci::kepler>(orbit, x, "projected-rk4", cfg, none, {}, "model kepler");
    ASSERT_TRUE(r.completed());
    ASSERT_EQ(r.invariants[0].name, "hamiltonian");
    // each step's projection ends within a few roundings of H, which adds up as a random walk over the steps
    const double eps = std::numeric_limits<double>::epsilon();
    EXPECT_LE(r.invariants[0].max_rel_drift(), 4.0 * eps * std::sqrt(double(cfg.steps.value())));
    EXPECT_GT(x[2], 1e4);  // the angle, unwrapped
}

// Projection on a vector state (n-wave): the base step swaps the state's buffer with one of its own, and the
// projection read the state through a view taken before the step, so it projected the old state and every step
// returned the initial state, reporting drift 0 (projected-rk4 and projected-dp54 on n-wave and n-wave-complex).
// It must move with RK4, within RK4's own invariant error of it, and keep the invariants to round-off.
TEST(Solve, ProjectionOnAVectorStateTakesTheStep) {
    const auto waves = eci::n_wave<double>::random(30, 20, 1);
    const vec x0 = waves.random_state(2);
    eci::run_config cfg;
    cfg.dt = 0.01;
    cfg.steps = 200;
    discard<vec> none;
    vec rk = x0, projected = x0;
    ASSERT_TRUE(eci::solve_model<eci::n_wave<double>>(waves, rk, "rk4", cfg, none, {}, "model n-wave").completed());
    const eci::solve_report r =
        eci::solve_model<eci::n_wave<double>>(waves, projected, "projected-rk4", cfg, none, {}, "model n-wave");
    ASSERT_TRUE(r.completed());
    double moved = 0.0, apart = 0.0;
    for (std::size_t i = 0; i < x0.size(); ++i)
        moved = std::max(moved, std::abs(rk[i] - x0[i])), apart = std::max(apart, std::abs(projected[i] - rk[i]));
    EXPECT_GT(moved, 0.1);
    EXPECT_LT(apart, 1e-6 * moved);
    const double eps = std::numeric_limits<double>::epsilon();
    for (const auto& inv : r.invariants) EXPECT_LE(inv.max_rel_drift(), 8.0 * eps * std::sqrt(200.0)) << inv.name;
}
