// The negative-radicand remedy: at steps where many components fail every step, energy and enstrophy
// stay exact to round-off without halvings, C-PC and C-RK4 keep orders 2 and 4, and the fallback still halves.
#include <gtest/gtest.h>

#include <complex>
#include <cstdio>
#include <eci/models/n_wave.hpp>
#include <eci/models/three_wave.hpp>
#include <vector>

#include "numeric/support.hpp"

namespace {

using namespace eci::test;

struct conservation_run {
    eci::run_stats stats;
    eci::remedy_stats remedy;
    double worst = 0.0;  // max over steps and invariants of |I - I0| / I0
};

// Run `steps` steps and record the worst relative change of every declared invariant.
template <class Stepper, class Model>
conservation_run run_and_measure(Stepper& st, const Model& model, typename Model::state_type x, double dt,
                                 std::uint64_t steps) {
    const eci::quadratic_weights w = eci::quadratic_weights_of(model, model.size());
    std::vector<double> i0;
    for (const auto& row : w) i0.push_back(weighted_square_sum(x, row));
    conservation_run r;
    r.stats = eci::integrate_n_steps(st, model, x, 0.0, dt, steps, [&](const auto& s, double, std::uint64_t) {
        for (std::size_t j = 0; j < w.size(); ++j)
            r.worst = std::max(r.worst, relative_change(weighted_square_sum(s, w[j]), i0[j]));
    });
    r.remedy = st.remedy_statistics();
    return r;
}

// Each step rounds every psi_k^2 about twice (forming xi, and the square root), relative eps/2 each; an invariant
// is a sum of positive terms, so it changes by at most ~2 eps (relative) per step, a random walk over steps. The
// rescale adds one more rounding per term and leaves at most 4 eps of defect (radicand_remedy.hpp). 8 for margin.
double round_off_bound(std::uint64_t steps) { return 8.0 * eps * std::sqrt(double(steps)); }

template <class Method, class T>
void expect_exact_without_halvings(double dt) {
    using S = std::vector<T>;
    // N = 10^4 modes (2 10^4 real unknowns when complex), 4 triads per mode: coupled as in the realistic system,
    // cheap enough for 10^3 steps in seconds.
    const auto model = eci::n_wave<T>::random(10002, 4, 7);
    typename Method::template stepper<S> st;
    const std::uint64_t steps = 1000;
    const conservation_run r = run_and_measure(st, model, model.random_state(8), dt, steps);
    std::printf(
        "  %-6s %s dt = %g: %llu remedied steps, %llu components remedied, %llu halvings, worst drift %.2g eps\n",
        Method::name, eci::n_wave<T>::is_complex ? "complex" : "real", dt,
        static_cast<unsigned long long>(r.stats.remedied_steps),
        static_cast<unsigned long long>(r.stats.components_remedied),
        static_cast<unsigned long long>(r.stats.step_reductions), r.worst / eps);
    EXPECT_EQ(r.stats.step_reductions, 0u) << "isolated failures must not halve the step";
    // "Many components every step": the remedy fired in (nearly) every step, several components at a time.
    EXPECT_GE(r.stats.remedied_steps, steps * 9 / 10);
    EXPECT_GE(r.stats.components_remedied, 2 * r.stats.remedied_steps);
    EXPECT_EQ(r.stats.remedied_steps, r.remedy.remedied_steps);
    EXPECT_LE(r.worst, round_off_bound(steps));
}

// The step sizes were chosen so that failures occur in almost every step (C-RK4's radicand is accurate to
// O(tau^5), so it needs a larger step to fail as often).
TEST(RadicandRemedy, CPcRealIsExactWithoutHalvings) { expect_exact_without_halvings<c_pc_m, double>(0.05); }
TEST(RadicandRemedy, CPcComplexIsExactWithoutHalvings) {
    expect_exact_without_halvings<c_pc_m, std::complex<double>>(0.05);
}
TEST(RadicandRemedy, CRk2RealIsExactWithoutHalvings) { expect_exact_without_halvings<c_rk2_m, double>(0.05); }
TEST(RadicandRemedy, CRk4RealIsExactWithoutHalvings) { expect_exact_without_halvings<c_rk4_m, double>(0.12); }
TEST(RadicandRemedy, CRk4ComplexIsExactWithoutHalvings) {
    expect_exact_without_halvings<c_rk4_m, std::complex<double>>(0.12);
}

using compensated_c_pc_m = method_tag<eci::method_entries::c_pc_compensated>;
TEST(RadicandRemedy, CompensatedCPcIsExactWithoutHalvings) {
    expect_exact_without_halvings<compensated_c_pc_m, double>(0.05);
}

// C-Euler's own test (a mode within tau |S| of zero) is wide, so the remedy fires only at small steps; there it
// replaces the implicit step for the whole state.
TEST(RadicandRemedy, CEulerRemediesNearZeroModesWithoutImplicitSteps) {
    using S = std::vector<double>;
    const auto model = eci::n_wave<double>::random(10002, 4, 7);
    eci::c_euler<S> st;
    const std::uint64_t steps = 300;
    const conservation_run r = run_and_measure(st, model, model.random_state(8), 5e-4, steps);
    std::printf("  c-euler: %llu remedied steps, %llu components, %llu implicit steps\n",
                static_cast<unsigned long long>(r.stats.remedied_steps),
                static_cast<unsigned long long>(r.stats.components_remedied),
                static_cast<unsigned long long>(r.stats.solver.solves));
    EXPECT_GE(r.stats.remedied_steps, steps * 9 / 10);
    EXPECT_EQ(r.stats.solver.solves, 0u);
    EXPECT_LE(r.worst, round_off_bound(steps));
}

// Global order: the RMS error at t = 1 against a small-step RK4 reference, as dt halves from a step at which the
// remedy fires. The remedy's rescale is O(tau^(p+1)) like the defect it removes, so the slope stays p; and at every
// dt the error is that of the same method with the paper's halving, within a small factor. (The max-norm error of
// the conservative methods converges irregularly: a mode passing near zero has psi error ~ (error of psi^2) / psi,
// with or without the remedy.)
template <class Method>
double global_slope(const std::vector<double>& dts) {
    using S = std::vector<double>;
    const auto model = eci::n_wave<double>::random(3000, 4, 11);
    const S x0 = model.random_state(12);
    const double t_end = 1.0;
    S ref = x0;
    eci::rk4<S> rk4;
    eci::integrate_to(rk4, model, ref, 0.0, t_end, 1e-4);  // error ~1e-15, below the finest error fitted
    auto rms_error = [&](eci::radicand_policy policy, double dt, eci::run_stats& s) {
        typename Method::template stepper<S> st;
        st.remedy.policy = policy;
        S x = x0;
        s = eci::integrate_to(st, model, x, 0.0, t_end, dt);
        double e2 = 0.0;
        for (std::size_t i = 0; i < x.size(); ++i) e2 += (x[i] - ref[i]) * (x[i] - ref[i]);
        return std::sqrt(e2 / double(x.size()));
    };
    std::vector<double> errors;
    for (double dt : dts) {
        eci::run_stats s, h;
        const double e = rms_error(eci::radicand_policy::remedy, dt, s);
        const double e_halving = rms_error(eci::radicand_policy::halve, dt, h);
        errors.push_back(e);
        std::printf(
            "  %-6s dt = %-8g RMS error %.3e (%llu remedied steps, %llu components); with halving %.3e "
            "(%llu halvings)\n",
            Method::name, dt, e, static_cast<unsigned long long>(s.remedied_steps),
            static_cast<unsigned long long>(s.components_remedied), e_halving,
            static_cast<unsigned long long>(h.step_reductions));
        if (dt == dts.front()) {
            EXPECT_GT(s.remedied_steps, 0u) << "the coarsest step must exercise the remedy";
        }
        EXPECT_EQ(s.step_reductions, 0u);
        EXPECT_LT(e, 4.0 * e_halving);  // halving takes shorter steps where it fails: a little more accurate
    }
    const double slope = log_log_slope(dts, errors);
    std::printf("  %-6s fitted global order %.3f\n", Method::name, slope);
    return slope;
}

TEST(RadicandRemedy, CPcKeepsOrderTwo) {
    const double p = global_slope<c_pc_m>({0.04, 0.02, 0.01, 0.005});
    EXPECT_NEAR(p, 2.0, 0.15);
}
TEST(RadicandRemedy, CRk4KeepsOrderFour) {
    const double p = global_slope<c_rk4_m>({0.1, 0.05, 0.025, 0.0125, 0.00625});
    EXPECT_NEAR(p, 4.0, 0.3);
}

// Weights that are exactly dependent (one invariant declared twice, under two scales) make the Gram matrix
// singular; the defect lies in its range, so the remedy still applies and both stay exact.
TEST(RadicandRemedy, SingularGramFromDependentWeightsIsStillRemedied) {
    using S = std::vector<double>;
    const auto model = eci::n_wave<double>::random(10002, 4, 7);
    eci::c_pc<S> st;
    eci::quadratic_weights w = eci::quadratic_weights_of(model, model.size());
    w.push_back(w[0]);
    for (double& v : w.back()) v *= 3.0;  // 3 E, dependent on E
    st.set_quadratic_invariants(w);
    S x = model.random_state(8);
    const double e0 = weighted_square_sum(x, w[0]), z0 = weighted_square_sum(x, w[1]);
    eci::run_stats stats;
    const std::uint64_t steps = 200;
    double worst = 0.0;
    for (std::uint64_t i = 0; i < steps; ++i) {
        eci::detail::advance_with_reduction(st, model, x, double(i) * 0.05, 0.05, 40, stats);
        worst = std::max({worst, relative_change(weighted_square_sum(x, w[0]), e0),
                          relative_change(weighted_square_sum(x, w[1]), z0)});
    }
    EXPECT_EQ(stats.step_reductions, 0u);
    EXPECT_GE(st.remedy_statistics().remedied_steps, steps * 9 / 10);
    EXPECT_LE(worst, round_off_bound(steps));
}

// Nearly dependent weights: wavenumbers within 1 + 1e-6 of each other make enstrophy all but a multiple of
// energy (the Gram matrix's scaled condition number ~1e12). Whatever the remedy decides step by step (solve, or
// decline and halve), both invariants must stay exact; and it must decline rather than rescale by much.
TEST(RadicandRemedy, NearlyDependentWeightsStayExactEitherWay) {
    using S = std::vector<double>;
    auto model = eci::n_wave<double>::random(10002, 4, 7);
    for (std::size_t i = 0; i < model.size(); ++i) model.wavenumber[i] = 1.0 + 1e-6 * double(i % 97) / 97.0;
    for (eci::triad& t : model.triads) {  // coefficients obeying eqs. (2)-(3) for the new wavenumbers
        const double k2 = model.wavenumber[t.k] * model.wavenumber[t.k],
                     p2 = model.wavenumber[t.p] * model.wavenumber[t.p],
                     q2 = model.wavenumber[t.q] * model.wavenumber[t.q];
        const double mk = p2 - q2, mp = q2 - k2, mq = k2 - p2;
        const double scale = 1.0 / std::max({std::abs(mk), std::abs(mp), std::abs(mq), 1e-300});
        t.Mk = scale * mk, t.Mp = scale * mp, t.Mq = scale * mq;
    }
    eci::c_pc<S> st;
    const std::uint64_t steps = 200;
    const conservation_run r = run_and_measure(st, model, model.random_state(8), 0.05, steps);
    std::printf("  nearly dependent weights: %llu remedied steps, %llu declined, %llu halvings, worst drift %.2g eps\n",
                static_cast<unsigned long long>(r.stats.remedied_steps),
                static_cast<unsigned long long>(r.remedy.declined),
                static_cast<unsigned long long>(r.stats.step_reductions), r.worst / eps);
    EXPECT_GT(r.stats.remedied_steps + r.stats.step_reductions, steps / 2) << "failures occur at this step";
    EXPECT_LE(r.worst, round_off_bound(steps + r.stats.step_reductions));
}

// Many failures at once (a step far too large): not isolated, so the step is halved as before, and counted.
TEST(RadicandRemedy, ManyFailuresFallBackToHalving) {
    using S = std::vector<double>;
    const auto model = eci::n_wave<double>::random(10002, 4, 7);
    eci::c_pc<S> st;
    const std::uint64_t steps = 5;
    const conservation_run r = run_and_measure(st, model, model.random_state(8), 1.0, steps);
    std::printf("  dt = 1: %llu halvings, %llu declined, %llu remedied steps\n",
                static_cast<unsigned long long>(r.stats.step_reductions),
                static_cast<unsigned long long>(r.remedy.declined),
                static_cast<unsigned long long>(r.stats.remedied_steps));
    EXPECT_GT(r.stats.step_reductions, 0u);
    EXPECT_GT(r.remedy.declined, 0u);
    EXPECT_LE(r.worst, round_off_bound(steps + r.stats.step_reductions));
}

// The halving policy (the paper's procedure) and a system without declared weights (a plain lambda) both halve.
TEST(RadicandRemedy, HalvingPolicyAndUndeclaredWeightsHalve) {
    using S = std::vector<double>;
    const auto model = eci::n_wave<double>::random(10002, 4, 7);
    eci::c_pc<S> by_policy;
    by_policy.remedy.policy = eci::radicand_policy::halve;
    const conservation_run r = run_and_measure(by_policy, model, model.random_state(8), 0.05, 20);
    EXPECT_GT(r.stats.step_reductions, 0u);
    EXPECT_EQ(r.stats.remedied_steps, 0u);

    eci::c_pc<S> no_weights;
    S x = model.random_state(8);
    const eci::run_stats s = eci::integrate_n_steps(
        no_weights, [&](const S& a, S& b, double t) { model(a, b, t); }, x, 0.0, 0.05, 20);
    EXPECT_GT(s.step_reductions, 0u);
    EXPECT_EQ(s.remedied_steps, 0u);
}

// On three modes one failing mode is a third of the state, never isolated: Figure 2's run halves as in the paper.
TEST(RadicandRemedy, ThreeWaveNeverRemedies) {
    const eci::three_wave model{};
    eci::c_pc<eci::three_wave::state_type> st;
    eci::three_wave::state_type x{std::sqrt(1.5), 0.0, std::sqrt(1.5)};
    const eci::run_stats s = eci::integrate_to(st, model, x, 0.0, 100.0, 0.2);
    EXPECT_GT(s.step_reductions, 0u);
    EXPECT_EQ(s.remedied_steps, 0u);
}

// A model whose declared weights do not match its state is a programming error the driver reports at once.
TEST(RadicandRemedy, DriverRejectsWeightsOfAnotherSize) {
    struct wrong_weights {
        eci::n_wave<double> model = eci::n_wave<double>::random(300, 4, 7);
        void operator()(const std::vector<double>& x, std::vector<double>& dxdt, double t) const { model(x, dxdt, t); }
        eci::quadratic_weights quadratic_invariant_weights() const { return {std::vector<double>(299, 0.5)}; }
    } f;
    std::vector<double> x = f.model.random_state(8);
    eci::c_pc<std::vector<double>> st;
    EXPECT_THROW(eci::integrate_n_steps(st, f, x, 0.0, 0.01, 1), std::invalid_argument);
}

}  // namespace
