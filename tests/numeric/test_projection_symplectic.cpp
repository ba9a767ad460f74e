// Orthogonal projection and the symplectic splittings: order, conservation, the projection's failure
// path, agreement with Boost.Odeint's symplectic_rkn_sb3a_mclachlan, and Kepler e = 0.5's error growth exponents.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <utility>
#include <vector>

#include <boost/numeric/odeint/stepper/symplectic_rkn_sb3a_mclachlan.hpp>

#include <eci/models/list.hpp>
#include <eci/models/rigid_body_exact.hpp>
#include <eci/steppers/projection.hpp>
#include <eci/steppers/relaxation_rk.hpp>
#include <eci/steppers/symplectic.hpp>

#include "numeric/support.hpp"

namespace {

using namespace eci;
using eci::test::eps;
using K = kepler_cartesian::state_type;
using rb_state = rigid_body::state_type;

const kepler_cartesian kc{};
const K k0 = kepler_cartesian::initial_state(0.5);

double max_diff(const K& a, const K& b) {
    double m = 0.0;
    for (std::size_t i = 0; i < 4; ++i) m = std::max(m, std::abs(a[i] - b[i]));
    return m;
}

// Global order on Kepler e = 0.5 over one period (2 pi), n = 200..1600 steps: errors 1e-4..1e-9 (fourth order).
template <class Make>
double kepler_order(Make make) {
    const kepler_cartesian_exact exact(k0);
    std::vector<double> dts, errs;
    for (int n = 200; n <= 1600; n *= 2) {
        auto st = make();
        K u = k0;
        const double dt = 2.0 * std::numbers::pi / n;
        integrate_n_steps(st, kc, u, 0.0, dt, std::uint64_t(n));
        dts.push_back(dt);
        errs.push_back(max_diff(u, exact(2.0 * std::numbers::pi)));
    }
    const double p = test::log_log_slope(dts, errs);
    std::printf("  errors %.2e .. %.2e, observed order %.3f\n", errs.front(), errs.back(), p);
    return p;
}

const auto kepler_hl = pick_invariants(invariants_of(kc), {0, 1});
using hl_set = std::remove_const_t<decltype(kepler_hl)>;
using projected_rk4 = orthogonal_projection<rk4<K>, K, hl_set>;

TEST(ProjectionOrder, ProjectedRk4IsFourthOrder) {
    EXPECT_NEAR(kepler_order([] { return projected_rk4(kepler_hl); }), 4.0, 0.3);
}
TEST(SymplecticOrder, StormerVerletIsSecondOrder) {
    EXPECT_NEAR(kepler_order([] { return stormer_verlet<K>{}; }), 2.0, 0.15);
}
TEST(SymplecticOrder, Sb3aIsFourthOrderInBothDriftRules) {
    EXPECT_NEAR(kepler_order([] { return sb3a<K>{}; }), 4.0, 0.3);
    using nystrom = symplectic_splitting<splittings::mclachlan_sb3a, K, drift_rule::momentum>;
    EXPECT_NEAR(kepler_order([] { return nystrom{}; }), 4.0, 0.3);
}

// The same coefficients, the same order of operations as Boost.Odeint's stepper (given the force only, q' = p):
// the two agree to a few roundings per step.
TEST(Symplectic, Sb3aAgreesWithBoostOdeint) {
    using coor = std::array<double, 2>;
    boost::numeric::odeint::symplectic_rkn_sb3a_mclachlan<coor> odeint_stepper;
    auto force = [](const coor& q, coor& dpdt) {
        const double r2 = q[0] * q[0] + q[1] * q[1], r3 = r2 * std::sqrt(r2);
        dpdt = {-q[0] / r3, -q[1] / r3};
    };
    coor q{k0[0], k0[1]}, p{k0[2], k0[3]};
    symplectic_splitting<splittings::mclachlan_sb3a, K, drift_rule::momentum> ours;
    K u = k0;
    const double dt = 0.01;
    const int n = 1000;
    for (int i = 0; i < n; ++i) {
        odeint_stepper.do_step(force, std::make_pair(std::ref(q), std::ref(p)), 0.0, dt);
        ASSERT_TRUE(ours.step(kc, u, i * dt, dt));
    }
    // Both round differently only where odeint applies its zero last kick; differences grow like the error
    // propagation of the orbit, linearly in time: 1e4 eps after 1000 steps is far below the 1e-9 truncation error.
    EXPECT_LE(max_diff(u, K{q[0], q[1], p[0], p[1]}), 1e4 * eps);
}

// Drifts through the system: one right-hand side per drift and per kick, the first drift of a step reusing the last
// evaluation. Verlet: 3 on the first step, 2 after; SB3A: 11, then 10. The momentum rule: kicks only (2 for Verlet...)
TEST(Symplectic, CountsOfRightHandSides) {
    K u = k0;
    stormer_verlet<K> sv;
    EXPECT_EQ(integrate_n_steps(sv, kc, u, 0.0, 0.01, 10).rhs_evals, 3u + 9u * 2u);
    u = k0;
    sb3a<K> s4;
    EXPECT_EQ(integrate_n_steps(s4, kc, u, 0.0, 0.01, 10).rhs_evals, 11u + 9u * 10u);
    u = k0;
    symplectic_splitting<splittings::mclachlan_sb3a, K, drift_rule::momentum> nystrom;
    EXPECT_EQ(integrate_n_steps(nystrom, kc, u, 0.0, 0.01, 10).rhs_evals, 10u * 5u);
}

TEST(Symplectic, MomentumRuleRejectsASystemWithAnotherVelocity) {
    auto not_unit_mass = [](const K& u, K& d, double) { d = {2.0 * u[2], 2.0 * u[3], -u[0], -u[1]}; };
    symplectic_splitting<splittings::stormer_verlet, K, drift_rule::momentum> st;
    K u = k0;
    EXPECT_THROW(st.step(not_unit_mass, u, 0.0, 0.1), std::invalid_argument);
    std::array<double, 3> odd{1.0, 2.0, 3.0};
    stormer_verlet<std::array<double, 3>> sv;
    auto f3 = [](const std::array<double, 3>&, std::array<double, 3>& d, double) { d = {}; };
    EXPECT_THROW(sv.step(f3, odd, 0.0, 0.1), std::invalid_argument);
}

// Projection keeps H and L to round-off relative to the initial values (carried, so no random walk).
TEST(Projection, KeepsBothInvariantsToTheSolvesTolerance) {
    projected_rk4 st(kepler_hl);
    K u = k0;
    double dh = 0.0, dl = 0.0;
    const std::uint64_t n = 20000;
    integrate_n_steps(st, kc, u, 0.0, 0.05, n, [&](const K& s, double, std::uint64_t) {
        dh = std::max(dh, std::abs(kc.hamiltonian(s) - kc.hamiltonian(k0)));
        dl = std::max(dl, std::abs(kc.angular_momentum(s) - kc.angular_momentum(k0)));
    });
    // The solve stops within 4 eps of each invariant's rounding scale (|I| + sum |u dI/du| <= ~10 here): a bound
    // independent of the step count, since every projection aims at the initial values.
    EXPECT_LE(dh, 40.0 * eps);
    EXPECT_LE(dl, 40.0 * eps);
    EXPECT_EQ(st.statistics().accepted, n);
    EXPECT_GT(st.statistics().solver.iterations, 0u);
    EXPECT_LE(st.statistics().solver.max_iterations, 4);  // simplified Newton from an O(dt^5) distance
}

// An invariant that cannot be reached (NaN) fails every projection: counted, x untouched, and the run stops after
// the driver's 40 halvings rather than looping. Dependent invariants (H, L, A_x, A_y) make G G^T singular: rejected.
TEST(Projection, NonConvergenceAndSingularGramAreRejectedSteps) {
    const auto broken = make_invariants<K>(
        1, [](const K&, std::size_t) { return std::numeric_limits<double>::quiet_NaN(); },
        [](const K&, std::size_t, K& g) { g = {1.0, 0.0, 0.0, 0.0}; });
    orthogonal_projection<rk4<K>, K, decltype(broken)> never(broken);
    K u = k0;
    EXPECT_THROW(integrate_n_steps(never, kc, u, 0.0, 0.05, 10), step_size_underflow);
    EXPECT_EQ(never.statistics().rejected_solver, 41u);  // the first attempt and one per halving
    EXPECT_EQ(u, k0);
    orthogonal_projection<rk4<K>, K, kepler_cartesian::invariant_set> dependent(invariants_of(kc));
    K v = k0;
    EXPECT_FALSE(dependent.step(kc, v, 0.0, 0.05));
    EXPECT_EQ(dependent.statistics().rejected_solver, 1u);
    EXPECT_EQ(v, k0);
}

// No Newton iteration allowed: a step is accepted only if RK4's own result already lies on the level set (to the
// tolerance), which halving reaches while the accepted steps' small deviations have not added up; once they have,
// nothing can be accepted and the run ends with step_size_underflow after 40 halvings: rejected, counted, no hang.
TEST(Projection, AnIterationLimitOfZeroEndsTheRunWithoutLooping) {
    orthogonal_projection<rk4<K>, K, hl_set> none(kepler_hl, rk4<K>{}, 0);
    K u = k0;
    EXPECT_THROW(integrate_n_steps(none, kc, u, 0.0, 0.05, 4), step_size_underflow);
    EXPECT_GT(none.statistics().accepted, 0u);
    EXPECT_GE(none.statistics().rejected_solver, 41u);
    EXPECT_EQ(none.statistics().solver.iterations, 0u);
}

TEST(Projection, RigidBodyBothInvariantsAndExactSolution) {
    const rigid_body body;
    orthogonal_projection<rk4<rb_state>, rb_state, rigid_body::invariant_set> st(invariants_of(body));
    rb_state u = rigid_body::initial_state();
    integrate_n_steps(st, body, u, 0.0, 0.01, 1000);
    const rb_state e = rigid_body_exact(10.0);
    for (std::size_t i = 0; i < 3; ++i) EXPECT_NEAR(u[i], e[i], 1e-9);  // RK4 at dt = 0.01: ~1e-10
    EXPECT_LE(std::abs(body.g1(u) - 2.0), 40.0 * eps);
}

// Ranocha & Ketcheson's Kepler e = 0.5 to t = 300 pi: the error grows like t^2 for RK4 and like t for the methods
// keeping H (relaxation), H and L (projection), the symplectic method and eci's transformation method (H and the
// Runge-Lenz vector, in polar variables). Exponents fitted over t in [10, 300 pi], dt = 0.025.
double growth_exponent(const std::vector<double>& t, const std::vector<double>& e) { return test::log_log_slope(t, e); }

template <class St, class Model, class Map, class Lag>
double kepler_growth(St st, const Model& model, typename Model::state_type x0, Map to_cartesian, Lag lag) {
    const kepler_cartesian_exact exact(k0);
    const double dt = 0.025, T = 300.0 * std::numbers::pi;
    std::vector<double> ts, es;
    integrate_n_steps(
        st, model, x0, 0.0, dt, steps_to_reach(0.0, T, dt),
        [&](const auto& s, double t, std::uint64_t) {
            if (t < 10.0) return;
            ts.push_back(t);
            es.push_back(max_diff(to_cartesian(s), exact(t + lag(st))));
        },
        run_options{40});
    return growth_exponent(ts, es);
}

TEST(KeplerErrorGrowth, QuadraticForRk4LinearForConservingMethods) {
    auto same = [](const K& s) { return s; };
    auto zero = [](const auto&) { return 0.0; };
    const auto H = pick_invariants(invariants_of(kc), {0});
    const double rk = kepler_growth(rk4<K>{}, kc, k0, same, zero);
    const double rrk = kepler_growth(rrk4<K, decltype(H)>(H), kc, k0, same, [](const auto& s) { return s.time_lag(); });
    const double proj = kepler_growth(projected_rk4(kepler_hl), kc, k0, same, zero);
    const double symp =
        kepler_growth(symplectic_splitting<splittings::mclachlan_sb3a, K, drift_rule::momentum>{}, kc, k0, same, zero);
    const auto [pm, p0] = kepler_cartesian::to_polar(k0);
    const double ell = pm.ell;
    const double trk = kepler_growth(transformed_rk4<kepler::transform>{}, pm, p0,
                                     [&](const kepler::state_type& s) { return kepler_cartesian::from_polar(s, ell); },
                                     zero);
    std::printf("  error growth exponents: RK4 %.2f, RRK4(H) %.2f, projection(H, L) %.2f, SB3A %.2f, "
                "C-RK4 (transform) %.2f\n",
                rk, rrk, proj, symp, trk);
    EXPECT_NEAR(rk, 2.0, 0.25);
    EXPECT_NEAR(rrk, 1.0, 0.2);
    EXPECT_NEAR(proj, 1.0, 0.2);
    EXPECT_NEAR(symp, 1.0, 0.2);
    EXPECT_NEAR(trk, 1.0, 0.2);
}

}  // namespace
