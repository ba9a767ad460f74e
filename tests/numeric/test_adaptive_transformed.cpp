// Adaptive conservative DP54 through the invariant-linearizing transforms: Kepler with e = 0.9 over
// 100 orbits keeps H and the Runge-Lenz vector to round-off and does not precess, where odeint's dopri5 at the same
// tolerance does; Lotka-Volterra keeps H at every tolerance.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <vector>

#include <boost/numeric/odeint.hpp>

#include <eci/adaptive.hpp>
#include <eci/models/kepler.hpp>
#include <eci/models/kepler_exact.hpp>
#include <eci/models/lotka_volterra.hpp>
#include <eci/steppers/transformed_embedded_rk.hpp>

#include "numeric/support.hpp"

namespace {

using namespace eci::test;
using kstate = eci::kepler::state_type;

/// The orbit of eccentricity e starting at perihelion on the x axis, and its period.
struct eccentric_orbit {
    eci::kepler model{};
    kstate x0{};
    double period = 0.0;
    explicit eccentric_orbit(double e) {
        const double p = model.ell * model.ell / (model.m * model.K);  // semi-latus rectum
        x0 = {p / (1.0 + e), 0.0, 0.0};
        const double a = p / (1.0 - e * e);
        period = 2.0 * std::numbers::pi * std::sqrt(model.m * a * a * a / model.K);
    }
};

struct kepler_result {
    double h_drift = 0.0;     // largest |H - H0| / |H0| at any accepted step
    double a_drift = 0.0;     // largest |A - A0| / |A0|
    double turn = 0.0;        // the Runge-Lenz vector's turn at the end, radians
    double theta_end = 0.0;   // the final angle (unwrapped)
    double scale_ratio = 0.0; // max over the run of (K + ell^2/(m r) + |ell v_r|) / |A|: A's rounding, relative
    eci::adaptive_stats stats{};
};

kepler_result run_eci(const eccentric_orbit& o, double tol, double orbits) {
    eci::transformed_dp54<eci::kepler::transform> st;
    eci::adaptive_options opt;
    opt.rtol = opt.atol = tol;
    kstate x = o.x0;
    const double h0 = o.model.hamiltonian(x);
    const auto a0 = o.model.runge_lenz(x);
    const double a0n = std::hypot(a0[0], a0[1]);
    kepler_result r;
    r.stats = eci::integrate_adaptive(st, o.model, x, 0.0, orbits * o.period, 1e-3, opt, [&](const kstate& s, double) {
        r.h_drift = std::max(r.h_drift, std::abs(o.model.hamiltonian(s) - h0) / std::abs(h0));
        const auto a = o.model.runge_lenz(s);
        r.a_drift = std::max(r.a_drift, std::hypot(a[0] - a0[0], a[1] - a0[1]) / a0n);
        const double scale = o.model.K + o.model.ell * o.model.ell / (o.model.m * s[0]) + std::abs(o.model.ell * s[1]);
        r.scale_ratio = std::max(r.scale_ratio, scale / a0n);
    });
    r.turn = o.model.runge_lenz_turn(o.x0, x);
    r.theta_end = x[2];
    return r;
}

kepler_result run_odeint(const eccentric_orbit& o, double tol, double orbits) {
    namespace odeint = boost::numeric::odeint;
    kstate x = o.x0;
    const double h0 = o.model.hamiltonian(x);
    kepler_result r;
    auto f = [&](const kstate& s, kstate& d, double t) {
        ++r.stats.rhs_evals;
        o.model(s, d, t);
    };
    r.stats.accepted = odeint::integrate_adaptive(odeint::make_controlled(tol, tol, odeint::runge_kutta_dopri5<kstate>()),
                                                  f, x, 0.0, orbits * o.period, 1e-3,
                                                  [&](const kstate& s, double) {
                                                      r.h_drift = std::max(r.h_drift,
                                                                           std::abs(o.model.hamiltonian(s) - h0) / std::abs(h0));
                                                  });
    r.turn = o.model.runge_lenz_turn(o.x0, x);
    return r;
}

// e = 0.9 over 100 orbits at tol 1e-8. Bounds from the representation, not the method:
// - H = xi_1 + xi_2 is carried with dxi_1 = -dxi_2 exactly, so it changes by the rounding of the additions to
//   |xi_1| <= K / r_perihelion, random-walking: 4 eps (K / r_p) / |H| sqrt(steps) relative (plus the same for
//   recomputing H from r, v_r, a few eps (K / r_p) / |H|).
// - A is carried exactly (its rate is zero); the state's A is recomputed from (r, v_r, theta): theta is solved to
//   4 eps (scale / |A| + |theta|) (kepler.hpp), so A and its turn are known to about 8 eps (scale / |A| + |theta|).
TEST(AdaptiveKepler, EccentricOrbitKeepsInvariantsAndDoesNotPrecessWhereDopri5Does) {
    const eccentric_orbit o(0.9);
    const double tol = 1e-8, orbits = 100.0;
    const kepler_result c = run_eci(o, tol, orbits);
    const kepler_result d = run_odeint(o, tol, orbits);
    const double h0 = std::abs(o.model.hamiltonian(o.x0));
    const double xi1_max = o.model.K / o.x0[0];
    const double h_bound = 4.0 * eps * xi1_max / h0 * (2.0 + std::sqrt(double(c.stats.accepted)));
    const double a_bound = 8.0 * eps * (c.scale_ratio + std::abs(c.theta_end));
    std::printf("  e = 0.9, %g orbits, tol %g:\n", orbits, tol);
    std::printf("    c-dp54 (transformed): %llu steps, %llu/%llu rejected, %llu RHS; |dH/H| %.2e (bound %.2e), "
                "|dA|/|A| %.2e, turn %.2e deg (bound %.2e)\n",
                (unsigned long long)c.stats.accepted, (unsigned long long)c.stats.rejected_error,
                (unsigned long long)c.stats.rejected_radicand, (unsigned long long)c.stats.rhs_evals, c.h_drift,
                h_bound, c.a_drift, c.turn * 180.0 / std::numbers::pi, a_bound * 180.0 / std::numbers::pi);
    std::printf("    odeint dopri5:        %llu steps, %llu RHS; |dH/H| %.2e, turn %.3e deg\n",
                (unsigned long long)d.stats.accepted, (unsigned long long)d.stats.rhs_evals, d.h_drift,
                d.turn * 180.0 / std::numbers::pi);
    EXPECT_LE(c.h_drift, h_bound);
    EXPECT_LE(c.a_drift, a_bound);
    EXPECT_LE(std::abs(c.turn), a_bound);
    // odeint's orbit turns by orders of magnitude more than round-off, and loses energy.
    EXPECT_GT(std::abs(d.turn), 1e3 * a_bound);
    EXPECT_GT(d.h_drift, 1e3 * h_bound);
}

// Every tolerance from 1e-3 to 1e-12, ten orbits: the same bounds.
TEST(AdaptiveKepler, KeepsInvariantsAtEveryTolerance) {
    const eccentric_orbit o(0.9);
    for (int e = 3; e <= 12; ++e) {
        const double tol = std::pow(10.0, -e);
        const kepler_result c = run_eci(o, tol, 10.0);
        const double h_bound =
            4.0 * eps * (o.model.K / o.x0[0]) / std::abs(o.model.hamiltonian(o.x0)) * (2.0 + std::sqrt(double(c.stats.accepted)));
        const double a_bound = 8.0 * eps * (c.scale_ratio + std::abs(c.theta_end));
        EXPECT_LE(c.h_drift, h_bound) << "tol " << tol;
        EXPECT_LE(c.a_drift, a_bound) << "tol " << tol;
        // At 1e-3 the controller proposes steps past perihelion where xi_1 >= 0 or v_r^2 < 0: non-invertible
        // transforms, rejected and counted apart from error rejections (measured 46 in 163 steps).
        if (e == 3) {
            EXPECT_GT(c.stats.rejected_radicand, 0u);
        }
        if (e == 3 || e == 12)
            std::printf("  tol %.0e: %llu steps, %llu/%llu rejected (error/non-invertible), |dH/H| %.2e, |dA|/|A| %.2e\n",
                        tol, (unsigned long long)c.stats.accepted, (unsigned long long)c.stats.rejected_error,
                        (unsigned long long)c.stats.rejected_radicand, c.h_drift, c.a_drift);
    }
}

// Lotka-Volterra (paper §IV), mu = 1.5 from (1, 0.4): H = 1 + mu + xi_1 + xi_2 carried with dxi_1 = -dxi_2.
TEST(AdaptiveLotkaVolterra, KeepsHAtEveryTolerance) {
    const eci::lotka_volterra model{};
    for (int e = 3; e <= 12; ++e) {
        const double tol = std::pow(10.0, -e);
        eci::transformed_dp54<eci::lotka_volterra::transform> st;
        eci::adaptive_options opt;
        opt.rtol = opt.atol = tol;
        std::array<double, 2> x{1.0, 0.4};
        const double h0 = model.hamiltonian(x);
        double worst = 0.0;
        const auto s = eci::integrate_adaptive(st, model, x, 0.0, 100.0, 1e-3, opt, [&](const auto& y, double) {
            worst = std::max(worst, std::abs(model.hamiltonian(y) - h0) / h0);
        });
        // Each step rounds the additions to xi (<= H) and each inverse recomputes x to a few eps: 8 eps sqrt(n).
        EXPECT_LE(worst, 8.0 * eps * std::sqrt(double(s.accepted) + 1.0)) << "tol " << tol;
        if (e == 3 || e == 12)
            std::printf("  LV tol %.0e: %llu steps, %llu/%llu rejected, |dH/H| %.2e\n", tol,
                        (unsigned long long)s.accepted, (unsigned long long)s.rejected_error,
                        (unsigned long long)s.rejected_radicand, worst);
    }
}

// The transformed pair keeps its order: fixed steps against the exact Kepler orbit, e = 0.5, to 0.3 of a period.
// (Not to a whole period: at a turning point v_r = sqrt(2 xi_2 / m - ...) is near zero, where an O(dt^6) error of
// xi_2 becomes an O(dt^3) error of v_r; away from the turning points the error is O(dt^5).)
TEST(AdaptiveKepler, TransformedDp54IsFifthOrder) {
    const eccentric_orbit o(0.5);
    const eci::kepler_exact exact(o.model, o.x0);
    std::vector<double> dts, errs;
    for (int n : {50, 100, 200}) {
        eci::transformed_dp54<eci::kepler::transform> st;
        kstate x = o.x0;
        const double dt = 0.3 * o.period / n;
        eci::integrate_n_steps(st, o.model, x, 0.0, dt, std::uint64_t(n));
        const kstate e = exact(0.3 * o.period);
        dts.push_back(dt);
        errs.push_back(std::max({std::abs(x[0] - e[0]), std::abs(x[1] - e[1]), std::abs(x[2] - e[2])}));
    }
    const double p = log_log_slope(dts, errs);
    std::printf("  transformed c-dp54 on Kepler e = 0.5: error %.2e .. %.2e, order %.2f\n", errs.front(), errs.back(), p);
    EXPECT_GE(p, 4.6);
}

// ---------------------------------------------------------------------------------------------------------------
// Conservative dense output through the transform: xi interpolated (DP54's continuous extension with the stage
// rates of xi), then inverted at each output time. The invariants are linear in xi and every rate keeps them, so
// each dense point keeps them as the steps do: the same bounds as above, at 400 output times per run.

std::vector<double> output_times(double t_end, std::size_t n, double offset) {
    std::vector<double> t;
    for (std::size_t i = 1; i <= n; ++i) t.push_back(t_end * double(i) / double(n) + offset);
    return t;
}

// The same for DP54 and DP853 (its continuous extension through the transform: xi interpolated with the rates
// of xi at its 16 stages, the three extra ones evaluated for the dense output).
template <const auto& Tableau>
void lotka_volterra_keeps_h_at_every_dense_point() {
    const eci::lotka_volterra model{};
    const auto times = output_times(100.0, 400, 0.0);
    for (int e = 3; e <= 12; ++e) {
        const double tol = std::pow(10.0, -e);
        eci::transformed_embedded_rk<Tableau, eci::lotka_volterra::transform> st;
        eci::adaptive_options opt;
        opt.rtol = opt.atol = tol;
        std::array<double, 2> x{1.0, 0.4};
        const double h0 = model.hamiltonian(x);
        double worst = 0.0;
        const auto s = eci::integrate_adaptive_at(st, model, x, 0.0, times, 1e-3, opt,
                                                  [&](const auto& y, double, std::size_t) {
                                                      worst = std::max(worst, std::abs(model.hamiltonian(y) - h0) / h0);
                                                  });
        // as KeepsHAtEveryTolerance: each step rounds the additions to xi, each inverse recomputes x to a few eps;
        // the interpolated xi adds one rounded combination of them
        EXPECT_LE(worst, 8.0 * eps * std::sqrt(double(s.accepted) + 1.0)) << "tol " << tol;
        // automatic output is dense here (the continuous extension); a non-invertible interpolated xi lands;
        // the last time is the run's end, reached by a step
        EXPECT_EQ(s.dense_points + s.dense_fallbacks, times.size() - 1) << "tol " << tol;
        EXPECT_GE(s.dense_points, times.size() - 10) << "tol " << tol;
        if (e == 3 || e == 12)
            std::printf("  LV dense tol %.0e: %llu steps, %llu dense points, %llu landed, |dH/H| %.2e\n", tol,
                        (unsigned long long)s.accepted, (unsigned long long)s.dense_points,
                        (unsigned long long)s.dense_fallbacks, worst);
    }
}

TEST(AdaptiveTransformedDense, LotkaVolterraKeepsHAtEveryDensePoint) {
    lotka_volterra_keeps_h_at_every_dense_point<eci::tableaus::dormand_prince_54>();
}
TEST(AdaptiveTransformedDense, LotkaVolterraKeepsHAtEveryDensePointDP853) {
    lotka_volterra_keeps_h_at_every_dense_point<eci::tableaus::dormand_prince_853>();
}

template <const auto& Tableau>
void kepler_keeps_h_and_a_at_dense_points_as_accurate_as_the_steps() {
    const eccentric_orbit o(0.9);
    const eci::kepler_exact exact(o.model, o.x0);
    const auto times = output_times(10.0 * o.period, 400, 0.0123);  // off the steps' ends
    const double h0 = o.model.hamiltonian(o.x0);
    const auto a0 = o.model.runge_lenz(o.x0);
    const double a0n = std::hypot(a0[0], a0[1]);
    auto error = [&](const kstate& y, double t) {
        const kstate e = exact(t);
        return std::max({std::abs(y[0] - e[0]), std::abs(y[1] - e[1]),
                         std::abs(std::remainder(y[2] - e[2], 2.0 * std::numbers::pi))});
    };
    for (int e = 3; e <= 12; ++e) {
        const double tol = std::pow(10.0, -e);
        eci::adaptive_options opt;
        opt.rtol = opt.atol = tol;
        double h_drift = 0.0, a_drift = 0.0, scale_ratio = 0.0, dense_error = 0.0, step_error = 0.0;
        kstate x = o.x0;
        eci::transformed_embedded_rk<Tableau, eci::kepler::transform> st;
        const auto s = eci::integrate_adaptive_at(
            st, o.model, x, 0.0, times, 1e-3, opt,
            [&](const kstate& y, double t, std::size_t) {
                h_drift = std::max(h_drift, std::abs(o.model.hamiltonian(y) - h0) / std::abs(h0));
                const auto a = o.model.runge_lenz(y);
                a_drift = std::max(a_drift, std::hypot(a[0] - a0[0], a[1] - a0[1]) / a0n);
                const double scale =
                    o.model.K + o.model.ell * o.model.ell / (o.model.m * y[0]) + std::abs(o.model.ell * y[1]);
                scale_ratio = std::max(scale_ratio, scale / a0n);
                dense_error = std::max(dense_error, error(y, t));
            },
            eci::output_mode::dense);
        // the same run without outputs takes the same steps (FSAL: dense output costs no step)
        kstate z = o.x0;
        eci::transformed_embedded_rk<Tableau, eci::kepler::transform> plain;
        const auto p = eci::integrate_adaptive(plain, o.model, z, 0.0, times.back(), 1e-3, opt,
                                               [&](const kstate& y, double t) { step_error = std::max(step_error, error(y, t)); });
        EXPECT_EQ(p.accepted, s.accepted) << "tol " << tol;
        // the bounds of KeepsInvariantsAtEveryTolerance
        const double h_bound = 4.0 * eps * (o.model.K / o.x0[0]) / std::abs(h0) * (2.0 + std::sqrt(double(s.accepted)));
        const double a_bound = 8.0 * eps * (scale_ratio + std::abs(x[2]));
        EXPECT_LE(h_drift, h_bound) << "tol " << tol;
        EXPECT_LE(a_drift, a_bound) << "tol " << tol;
        EXPECT_GE(s.dense_points, times.size() - 10) << "tol " << tol;
        // As accurate as the steps of the same run (measured 0.99 of it from 1e-5 to 1e-12; at 1e-3 and 1e-4 the
        // error is of the orbit's size at both)
        if (e >= 5) {
            EXPECT_LE(dense_error, 1.5 * step_error) << "tol " << tol;
        }
        if (e == 3 || e == 8 || e == 12)
            std::printf("  Kepler e = 0.9 dense tol %.0e: %llu steps, %llu dense / %llu landed, |dH/H| %.2e, |dA|/|A| "
                        "%.2e, error at dense points %.2e, at the steps %.2e\n",
                        tol, (unsigned long long)s.accepted, (unsigned long long)s.dense_points,
                        (unsigned long long)s.dense_fallbacks, h_drift, a_drift, dense_error, step_error);
    }
}

TEST(AdaptiveTransformedDense, KeplerKeepsHAndAAtDensePointsAsAccurateAsTheSteps) {
    kepler_keeps_h_and_a_at_dense_points_as_accurate_as_the_steps<eci::tableaus::dormand_prince_54>();
}
TEST(AdaptiveTransformedDense, KeplerKeepsHAndAAtDensePointsAsAccurateAsTheStepsDP853) {
    kepler_keeps_h_and_a_at_dense_points_as_accurate_as_the_steps<eci::tableaus::dormand_prince_853>();
}

TEST(AdaptiveTransformedDense, AutomaticOutputIsDenseAndFallbackLandsOnNonInvertiblePoints) {
    // At 1e-3 on Kepler e = 0.9 some interpolated xi are not invertible (past perihelion, v_r^2 < 0): those
    // points are landed, and every output is produced once, in order, at its time.
    const eccentric_orbit o(0.9);
    const auto times = output_times(10.0 * o.period, 400, 0.0123);
    eci::adaptive_options opt;
    opt.rtol = opt.atol = 1e-3;
    kstate x = o.x0;
    eci::transformed_dp54<eci::kepler::transform> st;
    std::size_t seen = 0;
    double last = -1.0;
    const auto s = eci::integrate_adaptive_at(st, o.model, x, 0.0, times, 1e-3, opt,
                                              [&](const kstate&, double t, std::size_t i) {
                                                  EXPECT_EQ(i, seen);
                                                  EXPECT_EQ(t, times[i]);
                                                  EXPECT_GT(t, last);
                                                  last = t;
                                                  ++seen;
                                              });
    EXPECT_EQ(seen, times.size());
    EXPECT_GT(s.dense_points, 0u);
    EXPECT_GT(s.dense_fallbacks, 0u);
    EXPECT_EQ(s.dense_points + s.dense_fallbacks, times.size() - 1);  // the last time is the run's end
}

}  // namespace
