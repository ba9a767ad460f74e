// The invariant sets of the models and the new problems' exact solutions: gradients against central
// differences, invariants constant along the exact solutions, and a user's set built from lambdas.
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <limits>

#include <eci/invariants.hpp>
#include <eci/models/list.hpp>
#include <eci/models/rigid_body_exact.hpp>
#include <eci/models/three_wave_exact.hpp>

#include "numeric/support.hpp"

namespace {

using namespace eci;
using eci::test::eps;

// Central differences with h = eps^(1/3) |x|-scaled: error O(h^2) + O(eps / h) ~ eps^(2/3) ~ 4e-11 relative to the
// invariant's scale; 1e-8 leaves room for third derivatives of order 100 (Kepler near pericentre).
template <class Set, class S>
void expect_gradients(const Set& set, const S& x) {
    for (std::size_t i = 0; i < set.count(); ++i) {
        S g = x;
        set.gradient(x, i, g);
        const auto gr = detail::reals(std::as_const(g));
        for (std::size_t j = 0; j < gr.size(); ++j) {
            S a = x, b = x;
            const double h = std::cbrt(eps) * std::max(1.0, std::abs(detail::reals(x)[j]));
            detail::reals(a)[j] += h;
            detail::reals(b)[j] -= h;
            const double fd = (set.value(a, i) - set.value(b, i)) / (2.0 * h);
            EXPECT_NEAR(gr[j], fd, 1e-8 * std::max(1.0, std::abs(fd))) << "invariant " << i << ", unknown " << j;
        }
    }
}

TEST(InvariantSets, GradientsMatchCentralDifferences) {
    expect_gradients(invariants_of(three_wave{}), three_wave::state_type{0.3, -1.2, 0.7});
    expect_gradients(invariants_of(lotka_volterra{}), lotka_volterra::state_type{0.6, 1.7});
    expect_gradients(invariants_of(kepler{1.3, 1.5, 0.8}), kepler::state_type{0.9, 0.3, 0.7});
    expect_gradients(invariants_of(kepler_cartesian{}), kepler_cartesian::state_type{0.3, -0.7, 0.9, 0.4});
    expect_gradients(invariants_of(rigid_body{}), rigid_body::state_type{0.4, 0.8, -0.6});
    expect_gradients(invariants_of(nonlinear_oscillator{}), nonlinear_oscillator::state_type{0.6, -0.9});
    expect_gradients(invariants_of(exponential_entropy{}), exponential_entropy::state_type{1.0, 0.5});
    const auto nw = n_wave<std::complex<double>>::random(9, 2, 7);
    expect_gradients(invariants_of(nw), nw.random_state(3));
}

// The sets measure what the models' named invariants measure.
TEST(InvariantSets, AgreeWithTheModelsNamedInvariants) {
    const three_wave tw;
    const three_wave::state_type x{0.3, -1.2, 0.7};
    EXPECT_DOUBLE_EQ(invariants_of(tw).value(x, 0), tw.energy(x));
    EXPECT_DOUBLE_EQ(invariants_of(tw).value(x, 1), tw.enstrophy(x));
    const kepler kp{1.3, 1.5, 0.8};
    const kepler::state_type s{0.9, 0.3, 0.7};
    EXPECT_DOUBLE_EQ(invariants_of(kp).value(s, 2), kp.runge_lenz_y(s));
    const lotka_volterra lv{2.0};
    EXPECT_DOUBLE_EQ(invariants_of(lv).value({0.6, 1.7}, 0), lv.hamiltonian({0.6, 1.7}));
}

TEST(InvariantSets, UserSetsFromLambdasAndSubsets) {
    using S = std::array<double, 2>;
    const auto inv = make_invariants<S>(
        2, [](const S& x, std::size_t i) { return i == 0 ? x[0] + x[1] : x[0] * x[1]; },
        [](const S& x, std::size_t i, S& g) { g = i == 0 ? S{1.0, 1.0} : S{x[1], x[0]}; });
    static_assert(invariant_set<decltype(inv), S>);
    static_assert(!quadratic_invariant_set<decltype(inv), S>);
    expect_gradients(inv, S{0.3, 2.0});
    const auto second = pick_invariants(inv, {1});
    EXPECT_EQ(second.count(), 1u);
    EXPECT_DOUBLE_EQ(second.value(S{3.0, 2.0}, 0), 6.0);
    EXPECT_THROW(pick_invariants(inv, {2}), std::invalid_argument);
    EXPECT_THROW(make_invariants<S>(0, [](const S&, std::size_t) { return 0.0; }, [](const S&, std::size_t, S&) {}),
                 std::invalid_argument);
    static_assert(quadratic_invariant_set<decltype(pick_invariants(invariants_of(rigid_body{}), {1})),
                                          rigid_body::state_type>);
}

// The rigid body is a three-wave system with K^2, P^2, Q^2 = 1, beta, alpha: its Jacobi-function solution and
// three_wave_exact's agree, and the invariants stay constant along it. Both are accurate to a few eps per unit
// of elliptic argument (Boost's argument reduction), so 1e3 eps at t <= 20.
TEST(RigidBodyExact, AgreesWithTheThreeWaveSolutionAndKeepsTheInvariants) {
    const rigid_body body;
    three_wave tw;
    tw.K = 1.0, tw.P = std::sqrt(body.beta), tw.Q = std::sqrt(body.alpha);
    tw.M = {body.alpha - body.beta, 1.0 - body.alpha, body.beta - 1.0};
    const three_wave_exact other(tw, rigid_body::initial_state());
    for (double t : {0.3, 1.7, 5.0, 12.0, 20.0}) {
        const auto a = rigid_body_exact(t), b = other(t);
        for (std::size_t i = 0; i < 3; ++i) EXPECT_NEAR(a[i], b[i], 1e3 * eps) << "t = " << t;
        EXPECT_NEAR(body.g1(a), 2.0, 16 * eps);
        EXPECT_NEAR(body.g2(a), body.g2(rigid_body::initial_state()), 16 * eps);
    }
}

// The exact solutions of the oscillator and the exponential entropy solve their equations: a centred difference
// of the solution matches the right-hand side (error h^2 |u'''| / 6, |u'''| up to C^3 ~ 100 here: 1e-7 at h = 1e-4,
// plus eps / h ~ 1e-12).
TEST(NewModelsExact, SolveTheirEquations) {
    const exponential_entropy ee;
    const nonlinear_oscillator osc;
    const double h = 1e-4;
    for (double t : {0.5, 2.0, 4.5}) {
        const auto s0 = exponential_entropy::initial_state();
        auto a = exponential_entropy::exact(s0, t + h), b = exponential_entropy::exact(s0, t - h),
             c = exponential_entropy::exact(s0, t);
        exponential_entropy::state_type d{};
        ee(c, d, t);
        for (std::size_t i = 0; i < 2; ++i) EXPECT_NEAR((a[i] - b[i]) / (2 * h), d[i], 1e-6 * (1.0 + std::abs(d[i])));
        EXPECT_NEAR(ee.entropy(c), ee.entropy(s0), 16 * eps * ee.entropy(s0));
        const nonlinear_oscillator::state_type u0{0.6, 0.8};
        auto p = nonlinear_oscillator::exact(u0, t + h), q = nonlinear_oscillator::exact(u0, t - h),
             r = nonlinear_oscillator::exact(u0, t);
        nonlinear_oscillator::state_type e{};
        osc(r, e, t);
        for (std::size_t i = 0; i < 2; ++i) EXPECT_NEAR((p[i] - q[i]) / (2 * h), e[i], 1e-8);
    }
}

// Kepler in Cartesian variables: the exact orbit is closed (period 2 pi), keeps H, L and A, and the polar mapping
// round-trips.
TEST(KeplerCartesian, ExactOrbitAndPolarMapping) {
    const kepler_cartesian kc;
    const auto u0 = kepler_cartesian::initial_state(0.5);
    const kepler_cartesian_exact exact(u0);
    EXPECT_NEAR(exact.period(), 2.0 * std::acos(-1.0), 1e-14);
    const auto u = exact(2.0 * std::acos(-1.0));
    for (std::size_t i = 0; i < 4; ++i) EXPECT_NEAR(u[i], u0[i], 1e-12);
    const auto mid = exact(1.234);
    EXPECT_NEAR(kc.hamiltonian(mid), -0.5, 1e-14);
    EXPECT_NEAR(kc.angular_momentum(mid), std::sqrt(0.75), 1e-14);
    EXPECT_NEAR(kc.runge_lenz_x(mid), 0.5, 1e-14);
    const auto [pm, ps] = kepler_cartesian::to_polar(mid);
    const auto back = kepler_cartesian::from_polar(ps, pm.ell);
    for (std::size_t i = 0; i < 4; ++i) EXPECT_NEAR(back[i], mid[i], 8 * eps);
    EXPECT_THROW(kepler_cartesian::initial_state(1.0), std::invalid_argument);
    EXPECT_THROW(kepler_cartesian_exact(kepler_cartesian::state_type{1.0, 0.0, 0.0, 2.0}), std::invalid_argument);
}

// The transformation method on the exponential entropy through its transform xi = (e^u, e^v): entropy to
// round-off, fourth order against the exact solution.
TEST(ExponentialEntropyTransform, TransformedRk4KeepsTheEntropyAndIsFourthOrder) {
    const exponential_entropy ee;
    const auto s0 = exponential_entropy::initial_state();
    std::vector<double> dts, errs;
    for (int n = 100; n <= 800; n *= 2) {
        transformed_rk4<exponential_entropy::transform> st;  // the transform is the stepped model's
        auto s = s0;
        double drift = 0.0;
        integrate_n_steps(st, ee, s, 0.0, 5.0 / n, std::uint64_t(n), [&](const auto& x, double, std::uint64_t) {
            drift = std::max(drift, std::abs(ee.entropy(x) - ee.entropy(s0)));
        });
        // xi is carried and summed: a rounding of e^u + e^v ~ 4.4 per step, as a random walk, plus exp's rounding.
        EXPECT_LE(drift, 8.0 * eps * ee.entropy(s0) * std::sqrt(double(n)));
        const auto e = exponential_entropy::exact(s0, 5.0);
        dts.push_back(5.0 / n);
        errs.push_back(std::max(std::abs(s[0] - e[0]), std::abs(s[1] - e[1])));
    }
    EXPECT_NEAR(test::log_log_slope(dts, errs), 4.0, 0.25);
}

}  // namespace
