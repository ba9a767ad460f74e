// Unit tests of the transform mechanism (transformed_rk.hpp): xi = psi^2 reproduces C-PC and C-RK4 to round-off,
// the LV and Kepler inverses are exact on their branches, failures leave the state alone, and Kahan's equations.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <random>

#include <eci/eci.hpp>
#include <eci/models/kepler.hpp>
#include <eci/models/lotka_volterra.hpp>
#include <eci/models/n_wave.hpp>
#include <eci/models/three_wave.hpp>
#include <eci/steppers/kahan.hpp>
#include <eci/steppers/transformed_rk.hpp>

namespace {

constexpr double eps = std::numeric_limits<double>::epsilon();

// One step of St1 and St2 from the same state: equal to the rounding of psi^2(t+dt), whose terms are
// psi^2, dt psi S and dt psi~ S~ (each carries a few roundings); |d psi| = |d psi^2| / (|psi_a| + |psi_b|).
template <class St1, class St2, class Model, class S>
void expect_same_step(const Model& model, const S& x, double dt) {
    St1 a_stepper;
    St2 b_stepper;
    S a = x, b = x;
    ASSERT_TRUE(a_stepper.step(model, a, 0.0, dt));
    ASSERT_TRUE(b_stepper.step(model, b, 0.0, dt));
    S k{}, pred{}, kp{};
    eci::detail::resize_like(k, x);
    eci::detail::resize_like(kp, x);
    model(x, k, 0.0);
    pred = x;
    for (std::size_t i = 0; i < x.size(); ++i) pred[i] += dt * k[i];
    model(pred, kp, 0.0);
    for (std::size_t i = 0; i < x.size(); ++i) {
        const double terms = x[i] * x[i] + dt * (std::abs(x[i] * k[i]) + std::abs(pred[i] * kp[i]));
        const double tol = 16.0 * eps * terms / (std::abs(a[i]) + std::abs(b[i]));
        EXPECT_NEAR(a[i], b[i], tol) << "component " << i;
    }
}

}  // namespace

// Section III.D: C-PC is the transform mechanism with xi_k = psi_k^2 over Heun's tableau.
TEST(TransformedRk, SquareTransformIsCpcOnThreeWave) {
    eci::three_wave model;
    using S = eci::three_wave::state_type;
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> u(-1.5, 1.5);
    for (int trial = 0; trial < 500; ++trial) {
        const S x{u(rng), u(rng), u(rng)};
        expect_same_step<eci::c_pc<S>, eci::transformed_pc<eci::square_transform<S>>>(model, x, 0.01);
    }
}

// Over a run the two differ only by rounding, which shifts the phase of an integrable orbit linearly in the
// step count: bound the difference by k eps n (k for the a few roundings per step, times the orbit's scale).
TEST(TransformedRk, SquareTransformFollowsCpcOverARun) {
    eci::three_wave model;
    using S = eci::three_wave::state_type;
    const S x0{std::sqrt(1.5), 1.0, std::sqrt(1.5)};  // Fig. 5's initial condition
    const std::uint64_t n = 10000;
    const double dt = 0.01;
    S a = x0, b = x0;
    eci::c_pc<S> sa;
    eci::transformed_pc<eci::square_transform<S>> sb;
    std::vector<S> ta, tb;
    const auto ra = eci::integrate_n_steps(sa, model, a, 0.0, dt, n, [&](const S& s, double, std::uint64_t) {
        ta.push_back(s);
    });
    const auto rb = eci::integrate_n_steps(sb, model, b, 0.0, dt, n, [&](const S& s, double, std::uint64_t) {
        tb.push_back(s);
    });
    ASSERT_EQ(ra.step_reductions, 0u);
    ASSERT_EQ(rb.step_reductions, 0u);
    for (std::size_t i = 0; i < ta.size(); ++i)
        for (std::size_t k = 0; k < 3; ++k) ASSERT_NEAR(ta[i][k], tb[i][k], 16.0 * eps * double(i + 1)) << "step " << i;
}

// The same mechanism over RK4's tableau with the update's sign is errata item 9's conservative RK4.
TEST(TransformedRk, SquareTransformIsConservativeRk4OnComplexNWave) {
    const auto model = eci::n_wave<std::complex<double>>::random(12, 2, 5);
    using S = eci::n_wave<std::complex<double>>::state_type;
    const S x = model.random_state(9);
    eci::c_rk4<S> sa;
    eci::transformed_rk4<eci::square_transform<S>> sb;
    S a = x, b = x;
    ASSERT_TRUE(sa.step(model, a, 0.0, 0.01));
    ASSERT_TRUE(sb.step(model, b, 0.0, 0.01));
    const auto ar = eci::detail::reals(std::as_const(a)), br = eci::detail::reals(std::as_const(b));
    const auto xr = eci::detail::reals(x);
    for (std::size_t i = 0; i < ar.size(); ++i) {
        // psi^2 changes by O(dt); its rounding (a few eps of max(psi^2, dt |2 psi S|) ~ eps) over |psi_a| + |psi_b|.
        const double tol = 16.0 * eps * (xr[i] * xr[i] + 0.1) / (std::abs(ar[i]) + std::abs(br[i]));
        EXPECT_NEAR(ar[i], br[i], tol) << "real unknown " << i;
    }
}

