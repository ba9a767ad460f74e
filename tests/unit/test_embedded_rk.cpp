// Unit tests of the embedded Runge-Kutta engine: the conventional update is the explicit engine's to the bit, a
// failed attempt changes nothing carried, step() restarts on a state it did not produce, FSAL saves evaluations.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <complex>
#include <limits>
#include <vector>

#include <eci/models/three_wave.hpp>
#include <eci/steppers/conservative_rk.hpp>
#include <eci/steppers/embedded_rk.hpp>
#include <eci/steppers/explicit_rk.hpp>

namespace {

using state = eci::three_wave::state_type;
constexpr double eps = std::numeric_limits<double>::epsilon();
const eci::three_wave model{};
const state x0{std::sqrt(1.5), 1.0, std::sqrt(1.5)};

// Same stages, same operations in the same order: the conventional update is bit for bit explicit_rk's.
TEST(EmbeddedRk, ConventionalStepIsTheExplicitEngines) {
    state a = x0, b = x0;
    eci::dp54<state> e;
    eci::explicit_rk<eci::tableaus::dormand_prince_54, state> r;
    ASSERT_TRUE(e.step(model, a, 0.0, 0.1));
    ASSERT_TRUE(r.step(model, b, 0.0, 0.1));
    EXPECT_EQ(a, b);
}

// The conservative update is conservative_rk's up to the order of its sums (a few eps), and the first step
// (no FSAL derivative yet) is the same method.
TEST(EmbeddedRk, ConservativeFirstStepIsTheConservativeEngines) {
    state a = x0, b = x0;
    eci::c_dp54<state> e;
    eci::conservative_rk<eci::tableaus::dormand_prince_54, state> r;
    ASSERT_TRUE(e.step(model, a, 0.0, 0.1));
    ASSERT_TRUE(r.step(model, b, 0.0, 0.1));
    for (std::size_t i = 0; i < 3; ++i) EXPECT_NEAR(a[i], b[i], 4.0 * eps * std::abs(b[i]));
}

// A step so long that some radicand is negative fails, names a component, leaves x as it was, and carries
// nothing over: the next (short) step gives the bits of a fresh stepper's.
TEST(EmbeddedRk, FailedAttemptLeavesStateAndCarriedDataUntouched) {
    const state start{std::sqrt(1.5), 0.0, std::sqrt(1.5)};  // psi_P = 0: its radicand is the first to go negative
    eci::c_dp54_compensated<state> st;
    state x = start;
    ASSERT_TRUE(st.step(model, x, 0.0, 0.01));  // something carried: FSAL derivative, residual
    const state after_one = x;
    double dt = 0.5;
    eci::attempt_result r;
    for (; dt < 64.0; dt *= 2.0) {
        r = st.attempt(model, x, 0.01, dt);
        if (!r.ok) break;
    }
    ASSERT_FALSE(r.ok) << "no step length up to 64 gave a negative radicand";
    EXPECT_LT(r.component, 3u);
    EXPECT_EQ(x, after_one);
    state y = x;
    ASSERT_TRUE(st.step(model, y, 0.01, 0.01));
    eci::c_dp54_compensated<state> twin;
    state z = start;
    ASSERT_TRUE(twin.step(model, z, 0.0, 0.01));
    ASSERT_TRUE(twin.step(model, z, 0.01, 0.01));
    EXPECT_EQ(y, z);
}

// step() reuses carried data only for the state it produced at the time it reached: a changed x restarts.
TEST(EmbeddedRk, StepRestartsOnAStateItDidNotProduce) {
    eci::c_dp54<state> st, fresh;
    state x = x0;
    ASSERT_TRUE(st.step(model, x, 0.0, 0.05));
    state moved{0.3, -1.1, 0.7};
    ASSERT_TRUE(st.step(model, moved, 0.05, 0.05));
    state ref{0.3, -1.1, 0.7};
    ASSERT_TRUE(fresh.step(model, ref, 0.05, 0.05));
    EXPECT_EQ(moved, ref);
}

// FSAL: six evaluations per step after the first (seven); without it (CK54) six every step.
TEST(EmbeddedRk, FsalSavesOneEvaluationPerStep) {
    int calls = 0;
    auto f = [&](const state& x, state& d, double t) {
        ++calls;
        model(x, d, t);
    };
    eci::c_dp54<state> dp;
    state x = x0;
    for (int i = 0; i < 10; ++i) ASSERT_TRUE(dp.step(f, x, 0.01 * i, 0.01));
    EXPECT_EQ(calls, 7 + 9 * 6);
    calls = 0;
    eci::c_ck54<state> ck;
    x = x0;
    for (int i = 0; i < 10; ++i) ASSERT_TRUE(ck.step(f, x, 0.01 * i, 0.01));
    EXPECT_EQ(calls, 10 * 6);
    EXPECT_EQ(eci::c_dp54<state>::buffer_count(), 7u + 2u + 1u);  // stages, stage value, candidate, FSAL point
    EXPECT_EQ(eci::dp54<state>::buffer_count(), 7u + 2u);
}

// Complex states: each complex mode is two real unknowns, and per-component tolerances index real unknowns.
TEST(EmbeddedRk, ComplexStatesAndErrorWeights) {
    using cvec = std::vector<std::complex<double>>;
    const auto f = [](const cvec& x, cvec& d, double) {
        for (std::size_t i = 0; i < x.size(); ++i) d[i] = std::complex<double>(0.0, 1.0 + double(i)) * x[i];
    };
    cvec x{{1.0, 0.5}, {-0.25, 2.0}};
    eci::c_dp54<cvec> st;
    const std::vector<double> loose{1.0, 1.0, 1.0, 1.0}, tight{1e-12, 1e-12, 1.0, 1.0};
    const eci::error_weights wl{0.0, 0.0, loose.data(), loose.data()}, wt{0.0, 0.0, tight.data(), tight.data()};
    const double el = st.attempt(f, x, 0.0, 0.1, &wl).error;
    const double et = st.attempt(f, x, 0.0, 0.1, &wt, true).error;
    EXPECT_GT(et, 1e6 * el);
    EXPECT_LT(st.attempt(f, x, 0.0, 0.1, &wt, true).component, 2u);  // the tightly weighted mode is the worst
    // |x_k| is conserved mode by mode (each is an invariant here): one step keeps both to a few eps
    const cvec before = x;
    ASSERT_TRUE(st.step(f, x, 0.0, 0.1));
    for (std::size_t i = 0; i < 2; ++i) EXPECT_NEAR(std::norm(x[i]), std::norm(before[i]), 8.0 * eps * std::norm(before[i]));
}

}  // namespace

