// Unit tests of the library's reliability guarantees: a bounded, iterative step reduction, the cancellation hook,
// no non-finite state ever returned as a step, steps_to_reach never dropping a short span, and the models'
// range checks (overflowing squares, wrapped triad counts, orbits beyond double precision).
#include <gtest/gtest.h>

#include <array>
#include <atomic>
#include <cfenv>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include <eci/eci.hpp>
#include <eci/models/kepler.hpp>
#include <eci/models/lotka_volterra.hpp>
#include <eci/models/n_wave.hpp>
#include <eci/models/three_wave.hpp>
#include <eci/registry.hpp>

namespace {

using state = std::array<double, 1>;

struct rate_one {
    void operator()(const state&, state& d, double) const { d[0] = 1.0; }
};

// A stepper that fails every step larger than `works_below` and counts its attempts.
struct picky_stepper {
    static constexpr int order = 1;
    double works_below;
    std::uint64_t* attempts;
    template <class F>
    eci::step_result step(F& f, state& x, double t, double dt) {
        ++*attempts;
        if (!(dt < works_below)) return eci::step_result::failure(0);
        state k{};
        f(x, k, t);
        x[0] += dt * k[0];
        return eci::step_result::success();
    }
};

// A stepper that claims success and leaves a NaN: the driver must not pass it on.
struct lying_stepper {
    static constexpr int order = 1;
    template <class F>
    eci::step_result step(F&, state& x, double, double) {
        x[0] = std::numeric_limits<double>::quiet_NaN();
        return eci::step_result::success();
    }
};

TEST(StepsToReach, AShortSpanIsOneShortStepNeverNone) {
    EXPECT_EQ(eci::steps_to_reach(0.0, 1e-11, 0.01), 1u);
    EXPECT_EQ(eci::steps_to_reach(0.0, 10.0, 1e11), 1u);
    EXPECT_EQ(eci::steps_to_reach(0.0, 1e-300, 1.0), 1u);
    EXPECT_EQ(eci::steps_to_reach(0.0, 0.0, 0.1), 0u);
    EXPECT_EQ(eci::steps_to_reach(0.0, 0.3, 0.1), 3u);  // 0.3 / 0.1 = 2.9999999999999996: round-off, 3 steps
    EXPECT_EQ(eci::steps_to_reach(0.0, 1.0 + 1e-9, 0.1), 11u);  // a remainder of 1e-8 steps is a real step
    std::uint64_t attempts = 0;
    state x{0.0};
    picky_stepper st{1e300, &attempts};
    const auto stats = eci::integrate_to(st, rate_one{}, x, 0.0, 1e-11, 0.01);
    EXPECT_EQ(stats.steps, 1u);
    EXPECT_EQ(x[0], 1e-11);
}

TEST(StepReduction, TheWorkOfOneStepIsBounded) {
    std::uint64_t attempts = 0;
    state x{0.0};
    picky_stepper st{1e-9, &attempts};  // 2^30 sub-steps would be needed for dt = 1
    eci::run_options opt;
    opt.max_substeps = 1000;
    EXPECT_THROW(eci::integrate_n_steps(st, rate_one{}, x, 0.0, 1.0, 1, eci::no_observer{}, opt),
                 eci::step_work_exceeded);
    EXPECT_LE(attempts, 1001u);
    // Within the bound the same stepper finishes, and lands where it should.
    attempts = 0;
    x = {0.0};
    opt.max_substeps = 1u << 12;
    picky_stepper ok{0.3e-2, &attempts};
    eci::integrate_n_steps(ok, rate_one{}, x, 0.0, 1.0, 1, eci::no_observer{}, opt);
    EXPECT_DOUBLE_EQ(x[0], 1.0);
}

TEST(StepReduction, IsIterativeSoDeepHalvingsCannotOverflowTheStack) {
    std::uint64_t attempts = 0;
    state x{0.0};
    picky_stepper never{0.0, &attempts};
    eci::run_options opt;
    opt.max_halvings = 1'000'000;  // recursion this deep would overflow the stack
    opt.max_substeps = 2'000'000;
    EXPECT_THROW(eci::integrate_n_steps(never, rate_one{}, x, 0.0, 1.0, 1, eci::no_observer{}, opt),
                 eci::step_size_underflow);
    EXPECT_EQ(attempts, 1'000'001u);
}

TEST(Cancellation, TheFlagStopsARunBetweenSubStepsAndInsideIterations) {
    std::atomic<bool> cancel{false};
    eci::run_options opt;
    opt.cancel = &cancel;
    // Set from inside the right-hand side: the very next evaluation (inside the same implicit solve) throws.
    int evaluations = 0, after = 0;
    auto f = [&](const std::vector<double>& x, std::vector<double>& d, double) {
        ++evaluations;
        if (cancel.load()) ++after;
        d[0] = x[1], d[1] = -x[0];
        if (evaluations == 5) cancel.store(true);
    };
    std::vector<double> y{1.0, 0.0};
    eci::implicit_midpoint<std::vector<double>> im;
    try {
        eci::integrate_n_steps(im, f, y, 0.0, 0.1, 1000, eci::no_observer{}, opt);
        ADD_FAILURE() << "expected eci::interrupted";
    } catch (const eci::interrupted& e) {
        EXPECT_EQ(after, 0);
        EXPECT_NE(std::string(e.what()).find("interrupted at t = "), std::string::npos);
    }
}

// A stepper of a fixed number of evaluations (explicit Runge-Kutta, conservative or not) is polled before each
// step only: a flag set during a step lets that step finish, and the run stops before the next with the state of a
// complete step, on the general engine (std::vector) and in registers (std::array) alike.
template <class S, class St>
void expect_stop_at_the_next_step(St stepper) {
    std::atomic<bool> cancel{false};
    eci::run_options opt;
    opt.cancel = &cancel;
    int evaluations = 0;
    auto g = [](const S& v, S& d, double) { d[0] = v[1] * v[2], d[1] = -2.0 * v[2] * v[0], d[2] = v[0] * v[1]; };
    auto f = [&](const S& x, S& d, double t) {
        g(x, d, t);
        if (++evaluations == 6) cancel.store(true);  // inside the second step of RK4 and of C-PC's third
    };
    const S x0{0.9, -0.4, 0.3};
    S x = x0;
    constexpr int stages = int(St::tableau.stages);
    const int steps = (6 + stages - 1) / stages;  // the step the flag was set in completes
    try {
        eci::integrate_n_steps(stepper, f, x, 0.0, 0.1, 1000, eci::no_observer{}, opt);
        ADD_FAILURE() << "expected eci::interrupted";
    } catch (const eci::interrupted& e) {
        EXPECT_EQ(evaluations, steps * stages);
        EXPECT_DOUBLE_EQ(e.time, 0.1 * steps);
    }
    S y = x0;
    eci::integrate_n_steps(stepper, g, y, 0.0, 0.1, std::uint64_t(steps));
    EXPECT_EQ(x, y) << "the state is that of the last complete step";
}

TEST(Cancellation, AnExplicitStepperFinishesItsStepAndStopsBeforeTheNext) {
    expect_stop_at_the_next_step<std::vector<double>>(eci::rk4<std::vector<double>>{});
    expect_stop_at_the_next_step<std::array<double, 3>>(eci::rk4<std::array<double, 3>>{});
    expect_stop_at_the_next_step<std::vector<double>>(eci::c_pc<std::vector<double>>{});
    expect_stop_at_the_next_step<std::array<double, 3>>(eci::c_pc<std::array<double, 3>>{});
}

TEST(NonFiniteState, NoStepperReturnsOneAsAStep) {
    // Three-wave from Figure 1's start with steps far too large: every registered method either recovers by
    // halving (every value finite) or throws; none returns inf or NaN.
    const eci::three_wave model;
    for (const eci::method_info& m : eci::methods) {
        for (double dt : {1.5, 5.0, 1e120, 1e200}) {
            std::vector<double> x{std::sqrt(1.5), 0.0, std::sqrt(1.5)};
            auto f = [&](const std::vector<double>& a, std::vector<double>& d, double t) {
                std::array<double, 3> s{a[0], a[1], a[2]}, r{};
                model(s, r, t);
                d.assign(r.begin(), r.end());
            };
            eci::run_options opt;
            opt.max_substeps = 4096;
            bool ran = false;
            try {
                ran = eci::with_method<std::vector<double>>(m.name, [&](auto st) {
                    eci::integrate_n_steps(st, f, x, 0.0, dt, 2, eci::no_observer{}, opt);
                });
            } catch (const std::runtime_error&) {
                continue;  // refused: fine
            }
            if (!ran) continue;  // kahan: model-specific
            for (double v : x) EXPECT_TRUE(std::isfinite(v)) << m.name << " dt " << dt;
        }
    }
    state x{0.0};
    lying_stepper liar;
    EXPECT_THROW(eci::integrate_n_steps(liar, rate_one{}, x, 0.0, 0.1, 3), eci::non_finite_state);
}

// The drivers trust a stepper that declares checks_finite and skip their own pass: each such stepper must fail
// (not take) a step whose update overflows, and leave x as it was.
template <class St, class S = std::vector<double>>
void expect_overflow_fails_the_step(const char* name) {
    static_assert(eci::checks_finite<St>);
    S x{1e300, 1.0, 1e300, 1.0};
    const S before = x;
    auto f = [](const S& a, S& d, double) {
        if constexpr (!eci::detail::fixed_size_state<S>) d.resize(a.size());
        for (std::size_t i = 0; i < a.size(); ++i) d[i] = (i % 2 == 0 ? 1.0 : -1.0) * a[(i + 1) % a.size()] * 1e8;
    };
    St st;
    const eci::step_result r = st.step(f, x, 0.0, 1e10);
    EXPECT_FALSE(r) << name;
    EXPECT_EQ(x, before) << name;
}

TEST(NonFiniteState, SteppersThatCheckFinitenessFailAnOverflowingStep) {
    using S = std::vector<double>;
    expect_overflow_fails_the_step<eci::euler<S>>("euler");
    expect_overflow_fails_the_step<eci::pc<S>>("pc");
    expect_overflow_fails_the_step<eci::rk4<S>>("rk4");
    expect_overflow_fails_the_step<eci::c_pc<S>>("c-pc");
    expect_overflow_fails_the_step<eci::c_rk4<S>>("c-rk4");
    expect_overflow_fails_the_step<eci::c_pc_compensated<S>>("c-pc-compensated");
    static_assert(!eci::checks_finite<eci::implicit_midpoint<S>>);  // the driver checks its results
    // a small fixed-size state: the conventional steppers' stage buffers live on the stack (explicit_rk.hpp)
    using A = std::array<double, 4>;
    expect_overflow_fails_the_step<eci::euler<A>, A>("euler, std::array");
    expect_overflow_fails_the_step<eci::pc<A>, A>("pc, std::array");
    expect_overflow_fails_the_step<eci::rk4<A>, A>("rk4, std::array");
    expect_overflow_fails_the_step<eci::c_rk4<A>, A>("c-rk4, std::array");
}

// The paper's update counts infinite radicands in its own pass (and checks no more where none is negative): one
// radicand of +inf, at the start, middle or end of states short and long enough for the vectorized passes and their
// tails, fails the step and leaves x as it was; a radicand of 1e300 (a root of 1e150) does not.
template <class St>
void expect_an_infinite_radicand_fails_the_step(const char* name) {
    using S = std::vector<double>;
    for (const std::size_t n : {5u, 64u, 67u, 1001u})
        for (const std::size_t at : {std::size_t{0}, n / 2, n - 1})
            for (const double rate : {1e300, 1e150}) {
                S x(n, 1.0);
                const S before = x;
                auto f = [&](const S& a, S& d, double) {
                    d.assign(a.size(), 0.0);
                    d[at] = rate;
                };
                St st;
                const eci::step_result r = st.step(f, x, 0.0, 1.0);
                if (rate == 1e300) {
                    EXPECT_FALSE(r) << name << " n=" << n << " at " << at;
                    EXPECT_EQ(x, before) << name << " n=" << n << " at " << at;
                } else {
                    EXPECT_TRUE(r) << name << " n=" << n << " at " << at;
                    for (double v : x) EXPECT_TRUE(std::isfinite(v)) << name;
                    EXPECT_GT(x[at], 1e149) << name;
                }
            }
}

TEST(NonFiniteState, AnInfiniteRadicandFailsTheStepOfThePapersUpdate) {
    using S = std::vector<double>;
    expect_an_infinite_radicand_fails_the_step<eci::c_pc<S>>("c-pc");
    expect_an_infinite_radicand_fails_the_step<eci::c_rk2<S>>("c-rk2");
    expect_an_infinite_radicand_fails_the_step<eci::c_rk4<S>>("c-rk4");
    expect_an_infinite_radicand_fails_the_step<eci::c_pc_compensated<S>>("c-pc-compensated");
}

// The finiteness test the steppers fuse into their last pass (an add into bit 63, which vectorizes with baseline
// SSE2): exactly the infinities and NaNs, at every position of a long array and at the edges of the exponent range.
TEST(NonFiniteState, TheFusedFinitenessBitIsExactlyIsfinite) {
    using lim = std::numeric_limits<double>;
    const double values[] = {0.0, -0.0, lim::denorm_min(), -lim::denorm_min(), lim::min(), lim::max(), -lim::max(),
                             1.0, -3.5, std::nextafter(lim::max(), 0.0), lim::infinity(), -lim::infinity(),
                             lim::quiet_NaN(), -lim::quiet_NaN(), lim::signaling_NaN()};
    for (const double v : values) {
        EXPECT_EQ(eci::detail::none_non_finite(eci::detail::non_finite_bit(v)), bool(std::isfinite(v))) << v;
        for (const std::size_t n : {1u, 2u, 3u, 7u, 64u, 1001u})
            for (const std::size_t at : {std::size_t{0}, n / 2, n - 1}) {
                std::vector<double> x(n, -lim::max());
                x[at] = v;
                EXPECT_EQ(eci::detail::all_finite_reals(x.data(), n), bool(std::isfinite(v))) << v << " n=" << n;
            }
    }
}

// The vectorized update loops' form of that test (the OR of the bits of v - v, explicit_rk's
// combine_stages_finite_over): exactly the infinities and NaNs as well, also under downward rounding, where v - v
// is -0 for a finite v; and the conventional steppers' update on a vector state fails an overflow at any position.
TEST(NonFiniteState, TheDifferenceTestIsExactlyIsfinite) {
    using lim = std::numeric_limits<double>;
    const double values[] = {0.0, -0.0, lim::denorm_min(), -lim::denorm_min(), lim::min(), lim::max(), -lim::max(),
                             1.0, -3.5, std::nextafter(lim::max(), 0.0), lim::infinity(), -lim::infinity(),
                             lim::quiet_NaN(), -lim::quiet_NaN(), lim::signaling_NaN()};
    const int mode = std::fegetround();
    for (const int rounding : {FE_TONEAREST, FE_DOWNWARD, FE_UPWARD, FE_TOWARDZERO}) {
        std::fesetround(rounding);
        for (const double c : values) {
            volatile double keep = c;  // computed at run time, under the rounding mode set
            const double v = keep;
            EXPECT_EQ(eci::detail::none_non_finite_diff(eci::detail::non_finite_diff(v)), bool(std::isfinite(v)))
                << v << " rounding " << rounding;
        }
    }
    std::fesetround(mode);
    using S = std::vector<double>;
    for (const std::size_t n : {1u, 2u, 3u, 7u, 64u, 1001u})
        for (const std::size_t at : {std::size_t{0}, n / 2, n - 1}) {
            S x(n, 1.0);
            const S before = x;
            auto f = [&](const S& a, S& d, double) {
                d.assign(a.size(), 1.0);
                d[at] = 0.75 * lim::max();  // x + dt S overflows at `at` alone (dt = 2)
            };
            eci::pc<S> pc;
            EXPECT_FALSE(pc.step(f, x, 0.0, 2.0)) << "n=" << n << " at " << at;
            EXPECT_EQ(x, before);
            eci::rk4<S> rk4;
            EXPECT_FALSE(rk4.step(f, x, 0.0, 2.0)) << "n=" << n << " at " << at;
            EXPECT_EQ(x, before);
        }
}

TEST(ModelRanges, OverflowingSquaresAndProductsAreRejected) {
    for (const auto& [K, P] : std::vector<std::pair<double, double>>{{1e200, 3.0}, {1.7, 1.5e154}, {1e-170, 3.0}}) {
        eci::three_wave w;
        w.K = K, w.P = P;
        EXPECT_THROW(w.validate(), std::invalid_argument) << K << " " << P;
    }
    eci::three_wave w;
    w.M = {1.0, 1.0, -2.0000001};
    try {
        w.validate();
        ADD_FAILURE();
    } catch (const std::invalid_argument& e) {
        EXPECT_EQ(std::string(e.what()).find("-0.000000"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("e-08"), std::string::npos) << e.what();
    }
    using nw = eci::n_wave<double>;
    EXPECT_THROW(nw::triad_count(3, 6148914691236517206ull), std::invalid_argument);
    EXPECT_THROW(nw::triad_count(6, 3074457345618258603ull), std::invalid_argument);
    EXPECT_EQ(nw::triad_count(30, 20), 200u);
    EXPECT_EQ(nw::triad_count(31, 20), 206u);  // 620 / 3, without forming 620 if it would overflow
    EXPECT_EQ(nw::triad_count(30, 1), 10u);
}

TEST(ModelRanges, OrbitsBeyondDoublePrecisionAreRejectedWithAReason) {
    const eci::lotka_volterra lv;
    for (const auto& s : std::vector<eci::lotka_volterra::state_type>{{1.0, 1e-300}, {1e-320, 1e-320}, {900.0, 1.0}})
        EXPECT_THROW(lv.validate_state(s), std::invalid_argument) << s[0] << " " << s[1];
    EXPECT_NO_THROW(lv.validate_state({1.0, 0.4}));
    EXPECT_NO_THROW(lv.validate_state({1e-100, 1.0}));
    const eci::kepler k;
    for (double r : {1e-320, 1e-200}) {
        try {
            k.validate_state({r, 0.0, 0.0});
            ADD_FAILURE() << r;
        } catch (const std::invalid_argument& e) {
            EXPECT_EQ(std::string(e.what()).find("nan"), std::string::npos) << e.what();
        }
    }
    EXPECT_NO_THROW(k.validate_state({1.0, 0.0, 0.0}));
}

}  // namespace