// A failed step (xi pushed below its minimum) leaves x and the carried xi untouched.
TEST(TransformedRk, FailedStepLeavesStateAndXiAlone) {
    eci::lotka_volterra model;
    using S = eci::lotka_volterra::state_type;
    eci::transformed_pc<eci::lotka_volterra::transform> st;
    // The state before the first failed step of the paper's run (step 368): y is about to cross 1, and the
    // trapezoid pushes xi_2 below its minimum (the paper's xi_2 < mu).
    S x{0.31312108637717223, 0.98593820588116488};
    const S before = x;
    eci::lotka_volterra::transform::xi_type xi0{};
    model.linearizing_transform().to_xi(x, xi0);
    const auto r = st.step(model, x, 0.0, 0.02);
    ASSERT_FALSE(r);
    EXPECT_EQ(r.component, 1u);
    EXPECT_EQ(x, before);
    EXPECT_EQ(st.xi(), xi0);
    ASSERT_TRUE(st.step(model, x, 0.0, 0.01));  // the driver's half step then succeeds
    EXPECT_NE(x, before);
}

// The carried xi keeps H = 1 + mu + xi_1 + xi_2 to a few roundings per step, exactly as the paper intends.
TEST(TransformedRk, CarriedXiConservesLinearInvariant) {
    eci::lotka_volterra model;
    using S = eci::lotka_volterra::state_type;
    eci::transformed_pc<eci::lotka_volterra::transform> st;
    S x{1.0, 0.4};
    const double h0 = model.hamiltonian(x);
    const std::uint64_t n = 20000;
    eci::integrate_n_steps(st, model, x, 0.0, 0.02, n);
    // Each step rounds xi_1 + D and xi_2 - D once each: a random walk of 2 eps H per step.
    EXPECT_NEAR(1.0 + model.mu + st.xi()[0] + st.xi()[1], h0, 4.0 * eps * h0 * std::sqrt(double(n)));
    EXPECT_NEAR(model.hamiltonian(x), h0, 4.0 * eps * h0 * std::sqrt(double(n)));
}

// Newton's inverse of (x - 1) - log x: exact to round-off on both branches, from near x = 1 to far away,
// in a bounded number of iterations, and "not invertible" below the minimum.
TEST(LotkaVolterraInverse, NewtonIsExactOnTheHintsBranch) {
    int worst = 0;
    for (double x : {1e-6, 0.01, 0.3, 0.9, 0.999, 1.0 - 1e-7, 1.0 + 1e-7, 1.001, 1.1, 2.0, 10.0, 1e4}) {
        const double u = x - 1.0, target = u - std::log(x);
        for (double hint_offset : {0.0, 0.1, 1e-3}) {
            const double hint = x + (u > 0 ? hint_offset : -hint_offset) * std::abs(u);
            const auto root = eci::detail::invert_x_minus_log(target, hint);
            ASSERT_TRUE(root.ok) << x;
            // Attainable: target's rounding eps (|u| + |log x|) through the slope |x - 1| / x, plus x's own ulp.
            const double tol = 4.0 * eps * x * (1.0 + (std::abs(u) + std::abs(std::log(x))) / std::abs(u));
            EXPECT_NEAR(root.value, x, tol) << "hint " << hint;
            worst = std::max(worst, root.iterations);
        }
        // The other branch's hint gives the other root, never this one (for x = 1e4 the lower root,
        // exp(-9991), underflows: not invertible).
        if (target > 700.0) {
            EXPECT_FALSE(eci::detail::invert_x_minus_log(target, 0.5).ok);
            continue;
        }
        const auto mirror = eci::detail::invert_x_minus_log(target, u > 0 ? 0.5 : 2.0);
        ASSERT_TRUE(mirror.ok);
        EXPECT_EQ(mirror.value > 1.0, u < 0) << x;
    }
    EXPECT_LE(worst, 12);
    EXPECT_FALSE(eci::detail::invert_x_minus_log(-1e-12, 1.5).ok);
    EXPECT_FALSE(eci::detail::invert_x_minus_log(std::numeric_limits<double>::quiet_NaN(), 1.5).ok);
    EXPECT_FALSE(eci::detail::invert_x_minus_log(std::numeric_limits<double>::infinity(), 1.5).ok);
}