namespace {

// A right-hand side that is not finite makes every pair's error estimate nan (the attempt rejected by any
// controller, SciPy's included), never a number below 1: DP853's estimate, a quotient of two sums, read a nan
// denominator as zero and returned 0, so that eci.scipy.DP853 stepped to the end on nan states with status 0.
template <class Stepper>
void expect_rejected_on_a_nan_rate() {
    for (const double bad : {std::nan(""), std::numeric_limits<double>::infinity()}) {
        const auto f = [bad](const state& x, state& dxdt, double) {
            dxdt = x;
            dxdt.fill(0.0);
            dxdt[0] = bad;
        };
        Stepper st;
        state x = x0;
        const eci::error_weights w{1e-6, 1e-6};  // (without weights no error norm is formed)
        const eci::attempt_result r = st.attempt(f, x, 0.0, 0.1, &w);
        EXPECT_FALSE(r.ok && r.error <= 1.0) << "rate " << bad << ": ok " << r.ok << ", error " << r.error;
        EXPECT_EQ(x, x0);
    }
}

TEST(EmbeddedRk, ANonFiniteRateIsNeverAnAcceptableError) {
    expect_rejected_on_a_nan_rate<eci::dp54<state>>();
    expect_rejected_on_a_nan_rate<eci::dp853<state>>();
    expect_rejected_on_a_nan_rate<eci::f78<state>>();
    expect_rejected_on_a_nan_rate<eci::bs32<state>>();
    expect_rejected_on_a_nan_rate<eci::ck54<state>>();
    expect_rejected_on_a_nan_rate<eci::c_dp54<state>>();
    expect_rejected_on_a_nan_rate<eci::c_dp853<state>>();
}

}  // namespace
