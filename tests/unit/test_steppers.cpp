// Unit tests of the steppers: each method on linear systems with known solutions, and failed steps that leave the
// state untouched and name the component (state types and buffer reuse: test_stepper_states.cpp).
#include <gtest/gtest.h>

#include <array>
#include <complex>
#include <limits>
#include <vector>

#include <eci/eci.hpp>

#include "numeric/support.hpp"

namespace {

using namespace eci::test;
using cvec = std::vector<std::complex<double>>;

// ---------------------------------------------------------------------------------------------------------------
// One step on x' = lambda x is a known polynomial (or, for the conservative methods, the square root of one) in
// z = lambda dt: the stability function of the tableau, or the tableau applied to (psi, psi^2). Only rounding
// separates the stepper from the formula: a few eps relative.

double amplification(const char* name, double z) {
    const std::string m = name;
    const double y1 = 1.0 + z / 2.0, y2 = 1.0 + z / 2.0 * y1, y3 = 1.0 + z * y2;  // RK4 stages over psi
    if (m == "euler") return 1.0 + z;                                                  // eq. (7)
    if (m == "pc" || m == "rk2") return 1.0 + z + z * z / 2.0;                         // eq. (18)
    if (m == "rk4") return 1.0 + z + z * z / 2.0 + z * z * z / 6.0 + z * z * z * z / 24.0;
    if (m == "c-euler") return std::sqrt(1.0 + 2.0 * z);                                // eq. (16)
    if (m == "c-pc" || m == "c-pc-compensated") return std::copysign(std::sqrt((1.0 + z) * (1.0 + z + z * z)), 1.0 + z);  // eq. (30)
    if (m == "c-rk2") return std::copysign(std::sqrt(1.0 + 2.0 * z * y1 * y1), 1.0 + z * y1);
    if (m == "c-rk4")
        return std::copysign(std::sqrt(1.0 + z * (1.0 + 2.0 * y1 * y1 + 2.0 * y2 * y2 + y3 * y3) / 3.0),
                             1.0 + z + z * z / 2.0 + z * z * z / 6.0 + z * z * z * z / 24.0);
    if (m == "implicit-midpoint") return (1.0 + z / 2.0) / (1.0 - z / 2.0);  // the (1,1) Pade approximant
    return std::numeric_limits<double>::quiet_NaN();
}

// The paper's formulas above where they exist (checked independently of the tableaux); for any other explicit
// tableau (the pairs, a tableau added to the registry): the stability function R(z) = 1 + z sum_i b_i Y_i,
// Y_i = 1 + z sum_j a_ij Y_j, and for its conservative version the tableau applied to psi^2,
// sqrt(1 + 2 z sum_i b_i Y_i^2) with R's sign (the conventional update's: a method taking another sign, as C-PC
// its predictor's, has its formula above).
template <class Method>
double amplification_of(double z) {
    if (const double g = amplification(Method::name, z); !std::isnan(g)) return g;
    if constexpr (requires { Method::entry::tableau.a; } && !requires { Method::entry::sign; }) {
        const auto& T = Method::entry::tableau;
        constexpr std::size_t s = std::remove_cvref_t<decltype(T)>::stages;
        std::array<double, s> y{};
        double r = 1.0, xi = 1.0;
        for (std::size_t i = 0; i < s; ++i) {
            y[i] = 1.0;
            for (std::size_t j = 0; j < i; ++j) y[i] += z * T.a[i][j] * y[j];
            r += z * T.b[i] * y[i];
            xi += 2.0 * z * T.b[i] * y[i] * y[i];
        }
        return Method::entry::info.conservative ? std::copysign(std::sqrt(xi), r) : r;
    } else {
        return amplification(Method::name, z);
    }
}

template <class Method>
void expect_linear_step_matches_formula() {
    for (double lambda : {-0.7, 0.3}) {
        for (double dt : {0.01, 0.1, 0.3}) {
            const auto f = [lambda](const std::vector<double>& x, std::vector<double>& d, double) {
                for (std::size_t i = 0; i < x.size(); ++i) d[i] = lambda * x[i];
            };
            std::vector<double> x{1.5, -0.25, 2.0};
            const std::vector<double> x0 = x;
            typename Method::template stepper<std::vector<double>> st;
            ASSERT_TRUE(st.step(f, x, 0.0, dt));
            const double g = amplification_of<Method>(lambda * dt);
            for (std::size_t i = 0; i < x.size(); ++i)
                EXPECT_NEAR(x[i], g * x0[i], 8.0 * eps * std::abs(x0[i])) << Method::name << " dt " << dt;
        }
    }
}

// Integrated to t = 1 on x' = -x, the error against e^-1 falls by 2^p per halving of dt.
// (Steps grow with the order so that the error stays above round-off: 0.05 up to order 4, 0.1 for 5, 1 for 8:
// DP853's error constant is a tenth of Fehlberg's, 4e-16 at dt = 0.1, so its errors here are 3e-8 .. 4e-13.)
template <class Method, int P>
void expect_linear_convergence() {
    const auto f = [](const std::array<double, 1>& x, std::array<double, 1>& d, double) { d[0] = -x[0]; };
    double previous = 0.0;
    const double dt0 = P <= 4 ? 0.05 : P <= 5 ? 0.1 : 1.0;
    for (double dt : {dt0, dt0 / 2.0, dt0 / 4.0}) {
        std::array<double, 1> x{1.0};
        typename Method::template stepper<std::array<double, 1>> st;
        eci::integrate_to(st, f, x, 0.0, 1.0, dt);
        const double error = std::abs(x[0] - std::exp(-1.0));
        if (previous > 0.0) {
            // Up to order 4 the ratio is 2^p to 0.1; the embedded pairs (orders 5, 8) are tuned to small principal
            // error terms, so at steps where their error is still above round-off the next term can make it fall
            // faster: at least 2^(p - 0.3) per halving.
            if constexpr (P <= 4) {
                EXPECT_NEAR(std::log2(previous / error), double(P), 0.1) << Method::name << " dt " << dt;
            } else {
                EXPECT_GE(std::log2(previous / error), double(P) - 0.3) << Method::name << " dt " << dt;
            }
        }
        previous = error;
    }
}

template <class Method>
class EveryMethod : public ::testing::Test {};


TYPED_TEST_SUITE(EveryMethod, registry_methods_on_any_state, method_names);

TYPED_TEST(EveryMethod, OneLinearStepIsItsAmplificationFormula) { expect_linear_step_matches_formula<TypeParam>(); }

TYPED_TEST(EveryMethod, ConvergesOnLinearDecayAtItsOrder) {
    using St = typename TypeParam::template stepper<std::array<double, 1>>;
    expect_linear_convergence<TypeParam, St::order>();
}

// psi' = i omega psi in complex amplitudes: the exact solution is psi0 e^{i omega t}, |psi| is invariant, and
// every real unknown crosses zero twice per turn (the conservative methods meet negative radicands and reduce).
TYPED_TEST(EveryMethod, FollowsAComplexRotation) {
    const double omega = 2.0, t_end = 3.0, dt = 0.001;
    const auto f = [omega](const cvec& x, cvec& d, double) {
        for (std::size_t i = 0; i < x.size(); ++i) d[i] = std::complex<double>(0.0, omega) * x[i];
    };
    const cvec x0{{1.0, 0.5}, {-0.3, 0.8}};
    cvec x = x0;
    typename TypeParam::template stepper<cvec> st;
    const auto stats = eci::integrate_to(st, f, x, 0.0, t_end, dt);
    using St = typename TypeParam::template stepper<cvec>;
    double error = 0.0, drift = 0.0;
    for (std::size_t i = 0; i < x.size(); ++i) {
        error = std::max(error, std::abs(x[i] - x0[i] * std::exp(std::complex<double>(0.0, omega * t_end))));
        drift = std::max(drift, std::abs(std::norm(x[i]) - std::norm(x0[i])) / std::norm(x0[i]));
    }
    // Global error ~ C (omega dt)^p omega t_end; C <= 1 for these methods (Euler's is 1/2). For high orders that is
    // below round-off, which adds a phase error of a few eps per step: 4 eps steps.
    EXPECT_LT(error, std::pow(omega * dt, St::order) * omega * t_end + 4.0 * eps * double(stats.steps)) << TypeParam::name;
    if (std::string(TypeParam::name).starts_with("c-")) {
        // Each mode's |psi|^2 is itself invariant (Re(conj(psi) i omega psi) = 0 mode by mode): round-off only,
        // 4 eps per step as a random walk (see numeric/test_conservation.cpp).
        EXPECT_LE(drift, 4.0 * eps * std::sqrt(double(stats.steps + stats.step_reductions))) << TypeParam::name;
    }
}

// Paper §III.D: "C-PC uses no additional storage" over PC. Neither does any conservative RK method over its
// conventional one: the psi^2 stage sums are recomputed from x and the k_j in the finishing pass, and the new state
// goes to the stage value's buffer (conservative_rk.hpp).
TEST(Buffers, ConservativeMethodsHoldNoBufferMore) {
    using S = std::vector<double>;
    EXPECT_EQ(eci::c_pc<S>::buffer_count(), eci::pc<S>::buffer_count());
    EXPECT_EQ(eci::c_rk2<S>::buffer_count(), eci::rk2<S>::buffer_count());
    EXPECT_EQ(eci::c_rk4<S>::buffer_count(), eci::rk4<S>::buffer_count());
    EXPECT_EQ(eci::euler<S>::buffer_count(), 1u);
}

// ---------------------------------------------------------------------------------------------------------------
// Failed steps. x2' = -sgn(x2), with the sign of 0 taken as -1 so that x2' = +1 at 0, pushes psi_2 into zero
// from both sides: from x2 = 0 every conservative method asks for psi_2^2 < 0 whatever the step (C-PC's radicand
// is -tau^2, eq. (30b); C-Euler's implicit equation has no solution). x0, x1 rotate meanwhile.

struct sliding {
    template <class S>
    void operator()(const S& x, S& d, double) const {
        auto r = eci::detail::reals(x);
        auto dr = eci::detail::reals(d);
        dr[0] = r[1], dr[1] = -r[0];
        for (std::size_t i = 2; i < r.size(); ++i) dr[i] = r[i] <= 0.0 ? 1.0 : -1.0;
    }
};

template <class Method>
class ConservativeMethod : public ::testing::Test {};
TYPED_TEST_SUITE(ConservativeMethod, registry_conservative_methods_on_any_state, method_names);

TYPED_TEST(ConservativeMethod, FailedStepLeavesStateUntouchedAndNamesTheComponent) {
    for (double dt : {0.1, 1e-3, 1e-9}) {
        std::vector<double> x{0.8, -0.6, 0.0};
        const auto x0 = x;
        typename TypeParam::template stepper<std::vector<double>> st;
        sliding f;
        const eci::step_result r = st.step(f, x, 0.0, dt);
        EXPECT_FALSE(r) << TypeParam::name << " dt " << dt;
        EXPECT_EQ(r.component, 2u) << TypeParam::name << " dt " << dt;
        EXPECT_EQ(x, x0) << TypeParam::name << ": a failed step must not touch any component";
    }
    // Complex state: the component counts real unknowns, so the real part of the second mode is number 2.
    cvec c{{0.8, -0.6}, {0.0, 0.5}};
    const cvec c0 = c;
    typename TypeParam::template stepper<cvec> st;
    sliding f;
    const eci::step_result r = st.step(f, c, 0.0, 0.1);
    EXPECT_FALSE(r);
    EXPECT_EQ(r.component, 2u) << TypeParam::name;
    EXPECT_EQ(c, c0);
}

// A right-hand side that returns NaN must fail the step, never hand back a NaN state as a success.
TYPED_TEST(ConservativeMethod, NonFiniteRightHandSideFailsTheStep) {
    const auto nan_rhs = [](const std::vector<double>&, std::vector<double>& d, double) {
        for (double& v : d) v = std::numeric_limits<double>::quiet_NaN();
    };
    std::vector<double> x{1.0, 0.5, -0.25};
    const auto x0 = x;
    typename TypeParam::template stepper<std::vector<double>> st;
    EXPECT_FALSE(st.step(nan_rhs, x, 0.0, 0.1)) << TypeParam::name;
    EXPECT_EQ(x, x0);
}

}  // namespace
