// C-PC, eq. (30), with psi_k^2 carried to twice working precision: an opt-in variant for very long runs, whose
// invariants do not random-walk by one rounding of psi^2 per step (sqrt(steps) eps) but only by that of the increments.
#pragma once

#include <cmath>
#include <cstddef>
#include <limits>
#include <ranges>
#include <utility>

#include "../concepts.hpp"
#include "../detail/state_ops.hpp"
#include "radicand_remedy.hpp"

namespace eci {

namespace detail {

/// a * b = p + e exactly (error-free product); with hardware FMA when the target has it, else Dekker's split.
inline void two_product(double a, double b, double& p, double& e) {
    p = a * b;
#if defined(__FMA__) || defined(__FP_FAST_FMA)
    e = std::fma(a, b, -p);
#else
    constexpr double split = 134217729.0;  // 2^27 + 1 (Veltkamp)
    const double ca = split * a, cb = split * b;
    const double ah = ca - (ca - a), al = a - ah;
    const double bh = cb - (cb - b), bl = b - bh;
    e = ((ah * bh - p) + ah * bl + al * bh) + al * bl;
#endif
}

/// a + b = s + e exactly (Knuth's two-sum, no assumption on magnitudes).
inline void two_sum(double a, double b, double& s, double& e) {
    s = a + b;
    const double bb = s - a;
    e = (a - (s - bb)) + (b - bb);
}

/// The finishing pass of compensated C-PC over n real unknowns: p holds psi~ and becomes the new psi; k0 holds
/// S(psi) and becomes the new residual, except where the radicand is negative (p is then NaN and k0 keeps S, for
/// the remedy). Returns the counts of negative (or NaN) and of infinite radicands (doubles keep it vectorizable).
inline radicand_counts compensated_c_pc_finish_inline(double* p, double* k0, const double* x, const double* k1,
                                                      const double* r, double dt, std::size_t n) {
    constexpr double most = std::numeric_limits<double>::max();
    double bad = 0.0, inf = 0.0;
    const step_split sp = split_step(dt);
    for (std::size_t i = 0; i < n; ++i) {
        const double psi = x[i];
        double sq, sq_err;
        two_product(psi, psi, sq, sq_err);
        // eq. (30b), the increment of psi^2, with dt = p m (split_step): (p psi) S is p psi S exactly, of the
        // increment's size where psi S itself would over- or underflow, and the same bits wherever it does not
        const double inc = sp.m * ((sp.p * psi) * k0[i] + (sp.p * p[i]) * k1[i]);
        double hi, lo;
        two_sum(sq, inc, hi, lo);
        lo += sq_err + r[i];
        const double xi = hi + lo;  // renormalise (|lo| is below an ulp of hi)
        lo -= xi - hi;
        bad += xi >= 0.0 ? 0.0 : 1.0;
        inf += xi > most ? 1.0 : 0.0;
        const double root = std::sqrt(xi);
        double root_sq, root_err;
        two_product(root, root, root_sq, root_err);
        // xi - root^2 is exact (Sterbenz), so the new residual carries everything the square root dropped.
        const double residual = ((xi - root_sq) - root_err) + lo;
        k0[i] = xi >= 0.0 ? residual : k0[i];  // k0[i] is read above and, where the step succeeds, no longer needed
        p[i] = std::copysign(root, p[i]);  // the predictor's sign, eq. (30b)
    }
    return {bad, inf};
}

// x86-64 Linux GCC builds that do not already target AVX2 also compile the pass for AVX2 (twice the lanes for its
// double-double arithmetic) and pick the version at load time; AVX2 brings no FMA, so both round identically.
// Its square root vectorizes only where the user compiles with -fno-math-errno (eci's own builds do).
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__GLIBC__) && !defined(__AVX2__) && \
    !defined(__FMA__) && !defined(__SANITIZE_ADDRESS__)
#define ECI_DETAIL_COMPENSATED_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define ECI_DETAIL_COMPENSATED_CLONES
#endif

/// The same, dispatched at load time to the best compiled version.
ECI_DETAIL_COMPENSATED_CLONES inline radicand_counts compensated_c_pc_finish(double* p, double* k0, const double* x,
                                                                             const double* k1, const double* r,
                                                                             double dt, std::size_t n) {
    return compensated_c_pc_finish_inline(p, k0, x, k1, r, dt, n);
}

#undef ECI_DETAIL_COMPENSATED_CLONES

}  // namespace detail

/// C-PC, eq. (30), with the same results as eci::c_pc up to round-off, whose new squared amplitude
/// xi_k = psi_k^2 + tau (psi_k S_k + psi~_k S~_k) is formed in double-double arithmetic. The stepper keeps the
/// residual r_k = xi_k - psi_k^2 (below an ulp of psi_k^2) from step to step, so xi_k = psi_k^2 + r_k is carried
/// with compensated summation and only the rounding of the small increments tau (psi S + psi~ S~) remains.
/// reset() drops the residuals (the drivers call it when a run starts; a state of another size drops them too); a
/// state changed between steps without reset() inherits the old residual, a perturbation under one ulp.
/// Isolated negative radicands are remedied as in conservative_rk (radicand_remedy.hpp), residuals included.
template <state S>
class c_pc_compensated : public radicand_remedy {
   public:
    static constexpr int order = 2;
    static constexpr bool checks_finite = true;  ///< a non-finite update fails the step
    static constexpr bool fixed_evaluations = true;  ///< two evaluations per step