// The Kepler inverse returns (r, v_r, theta) from xi to round-off, also where r equals the semi-major axis:
// there eq. (54) has a double root (d/dtheta of A.v vanishes), but the vector equation does not.
TEST(KeplerInverse, RoundTripIncludingTheDoubleRootOfEq54) {
    const eci::kepler model;  // a = 0.75 for the paper's orbit
    const auto tr = model.linearizing_transform();
    const double h = -1.0, a_axis = -model.K / (2.0 * h);
    // At r = a on the orbit with H = -1: v_r^2 = 2 (H + K/r - ell^2/(2 m r^2)) / m.
    const double vr_at_a = std::sqrt(2.0 * (h + model.K / a_axis - 0.5 / (a_axis * a_axis)));
    for (const eci::kepler::state_type s : {eci::kepler::state_type{1.0, 0.0, 0.0},
                                            eci::kepler::state_type{a_axis, vr_at_a, 2.1},
                                            eci::kepler::state_type{a_axis, -vr_at_a, -40.0},
                                            eci::kepler::state_type{0.6, 0.3, 123.4}}) {
        eci::kepler::transform::xi_type xi{};
        tr.to_xi(s, xi);
        eci::solver_stats stats;
        eci::kepler::state_type back{};
        const eci::kepler::state_type hint{s[0], s[1], s[2] + 0.05};
        ASSERT_TRUE(tr.from_xi(xi, hint, back, stats));
        const double scale = model.K + model.ell * model.ell / (model.m * s[0]) + std::abs(s[1]);
        EXPECT_NEAR(back[0], s[0], 4.0 * eps * s[0]);
        // v_r^2 = (2 xi_2 - ell^2/(m r^2)) / m carries a few roundings of 2 xi_2 / m; the sign is the hint's.
        EXPECT_NEAR(back[1] * back[1], s[1] * s[1], 8.0 * eps * 2.0 * xi[1] / model.m);
        EXPECT_EQ(std::signbit(back[1]), std::signbit(s[1]));
        const auto A = model.runge_lenz(s);
        EXPECT_NEAR(back[2], s[2], 16.0 * eps * (scale / std::hypot(A[0], A[1]) + std::abs(s[2])));
        EXPECT_LE(stats.max_iterations, 5);
    }
    // At r = a the derivative of (54)'s residual A.v + K v_r in theta is A x v, which vanishes: (54) alone
    // would have a double root there.
    const eci::kepler::state_type s{a_axis, vr_at_a, 0.7};
    const auto A = model.runge_lenz(s);
    const double vx = vr_at_a * std::cos(0.7) - (model.ell / (model.m * a_axis)) * std::sin(0.7);
    const double vy = vr_at_a * std::sin(0.7) + (model.ell / (model.m * a_axis)) * std::cos(0.7);
    EXPECT_NEAR(A[0] * vy - A[1] * vx, 0.0, 16.0 * eps);
}

// Branch choice in the Kepler inverse: the hint's sign of v_r is kept; xi_1 >= 0 is not invertible.
TEST(KeplerInverse, BranchAndFailures) {
    const eci::kepler model;
    const auto tr = model.linearizing_transform();
    const eci::kepler::state_type s{0.8, 0.4, 1.0};
    eci::kepler::transform::xi_type xi{};
    tr.to_xi(s, xi);
    eci::solver_stats stats;
    eci::kepler::state_type out{};
    ASSERT_TRUE(tr.from_xi(xi, {0.8, -0.1, 1.0}, out, stats));
    EXPECT_LT(out[1], 0.0);
    auto bad = xi;
    bad[0] = 0.0;
    auto r = tr.from_xi(bad, s, out, stats);
    EXPECT_FALSE(r.ok);
    EXPECT_EQ(r.component, 0u);
    bad = xi;
    bad[1] = 0.0;  // below the centrifugal term: v_r^2 < 0
    r = tr.from_xi(bad, s, out, stats);
    EXPECT_FALSE(r.ok);
    EXPECT_EQ(r.component, 1u);
}

// Kahan's method solves its defining equations (x' - x)/dt = Qbar(x, x') + L (x + x')/2 for LV, where
// dx/dt = -mu x + mu x y: Qbar(x, x') = mu (x y' + x' y)/2, and dy/dt = y - x y: Qbar = -(x y' + x' y)/2.
TEST(Kahan, SolvesKahansEquationsForLotkaVolterra) {
    const eci::lotka_volterra model;
    eci::kahan<eci::lotka_volterra::state_type> st;
    for (const double dt : {0.01, 0.1, 0.5}) {
        const eci::lotka_volterra::state_type x{0.7, 1.6};
        auto y = x;
        ASSERT_TRUE(st.step(model, y, 0.0, dt));
        const double mu = model.mu;
        const double rx = (y[0] - x[0]) / dt - (-mu * 0.5 * (x[0] + y[0]) + mu * 0.5 * (x[0] * y[1] + y[0] * x[1]));
        const double ry = (y[1] - x[1]) / dt - (0.5 * (x[1] + y[1]) - 0.5 * (x[0] * y[1] + y[0] * x[1]));
        // Terms are O(1) (O(1/dt) for the difference quotient): a few roundings each.
        EXPECT_NEAR(rx, 0.0, 16.0 * eps / dt);
        EXPECT_NEAR(ry, 0.0, 16.0 * eps / dt);
    }
}
