// One engine for adaptive Runge-Kutta: any tableau (an embedded pair or a plain one), conventional or exactly
// conservative (errata item 9, xi = psi^2 advanced by the tableau), with FSAL, an embedded error estimate,
// conservative dense output (a Hermite interpolant of xi) and xi carried plainly or compensated (a policy).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <ranges>
#include <type_traits>
#include <utility>
#include <vector>

#include "../concepts.hpp"
#include "../detail/reduce.hpp"
#include "../detail/state_ops.hpp"
#include "../tableaus.hpp"
#include "compensated_c_pc.hpp"
#include "explicit_rk.hpp"
#include "radicand_remedy.hpp"

namespace eci {

/// How the new state is formed from the stages: the tableau's weights applied to psi (conventional), or to
/// xi = psi^2 with psi = sign * sqrt(xi) (conservative, errata item 9).
enum class update_rule { conventional, conservative };

/// How a conservative stepper carries xi = psi^2 from step to step: as psi^2 recomputed in double (plain), or
/// with the rounding residual xi - psi^2 kept between steps in double-double arithmetic (compensated), so that
/// the invariants do not random-walk by one rounding of psi^2 per step.
enum class xi_carry { plain, compensated };

/// The error norm's weights: component i's error e_i is measured against atol_i + rtol_i max(|x_i|, |x_new_i|).
/// Pointers (if not null) hold one value per real unknown and override the scalars.
struct error_weights {
    double rtol = 1e-6;
    double atol = 1e-6;
    const double* rtol_each = nullptr;
    const double* atol_each = nullptr;