    template <system<S> F>
    step_result step(F& f, S& x, double t, double dt) {
        for (S* b : {&k0_, &k1_, &pred_, &res_}) detail::resize_like(*b, x);
        f(x, k0_, t);
        const auto xr = detail::reals(std::as_const(x));
        const std::size_t n = xr.size();
        if (res_n_ != n) {  // a new (or resized) problem starts with xi = psi^2 exactly
            double* r = detail::reals(res_).data();
            for (std::size_t i = 0; i < n; ++i) r[i] = 0.0;
            res_n_ = n;
        }
        double* p = detail::reals(pred_).data();
        double* k0 = detail::reals(k0_).data();
        for (std::size_t i = 0; i < n; ++i) p[i] = xr[i] + dt * k0[i];  // eq. (30a)
        f(std::as_const(pred_), k1_, t + dt);
        const double* k1 = detail::reals(std::as_const(k1_)).data();
        const double* r = detail::reals(std::as_const(res_)).data();
        // a call only pays off beyond a few modes
        const detail::radicand_counts counts =
            n >= 64 ? detail::compensated_c_pc_finish(p, k0, xr.data(), k1, r, dt, n)
                    : detail::compensated_c_pc_finish_inline(p, k0, xr.data(), k1, r, dt, n);
        // Only steps with failures pay for the remedy; the failed unknowns are NaN in p.
        const bool bad = counts.negative != 0.0;
        if (bad && !remedy_failures(p, k0, xr.data(), k1, r, dt, n))
            return step_result::failure(first_failure(n, [&](std::size_t i) { return !(p[i] == p[i]); }));
        // An overflow (inf) fails the step too: counted by the pass where no radicand was negative (every new value
        // is then the root of one in [0, max]), else checked over the remedied state.
        if (bad ? !detail::all_finite_reals(p, n) : counts.infinite != 0.0)
            return step_result::failure(detail::first_index(n, [&](std::size_t i) { return !std::isfinite(p[i]); }));
        using std::swap;
        swap(x, pred_);
        swap(res_, k0_);
        return step_result::success();
    }

    /// Forget the carried residuals: the next step treats psi^2 as exact.
    void reset() { res_n_ = 0; }

    /// How many state-sized buffers this stepper holds: those of C-PC and the residual.
    static constexpr std::size_t buffer_count() { return 4; }

   private:
    static constexpr std::size_t per = sizeof(std::ranges::range_value_t<S>) / sizeof(double);

    // The remedy: failed unknowns (p NaN, k0 still S) take Heun's update with a zero residual; then every
    // xi = psi^2 + residual is rescaled in double-double, as the finishing pass forms it.
    bool remedy_failures(double* p, double* k0, const double* x, const double* k1, const double* r, double dt,
                         std::size_t n) {
        auto failed = [&](std::size_t i) { return !(p[i] == p[i]); };
        const detail::step_split sp = detail::split_step(dt);
        auto fix = [&](std::size_t i) -> std::pair<double, double> {
            const double pred = x[i] + dt * k0[i];  // eq. (30a)
            const double conv = x[i] + 0.5 * dt * (k0[i] + k1[i]);
            const double rad = x[i] * x[i] + r[i] + sp.m * ((sp.p * x[i]) * k0[i] + (sp.p * pred) * k1[i]);  // (30b)
            k0[i] = 0.0;  // conv^2 is taken as exact: no residual
            return {conv, rad};
        };
        auto rescale_pass = [&](const auto& c) {
            for_each_factor<per == 2 ? 1 : 0>(n, c, [&](std::size_t i, double s) {
                double sq, sq_err, hi, lo;
                detail::two_product(p[i], p[i], sq, sq_err);
                detail::two_sum(sq, sq * s, hi, lo);  // xi (1 + s); the rounding of sq * s is below eps |xi s|
                lo += sq_err + k0[i] * (1.0 + s);
                const double xi = hi + lo;
                lo -= xi - hi;
                const double root = std::sqrt(xi);
                double root_sq, root_err;
                detail::two_product(root, root, root_sq, root_err);
                k0[i] = ((xi - root_sq) - root_err) + lo;
                p[i] = std::copysign(root, p[i]);
            });
        };
        return try_remedy<per>(p, x, n, failed, fix, rescale_pass);
    }

    S k0_{}, k1_{}, pred_{}, res_{};
    std::size_t res_n_ = 0;
};

/// The former name of c_pc_compensated (deprecated: C++ names now follow the registry's, '-' written '_').
template <state S>
using compensated_c_pc = c_pc_compensated<S>;

}  // namespace eci
