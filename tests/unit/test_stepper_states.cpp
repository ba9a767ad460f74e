// Unit tests of the steppers on state types (std::vector, std::array, complex modes) and of buffer reuse: every
// method of the registry. (Apart from test_steppers.cpp so that the two compile side by side: each instantiates
// every method for several state types, the longest compiles of the unit tests.)
#include <gtest/gtest.h>

#include <array>
#include <complex>
#include <vector>

#include <eci/eci.hpp>

#include "numeric/support.hpp"

namespace {

using namespace eci::test;
using cvec = std::vector<std::complex<double>>;

template <class Method>
class EveryMethodOnStates : public ::testing::Test {};
TYPED_TEST_SUITE(EveryMethodOnStates, registry_methods_on_any_state, method_names);

// ---------------------------------------------------------------------------------------------------------------
// State types. The same system written for std::vector, std::array, and as complex modes versus interleaved real
// pairs (paper §III.C: n complex modes are 2n real ones) must give bit-for-bit the same steps.

struct coupled {  // a small nonlinear system with crossings: x0' = x1 x2, x1' = -2 x2 x0, x2' = x0 x1
    template <class S>
    void operator()(const S& x, S& d, double) const {
        for (std::size_t i = 0; i + 2 < std::size(x); i += 3) {
            d[i] = x[i + 1] * x[i + 2];
            d[i + 1] = -2.0 * x[i + 2] * x[i];
            d[i + 2] = x[i] * x[i + 1];
        }
    }
};

struct complex_coupled {  // the same real system, on (re, im) pairs of 3 complex modes = 6 real unknowns
    void operator()(const cvec& x, cvec& d, double) const {
        std::vector<double> r(6), dr(6);
        for (std::size_t i = 0; i < 3; ++i) r[2 * i] = x[i].real(), r[2 * i + 1] = x[i].imag();
        coupled{}(r, dr, 0.0);
        for (std::size_t i = 0; i < 3; ++i) d[i] = {dr[2 * i], dr[2 * i + 1]};
    }
};

TYPED_TEST(EveryMethodOnStates, VectorArrayAndComplexStatesStepIdentically) {
    const std::array<double, 6> init{1.1, -0.4, 0.05, 0.7, 0.9, -1.2};
    std::vector<double> v(init.begin(), init.end());
    std::array<double, 6> a = init;
    cvec c{{init[0], init[1]}, {init[2], init[3]}, {init[4], init[5]}};
    typename TypeParam::template stepper<std::vector<double>> sv;
    typename TypeParam::template stepper<std::array<double, 6>> sa;
    typename TypeParam::template stepper<cvec> sc;
    const auto rv = eci::integrate_n_steps(sv, coupled{}, v, 0.0, 0.05, 200);
    const auto ra = eci::integrate_n_steps(sa, coupled{}, a, 0.0, 0.05, 200);
    const auto rc = eci::integrate_n_steps(sc, complex_coupled{}, c, 0.0, 0.05, 200);
    for (std::size_t i = 0; i < 6; ++i) {
        EXPECT_EQ(v[i], a[i]) << i;
        EXPECT_EQ(v[i], i % 2 == 0 ? c[i / 2].real() : c[i / 2].imag()) << i;
    }
    EXPECT_EQ(rv.step_reductions, ra.step_reductions);
    EXPECT_EQ(rv.step_reductions, rc.step_reductions);
    EXPECT_EQ(rv.rhs_evals, rc.rhs_evals);
}

// One stepper object reused on states of different sizes resizes its buffers and gives what fresh ones give.
TYPED_TEST(EveryMethodOnStates, ReusedStepperResizesItsBuffers) {
    using S = std::vector<double>;
    typename TypeParam::template stepper<S> reused;
    for (std::size_t n : {3u, 9u, 6u, 3u}) {
        S x(n), y(n);
        for (std::size_t i = 0; i < n; ++i) x[i] = y[i] = 0.3 + 0.1 * double(i) * (i % 2 ? -1.0 : 1.0);
        typename TypeParam::template stepper<S> fresh;
        coupled f;
        ASSERT_TRUE(reused.step(f, x, 0.0, 0.01));
        ASSERT_TRUE(fresh.step(f, y, 0.0, 0.01));
        EXPECT_EQ(x, y) << "size " << n;
    }
}

}  // namespace
