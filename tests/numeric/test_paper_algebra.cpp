// The paper's algebra, checked to round-off: one Euler step raises E and Z by eqs. (8)-(9), one predictor-corrector
// step by eqs. (19)-(20), and one C-Euler / C-PC step is eq. (16) / eq. (30) computed by hand.
#include <gtest/gtest.h>

#include <complex>
#include <vector>

#include <eci/detail/state_ops.hpp>
#include <eci/models/n_wave.hpp>
#include <eci/models/three_wave.hpp>

#include "numeric/support.hpp"

namespace {

using namespace eci::test;
using eci::detail::reals;

// The weight of each real unknown in E (1) and in Z (k^2); a complex mode contributes two real unknowns.
std::vector<double> enstrophy_weights(const eci::three_wave& m) { return {m.K * m.K, m.P * m.P, m.Q * m.Q}; }
template <class T>
std::vector<double> enstrophy_weights(const eci::n_wave<T>& m) {
    std::vector<double> w;
    for (double k : m.wavenumber)
        for (int j = 0; j < (eci::n_wave<T>::is_complex ? 2 : 1); ++j) w.push_back(k * k);
    return w;
}

// Checks one step of Method against the predicted increase (E and Z at once, through the weights w).
// `predicted(w, x, S, S~)` is the paper's formula. The computed increase I(x1) - I(x0) is a difference of sums of
// w psi^2; each such term is rounded a few times, and so is each term of the formula, so the residual is bounded by
// a few eps times the sum of the magnitudes w (psi^2 + 2 tau |psi S| + tau^2 S^2) of the terms in play. The
// increases themselves (O(tau^2) for Euler, O(tau^4) for PC) must stand at least 100 times above that bound.
template <class Method, class Model, class Formula>
void expect_increase(const Model& model, const typename Model::state_type& x0, double tau, Formula predicted) {
    using S = typename Model::state_type;
    const std::vector<double> wz = enstrophy_weights(model), we(wz.size(), 1.0);
    S s = x0, x_tilde = x0, s_tilde = x0, x1 = x0;
    model(x0, s, 0.0);
    const auto xr = reals(x0), sr = reals(std::as_const(s));
    for (std::size_t i = 0; i < xr.size(); ++i) reals(x_tilde)[i] = xr[i] + tau * sr[i];  // eqs. (7), (18a)
    model(x_tilde, s_tilde, tau);
    typename Method::template stepper<S> st;
    ASSERT_TRUE(st.step(model, x1, 0.0, tau));
    for (const auto* w : {&we, &wz}) {
        auto invariant = [&](const S& x) {
            double sum = 0.0;
            for (std::size_t i = 0; i < xr.size(); ++i) sum += 0.5 * (*w)[i] * reals(x)[i] * reals(x)[i];
            return sum;
        };
        double magnitude = 0.0;
        for (std::size_t i = 0; i < xr.size(); ++i)
            magnitude += (*w)[i] * (xr[i] * xr[i] + 2.0 * tau * std::abs(xr[i] * sr[i]) + tau * tau * sr[i] * sr[i]);
        const double increase = invariant(x1) - invariant(x0);
        const double expected = predicted(*w, sr, reals(std::as_const(s_tilde)));
        const double tolerance = 4.0 * eps * magnitude;
        EXPECT_GT(expected, 100.0 * tolerance) << "the increase must stand far above round-off to be a test";
        EXPECT_NEAR(increase, expected, tolerance)
            << Method::name << ", tau = " << tau << (w == &we ? ", energy" : ", enstrophy");
    }
}

// eqs. (8), (9): I(t + tau) = I(t) + tau^2/2 sum_k w_k S_k^2
auto euler_increase(double tau) {
    return [tau](const std::vector<double>& w, std::span<const double> s, std::span<const double>) {
        double sum = 0.0;
        for (std::size_t i = 0; i < s.size(); ++i) sum += w[i] * s[i] * s[i];
        return 0.5 * tau * tau * sum;
    };
}
// eqs. (19), (20): I(t + tau) = I(t) + tau^2/8 sum_k w_k (S_k - S~_k)^2
auto pc_increase(double tau) {
    return [tau](const std::vector<double>& w, std::span<const double> s, std::span<const double> st) {
        double sum = 0.0;
        for (std::size_t i = 0; i < s.size(); ++i) sum += w[i] * (s[i] - st[i]) * (s[i] - st[i]);
        return 0.125 * tau * tau * sum;
    };
}

const eci::three_wave three_wave_model{};
const eci::three_wave::state_type figure5_ic{std::sqrt(1.5), 1.0, std::sqrt(1.5)};
const std::vector<double> taus{1e-3, 1e-2, 0.1, 0.2};

TEST(PaperAlgebra, EulerStepRaisesEnergyByEq8AndEnstrophyByEq9) {
    for (double tau : taus) expect_increase<euler_m>(three_wave_model, figure5_ic, tau, euler_increase(tau));
    const auto real_waves = eci::n_wave<double>::random(30, 10, 21);
    const auto complex_waves = eci::n_wave<std::complex<double>>::random(30, 10, 22);
    for (double tau : taus) {
        expect_increase<euler_m>(real_waves, real_waves.random_state(5), tau, euler_increase(tau));
        expect_increase<euler_m>(complex_waves, complex_waves.random_state(6), tau, euler_increase(tau));
    }
}

TEST(PaperAlgebra, PredictorCorrectorStepRaisesEnergyByEq19AndEnstrophyByEq20) {
    for (double tau : taus) expect_increase<pc_m>(three_wave_model, figure5_ic, tau, pc_increase(tau));
    const auto real_waves = eci::n_wave<double>::random(30, 10, 21);
    const auto complex_waves = eci::n_wave<std::complex<double>>::random(30, 10, 22);
    for (double tau : taus) {
        expect_increase<pc_m>(real_waves, real_waves.random_state(5), tau, pc_increase(tau));
        expect_increase<pc_m>(complex_waves, complex_waves.random_state(6), tau, pc_increase(tau));
    }
}

// The conservative steps against the paper's formulas written out here. Both are a square root of a few rounded
// terms: agreement to a few ulps of the largest term is all that can be asked.
TEST(PaperAlgebra, CEulerStepIsEq16AwayFromZero) {
    const auto x = figure5_ic;  // no mode near zero: the explicit branch, sigma_k = sgn(psi_k)
    for (double tau : taus) {
        eci::three_wave::state_type s{}, y = x;
        three_wave_model(x, s, 0.0);
        eci::c_euler<eci::three_wave::state_type> st;
        ASSERT_TRUE(st.step(three_wave_model, y, 0.0, tau));
        for (std::size_t k = 0; k < 3; ++k) {
            const double eq16 = std::copysign(std::sqrt(x[k] * x[k] + 2.0 * tau * s[k] * x[k]), x[k]);
            EXPECT_NEAR(y[k], eq16, 4.0 * eps * (std::abs(x[k]) + tau * std::abs(s[k]))) << "tau " << tau;
        }
        EXPECT_EQ(st.solver_statistics().solves, 0u) << "no implicit step was needed";
    }
}

TEST(PaperAlgebra, CPcStepIsEq30WithThePredictorsSign) {
    // Large steps too, where the sign of psi~ matters: psi_P = 0.05 is driven through zero within one step.
    for (const eci::three_wave::state_type& x : {figure5_ic, eci::three_wave::state_type{1.2, 0.05, -1.1}}) {
        for (double tau : taus) {
            eci::three_wave::state_type s{}, xt{}, stl{}, y = x;
            three_wave_model(x, s, 0.0);
            for (std::size_t k = 0; k < 3; ++k) xt[k] = x[k] + tau * s[k];  // eq. (30a)
            three_wave_model(xt, stl, tau);
            eci::c_pc<eci::three_wave::state_type> st;
            ASSERT_TRUE(st.step(three_wave_model, y, 0.0, tau));
            for (std::size_t k = 0; k < 3; ++k) {
                const double rad = x[k] * x[k] + tau * (x[k] * s[k] + xt[k] * stl[k]);
                const double eq30 = std::copysign(std::sqrt(rad), xt[k]);  // eq. (30b)
                const double size = std::abs(x[k]) + tau * (std::abs(s[k]) + std::abs(stl[k]));
                EXPECT_NEAR(y[k], eq30, 8.0 * eps * size * size / std::max(std::abs(eq30), eps * size))
                    << "tau " << tau << " mode " << k;
            }
        }
    }
}

}  // namespace