    /// atol_i + rtol_i max(|x|, |next|) of component i; Each: the per-unknown arrays are read where given (a
    /// compile-time choice, so that the scalar case loads nothing per unknown).
    template <bool Each>
    [[gnu::always_inline]] double scale(std::size_t i, double x, double next) const {
        double rt = rtol, at = atol;
        if constexpr (Each) {
            if (rtol_each) rt = rtol_each[i];
            if (atol_each) at = atol_each[i];
        }
        return at + rt * std::max(std::abs(x), std::abs(next));
    }
};

/// The outcome of one attempted step: whether the candidate exists (no negative radicand), which real unknown
/// failed, the RMS error norm (Hairer's, eq. (4.11) of Hairer-Norsett-Wanner I, section II.4), and which unknown
/// had the largest weighted error (computed only on request).
struct attempt_result {
    bool ok = true;
    std::size_t component = 0;  ///< the first negative radicand (if !ok) or the worst error (if requested)
    double error = 0.0;         ///< RMS of e_i / weight_i; <= 1 means the step meets the tolerances
};

namespace detail {

template <class Tab>
concept embedded_pair = requires(const Tab& t) { t.bhat; t.embedded_order; };

template <class Tab>
concept with_continuous_extension = requires(const Tab& t) { t.d; };

/// A pair whose error estimate combines two embedded solutions (doubly_embedded_tableau).
template <class Tab>
concept with_second_estimate = requires(const Tab& t) { t.bhat_low; t.low_mix; };

/// The number of terms of a continuous extension beyond the cubic (0 without one).
template <class Tab>
constexpr std::size_t dense_terms_of() {
    if constexpr (with_continuous_extension<Tab>)
        return Tab::dense_terms;
    else
        return 0;
}

/// The number of stages a continuous extension evaluates after the step (0 without one).
template <class Tab>
constexpr std::size_t extra_stages_of() {
    if constexpr (with_continuous_extension<Tab>)
        return Tab::extra_stages;
    else
        return 0;
}

/// The order whose error the pair's estimate has the size of: the embedded solution's, or for two combined
/// (doubly_embedded_tableau) 2 embedded_order - low_order.
template <class Tab>
constexpr int estimate_order(const Tab& t) {
    if constexpr (with_second_estimate<Tab>)
        return 2 * t.embedded_order - t.low_order;
    else
        return t.embedded_order;
}

template <const auto& T>
constexpr bool tableau_is_fsal() {
    if constexpr (embedded_pair<std::remove_cvref_t<decltype(T)>>)
        return is_fsal(T);
    else
        return false;
}

/// The value at theta in [0, 1] of a step of size h from y0 to y1 with end rates f0, f1: the continuous
/// extension's form (dense_embedded_tableau; fd[r] = sum_i d[r][i] rate_i, R terms beyond the cubic) or, for
/// R = 0, the cubic Hermite interpolant. Linear in its data, so data with equal linear invariants give a value
/// with the same invariants (the conservative dense output).
template <std::size_t R>
double dense_value(double theta, double h, double y0, double y1, double f0, double f1, const std::array<double, R>& fd) {
    if constexpr (R > 0) {
        // u = fd[0] + theta (fd[1] + (1 - theta)(fd[2] + theta fd[3])), the factors alternating
        double u = fd[R - 1];
        for (std::size_t r = R - 1; r-- > 0;) u = fd[r] + (r % 2 == 0 ? theta : 1.0 - theta) * u;
        const double dy = y1 - y0, c3 = h * f0 - dy, c4 = dy - h * f1 - c3;
        return y0 + theta * (dy + (1.0 - theta) * (c3 + theta * (c4 + (1.0 - theta) * h * u)));
    } else {
        (void)fd;
        const double h00 = (1.0 + 2.0 * theta) * (1.0 - theta) * (1.0 - theta);
        const double h10 = theta * (1.0 - theta) * (1.0 - theta);
        const double h01 = theta * theta * (3.0 - 2.0 * theta), h11 = theta * theta * (theta - 1.0);
        return (h00 * y0 + h01 * y1) + h * (h10 * f0 + h11 * f1);
    }
}

/// The base of a stepper without the conditioned update (conventional, or compensated xi).
struct no_conditioned_update {};

}  // namespace detail

/// The Runge-Kutta engine over the tableau T (an embedded_tableau or a butcher_tableau) for states S.
///
/// Protocol: `attempt(f, x, t, dt, w)` forms the candidate x(t+dt) and its error norm, leaving x untouched;
/// `accept(x)` makes the candidate the state. Between an accept and the next attempt, `interpolate` evaluates the
/// dense output on the accepted step. The stepper carries data from one step to the next (the FSAL derivative,
/// the compensated residual): `reset()` drops it, and must be called whenever x is changed by anyone else.
/// `step(f, x, t, dt)` is the fixed-step face of every eci stepper (it checks x itself, so needs no reset).
///
/// A conservative stepper with plain xi derives from radicand_remedy: told the system's quadratic invariants
/// (set_quadratic_invariants; the adaptive drivers pass a model's), it takes the conditioned update of the fixed-step
/// engine on systems of remedy.min_unknowns real unknowns or more (docs/methods.md, "Adaptive pairs").
template <const auto& T, state S, update_rule U, xi_carry X = xi_carry::plain>
class embedded_rk
    : public std::conditional_t<U == update_rule::conservative && X == xi_carry::plain, radicand_remedy,
                                detail::no_conditioned_update> {
    using tableau_type = std::remove_cvref_t<decltype(T)>;
    static constexpr std::size_t s = tableau_type::stages;
    static constexpr bool conservative = U == update_rule::conservative;
    static constexpr bool compensated = X == xi_carry::compensated;
    static_assert(conservative || !compensated, "only a conservative stepper carries xi");
    static constexpr bool fsal = detail::tableau_is_fsal<T>();
    static constexpr bool two_estimates = detail::with_second_estimate<tableau_type>;
    // terms of the continuous extension beyond the cubic, and the stages it evaluates after the step
    static constexpr std::size_t R = detail::with_continuous_extension<tableau_type> && fsal
                                         ? detail::dense_terms_of<tableau_type>() : 0;
    static constexpr std::size_t E = R > 0 ? detail::extra_stages_of<tableau_type>() : 0;

   public:
    /// Order of the propagated solution.
    static constexpr int order = T.order;
    /// Whether the tableau has an embedded solution (an error estimate for step control).
    static constexpr bool has_error_estimate = detail::embedded_pair<tableau_type>;
    /// Order of the embedded solution (0 if there is none): the error estimate is O(dt^(embedded_order + 1)).
    /// For two embedded solutions combined (doubly_embedded_tableau), the order whose error the estimate has the
    /// size of (DP853: 7, as SciPy's DOP853 declares).
    static constexpr int embedded_order = [] {
        if constexpr (has_error_estimate)
            return detail::estimate_order(T);
        else
            return 0;
    }();
    /// Whether the stepper keeps every invariant sum_k w_k psi_k^2 of the system exactly.
    static constexpr bool is_conservative = conservative;
    /// Whether the first stage of a step reuses the last of the step before.
    static constexpr bool first_same_as_last = fsal;
    /// Whether the dense output is the pair's own continuous extension (else a cubic Hermite interpolant).
    static constexpr bool has_continuous_extension = detail::with_continuous_extension<tableau_type> && fsal;
    /// The degree of the dense output's polynomial in the step fraction (of psi, or of xi = psi^2 if conservative):
    /// 3 + the continuous extension's terms beyond the cubic (DP54: 4, DP853: 7), or 3 (cubic Hermite).
    static constexpr int dense_degree = 3 + int(has_continuous_extension ? detail::dense_terms_of<tableau_type>() : 0);
    /// Whether the dense output is as accurate as the steps themselves (measured in tests/numeric/test_adaptive.cpp):
    /// a conventional pair's continuous extension, or a cubic Hermite interpolant for a pair of order at most 3.
    /// Not a conservative pair's continuous extension: interpolated xi near a zero of psi turns an O(dt^5) error of
    /// xi into its square root in psi (up to 9x the steps' error measured on the three-wave model at 1e-6).
    static constexpr bool dense_matches_steps = (has_continuous_extension && !conservative) || T.order <= 3;
    /// Whether the dense output interpolates xi = psi^2 of every real unknown (the conservative update), so that
    /// the interpolant is a polynomial in the step fraction of xi, not of psi.
    static constexpr bool dense_of_squares = conservative;

    embedded_rk() {
        // The conditioned update without the share cap (only the rescale's caps, max_rescale and |s_k| <= 1/2): the
        // error estimate measures each element taken conventional by the conventional estimate, so the controller
        // bounds their error as it bounds dp54's, and the cap would only keep ill-conditioned square roots, whose
        // error the estimate sees and the controller answers with smaller steps (docs/methods.md, "Adaptive
        // pairs": 5 % cost 1.0-1.6x dp54's evaluations at equal error on the random n-wave system, 1 cost 0.8-1.1x).
        if constexpr (conditioning) this->remedy.max_share = 1.0;
    }

    /// Attempt a step of dt from (x, t). x is not changed; on success, accept() makes the candidate the state.
    /// With `w`, the error norm is computed; with `track_worst`, also the component with the largest error.
    template <system<S> F>
    attempt_result attempt(F& f, const S& x, double t, double dt, const error_weights* w = nullptr,
                           bool track_worst = false) {
        // its error norm and negative radicands are over this process's unknowns (detail/reduce.hpp)
        detail::require_one_process(f, "the embedded pairs");
        prepare(x);
        if (!have_first_) {
            f(x, k_[0], t);
            first_is_x_ = true;
        } else if (pending_first_) {
            using std::swap;
            swap(k_[0], k_[s - 1]);  // f(x) evaluated for the dense output of the step before
        }
        pending_first_ = false;
        have_first_ = true;
        dense_ready_ = false;
        extras_ready_ = false;
        run_stages(f, x, t, dt, std::make_index_sequence<s>{});
        const auto xr = detail::reals(x);
        const double* p0 = conservative && !first_is_x_ ? detail::reals(std::as_const(first_point_)).data() : xr.data();
        std::array<const double*, s> kp{};
        for (std::size_t j = 0; j < s; ++j) kp[j] = detail::reals(std::as_const(k_[j])).data();
        double* o = detail::reals(result_).data();
        double* rn = compensated ? detail::reals(res_new_).data() : nullptr;
        const double* r = compensated ? detail::reals(std::as_const(res_)).data() : nullptr;
        const std::size_t n = xr.size();
        finish_sums sums;
        constexpr auto J = std::make_index_sequence<s>{};
        if constexpr (conditioning) {
            if (conditioned_update_applies(n)) {
                const error_weights none{};
                const bool ok = w == nullptr ? finish_conditioned<false, false, false>(o, xr.data(), p0, kp, dt, n, none, sums)
                                : track_worst ? finish_conditioned<true, true, true>(o, xr.data(), p0, kp, dt, n, *w, sums)
                                              : finish_conditioned<true, false, true>(o, xr.data(), p0, kp, dt, n, *w, sums);
                attempt_result res;
                if (!ok) {
                    res.ok = false;
                    res.component = this->template first_negative<per>();
                    return res;
                }
                return finish_result(res, sums, n, dt);
            }
        }
        if (w == nullptr)
            finish<false, false, false>(o, rn, xr.data(), p0, r, kp, dt, n, error_weights{}, sums, J);
        else if (track_worst)
            finish<true, true, true>(o, rn, xr.data(), p0, r, kp, dt, n, *w, sums, J);
        else if (w->rtol_each || w->atol_each)
            finish<true, false, true>(o, rn, xr.data(), p0, r, kp, dt, n, *w, sums, J);
        else  // scalar tolerances: no per-unknown branch, so the pass vectorizes
            finish<true, false, false>(o, rn, xr.data(), p0, r, kp, dt, n, *w, sums, J);
        attempt_result res;
        if (sums.bad != 0.0) {
            res.ok = false;
            res.component = detail::first_index(n, [&](std::size_t i) { return !std::isfinite(o[i]); });
            return res;
        }
        return finish_result(res, sums, n, dt);
    }

    /// Make the candidate of the last successful attempt the state x (the x that attempt was given).
    void accept(S& x) {
        using std::swap;
        swap(x, result_);  // result_ now holds the step's start, x0, for the dense output
        if constexpr (compensated) swap(res_, res_new_);
        p0_is_x0_ = first_is_x_;
        if constexpr (fsal) {
            swap(k_[0], k_[s - 1]);  // the derivative at the new state (conventional: the state itself)
            if constexpr (conservative) {
                // Conservative FSAL: the derivative was taken at the conventional update Y_s, not at the new psi,
                // and the xi rate of the next step's first stage pairs it with Y_s (see docs/methods.md).
                swap(first_point_, stage_);
                first_is_x_ = false;
            }
            have_first_ = true;
            dense_ready_ = true;
        } else {
            have_first_ = false;
            first_is_x_ = true;
            dense_ready_ = false;
        }
    }

    /// Make the dense output of the accepted step available: a non-FSAL tableau needs f at the new state, which
    /// this evaluates once and keeps as the next step's first stage (so dense output costs no extra evaluation
    /// over a run); a continuous extension with extra stages (DP853) evaluates them (E calls of f per step that
    /// is interpolated). x is the current state (the one accept() produced), t its time.
    template <system<S> F>
    void prepare_dense(F& f, const S& x, double t) {
        if (!dense_ready_) {
            f(x, k_[s - 1], t);
            pending_first_ = true;
            have_first_ = true;
            first_is_x_ = true;
            dense_ready_ = true;
        }
        if constexpr (E > 0) {
            if (!extras_ready_) run_extra_stages(f, t);
            extras_ready_ = true;
        }
    }

    /// The dense output at t0 + theta dt of the accepted step (x is the current state; call prepare_dense first).
    /// Conventional: the pair's continuous extension (DP54: fourth order; DP853: seventh, with its three extra
    /// stages) or the cubic Hermite interpolant of psi.
    /// Conservative: the same interpolant applied to xi = psi^2, with the stage rates 2 Y_i S(Y_i) in place of the
    /// k_i. Every such interpolant is xi0 + c (xi1 - xi0) + dt sum_i beta_i 2 Y_i S(Y_i): xi0 and xi1 have equal
    /// invariants and every rate term has sum_k w_k Y_k S_k(Y) = 0, so each interpolated point keeps every
    /// invariant of the step's ends. psi takes the sign of the conventional interpolant. A negative interpolated
    /// xi fails (the component named): the caller then lands a step on that time instead. With `conventional`,
    /// the conventional interpolant of psi (whose sign the conservative one takes) is written there too.
    step_result interpolate(const S& x, double theta, S& out, S* conventional = nullptr) const {
        detail::resize_like(out, x);
        double* c = nullptr;
        if (conventional) {
            detail::resize_like(*conventional, x);
            c = detail::reals(*conventional).data();
        }
        const auto x1 = detail::reals(x);
        const double* x0 = detail::reals(std::as_const(result_)).data();
        // the stage derivatives of the accepted step, in stage order (an FSAL accept rotated k_0 and k_{s-1})
        std::array<const double*, s> k{};
        for (std::size_t j = 0; j < s; ++j) k[j] = detail::reals(std::as_const(k_[j])).data();
        if constexpr (fsal) std::swap(k[0], k[s - 1]);
        const double* k_end = fsal ? k[s - 1] : detail::reals(std::as_const(k_[s - 1])).data();
        const double h = last_dt_;
        double* o = detail::reals(out).data();
        const std::size_t n = x1.size();
        // Where each end's derivative was taken: the state itself, or (conservative FSAL) the conventional update.
        const double* p0 = x0;
        const double* p1 = x1.data();
        if constexpr (conservative && fsal) {
            if (!p0_is_x0_) p0 = detail::reals(std::as_const(stage_)).data();
            p1 = detail::reals(std::as_const(first_point_)).data();
        }
        const double* r0 = compensated ? detail::reals(std::as_const(res_new_)).data() : nullptr;
        const double* r1 = compensated ? detail::reals(std::as_const(res_)).data() : nullptr;
        std::array<const double*, E> ky{}, yy{};  // the extra stages' derivatives and values
        if constexpr (E > 0)
            for (std::size_t e = 0; e < E; ++e) {
                ky[e] = detail::reals(std::as_const(k_extra_[e])).data();
                yy[e] = detail::reals(std::as_const(y_extra_[e])).data();
            }
        // psi's interpolant takes the step h and the rates k_i; xi's takes the rates 2 Y_i S(Y_i) times p and the
        // step as m, h = p m (detail::split_step), as the steps form them: no over- or underflow where xi and its
        // change are representable, the same bits wherever they were
        const detail::step_split hs = detail::split_step(h);
        double bad = 0.0;
        for (std::size_t i = 0; i < n; ++i) {
            std::array<double, R> kd{}, rd{};  // sum_j d[r][j] k_j and sum_j d[r][j] 2 Y_j k_j
            if constexpr (R > 0) {
                [&]<std::size_t... J>(std::index_sequence<J...>) {
                    (add_dense_terms<J>(p0[i], x0[i], k, i, h, hs.p, kd, rd), ...);
                }(std::make_index_sequence<s>{});
                if constexpr (E > 0)
                    for (std::size_t e = 0; e < E; ++e)
                        for (std::size_t r = 0; r < R; ++r) {
                            const double dv = T.d[r][s + e];
                            if (dv == 0.0) continue;
                            kd[r] += dv * ky[e][i];
                            if constexpr (conservative) rd[r] += dv * 2.0 * hs.p * yy[e][i] * ky[e][i];
                        }
            }
            // conventional interpolant of psi: between x0 and the conventional update (x1 itself if conventional)
            const double psi = detail::dense_value<R>(theta, h, x0[i], p1[i], k[0][i], k_end[i], kd);
            if (c) c[i] = psi;
            if constexpr (!conservative) {
                o[i] = psi;
            } else {
                double xi0 = x0[i] * x0[i], xi1 = x1[i] * x1[i];
                if constexpr (compensated) xi0 += r0[i], xi1 += r1[i];
                const double xi = detail::dense_value<R>(theta, hs.m, xi0, xi1, 2.0 * hs.p * p0[i] * k[0][i],
                                                         2.0 * hs.p * p1[i] * k_end[i], rd);
                bad += xi >= 0.0 ? 0.0 : 1.0;
                o[i] = std::copysign(std::sqrt(xi), psi);
            }
        }
        if (bad != 0.0)
            return step_result::failure(detail::first_index(n, [&](std::size_t i) { return !(o[i] == o[i]); }));
        return step_result::success();
    }

    /// The state at the start of the accepted step (valid from accept() to the next attempt).
    const S& step_start() const { return result_; }
    /// The size of the last attempted step.
    double last_step_size() const { return last_dt_; }

    /// Forget everything carried between steps (FSAL derivative, compensated residual, dense output).
    void reset() {
        have_first_ = pending_first_ = dense_ready_ = extras_ready_ = false;
        first_is_x_ = true;
        residual_valid_ = false;
    }

    /// The fixed-step face: one step of dt, reusing carried data only if x is the state this stepper produced
    /// last (so a caller that changes x between steps needs no reset()).
    template <system<S> F>
    step_result step(F& f, S& x, double t, double dt) {
        if (!(stepped_ && x == last_x_)) reset();
        const attempt_result r = attempt(f, x, t, dt);
        if (!r.ok) return step_result::failure(r.component);
        accept(x);
        stepped_ = true;
        last_x_ = x;
        return step_result::success();
    }

    /// How many state-sized buffers an adaptive run holds: the stages, one stage value, the candidate, and for a
    /// conservative FSAL pair the point of the carried derivative, for a compensated one two residuals, for a
    /// continuous extension with extra stages their values and derivatives (allocated at the first dense output).
    /// (step() keeps one more, a copy of the last state, to detect a changed x.)
    static constexpr std::size_t buffer_count() {
        return s + 2 + (conservative && fsal ? 1 : 0) + (compensated ? 2 : 0) + 2 * E;
    }

   private:
    struct finish_sums {
        double bad = 0.0;  // negative radicands, as a double to keep the loop vectorizable
        double sq = 0.0;   // sum of squared weighted errors
        double sq_low = 0.0;  // the same for the second embedded solution (two_estimates)
        double worst_ratio = -1.0;
        std::size_t worst = 0;
    };

    // The error norm from the finishing pass's sums.
    attempt_result finish_result(attempt_result res, const finish_sums& sums, std::size_t n, double dt) {
        if constexpr (two_estimates) {  // |err|^2 / sqrt(|err|^2 + mix |err_low|^2), RMS norms (doubly_embedded_tableau)
            const double den = sums.sq + T.low_mix * sums.sq_low;
            // (a nan sum, from a rate that is not finite, stays nan: the step is rejected, never taken as exact)
            res.error = den > 0.0 ? sums.sq / std::sqrt(double(n) * den) : den == 0.0 ? 0.0 : den;
        } else {
            res.error = n > 0 ? std::sqrt(sums.sq / double(n)) : 0.0;
        }
        res.component = sums.worst;
        last_dt_ = dt;
        return res;
    }

    // The conditioned update (conservative, plain xi): real parts per state element (2 for a complex mode).
    static constexpr bool conditioning = conservative && !compensated;
    static constexpr std::size_t per = sizeof(std::ranges::range_value_t<S>) / sizeof(double);

    // It needs the declared weights (the rescale restores them, and they say the invariants of a complex state are
    // sums w_k |psi_k|^2, phase-free), the remedy policy, and at least min_unknowns real unknowns.
    bool conditioned_update_applies(std::size_t n) const {
        const auto& w = this->quadratic_invariants();
        return this->remedy.update == update_kind::conditioned && this->remedy.policy == radicand_policy::remedy &&
               !w.empty() && w.front().size() * per == n && n >= this->remedy.min_unknowns;
    }

    // One real unknown's share of a step, as finish forms it: the conventional update, the increment of xi
    // (dt sum_j b_j 2 Y_j k_j), and for the error estimate dt sum_j b_j k_j (Y_j - x), dt sum_j b_j k_j and the
    // embedded solutions' differences from the conventional update, dt sum_j (b_j - bhat_j) k_j (and bhat_low).
    struct part_values {
        double conv, inc, a, bt, dconv, dconv_low;
    };
    template <bool Est, std::size_t... J>
    static part_values part_update(const double* p0, const double* x, const std::array<const double*, s>& k,
                                   std::size_t i, double dt, detail::step_split sp, std::index_sequence<J...>) {
        constexpr auto d = error_weights_of_tableau;
        constexpr auto dl = low_error_weights_of_tableau;
        (void)dl;
        const std::array<double, s> wb{(dt * T.b[J])...};
        part_values v{x[i], 0.0, 0.0, 0.0, 0.0, 0.0};
        ((T.b[J] != 0.0 ? (v.conv += wb[J] * k[J][i], 0) : 0), ...);
        double rate = 0.0;
        (add_rate<J, Est>(p0[i], x[i], k, i, dt, 2.0 * sp.p, wb, rate, v.a), ...);
        v.inc = sp.m * rate;
        if constexpr (Est) {
            ((d[J] != 0.0 ? (v.dconv += (dt * d[J]) * k[J][i], 0) : 0), ...);
            ((T.b[J] != 0.0 ? (v.bt += wb[J] * k[J][i], 0) : 0), ...);
            if constexpr (two_estimates) ((dl[J] != 0.0 ? (v.dconv_low += (dt * dl[J]) * k[J][i], 0) : 0), ...);
        }
        return v;
    }

    // Real unknowns of a pair of order 3 or more (remedy_options::real_by_rescale): every unknown's conventional
    // update into o, the conventional pair's error estimate, and in the same pass each invariant's defect
    // sum_i w_ji (c_i^2 - xi_i) and the Gram sums of c_i^2; radicand_remedy::rescale_conventional then restores
    // every invariant by one exact rescale (nothing filed). false: the rescale refused (o is written again by
    // finish_conditioned's pass, which then files by kappa's rule with every element ill-conditioned).
    template <bool Norm, bool Track, bool Each>
    bool finish_by_rescale(double* o, const double* x, const double* p0, const std::array<const double*, s>& k,
                           double dt, std::size_t n, const error_weights& w, finish_sums& sums) {
        constexpr bool est = Norm && has_error_estimate;
        constexpr auto J = std::make_index_sequence<s>{};
        const detail::step_split sp = detail::split_step(dt);
        const auto& weights = this->quadratic_invariants();
        const std::size_t m = weights.size();
        auto pass = this->begin_rescale();
        std::array<double, radicand_remedy::max_invariants> defect{};
        double negatives = 0.0, sq = 0.0, sq_low = 0.0;
        for (std::size_t i = 0; i < n; ++i) {
            const part_values v = part_update<est>(p0, x, k, i, dt, sp, J);
            const double c2 = v.conv * v.conv, xi = x[i] * x[i] + v.inc, d = c2 - xi;
            o[i] = v.conv;
            for (std::size_t a = 0; a < m; ++a) defect[a] += weights[a][i] * d;
            negatives += xi < 0.0 ? 1.0 : 0.0;
            radicand_remedy::gram_add(pass, i, c2);
            if constexpr (est) {
                const double scale = w.template scale<Each>(i, x[i], v.conv);
                const double r = v.dconv / scale, rl = v.dconv_low / scale;
                sq += r * r, sq_low += rl * rl;
                if constexpr (Track)
                    if (!(std::sqrt(r * r) <= sums.worst_ratio)) sums.worst_ratio = std::sqrt(r * r), sums.worst = i;
            }
        }
        if (!this->template rescale_conventional<1>(o, n, pass, defect, negatives)) {
            sums.worst_ratio = -1.0, sums.worst = 0;
            return false;
        }
        sums.sq = std::max(sq, 0.0);
        sums.sq_low = std::max(sq_low, 0.0);
        return true;
    }

    // The conditioned finishing pass (docs/methods.md, "Adaptive pairs"): every element's conventional update and
    // xi = the tableau applied to |psi_e|^2, filed by the remedy's condition_element (the sign of the conventional
    // update for a real unknown, its phase for a complex mode), then remedy_elements: negative radicands and
    // ill-conditioned square roots take the conventional update, one exact rescale restores every invariant.
    // The error estimate measures what each element becomes: psi - psihat where it keeps the conservative value,
    // the conventional estimate dt sum_j (b_j - bhat_j) k_j where it takes the conventional update. For the
    // ill-conditioned elements the remedy may yet take, both are kept and the sums corrected for those it took.
    // false: the remedy refused (the step fails, as for a negative radicand in the paper's update).
    template <bool Norm, bool Track, bool Each>
    bool finish_conditioned(double* o, const double* x, const double* p0, const std::array<const double*, s>& k,
                            double dt, std::size_t n, const error_weights& w, finish_sums& sums) {
        constexpr bool est = Norm && has_error_estimate;
        constexpr auto J = std::make_index_sequence<s>{};
        // real unknowns of a pair of order 3 or more: every one conventional, and the exact rescale
        // (remedy_options::real_by_rescale; the kappa rule left c-bs32 at 3.4x bs32's error at rtol 1e-10)
        const bool every = per == 1 && T.order >= 3 && this->remedy.real_by_rescale;
        if constexpr (per == 1)
            if (every && finish_by_rescale<Norm, Track, Each>(o, x, p0, k, dt, n, w, sums)) return true;
        auto pass = this->begin_conditioned(n / per, false, 1, false, every);
        cond_err_.clear();
        double sq = 0.0, sq_low = 0.0;
        const std::size_t ne = n / per;
        const detail::step_split sp = detail::split_step(dt);
        for (std::size_t e = 0; e < ne; ++e) {
            std::array<part_values, per> v;
            std::array<double, per> c{};
            double c2 = 0.0, xi = 0.0;
            for (std::size_t p = 0; p < per; ++p) {
                const std::size_t i = e * per + p;
                v[p] = part_update<est>(p0, x, k, i, dt, sp, J);
                c[p] = v[p].conv;
                c2 += c[p] * c[p];
                xi += x[i] * x[i] + v[p].inc;
            }
            const std::size_t filed = this->cond_.size();
            const auto kind = this->template condition_element<per>(o, x, e, c, c2, xi, c[0], pass);
            if constexpr (est) {
                // each part's ratio to its weight, squared and summed: conventional and conservative estimates
                std::array<double, 2> conv_sq{}, cons_sq{};  // [0]: the estimate, [1]: the second (two_estimates)
                double own_g = 0.0;  // complex mode: psi_p - c_p = c_p g, g = sqrt(xi / |c|^2) - 1
                if constexpr (per == 2) {
                    if (kind == radicand_remedy::element_kind::conservative) {
                        // xi - |c|^2 = sum_p (2 a_p - bt_p^2) (see finish), without the cancellation of |psi|^2
                        double diff = 0.0;
                        for (std::size_t p = 0; p < per; ++p) diff += 2.0 * v[p].a - v[p].bt * v[p].bt;
                        const double r = std::sqrt(c2);
                        own_g = diff / (r * (std::sqrt(xi) + r));
                    }
                }
                for (std::size_t p = 0; p < per; ++p) {
                    const std::size_t i = e * per + p;
                    const double conv_scale = w.template scale<Each>(i, x[i], c[p]);
                    const double rc = v[p].dconv / conv_scale, rcl = v[p].dconv_low / conv_scale;
                    conv_sq[0] += rc * rc, conv_sq[1] += rcl * rcl;
                    if (kind != radicand_remedy::element_kind::conservative) continue;
                    const double next = o[i];
                    double own;  // psi - conv, as finish forms it
                    if constexpr (per == 1) {
                        const double den = next + x[i];
                        const double smooth = (2.0 * v[p].a - (v[p].inc / den) * v[p].bt) / den;
                        own = x[i] * next > 0.0 ? smooth : next - c[p];
                    } else {
                        own = c[p] * own_g;
                    }
                    const double scale = w.template scale<Each>(i, x[i], next);
                    const double r = (own + v[p].dconv) / scale, rl = (own + v[p].dconv_low) / scale;
                    cons_sq[0] += r * r, cons_sq[1] += rl * rl;
                }
                const bool conservative_value = kind == radicand_remedy::element_kind::conservative;
                const std::array<double, 2>& added = conservative_value ? cons_sq : conv_sq;
                sq += added[0], sq_low += added[1];
                if (this->cond_.size() != filed)  // the remedy may take it: what taking it changes
                    cond_err_.push_back({conv_sq[0] - cons_sq[0], conv_sq[1] - cons_sq[1]});
                if constexpr (Track)
                    if (!(std::sqrt(added[0]) <= sums.worst_ratio)) sums.worst_ratio = std::sqrt(added[0]), sums.worst = e * per;
            }
        }
        this->end_conditioned(pass);
        if (!this->filed_none()) {
            const bool ok = this->template remedy_elements<per>(o, x, n, [&](std::size_t e, std::array<double, per>& c) {
                double c2 = 0.0, xi = 0.0;
                for (std::size_t p = 0; p < per; ++p) {
                    const std::size_t i = e * per + p;
                    const part_values v = part_update<false>(p0, x, k, i, dt, sp, J);
                    c[p] = v.conv;
                    c2 += c[p] * c[p];
                    xi += x[i] * x[i] + v.inc;
                }
                return typename radicand_remedy::element_update{c2, xi, c[0]};
            });
            if (!ok) return false;
            if constexpr (est)
                this->for_each_taken([&](std::size_t j) {
                    const auto& d = cond_err_[j];
                    sq += d[0], sq_low += d[1];
                });
        }
        sums.sq = std::max(sq, 0.0);
        sums.sq_low = std::max(sq_low, 0.0);
        return true;
    }

    void prepare(const S& x) {
        for (auto& ki : k_) detail::resize_like(ki, x);
        detail::resize_like(stage_, x);
        detail::resize_like(result_, x);
        if constexpr (conservative && fsal) detail::resize_like(first_point_, x);
        if constexpr (compensated) {
            detail::resize_like(res_, x);
            detail::resize_like(res_new_, x);
            if (!residual_valid_) {
                for (double& v : detail::reals(res_)) v = 0.0;
                residual_valid_ = true;
            }
        }
    }

    template <class F, std::size_t... I>
    void run_stages(F& f, const S& x, double t, double dt, std::index_sequence<0, I...>) {
        (run_stage<I>(f, x, t, dt), ...);
    }

    template <std::size_t I, class F>
    void run_stage(F& f, const S& x, double t, double dt) {
        std::array<const double*, I> kp{};
        for (std::size_t j = 0; j < I; ++j) kp[j] = detail::reals(std::as_const(k_[j])).data();
        const auto xr = detail::reals(x);
        detail::combine_stages_for<row<I>, S>(detail::reals(stage_).data(), xr.data(), kp, dt, xr.size(),
                                              std::make_index_sequence<I>{});
        f(std::as_const(stage_), k_[I], t + T.c[I] * dt);
    }

    template <std::size_t I>
    static constexpr std::array<double, I> row = [] {
        std::array<double, I> r{};
        for (std::size_t j = 0; j < I; ++j) r[j] = T.a[I][j];
        return r;
    }();

    static constexpr std::array<double, s> error_weights_of_tableau = [] {
        std::array<double, s> d{};
        if constexpr (has_error_estimate)
            for (std::size_t j = 0; j < s; ++j) d[j] = T.b[j] - T.bhat[j];
        return d;
    }();

    // b - bhat_low, the second estimate's weights (two_estimates; zero otherwise)
    static constexpr std::array<double, s> low_error_weights_of_tableau = [] {
        std::array<double, s> d{};
        if constexpr (two_estimates)
            for (std::size_t j = 0; j < s; ++j) d[j] = T.b[j] - T.bhat_low[j];
        return d;
    }();

    // The stage derivatives of the accepted step in stage order (an FSAL accept rotated k_0 and k_{s-1}).
    std::array<const double*, s> stage_derivatives() const {
        std::array<const double*, s> k{};
        for (std::size_t j = 0; j < s; ++j) k[j] = detail::reals(std::as_const(k_[j])).data();
        if constexpr (fsal) std::swap(k[0], k[s - 1]);
        return k;
    }

    // The continuous extension's extra stages (E > 0) of the accepted step from result_ (its start) over
    // last_dt_ ending at t_end: values y_extra_ and derivatives k_extra_, each from the stages before it.
    template <class F>
    void run_extra_stages(F& f, double t_end) {
        const double h = last_dt_, t0 = t_end - h;
        const std::array<const double*, s> k = stage_derivatives();
        const auto x0 = detail::reals(std::as_const(result_));
        const std::size_t n = x0.size();
        for (std::size_t e = 0; e < E; ++e) {
            detail::resize_like(y_extra_[e], result_);
            detail::resize_like(k_extra_[e], result_);
            double* y = detail::reals(y_extra_[e]).data();
            std::copy(x0.begin(), x0.end(), y);
            for (std::size_t j = 0; j < s + e; ++j) {
                const double a = T.a_extra[e][j];
                if (a == 0.0) continue;
                const double w = h * a;
                const double* kj = j < s ? k[j] : detail::reals(std::as_const(k_extra_[j - s])).data();
                for (std::size_t i = 0; i < n; ++i) y[i] += w * kj[i];
            }
            f(std::as_const(y_extra_[e]), k_extra_[e], t0 + T.c_extra[e] * h);
        }
    }

    // Stage J's terms of the continuous extension at unknown i: d[r][J] k_J into kd[r] and (conservative)
    // d[r][J] 2 Y_J k_J into rd[r], Y_J recomputed once (Y_0: p0, the point k_0 was taken at).
    template <std::size_t J>
    static void add_dense_terms(double p0, double x0, const std::array<const double*, s>& k, std::size_t i, double h,
                                double hp, std::array<double, R>& kd, std::array<double, R>& rd) {
        (void)p0, (void)x0, (void)h, (void)hp, (void)rd;
        constexpr bool used = [] {
            for (std::size_t r = 0; r < R; ++r)
                if (T.d[r][J] != 0.0) return true;
            return false;
        }();
        if constexpr (used) {
            const double kj = k[J][i];
            double y = 0.0;
            if constexpr (conservative) y = stage_or_start<J>(p0, x0, k, i, h);
            for (std::size_t r = 0; r < R; ++r) {
                if (T.d[r][J] == 0.0) continue;
                kd[r] += T.d[r][J] * kj;
                if constexpr (conservative) rd[r] += T.d[r][J] * 2.0 * hp * y * kj;
            }
        }
    }

    // Stage value Y_J at one unknown, recomputed with the operations combine_stages used (the same bits).
    template <std::size_t J>
    static double stage_value(double x, const std::array<const double*, s>& k, std::size_t i, double dt) {
        double acc = x;
        [&]<std::size_t... M>(std::index_sequence<M...>) {
            ((T.a[J][M] != 0.0 ? (acc += (dt * T.a[J][M]) * k[M][i], 0) : 0), ...);
        }(std::make_index_sequence<J>{});
        return acc;
    }

    // Stage J's value at unknown i: the step's start point p0 for J = 0, else recomputed (stage_value).
    template <std::size_t J>
    static double stage_or_start(double p0, double x, const std::array<const double*, s>& k, std::size_t i,
                                 double dt) {
        if constexpr (J == 0)
            return p0;
        else
            return stage_value<J>(x, k, i, dt);
    }

    // Stage J's term b_J 2 Y_J k_J of the rate of xi (Y_0 is the point the first derivative was taken at: x, or
    // the FSAL point); terms with zero weight vanish at compile time. With Est, also dt b_J k_J (Y_J - x) for the
    // error estimate (see finish).
    template <std::size_t J, bool Est>
    static void add_rate(double p0, double x, const std::array<const double*, s>& k, std::size_t i, double dt,
                         double twop, const std::array<double, s>& wb, double& rate, double& a_acc) {
        (void)wb, (void)a_acc;
        if constexpr (T.b[J] != 0.0) {
            const double y = stage_or_start<J>(p0, x, k, i, dt);
            rate += T.b[J] * (twop * y * k[J][i]);
            if constexpr (Est) a_acc += wb[J] * k[J][i] * (y - x);
        }
    }

    // Compensated: stage J's term c_J Y_J k_J of the increment of xi, c_J = 2 dt b_J, added to (hi, lo) in
    // double-double (the products Y_J k_J and c_J (Y_J k_J) error-free). Conservation holds for any weights
    // (sum_J c_J sum_k w_k Y_Jk S_k(Y_J) = 0 whatever c_J is), so the rounding of c_J does not matter; what this
    // removes is the rounding of each product and sum, which in double would leave a random walk of a few
    // eps |increment| per step.
    template <std::size_t J, bool Est>
    static void add_rate_compensated(double p0, double x, const std::array<const double*, s>& k, std::size_t i,
                                     double dt, double scale, const std::array<double, s>& c,
                                     const std::array<double, s>& wb, double& hi, double& lo, double& a_acc) {
        (void)wb, (void)a_acc;
        if constexpr (T.b[J] != 0.0) {
            const double y = stage_or_start<J>(p0, x, k, i, dt);
            double p, e, q, f, sum, g;
            detail::two_product(scale * y, k[J][i], p, e);
            detail::two_product(c[J], p, q, f);
            detail::two_sum(hi, q, sum, g);
            hi = sum;
            lo += g + (f + c[J] * e);
            if constexpr (Est) a_acc += wb[J] * k[J][i] * (y - x);
        }
    }

    // One pass over the unknowns: the new state, its error and the error norm's sums.
    template <bool Norm, bool Track, bool Each, std::size_t... J>
    static void finish(double* o, double* rn, const double* x, const double* p0, const double* r,
                       const std::array<const double*, s>& k, double dt, std::size_t n, const error_weights& w,
                       finish_sums& sums, std::index_sequence<J...>) {
        constexpr auto d = error_weights_of_tableau;
        constexpr auto dl = low_error_weights_of_tableau;
        (void)w, (void)rn, (void)r, (void)p0, (void)dl;
        const std::array<double, s> wb{(dt * T.b[J])...};
        // dt = p m (detail::split_step): the rate of xi summed as p times itself and multiplied by m, the
        // compensated products as (p Y_J) k_J times c_J = 2 m b_J, so that neither over- nor underflows where xi
        // and its increment are representable, with the bits of the unscaled forms wherever those are
        const detail::step_split sp = detail::split_step(dt);
        [[maybe_unused]] const std::array<double, s> c2{(2.0 * (sp.m * T.b[J]))...};  // c_J (compensated)
        double bad = 0.0, sq = 0.0, sq_low = 0.0;
        for (std::size_t i = 0; i < n; ++i) {
            double conv = x[i];  // the conventional update: the state, or the sign of the conservative one
            ((T.b[J] != 0.0 ? (conv += wb[J] * k[J][i], 0) : 0), ...);
            double next = conv, err = 0.0, err_low = 0.0;
            if constexpr (conservative) {
                constexpr bool est = Norm && has_error_estimate;
                double xi, inc, a_acc = 0.0;  // inc: the increment of xi; a_acc: dt sum_j b_j k_j (Y_j - x)
                if constexpr (compensated) {
                    // xi = psi^2 + r + dt sum_j b_j 2 Y_j k_j, every term carried in double-double
                    double inc_hi = 0.0, inc_lo = 0.0;
                    (add_rate_compensated<J, est>(p0[i], x[i], k, i, dt, sp.p, c2, wb, inc_hi, inc_lo, a_acc), ...);
                    inc = inc_hi;
                    double sq0, sq_err, hi, lo;
                    detail::two_product(x[i], x[i], sq0, sq_err);
                    detail::two_sum(sq0, inc_hi, hi, lo);
                    lo += (sq_err + r[i]) + inc_lo;
                    xi = hi + lo;  // renormalise (|lo| is below an ulp of hi)
                    lo -= xi - hi;
                    bad += xi >= 0.0 ? 0.0 : 1.0;
                    const double root = std::sqrt(xi);
                    double root_sq, root_err;
                    detail::two_product(root, root, root_sq, root_err);
                    rn[i] = ((xi - root_sq) - root_err) + lo;  // all the square root dropped
                    next = std::copysign(root, conv);
                } else {
                    double rate = 0.0;  // sum_j b_j 2 Y_j k_j
                    (add_rate<J, est>(p0[i], x[i], k, i, dt, 2.0 * sp.p, wb, rate, a_acc), ...);
                    inc = sp.m * rate;
                    xi = x[i] * x[i] + inc;  // errata item 9: the tableau applied to d(psi^2)/dt = 2 psi S
                    // a negative (or NaN) xi has no root; an infinite one a root that is no state (inf passed the
                    // error norm, whose scale it made infinite): both fail the attempt
                    bad += xi >= 0.0 && xi <= std::numeric_limits<double>::max() ? 0.0 : 1.0;
                    next = std::copysign(std::sqrt(xi), conv);
                }
                if constexpr (Norm && has_error_estimate) {
                    // psi - psihat: the propagated (conservative) solution minus the pair's embedded solution
                    // psihat = x + dt sum_j bhat_j k_j from the same stages (docs/methods.md, "The error estimate"),
                    // = (psi - conv) + dt sum_j (b_j - bhat_j) k_j. psi - conv is O(dt^(p+1)); formed as a
                    // difference of the rounded psi and conv it would carry their rounding (eps |psi|, far above the
                    // estimate at small steps). Where x and psi have one sign it is formed without cancellation
                    // of O(1) terms: psi - x = inc / (psi + x) =: delta, conv - x = dt B with B = sum_j b_j k_j,
                    // inc = 2 x dt B + 2 A with A = dt sum_j b_j k_j (Y_j - x), so
                    // psi - conv = (2 A - delta dt B) / (psi + x). Across a zero crossing the plain difference.
                    double dconv = 0.0, bt = 0.0;
                    ((d[J] != 0.0 ? (dconv += (dt * d[J]) * k[J][i], 0) : 0), ...);
                    ((T.b[J] != 0.0 ? (bt += wb[J] * k[J][i], 0) : 0), ...);
                    const double den = next + x[i];
                    const double smooth = (2.0 * a_acc - (inc / den) * bt) / den;
                    const double own = x[i] * next > 0.0 ? smooth : next - conv;  // psi - conv
                    err = own + dconv;
                    if constexpr (two_estimates) {  // psi - psihat_low, the same way
                        double dconv_low = 0.0;
                        ((dl[J] != 0.0 ? (dconv_low += (dt * dl[J]) * k[J][i], 0) : 0), ...);
                        err_low = own + dconv_low;
                    }
                }
            } else if constexpr (Norm && has_error_estimate) {
                ((d[J] != 0.0 ? (err += (dt * d[J]) * k[J][i], 0) : 0), ...);
                if constexpr (two_estimates) ((dl[J] != 0.0 ? (err_low += (dt * dl[J]) * k[J][i], 0) : 0), ...);
            }
            o[i] = next;
            if constexpr (Norm && has_error_estimate) {
                const double scale = w.template scale<Each>(i, x[i], next);
                const double ratio = err / scale;
                sq += ratio * ratio;
                if constexpr (two_estimates) {
                    const double ratio_low = err_low / scale;
                    sq_low += ratio_low * ratio_low;
                }
                if constexpr (Track) {
                    if (!(std::abs(ratio) <= sums.worst_ratio)) {
                        sums.worst_ratio = std::abs(ratio);
                        sums.worst = i;
                    }
                }
            }
        }
        sums.bad = bad;
        sums.sq = sq;
        sums.sq_low = sq_low;
    }

    std::vector<std::array<double, 2>> cond_err_;  // per cond_ entry: what taking it conventional adds to the sums
    std::array<S, s> k_{};
    std::array<S, E> k_extra_{}, y_extra_{};  // the continuous extension's extra stages (after prepare_dense)
    S stage_{}, result_{}, first_point_{}, res_{}, res_new_{}, last_x_{};
    bool have_first_ = false;      // k_[0] holds the derivative for the current state's first stage
    bool pending_first_ = false;   // ... but it waits in k_[s - 1] (evaluated for the dense output)
    bool first_is_x_ = true;       // the first derivative was taken at x itself (else at first_point_)
    bool p0_is_x0_ = true;         // the same, for the start of the accepted step (dense output)
    bool dense_ready_ = false;
    bool extras_ready_ = false;    // the extra stages of the accepted step are evaluated
    bool residual_valid_ = false;
    bool stepped_ = false;
    double last_dt_ = 0.0;
};

/// Bogacki-Shampine 3(2), conventional.
template <state S> using bs32 = embedded_rk<tableaus::bogacki_shampine_32, S, update_rule::conventional>;
/// Bogacki-Shampine 3(2), conservative.
template <state S> using c_bs32 = embedded_rk<tableaus::bogacki_shampine_32, S, update_rule::conservative>;
/// Cash-Karp 5(4), conventional.
template <state S> using ck54 = embedded_rk<tableaus::cash_karp_54, S, update_rule::conventional>;
/// Cash-Karp 5(4), conservative.
template <state S> using c_ck54 = embedded_rk<tableaus::cash_karp_54, S, update_rule::conservative>;
/// Dormand-Prince 5(4), conventional.
template <state S> using dp54 = embedded_rk<tableaus::dormand_prince_54, S, update_rule::conventional>;
/// Dormand-Prince 5(4), conservative.
template <state S> using c_dp54 = embedded_rk<tableaus::dormand_prince_54, S, update_rule::conservative>;
/// Dormand-Prince 8(5,3), conventional (SciPy's DOP853).
template <state S> using dp853 = embedded_rk<tableaus::dormand_prince_853, S, update_rule::conventional>;
/// Dormand-Prince 8(5,3), conservative.
template <state S> using c_dp853 = embedded_rk<tableaus::dormand_prince_853, S, update_rule::conservative>;
/// Fehlberg 7(8) (propagating order 8), conventional.
template <state S> using f78 = embedded_rk<tableaus::fehlberg_78, S, update_rule::conventional>;
/// Fehlberg 7(8) (propagating order 8), conservative.
template <state S> using c_f78 = embedded_rk<tableaus::fehlberg_78, S, update_rule::conservative>;
/// Conservative Dormand-Prince 5(4) with compensated xi.
template <state S>
using c_dp54_compensated = embedded_rk<tableaus::dormand_prince_54, S, update_rule::conservative, xi_carry::compensated>;
/// Conservative classical Runge-Kutta with compensated xi (fixed steps; no error estimate).
template <state S>
using c_rk4_compensated = embedded_rk<tableaus::rk4, S, update_rule::conservative, xi_carry::compensated>;

}  // namespace eci
