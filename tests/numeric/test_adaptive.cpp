// Adaptive, exactly conservative integration: order of each embedded pair, the error estimate's
// scaling, invariants at every tolerance and at dense-output points, tolerance proportionality, rejections by cause.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <numbers>
#include <optional>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include <eci/adaptive.hpp>
#include <eci/models/n_wave.hpp>
#include <eci/models/three_wave.hpp>
#include <eci/models/three_wave_exact.hpp>

#include "numeric/support.hpp"

namespace {

using namespace eci::test;
using state = eci::three_wave::state_type;
using rvec = std::vector<double>;
using cvec = std::vector<std::complex<double>>;

const eci::three_wave model{};
const state figure5_ic{std::sqrt(1.5), 1.0, std::sqrt(1.5)};

// sum_i |b_i|: how much larger than its result the sum that advances xi can be (its rounding, see check_invariants)
template <std::size_t S>
constexpr double weight_sum(const eci::embedded_tableau<S>& t) {
    double s = 0.0;
    for (double b : t.b) s += b < 0.0 ? -b : b;
    return s;
}

#define ECI_PAIR(tag, alias, label, q_, tableau)                                 \
    struct tag {                                                                 \
        template <class S>                                                       \
        using stepper = eci::alias<S>;                                           \
        static constexpr const char* name = label;                               \
        static constexpr int q = q_;                                             \
        static constexpr double b_sum = weight_sum(eci::tableaus::tableau);      \
    }
ECI_PAIR(bs32_m, bs32, "bs32", 2, bogacki_shampine_32);
ECI_PAIR(c_bs32_m, c_bs32, "c-bs32", 2, bogacki_shampine_32);
ECI_PAIR(ck54_m, ck54, "ck54", 4, cash_karp_54);
ECI_PAIR(c_ck54_m, c_ck54, "c-ck54", 4, cash_karp_54);
ECI_PAIR(dp54_m, dp54, "dp54", 4, dormand_prince_54);
ECI_PAIR(c_dp54_m, c_dp54, "c-dp54", 4, dormand_prince_54);
ECI_PAIR(dp853_m, dp853, "dp853", 7, dormand_prince_853);
ECI_PAIR(c_dp853_m, c_dp853, "c-dp853", 7, dormand_prince_853);
ECI_PAIR(f78_m, f78, "f78", 7, fehlberg_78);
ECI_PAIR(c_f78_m, c_f78, "c-f78", 7, fehlberg_78);
ECI_PAIR(c_dp54_comp_m, c_dp54_compensated, "c-dp54-compensated", 4, dormand_prince_54);
#undef ECI_PAIR

template <class M>
class AdaptivePair : public ::testing::Test {};
using all_pairs = ::testing::Types<bs32_m, c_bs32_m, ck54_m, c_ck54_m, dp54_m, c_dp54_m, dp853_m, c_dp853_m, f78_m,
                                   c_f78_m, c_dp54_comp_m>;
TYPED_TEST_SUITE(AdaptivePair, all_pairs, method_names);

template <class M>
class ConservativePair : public ::testing::Test {};
using conservative_pairs = ::testing::Types<c_bs32_m, c_ck54_m, c_dp54_m, c_dp853_m, c_f78_m, c_dp54_comp_m>;
TYPED_TEST_SUITE(ConservativePair, conservative_pairs, method_names);

// ---------------------------------------------------------------------------------------------------------------
// Order of the propagated solution: fixed steps through step() (which carries the FSAL derivative and, for
// conservative FSAL pairs, its point), the largest error against the exact solution on [0, 10] as dt halves.
// Step ranges keep the smallest error well above round-off (about 1e-13 here).

template <class M>
double fixed_step_order(double dt0, int halvings) {
    const eci::three_wave_exact exact(model, figure5_ic);
    std::vector<double> dts, errors;
    for (int h = 0; h <= halvings; ++h) {
        const double dt = dt0 / double(1 << h);
        state x = figure5_ic;
        typename M::template stepper<state> st;
        double worst = 0.0;
        eci::integrate_to(st, model, x, 0.0, 10.0, dt, [&](const state& s, double t, std::uint64_t) {
            const state e = exact(t);
            for (std::size_t k = 0; k < 3; ++k) worst = std::max(worst, std::abs(s[k] - e[k]));
        });
        dts.push_back(dt);
        errors.push_back(worst);
    }
    const double p = log_log_slope(dts, errors);
    std::printf("  %-20s max error %.2e (dt %g) .. %.2e (dt %g), order %.3f\n", M::name, errors.front(), dts.front(),
                errors.back(), dts.back(), p);
    return p;
}

TYPED_TEST(AdaptivePair, FixedStepRunsHaveTheDeclaredOrder) {
    using St = typename TypeParam::template stepper<state>;
    constexpr int p = St::order;
    // dt ranges where the conventional pairs are asymptotic and the error stays above 1e-12. The conservative
    // pairs' error is uneven from one halving to the next (where a step ends near a zero crossing, the error of
    // psi = sqrt(xi) is that of xi divided by 2 psi) and often falls faster: they must reach at least order p.
    const double dt0 = p == 3 ? 0.05 : p == 5 ? 0.025 : 0.4;
    const int halvings = p == 3 ? 4 : p == 5 && !St::is_conservative ? 2 : 3;
    const double fitted = fixed_step_order<TypeParam>(dt0, halvings);
    if (St::is_conservative)
        EXPECT_GE(fitted, p - 0.4);
    else
        EXPECT_NEAR(fitted, double(p), p == 8 ? 0.5 : 0.25);
}

// ---------------------------------------------------------------------------------------------------------------
// The embedded estimate is O(dt^(q+1)): one attempt from a state, atol = 1 and rtol = 0, so the norm is the RMS
// of the estimated errors themselves. For the conservative pairs that is psi - psihat, the two square roots of the
// xi solutions of b and bhat (see docs/methods.md).

template <class St, class F, class S>
double estimate_slope(const F& f, const S& x0, double dt_lo, double dt_hi, const char* label) {
    const std::vector<double> dts = log_space(dt_lo, dt_hi, 7);
    std::vector<double> est;
    const eci::error_weights w{0.0, 1.0};
    for (double dt : dts) {
        St st;
        auto g = f;
        const eci::attempt_result r = st.attempt(g, x0, 0.0, dt, &w);
        EXPECT_TRUE(r.ok);
        est.push_back(r.error);
    }
    const double slope = log_log_slope(dts, est);
    std::printf("  %-20s estimate %.2e (dt %g) .. %.2e (dt %g), slope %.3f\n", label, est.front(), dts.front(),
                est.back(), dts.back(), slope);
    return slope;
}

TYPED_TEST(AdaptivePair, ErrorEstimateScalesAsDtToTheEmbeddedOrderPlusOne) {
    constexpr int q = TypeParam::q;
    using St3 = typename TypeParam::template stepper<state>;
    // dt ranges where the estimate is asymptotic and above its own rounding (~1e-18 here). The conservative
    // estimate forms psi - conv without the rounding of psi itself (embedded_rk::finish), or it would stop at
    // ~eps |psi| and fail this at the small steps.
    const eci::three_wave_exact exact(model, figure5_ic);
    const double hi = q == 2 ? 0.025 : q == 4 ? 0.05 : 0.1;
    const double slope3 = estimate_slope<St3>(model, exact(1.0), hi / (q == 7 ? 4.0 : 8.0), hi, TypeParam::name);
    EXPECT_NEAR(slope3, q + 1.0, 0.2);
    const auto nw = eci::n_wave<std::complex<double>>::random(30, 4, 7);
    const double hc = q == 2 ? 0.00625 : q == 4 ? 0.003125 : 0.05;  // |S| is larger on the n-wave system
    EXPECT_NEAR((estimate_slope<typename TypeParam::template stepper<cvec>>(nw, nw.random_state(8),
                                                                         hc / (q == 7 ? 4.0 : 8.0), hc,
                                                                         TypeParam::name)),
                q + 1.0, 0.2);
}

// ---------------------------------------------------------------------------------------------------------------
// Invariants at every tolerance, at every accepted step and at dense-output points. Each accepted step rounds
// xi once (a few eps), and each dense point adds the rounding of one Hermite combination of equal-invariant data:
// the relative drift random-walks, bounded by 4 eps sqrt(steps + 1) (measured 0.1..0.5 of that). The increment
// of xi, dt sum_i b_i 2 Y_i S(Y_i), is a sum of terms up to |b_i| times larger than it, each rounded: where
// dt sum |b_i| is beyond 2 (DP853's weights sum to 12.9 in magnitude; its steps at loose tolerances are O(1) on
// these models, whose |2 Y S| is of the size of xi) that rounding is the larger one, and the bound grows with it
// (measured 1.5 and 1.7 x 4 eps sqrt(steps) for c-dp853 at 1e-3 on three-wave, steps up to 1.2 long).

struct drift_check {
    double worst = 0.0;        // the largest relative change of E or Z, over the bound
    std::uint64_t points = 0;  // observations made
};

template <class St, class Model>
drift_check check_invariants(const Model& m, typename Model::state_type x, double t_end, double tol,
                             eci::output_mode mode, eci::adaptive_stats* out = nullptr, double b_sum = 1.0) {
    St st;
    eci::adaptive_options o;
    o.rtol = o.atol = tol;
    const double e0 = m.energy(x), z0 = m.enstrophy(x);
    drift_check d;
    auto observe = [&](const typename Model::state_type& s, double) {
        d.worst = std::max({d.worst, relative_change(m.energy(s), e0), relative_change(m.enstrophy(s), z0)});
        ++d.points;
    };
    eci::adaptive_stats s;
    if (mode == eci::output_mode::landing) {
        s = eci::integrate_adaptive(st, m, x, 0.0, t_end, 1e-3, o, observe);
    } else {
        std::vector<double> times;
        for (int i = 1; i <= 400; ++i) times.push_back(t_end * i / 400.0);
        s = eci::integrate_adaptive_at(st, m, x, 0.0, times, 1e-3, o, observe, mode);
        // every output time but those that fall on a step's end (t_end at least) is interpolated
        EXPECT_GE(s.dense_points + s.dense_fallbacks, 390u);
    }
    d.worst /= 4.0 * eps * std::sqrt(double(s.accepted) + 1.0) * std::max(1.0, 0.5 * s.dt_largest * b_sum);
    if (out) *out = s;
    return d;
}

template <class St, class Model>
void expect_conserved_at_all_tolerances(const Model& m, const typename Model::state_type& x0, double t_end,
                                        const char* label, double b_sum) {
    for (int e = 3; e <= 12; ++e) {
        const double tol = std::pow(10.0, -e);
        for (auto mode : {eci::output_mode::landing, eci::output_mode::dense}) {
            eci::adaptive_stats s;
            const drift_check d = check_invariants<St>(m, x0, t_end, tol, mode, &s, b_sum);
            EXPECT_LE(d.worst, 1.0) << label << " tol " << tol << (mode == eci::output_mode::dense ? " dense" : "");
            // enough observations for the drift to mean something: the eighth-order pairs cross the span (t = 5)
            // in 9 steps at 1e-3 on real n-wave (the conditioned update takes the widest set the caps allow)
            EXPECT_GE(d.points, 8u);
            if (e == 3 || e == 12)
                std::printf("  %-20s %-7s tol %.0e: %8llu steps, %5llu/%llu rejected (error/radicand), %llu dense "
                            "fallbacks, largest step %.2f, worst drift %.2f of the bound\n",
                            label, mode == eci::output_mode::dense ? "dense" : "landing", tol,
                            (unsigned long long)s.accepted, (unsigned long long)s.rejected_error,
                            (unsigned long long)s.rejected_radicand, (unsigned long long)s.dense_fallbacks,
                            s.dt_largest, d.worst);
        }
    }
}

TYPED_TEST(ConservativePair, KeepsThreeWaveInvariantsAtEveryTolerance) {
    expect_conserved_at_all_tolerances<typename TypeParam::template stepper<state>>(model, figure5_ic, 50.0,
                                                                                    TypeParam::name, TypeParam::b_sum);
}
TYPED_TEST(ConservativePair, KeepsRealNWaveInvariantsAtEveryTolerance) {
    const auto nw = eci::n_wave<double>::random(45, 4, 3);
    expect_conserved_at_all_tolerances<typename TypeParam::template stepper<rvec>>(nw, nw.random_state(4), 5.0,
                                                                                   TypeParam::name, TypeParam::b_sum);
}
TYPED_TEST(ConservativePair, KeepsComplexNWaveInvariantsAtEveryTolerance) {
    const auto nw = eci::n_wave<std::complex<double>>::random(45, 4, 5);
    expect_conserved_at_all_tolerances<typename TypeParam::template stepper<cvec>>(nw, nw.random_state(6), 5.0,
                                                                                   TypeParam::name, TypeParam::b_sum);
}

// The conventional pairs do not: their drift at a loose tolerance is far above round-off (so the check above
// can fail).
TEST(AdaptiveConventional, DriftsAtLooseTolerance) {
    const drift_check d = check_invariants<eci::dp54<state>>(model, figure5_ic, 50.0, 1e-6, eci::output_mode::landing);
    EXPECT_GT(d.worst, 1e6);
}

// ---------------------------------------------------------------------------------------------------------------
// Dense output keeps the invariants (above). Its accuracy, against the exact solution at 400 output times on
// [0, 20], compared with the same run's error at its own steps: DP54's continuous extension (fourth order) applied
// to xi, and the cubic Hermite interpolant for BS32 (its own order), are as accurate as the steps, so
// output_mode::automatic uses them. For CK54 and F78 only the Hermite cubic exists: far less accurate than their
// steps (measured c-ck54 1.5e-5 against 1.6e-8 at tol 1e-10), so they land on output times unless asked.

template <class St>
std::pair<double, double> dense_and_step_error(double tol) {
    const eci::three_wave_exact exact(model, figure5_ic);
    std::vector<double> times;
    for (int i = 1; i <= 400; ++i) times.push_back(20.0 * i / 400.0);
    eci::adaptive_options o;
    o.rtol = o.atol = tol;
    double err[2] = {0.0, 0.0};
    for (int m = 0; m < 2; ++m) {
        St st;
        state x = figure5_ic;
        auto observe = [&](const state& s, double t) {
            const state e = exact(t);
            for (int k = 0; k < 3; ++k) err[m] = std::max(err[m], std::abs(s[std::size_t(k)] - e[std::size_t(k)]));
        };
        if (m == 0)
            eci::integrate_adaptive_at(st, model, x, 0.0, times, 1e-3, o, observe, eci::output_mode::dense);
        else
            eci::integrate_adaptive(st, model, x, 0.0, 20.0, 1e-3, o, observe);
    }
    return {err[0], err[1]};
}

TYPED_TEST(ConservativePair, DenseOutputIsAsAccurateAsTheStepsWhereItIsTheDefault) {
    using St = typename TypeParam::template stepper<state>;
    std::vector<double> dense_errors;
    for (double tol : {1e-4, 1e-6, 1e-8, 1e-10, 1e-12}) {
        const auto [dense, steps] = dense_and_step_error<St>(tol);
        std::printf("  %-20s tol %.0e: max error dense %.2e, at the steps %.2e\n", TypeParam::name, tol, dense, steps);
        dense_errors.push_back(dense);
        // measured at most 1.0x (c-bs32); c-dp54's continuous extension of xi, 1.5-9x, is not the default
        if (St::dense_matches_steps) {
            EXPECT_LE(dense, 3.0 * steps) << "tol " << tol;
        }
    }
    // Every dense output converges: eight decades of tolerance gain at least three decades of dense error (two for
    // F78, whose steps are longest for the cubic: measured 0.37 at 1e-4, 6.3e-4 at 1e-12).
    EXPECT_LE(dense_errors.back(), (St::order == 8 ? 1e-2 : 1e-3) * dense_errors.front());
}

// The order of a continuous extension: one step of dt from the exact state, the dense output at interior points
// against the exact solution. An extension of order q errs by C(theta) dt^(q+1) there (DP853: q = 7, DP54: 4).
// On the rotation y' = (y1, -y0), whose exact flow every elementary differential of the linear trees enters, so
// that no error term vanishes by the problem's structure (on the quadratic three-wave model they partly do: slopes
// 8.4-8.7 there); started at the angle where both components stay within (0.28, 0.96) over the longest step, so
// that the conservative extension, the same interpolant of xi = psi^2 square-rooted, has the same order.
template <class St>
double dense_local_slope(const std::vector<double>& dts) {
    using s2 = std::array<double, 2>;
    const double a = -std::numbers::pi / 4.0 - 0.5;
    auto exact = [&](double t) { return s2{std::cos(a + t), -std::sin(a + t)}; };
    auto f = [](const s2& x, s2& d, double) { d = {x[1], -x[0]}; };
    std::vector<double> errors;
    for (double dt : dts) {
        St st;
        s2 x = exact(0.0);
        EXPECT_TRUE(st.attempt(f, x, 0.0, dt).ok);
        st.accept(x);
        st.prepare_dense(f, x, dt);
        double worst = 0.0;
        for (double theta : {0.2, 0.45, 0.7, 0.9}) {
            s2 out{};
            EXPECT_TRUE(st.interpolate(x, theta, out));
            const s2 e = exact(theta * dt);
            for (std::size_t k = 0; k < 2; ++k) worst = std::max(worst, std::abs(out[k] - e[k]));
        }
        errors.push_back(worst);
    }
    const double slope = log_log_slope(dts, errors);
    std::printf("  dense local error %.2e (dt %g) .. %.2e (dt %g), slope %.3f\n", errors.front(), dts.front(),
                errors.back(), dts.back(), slope);
    return slope;
}

TEST(AdaptiveDense, ContinuousExtensionsHaveTheirOrder) {
    using s2 = std::array<double, 2>;
    static_assert(eci::dp853<s2>::has_continuous_extension && eci::dp853<s2>::dense_degree == 7);
    static_assert(eci::dp54<s2>::dense_degree == 4 && eci::f78<s2>::dense_degree == 3);
    // steps where the local error is asymptotic and far above round-off (DP853: 3e-9 .. 5e-14)
    const std::vector<double> dts{0.5, 0.35, 0.25, 0.18, 0.125};
    EXPECT_NEAR(dense_local_slope<eci::dp853<s2>>(dts), 8.0, 0.3);  // measured 7.97
    // The conservative extension is DP853's applied to xi = psi^2, which oscillates at twice the frequency: its
    // error's next term is relatively twice as large, and the slope approaches 8 from below over these steps
    // (7.1, 7.5, 7.6 over successive halvings from dt 1; 7.3 fitted here). An extension of order 6 would give 7.
    const double conservative = dense_local_slope<eci::c_dp853<s2>>(dts);
    EXPECT_GT(conservative, 7.2);
    EXPECT_LT(conservative, 8.3);
    EXPECT_NEAR(dense_local_slope<eci::dp54<s2>>({1.0, 0.7, 0.5, 0.35, 0.25}), 5.0, 0.3);  // measured 5.07
}

TEST(AdaptiveDense, AutomaticModeIsDenseOnlyWhereItMatchesTheSteps) {
    static_assert(eci::dp54<state>::dense_matches_steps && eci::c_bs32<state>::dense_matches_steps &&
                  eci::dp853<state>::dense_matches_steps);
    static_assert(!eci::c_dp54<state>::dense_matches_steps && !eci::c_ck54<state>::dense_matches_steps &&
                  !eci::c_f78<state>::dense_matches_steps && !eci::c_dp853<state>::dense_matches_steps);
    const std::vector<double> times{0.5, 1.0, 1.5, 2.0};
    eci::adaptive_options o;
    o.rtol = o.atol = 1e-8;
    auto count = [&](auto st, eci::output_mode mode) {
        state x = figure5_ic;
        return eci::integrate_adaptive_at(st, model, x, 0.0, times, 1e-3, o, [](const state&, double) {}, mode);
    };
    EXPECT_EQ(count(eci::dp54<state>{}, eci::output_mode::automatic).dense_points, 3u);
    EXPECT_EQ(count(eci::dp853<state>{}, eci::output_mode::automatic).dense_points, 3u);
    EXPECT_EQ(count(eci::c_bs32<state>{}, eci::output_mode::automatic).dense_points, 3u);
    EXPECT_EQ(count(eci::c_dp54<state>{}, eci::output_mode::automatic).landed_points, 4u);
    EXPECT_EQ(count(eci::c_dp54<state>{}, eci::output_mode::dense).dense_points, 3u);
    EXPECT_EQ(count(eci::c_ck54<state>{}, eci::output_mode::automatic).landed_points, 4u);
    EXPECT_EQ(count(eci::c_ck54<state>{}, eci::output_mode::dense).dense_points, 3u);
}

// ---------------------------------------------------------------------------------------------------------------
// Tolerance proportionality: the global error at t = 10 against rtol = atol over six decades fits slope ~1
// (a pair that propagates the higher order with an error-per-step controller: dt^(q+1) ~ tol, error ~ dt^p).
// Six, not four: the conservative pairs' global error is uneven from one tolerance to the next (it depends on
// where steps end near zero crossings, see docs/methods.md), so a four-decade fit is dominated by that
// scatter (C-F78: 0.73 over 1e-5..1e-9, 0.85 over 1e-4..1e-10).

// A quadratic system is free of scale (psi(t) solves it, so does a psi(a t)): with a = 2^k and the state, the
// first step, the output times and atol scaled, each product of an adaptive run is the unscaled run's times a power
// of two, so the run, its step sizes, its rejections and its dense output are the unscaled ones scaled, bit for
// bit, while nothing leaves the range of double. The conservative pairs' rate of xi = psi^2 (sum_j 2 b_j Y_j S_j,
// cubic in the scale, and the dense output's end rates 2 psi S) overflowed at |psi| ~ 2^400 ("adaptive step fell
// below the minimum" where dp54 ran) and underflowed at 2^-400 (the state left where it was); they are formed with
// the step's power of two inside (detail::split_step). Three-wave (the paper's update) and the random real n-wave
// system (45 unknowns: the conditioned update), rows at fixed times by dense output.
template <class St, class Model>
void expect_the_scaled_adaptive_run(const Model& m, const typename Model::state_type& x0, int k, const char* label) {
    const double a = std::ldexp(1.0, k);
    std::vector<double> times, scaled_times;
    for (int i = 1; i <= 40; ++i) times.push_back(0.05 * i), scaled_times.push_back(0.05 * i / a);
    std::vector<typename Model::state_type> rows, scaled_rows;
    auto run = [&](typename Model::state_type x, double scale, const std::vector<double>& at,
                   std::vector<typename Model::state_type>& out) {
        St st;
        eci::adaptive_options o;
        o.rtol = 1e-8;
        o.atol = 1e-8 * scale;
        return eci::integrate_adaptive_at(st, m, x, 0.0, at, 1e-3 / scale, o,
                                          [&](const typename Model::state_type& s, double) { out.push_back(s); },
                                          eci::output_mode::dense);
    };
    auto big = x0;
    for (auto& v : big) v *= a;
    const eci::adaptive_stats s = run(x0, 1.0, times, rows);
    const eci::adaptive_stats b = run(big, a, scaled_times, scaled_rows);
    EXPECT_EQ(b.accepted, s.accepted) << label << ", 2^" << k;
    EXPECT_EQ(b.rejected_error, s.rejected_error) << label << ", 2^" << k;
    EXPECT_EQ(b.rejected_radicand, s.rejected_radicand) << label << ", 2^" << k;
    EXPECT_EQ(b.dense_points, s.dense_points) << label << ", 2^" << k;
    ASSERT_EQ(rows.size(), scaled_rows.size()) << label << ", 2^" << k;
    std::size_t differ = 0;
    for (std::size_t r = 0; r < rows.size(); ++r)
        for (std::size_t i = 0; i < rows[r].size(); ++i) differ += scaled_rows[r][i] / a == rows[r][i] ? 0 : 1;
    EXPECT_EQ(differ, 0u) << label << " scaled by 2^" << k << ": values of the rows differ from the unscaled run's";
}

TYPED_TEST(AdaptivePair, AScaledRunIsTheRunScaledBitForBit) {
    const auto nw = eci::n_wave<double>::random(45, 4, 3);
    for (int k : {-400, 400}) {
        expect_the_scaled_adaptive_run<typename TypeParam::template stepper<state>>(model, figure5_ic, k,
                                                                                     "three-wave");
        expect_the_scaled_adaptive_run<typename TypeParam::template stepper<rvec>>(nw, nw.random_state(4), k,
                                                                                    "real n-wave");
    }
}

TYPED_TEST(AdaptivePair, GlobalErrorIsProportionalToTheTolerance) {
    using St = typename TypeParam::template stepper<state>;
    const eci::three_wave_exact exact(model, figure5_ic);
    const state e = exact(10.0);
    std::vector<double> tols, errors;
    for (int k = 4; k <= 10; ++k) {
        const double tol = std::pow(10.0, -k);
        St st;
        state x = figure5_ic;
        eci::adaptive_options o;
        o.rtol = o.atol = tol;
        eci::integrate_adaptive(st, model, x, 0.0, 10.0, 1e-3, o);
        double err = 0.0;
        for (int i = 0; i < 3; ++i) err = std::max(err, std::abs(x[std::size_t(i)] - e[std::size_t(i)]));
        tols.push_back(tol);
        errors.push_back(err);
    }
    const double slope = log_log_slope(tols, errors);
    std::printf("  %-20s error %.2e (tol 1e-4) .. %.2e (tol 1e-10), slope %.3f\n", TypeParam::name, errors.front(),
                errors.back(), slope);
    // BS32 propagates order 3 with a dt^3 estimate, so slope ~1; the higher pairs' slope is p/(q+1) ~ 1 too.
    EXPECT_GT(slope, 0.75);
    EXPECT_LT(slope, 1.3);
}

// ---------------------------------------------------------------------------------------------------------------
// Counters: FSAL pairs spend s - 1 evaluations per attempt (the first stage is the last of the step before, or
// of the rejected attempt at the same state); others s - 1 per attempt plus one per new state.

TEST(AdaptiveCounters, FsalAndReusedFirstStagesAreCounted) {
    eci::adaptive_options o;
    o.rtol = o.atol = 1e-6;
    {
        eci::c_dp54<state> st;
        state x = figure5_ic;
        const auto s = eci::integrate_adaptive(st, model, x, 0.0, 20.0, 1e-3, o);
        EXPECT_EQ(s.rhs_evals, 1 + 6 * (s.accepted + s.rejected()));
    }
    {
        eci::c_ck54<state> st;
        state x = figure5_ic;
        const auto s = eci::integrate_adaptive(st, model, x, 0.0, 20.0, 1e-3, o);
        EXPECT_EQ(s.rhs_evals, 5 * (s.accepted + s.rejected()) + s.accepted);
        EXPECT_GT(s.rejected_error, 0u);
        EXPECT_LE(s.dt_smallest, s.dt_largest);
    }
}

// At a loose tolerance the controller proposes steps too long for some mode near zero: a negative radicand,
// counted apart from error rejections, and the run still conserves.
TEST(AdaptiveRejections, NegativeRadicandIsARejectedStepWithItsOwnCounter) {
    eci::adaptive_stats s;
    const drift_check d =
        check_invariants<eci::c_dp54<state>>(model, figure5_ic, 100.0, 1e-3, eci::output_mode::landing, &s);
    std::printf("  c-dp54 tol 1e-3: %llu accepted, %llu rejected by error, %llu by negative radicand\n",
                (unsigned long long)s.accepted, (unsigned long long)s.rejected_error,
                (unsigned long long)s.rejected_radicand);
    EXPECT_GT(s.rejected_radicand, 0u);
    EXPECT_LE(d.worst, 1.0);
}

// x' = x^2 from 1 blows up at t = 1: the step shrinks below the minimum there, and the error names the time and
// the component and carries the statistics so far.
TEST(AdaptiveRejections, MinimumStepStopsWithTimeAndComponent) {
    auto f = [](const std::array<double, 2>& x, std::array<double, 2>& d, double) {
        d[0] = 0.1;
        d[1] = x[1] * x[1];
    };
    for (int cons = 0; cons < 2; ++cons) {
        std::array<double, 2> x{1.0, 1.0};
        eci::adaptive_options o;
        o.rtol = o.atol = 1e-8;
        try {
            if (cons) {
                eci::c_dp54<std::array<double, 2>> st;
                eci::integrate_adaptive(st, f, x, 0.0, 2.0, 1e-3, o);
            } else {
                eci::dp54<std::array<double, 2>> st;
                eci::integrate_adaptive(st, f, x, 0.0, 2.0, 1e-3, o);
            }
            ADD_FAILURE() << "a blow-up must not integrate to the end";
        } catch (const eci::adaptive_failure& e) {
            EXPECT_EQ(e.why, eci::adaptive_failure::reason::step_too_small);
            EXPECT_NEAR(e.time, 1.0, 1e-3);
            EXPECT_EQ(e.component, 1u);
            EXPECT_GT(e.stats.accepted, 10u);
            EXPECT_NE(std::string(e.what()).find("at t = "), std::string::npos) << e.what();
            EXPECT_NE(std::string(e.what()).find("component 1"), std::string::npos) << e.what();
        }
    }
}

// A floor the user sets (dt_min > 0) holds for every step but one landing on the end: a first step below it is
// raised to it, a tolerance the floor cannot meet stops the run rather than taking smaller accepted steps.
TEST(AdaptiveRejections, UserMinimumStepIsAFloorForEveryStep) {
    for (double dt_min : {0.01, 0.02}) {
        eci::c_dp54<state> st;
        state x = figure5_ic;
        eci::adaptive_options o;
        o.rtol = o.atol = 1e-4;
        o.dt_min = dt_min;
        std::vector<double> times;
        eci::integrate_adaptive(st, model, x, 0.0, 10.0, 1e-3, o,  // first step 1e-3 < dt_min
                                [&](const state&, double t) { times.push_back(t); });
        ASSERT_GT(times.size(), 3u);
        EXPECT_EQ(times.back(), 10.0);
        for (std::size_t i = 1; i + 1 < times.size(); ++i)  // the last one lands on t = 10 and may be shorter
            EXPECT_GE(times[i] - times[i - 1], dt_min * (1.0 - 1e-12)) << "step " << i << " at t = " << times[i];
    }
    eci::c_dp54<state> st;
    state x = figure5_ic;
    eci::adaptive_options o;
    o.rtol = o.atol = 1e-12;
    o.dt_min = 0.1;  // at 1e-12 c-dp54 needs steps near 0.01 on this orbit
    try {
        eci::integrate_adaptive(st, model, x, 0.0, 10.0, 1e-3, o);
        ADD_FAILURE() << "a tolerance the floor cannot meet must stop the run";
    } catch (const eci::adaptive_failure& e) {
        EXPECT_EQ(e.why, eci::adaptive_failure::reason::step_too_small);
        EXPECT_LT(e.dt, 0.1);
        EXPECT_GE(e.stats.rejected_error, 1u);
    }
}

TEST(AdaptiveRejections, MaximumStepsStopsTheRun) {
    eci::c_dp54<state> st;
    state x = figure5_ic;
    eci::adaptive_options o;
    o.max_attempts = 50;
    try {
        eci::integrate_adaptive(st, model, x, 0.0, 100.0, 1e-3, o);
        ADD_FAILURE() << "100 time units at 1e-6 need more than 50 steps";
    } catch (const eci::adaptive_failure& e) {
        EXPECT_EQ(e.why, eci::adaptive_failure::reason::too_many_steps);
        EXPECT_EQ(e.stats.accepted + e.stats.rejected(), 50u);
        EXPECT_GT(e.time, 0.0);
    }
}

TEST(AdaptiveOptions, BadInputIsRefusedWithAClearMessage) {
    eci::c_dp54<state> st;
    state x = figure5_ic;
    auto run = [&](eci::adaptive_options o, double dt0 = 1e-3, double t_end = 1.0) {
        eci::integrate_adaptive(st, model, x, 0.0, t_end, dt0, o);
    };
    eci::adaptive_options o;
    o.rtol = -1.0;
    EXPECT_THROW(run(o), std::invalid_argument);
    o = {};
    o.rtol = o.atol = 0.0;
    EXPECT_THROW(run(o), std::invalid_argument);
    o = {};
    o.atol_each = {1e-6, 1e-6};  // three components
    EXPECT_THROW(run(o), std::invalid_argument);
    o = {};
    o.atol = std::nan("");
    EXPECT_THROW(run(o), std::invalid_argument);
    EXPECT_THROW(run({}, 0.0), std::invalid_argument);
    EXPECT_THROW(run({}, 1e-3, std::nan("")), std::invalid_argument);  // an end time before the start runs backward
    EXPECT_EQ(x, figure5_ic);
}

// Per-component tolerances equal to the scalars give the same run bit for bit; a tighter tolerance on one
// component makes that component more accurate.
TEST(AdaptiveOptions, PerComponentTolerances) {
    const eci::three_wave_exact exact(model, figure5_ic);
    auto run = [&](const eci::adaptive_options& o) {
        eci::c_dp54<state> st;
        state x = figure5_ic;
        const auto s = eci::integrate_adaptive(st, model, x, 0.0, 10.0, 1e-3, o);
        return std::pair{x, s.accepted};
    };
    eci::adaptive_options scalar;
    scalar.rtol = scalar.atol = 1e-6;
    eci::adaptive_options each = scalar;
    each.rtol_each = {1e-6, 1e-6, 1e-6};
    each.atol_each = {1e-6, 1e-6, 1e-6};
    EXPECT_EQ(run(scalar), run(each));
    eci::adaptive_options tight = scalar;
    tight.rtol_each = {1e-10, 1e-6, 1e-6};
    tight.atol_each = {1e-10, 1e-6, 1e-6};
    EXPECT_GT(run(tight).second, run(scalar).second);
}

TEST(AdaptiveOptions, PiControlAlsoConservesAndReachesTheEnd) {
    eci::adaptive_options o;
    o.rtol = o.atol = 1e-8;
    o.pi_control = true;
    eci::c_dp54<state> st;
    state x = figure5_ic;
    const auto s = eci::integrate_adaptive(st, model, x, 0.0, 50.0, 1e-3, o);
    const eci::three_wave_exact exact(model, figure5_ic);
    const state e = exact(50.0);
    for (int i = 0; i < 3; ++i) EXPECT_NEAR(x[std::size_t(i)], e[std::size_t(i)], 1e-5);
    EXPECT_LE(relative_change(model.energy(x), model.energy(figure5_ic)), 4.0 * eps * std::sqrt(double(s.accepted)));
}

// ---------------------------------------------------------------------------------------------------------------
// Compensated xi, a policy of the same engine: over a long fixed-step run the invariants do not random-walk by one
// rounding of psi^2 per step. The invariants are measured exactly (double-double) with the weights the flow keeps
// exactly: energy w = (1, 1, 1) and enstrophy w = (3, 9, 6) (K^2, P^2, Q^2 as integers; sum_k w_k M_k = 0
// exactly, which the model's rounded K*K, Q*Q are not), so what is measured is the state's own drift.

/// sum_k w_k x_k^2 in double-double (error below eps^2 of the sum): (hi, lo).
std::pair<double, double> exact_invariant(const state& x, const std::array<double, 3>& w) {
    double hi = 0.0, lo = 0.0;
    for (std::size_t k = 0; k < 3; ++k) {
        double p, e, q, f, s, g;
        eci::detail::two_product(x[k], x[k], p, e);
        eci::detail::two_product(w[k], p, q, f);
        eci::detail::two_sum(hi, q, s, g);
        hi = s;
        lo += g + f + w[k] * e;
    }
    return {hi, lo};
}

/// The worst relative change of the two exact invariants over n fixed steps of dt through eci::run's driver
/// (times t0 + i dt, as a user's run passes them), checked after every step.
template <class St>
double exact_drift(double dt, std::uint64_t n) {
    constexpr std::array<double, 3> we{1.0, 1.0, 1.0}, wz{3.0, 9.0, 6.0};
    state x = figure5_ic;
    const auto e0 = exact_invariant(x, we), z0 = exact_invariant(x, wz);
    double worst = 0.0;
    auto change = [](std::pair<double, double> a, std::pair<double, double> b) {
        return std::abs((a.first - b.first) + (a.second - b.second)) / b.first;
    };
    St st;
    eci::integrate_n_steps(st, model, x, 0.0, dt, n, [&](const state& y, double, std::uint64_t) {
        worst = std::max({worst, change(exact_invariant(y, we), e0), change(exact_invariant(y, wz), z0)});
    });
    return worst;
}

/// sum_j |b_j| of a tableau.
template <const auto& T>
constexpr double sum_abs_b() {
    double s = 0.0;
    for (double b : T.b) s += b < 0.0 ? -b : b;
    return s;
}

// What compensation leaves: (a) the rounding of psi = sqrt(xi) at the end, |psi^2 - xi| <= eps xi, which does not
// accumulate (psi0 is exact); (b) the rounding of the right-hand side, S_k = M_k Y_P Y_Q carries one rounding
// (M_k = 1, -2 multiply exactly), so stage j adds dt 2 b_j sum_k w_k Y_k S_k (eps/2) to the invariant, at most
// eps dt |b_j| sum_k w_k |Y_k S_k| = eps dt |b_j| |Y1 Y2 Y3| sum_k w_k |M_k|; on this orbit |Y1 Y2 Y3| <=
// (2E/3)^(3/2) = 1.54 and sum_k w_k |M_k| / sum_k w_k psi_k^2 <= 24 / 22.5, so at most 2 eps dt sum|b_j| I per
// step. Those roundings have no preferred sign: their sum over n steps walks, and its largest excursion stays
// below 4 times the per-step bound times sqrt(n). Every product and sum forming the increment is error-free
// (double-double), so nothing else is left. Plain xi walks by one rounding of psi^2 per step, about
// 0.3 eps sqrt(n) (docs/benchmarks.md): at dt = 1e-3 that is ~15 times the bound, at dt = 0.01 (the CLI's
// default step) ~3 times.
template <const auto& T>
double compensated_bound(double dt, std::uint64_t n) {
    return eps + 4.0 * 2.0 * eps * dt * sum_abs_b<T>() * std::sqrt(double(n));
}

TEST(CompensatedXi, RK4AndDP54DoNotRandomWalk) {
    constexpr std::uint64_t n = 100000;
    for (double dt : {1e-3, 1e-2}) {
        const double rk4 = exact_drift<eci::c_rk4_compensated<state>>(dt, n);
        const double dp54 = exact_drift<eci::c_dp54_compensated<state>>(dt, n);
        const double plain_rk4 = exact_drift<eci::c_rk4<state>>(dt, n);
        const double plain_dp54 = exact_drift<eci::c_dp54<state>>(dt, n);
        const double b_rk4 = compensated_bound<eci::tableaus::rk4>(dt, n);
        const double b_dp54 = compensated_bound<eci::tableaus::dormand_prince_54>(dt, n);
        std::printf("  dt %g, %llu steps, drift / eps: compensated c-rk4 %.2f (bound %.1f), compensated c-dp54 %.2f "
                    "(bound %.1f); plain c-rk4 %.1f, plain c-dp54 %.1f\n",
                    dt, (unsigned long long)n, rk4 / eps, b_rk4 / eps, dp54 / eps, b_dp54 / eps, plain_rk4 / eps,
                    plain_dp54 / eps);
        EXPECT_LE(rk4, b_rk4) << "dt " << dt;
        EXPECT_LE(dp54, b_dp54) << "dt " << dt;
        if (dt == 1e-3) {  // the bounds tell compensated from plain xi (a lost carry would fail them)
            EXPECT_GT(plain_rk4, b_rk4);
            EXPECT_GT(plain_dp54, b_dp54);
        }
    }
}

TEST(CompensatedXi, CarryIsKeptWhenStepTimesDoNotChain) {
    // step() restarts (drops the residual) only when x is not the state it produced; times that do not chain
    // exactly (t + dt != next t in floating point, as every driver's t0 + i dt) must not restart it. Same run,
    // once with chained times and once with t0 + i dt: bitwise the same states.
    eci::c_dp54_compensated<state> a, b;
    eci::three_wave f = model;
    state xa = figure5_ic, xb = figure5_ic;
    double ta = 0.0;
    for (int i = 0; i < 1000; ++i) {
        ASSERT_TRUE(a.step(f, xa, ta, 0.1).ok);
        ta += 0.1;
        ASSERT_TRUE(b.step(f, xb, 0.1 * double(i) + 1e-3 * double(i % 2), 0.1).ok);
    }
    EXPECT_EQ(xa, xb);
}

// ---------------------------------------------------------------------------------------------------------------
// Backward time: the controller works on the step's size and hands the stepper a negative step. Every
// operation of a step with -h on f is the negation of one with +h on the mirrored system g(x, s) = -f(x, -s), and
// negation is exact, so a backward run is the forward run of the mirror bit for bit: the same states, times and
// counts. It also returns to the exact solution's state at t = 0 within what the tolerance buys (1e-6 at 1e-9).

struct mirrored_three_wave {
    using state_type = state;
    void operator()(const state& x, state& dxdt, double s) const {
        model(x, dxdt, -s);
        for (double& v : dxdt) v = -v;
    }
};

TYPED_TEST(AdaptivePair, BackwardRunIsTheMirroredForwardRunBitForBit) {
    const eci::three_wave_exact exact(model, figure5_ic);
    eci::adaptive_options o;
    o.rtol = o.atol = 1e-9;
    state back = exact(10.0), mirror = back;
    typename TypeParam::template stepper<state> sb, sm;
    std::vector<double> tb, tm;
    const eci::adaptive_stats b = eci::integrate_adaptive(sb, model, back, 10.0, 0.0, 0.01, o,
                                                          [&](const state&, double t) { tb.push_back(t); });
    const eci::adaptive_stats m = eci::integrate_adaptive(sm, mirrored_three_wave{}, mirror, -10.0, 0.0, 0.01, o,
                                                          [&](const state&, double s) { tm.push_back(-s); });
    EXPECT_GT(b.accepted, 10u);
    EXPECT_EQ(b.accepted, m.accepted);
    EXPECT_EQ(b.rejected(), m.rejected());
    EXPECT_EQ(b.rhs_evals, m.rhs_evals);
    EXPECT_EQ(tb, tm);
    EXPECT_EQ(back, mirror);
    EXPECT_EQ(tb.back(), 0.0);
    for (std::size_t k = 0; k < 3; ++k) EXPECT_NEAR(back[k], figure5_ic[k], 1e-6) << TypeParam::name;
}

// integrate_adaptive_steps shows every accepted step with its dense output, and stops where on_step says (an
// event), with the state the dense output gives there; forward and backward.
TYPED_TEST(AdaptivePair, StepsDriverStopsOnTheDenseOutputInEitherDirection) {
    const eci::three_wave_exact exact(model, figure5_ic);
    eci::adaptive_options o;
    o.rtol = o.atol = 1e-9;
    for (const auto& [t0, t1, stop] : {std::array{0.0, 10.0, 3.3}, std::array{10.0, 0.0, 6.6}}) {
        state x = exact(t0), at_stop{};
        typename TypeParam::template stepper<state> st;
        std::uint64_t seen = 0;
        const eci::adaptive_stats s = eci::integrate_adaptive_steps(
            st, model, x, t0, t1, 0.01, o, [&](auto& step) -> std::optional<double> {
                ++seen;
                EXPECT_EQ(step.t_end() > step.t_start(), t1 > t0);
                const double lo = std::min(step.t_start(), step.t_end()), hi = std::max(step.t_start(), step.t_end());
                if (stop < lo || stop > hi) return std::nullopt;
                step.at(stop, at_stop);
                return stop;
            });
        EXPECT_EQ(seen, s.accepted);
        EXPECT_EQ(x, at_stop);
        // Where the dense output is as accurate as the steps, within what the tolerance buys; else (the cubic
        // Hermite interpolant on the long steps of ck54's and f78's pairs) within its own, coarser reach, which
        // the conservative ones' interpolation in psi^2 makes coarser still near a small component (an error d of
        // psi^2 is d / (2 |psi|) in psi: 5e-3 measured for c-f78 at psi = 0.04)
        using St = typename TypeParam::template stepper<state>;
        const double reach = St::dense_matches_steps ? 1e-6 : 1e-2;
        const state e = exact(stop);
        for (std::size_t k = 0; k < 3; ++k) EXPECT_NEAR(x[k], e[k], reach) << TypeParam::name << " from " << t0;
    }
}

}  // namespace
