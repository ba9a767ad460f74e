// Adaptive conservative Runge-Kutta through an invariant-linearizing transform xi = T(x) (Lotka-Volterra, Kepler):
// conventional stages in x, xi advanced by b and by bhat, both inverted; their difference is the error estimate;
// conservative dense output by interpolating xi and inverting at each output point.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <utility>

#include "../concepts.hpp"
#include "../detail/state_ops.hpp"
#include "../tableaus.hpp"
#include "embedded_rk.hpp"
#include "transformed_rk.hpp"

namespace eci {

/// The embedded pair T made conservative through the transform Tr (see transformed_rk for the fixed-step
/// version): xi(t+dt) = xi + dt sum_i b_i dxi/dt(Y_i), carried from step to step, and x = T^-1(xi) on the branch
/// of the conventional update. The error estimate is x - xhat, xhat = T^-1(xi + dt sum_i bhat_i dxi/dt(Y_i)) on
/// the branch of the conventional embedded update: the two solutions' difference in the state's own units.
/// A non-invertible xi (or xihat) rejects the step, like a negative radicand. FSAL as in embedded_rk: the carried
/// derivative is paired, in the rate of xi, with the conventional point it was taken at.
/// The transform comes from the model behind the f passed to attempt (model_of(f).linearizing_transform()).
/// Protocol as embedded_rk (attempt / accept / reset / step / prepare_dense / interpolate).
template <const auto& T, invariant_transform Tr>
class transformed_embedded_rk {
    using tableau_type = std::remove_cvref_t<decltype(T)>;
    static constexpr std::size_t s = tableau_type::stages;
    static constexpr bool fsal = is_fsal(T);
    static constexpr bool two_estimates = detail::with_second_estimate<tableau_type>;
    // terms of the continuous extension beyond the cubic, and the stages it evaluates after the step
    static constexpr std::size_t R =
        detail::with_continuous_extension<tableau_type> && fsal ? detail::dense_terms_of<tableau_type>() : 0;
    static constexpr std::size_t E = R > 0 ? detail::extra_stages_of<tableau_type>() : 0;
    using S = typename Tr::state_type;
    using X = typename Tr::xi_type;

   public:
    using state_type = S;
    static constexpr int order = T.order;
    static constexpr bool has_error_estimate = true;
    /// The estimate's order (two embedded solutions combined, DP853: 2 embedded_order - low_order).
    static constexpr int embedded_order = detail::estimate_order(T);
    static constexpr bool is_conservative = true;
    static constexpr bool first_same_as_last = fsal;
    /// Whether the dense output is the pair's own continuous extension (else a cubic Hermite interpolant).
    static constexpr bool has_continuous_extension = R > 0;
    /// The degree of the interpolant of xi in the step fraction (3 + the extension's terms, or 3: cubic Hermite).
    static constexpr int dense_degree = 3 + int(R);
    /// Whether the dense output is as accurate as the steps (as embedded_rk: a continuous extension, or order <= 3).
    static constexpr bool dense_matches_steps = has_continuous_extension || T.order <= 3;

    template <system<S> F>
    attempt_result attempt(F& f, const S& x, double t, double dt, const error_weights* w = nullptr,
                           bool track_worst = false) {
        // The transform is the system's own, taken from the model behind f at every attempt (as transformed_rk).
        tr_ = transformed_rk<T, Tr>::transform_of(model_of(f));
        const Tr& tr = tr_;
        for (auto& ki : k_) detail::resize_like(ki, x);
        for (S* b : {&stage_, &conv_, &conv_hat_, &x_new_, &x_hat_, &first_point_, &k_end_}) detail::resize_like(*b, x);
        if constexpr (two_estimates)
            for (S* b : {&conv_low_, &x_low_}) detail::resize_like(*b, x);
        if (!have_xi_) {
            tr.to_xi(x, xi_);
            have_xi_ = true;
        }
        if (pending_first_) {  // f at this x, evaluated by prepare_dense for the step before
            using std::swap;
            swap(k_[0], k_end_);
            first_point_ = x;
            have_first_ = true;
        }
        pending_first_ = false;
        if (!have_first_) {
            f(x, k_[0], t);
            first_point_ = x;
            have_first_ = true;
        }
        dense_ready_ = false;
        extras_ready_ = false;
        for (X* b : {&acc_, &acc_hat_, &xi_new_, &xi_hat_, &rate_end_}) detail::resize_like(*b, xi_);
        if constexpr (two_estimates)
            for (X* b : {&acc_low_, &xi_low_}) detail::resize_like(*b, xi_);
        for (X& b : rates_) detail::resize_like(b, xi_);
        auto acc = detail::reals(acc_), acc_hat = detail::reals(acc_hat_), acc_low = detail::reals(acc_low_);
        std::fill(acc.begin(), acc.end(), 0.0);
        std::fill(acc_hat.begin(), acc_hat.end(), 0.0);
        std::fill(acc_low.begin(), acc_low.end(), 0.0);
        auto add_rate = [&](std::size_t i, const S& y, const S& k) {
            tr.xi_rate(y, k, rates_[i]);  // every stage's rate is kept for the dense output
            const auto r = detail::reals(std::as_const(rates_[i]));
            if (T.b[i] != 0.0 || T.bhat[i] != 0.0)
                for (std::size_t m = 0; m < acc.size(); ++m) acc[m] += T.b[i] * r[m], acc_hat[m] += T.bhat[i] * r[m];
            if constexpr (two_estimates)
                if (T.bhat_low[i] != 0.0)
                    for (std::size_t m = 0; m < acc_low.size(); ++m) acc_low[m] += T.bhat_low[i] * r[m];
        };
        add_rate(0, first_point_, k_[0]);
        const auto xr = detail::reals(x);
        [&]<std::size_t... I>(std::index_sequence<0, I...>) {
            ((combine<row<I>>(stage_, x, dt, std::make_index_sequence<I>{}), f(std::as_const(stage_), k_[I], t + T.c[I] * dt),
              add_rate(I, stage_, k_[I])),
             ...);
        }(std::make_index_sequence<s>{});
        // eq. (42c,d), (51)-(52) generalised: the tableau's quadrature of dxi/dt, with b and with bhat
        const auto xo = detail::reals(std::as_const(xi_));
        const auto xn = detail::reals(xi_new_), xh = detail::reals(xi_hat_);
        for (std::size_t m = 0; m < xn.size(); ++m) xn[m] = xo[m] + dt * acc[m], xh[m] = xo[m] + dt * acc_hat[m];
        combine<T.b>(conv_, x, dt, std::make_index_sequence<s>{});
        combine<T.bhat>(conv_hat_, x, dt, std::make_index_sequence<s>{});
        attempt_result res;
        const step_result r = tr.from_xi(std::as_const(xi_new_), std::as_const(conv_), x_new_, stats_);
        if (!r) return {false, r.component, 0.0};
        last_dt_ = dt;
        if (w == nullptr) return res;
        const step_result rh = tr.from_xi(std::as_const(xi_hat_), std::as_const(conv_hat_), x_hat_, stats_);
        if (!rh) return {true, rh.component, std::numeric_limits<double>::infinity()};
        const double* c = nullptr;  // the second embedded solution (two_estimates)
        if constexpr (two_estimates) {
            const auto xl = detail::reals(xi_low_);
            for (std::size_t m = 0; m < xl.size(); ++m) xl[m] = xo[m] + dt * acc_low[m];
            combine<T.bhat_low>(conv_low_, x, dt, std::make_index_sequence<s>{});
            const step_result rl = tr.from_xi(std::as_const(xi_low_), std::as_const(conv_low_), x_low_, stats_);
            if (!rl) return {true, rl.component, std::numeric_limits<double>::infinity()};
            c = detail::reals(std::as_const(x_low_)).data();
        }
        const auto a = detail::reals(std::as_const(x_new_)), b = detail::reals(std::as_const(x_hat_));
        double sq = 0.0, sq_low = 0.0, worst = -1.0;
        for (std::size_t i = 0; i < a.size(); ++i) {
            const double rt = w->rtol_each ? w->rtol_each[i] : w->rtol;
            const double at = w->atol_each ? w->atol_each[i] : w->atol;
            const double scale = at + rt * std::max(std::abs(xr[i]), std::abs(a[i]));
            const double ratio = (a[i] - b[i]) / scale;
            sq += ratio * ratio;
            if (c) {
                const double ratio_low = (a[i] - c[i]) / scale;
                sq_low += ratio_low * ratio_low;
            }
            if (track_worst && !(std::abs(ratio) <= worst)) worst = std::abs(ratio), res.component = i;
        }
        if constexpr (two_estimates) {  // as embedded_rk: |err|^2 / sqrt(|err|^2 + mix |err_low|^2), RMS norms
            const double den = sq + T.low_mix * sq_low;
            res.error = den > 0.0 ? sq / std::sqrt(double(a.size()) * den) : 0.0;
        } else {
            res.error = std::sqrt(sq / double(a.size()));
        }
        last_dt_ = dt;
        return res;
    }

    /// Make the candidate of the last successful attempt the state x.
    void accept(S& x) {
        using std::swap;
        swap(x, x_new_);    // x_new_ now holds the step's start, for the dense output
        swap(xi_, xi_new_);  // and xi_new_ the start's xi
        p1_ = stage_;        // the conventional update (FSAL: where k_{s-1} was taken)
        if constexpr (fsal) {
            swap(k_[0], k_[s - 1]);
            first_point_ = stage_;  // the conventional update, where k_[0] was taken
            rate_end_ = rates_[s - 1];
            dense_ready_ = true;
        } else {
            have_first_ = false;
            dense_ready_ = false;
        }
    }

    /// Make the dense output of the accepted step available (x the new state, t its time): a non-FSAL pair needs
    /// f at x, evaluated once here and kept as the next attempt's first stage.
    /// A continuous extension with extra stages (DP853) evaluates them here, with their rates of xi.
    template <system<S> F>
    void prepare_dense(F& f, const S& x, double t) {
        if (!dense_ready_) {
            f(x, k_end_, t);
            tr_.xi_rate(x, k_end_, rate_end_);
            p1_ = x;
            pending_first_ = true;
            dense_ready_ = true;
        }
        if constexpr (E > 0) {
            if (!extras_ready_) run_extra_stages(f, t);
            extras_ready_ = true;
        }
    }

    /// The dense output at t0 + theta dt of the accepted step (x the current state; call prepare_dense first).
    /// xi is interpolated with the rates of xi at the stages (the pair's continuous extension, DP54's, or DP853's
    /// with its extra stages; else the cubic Hermite interpolant with the end rates), then inverted on the branch
    /// of the same interpolant applied to x with the stage derivatives. Each interpolated xi is xi0 + c (xi1 - xi0)
    /// + dt sum_i beta_i rate_i: xi0 and xi1 have equal invariants and every rate keeps them (they are linear in
    /// xi), so each point keeps the invariants of the step's ends up to rounding. A non-invertible interpolated xi fails (the driver lands a step instead).
    step_result interpolate(const S& x, double theta, S& out) const {
        detail::resize_like(out, x);
        detail::resize_like(xi_dense_, xi_);
        detail::resize_like(hint_, x);
        const double h = last_dt_;
        auto interpolant = [&](double y0, double y1, double f0, double f1, const std::array<double, R>& fd) {
            return detail::dense_value<R>(theta, h, y0, y1, f0, f1, fd);
        };
        const std::array<const double*, s> k = stage_derivatives();
        const double* k_end = fsal ? k[s - 1] : detail::reals(std::as_const(k_end_)).data();
        {  // the branch hint: the conventional interpolant of x, from the start to the conventional update
            const double* x0 = detail::reals(std::as_const(x_new_)).data();
            const double* x1 = detail::reals(std::as_const(p1_)).data();
            double* o = detail::reals(hint_).data();
            for (std::size_t i = 0; i < detail::reals(std::as_const(hint_)).size(); ++i) {
                std::array<double, R> kd{};
                if constexpr (R > 0)
                    for (std::size_t r = 0; r < R; ++r) {
                        for (std::size_t j = 0; j < s; ++j) kd[r] += T.d[r][j] * k[j][i];
                        if constexpr (E > 0)
                            for (std::size_t e = 0; e < E; ++e)
                                kd[r] += T.d[r][s + e] * detail::reals(std::as_const(k_extra_[e]))[i];
                    }
                o[i] = interpolant(x0[i], x1[i], k[0][i], k_end[i], kd);
            }
        }
        {  // xi
            const auto xi0 = detail::reals(std::as_const(xi_new_)), xi1 = detail::reals(std::as_const(xi_));
            const double* r0 = detail::reals(std::as_const(rates_[0])).data();
            const double* r1 = detail::reals(std::as_const(rate_end_)).data();
            double* o = detail::reals(xi_dense_).data();
            for (std::size_t m = 0; m < xi0.size(); ++m) {
                std::array<double, R> rd{};
                if constexpr (R > 0)
                    for (std::size_t r = 0; r < R; ++r) {
                        for (std::size_t j = 0; j < s; ++j)
                            rd[r] += T.d[r][j] * detail::reals(std::as_const(rates_[j]))[m];
                        if constexpr (E > 0)
                            for (std::size_t e = 0; e < E; ++e)
                                rd[r] += T.d[r][s + e] * detail::reals(std::as_const(rates_extra_[e]))[m];
                    }
                o[m] = interpolant(xi0[m], xi1[m], r0[m], r1[m], rd);
            }
        }
        return tr_.from_xi(std::as_const(xi_dense_), std::as_const(hint_), out, stats_);
    }

    /// The state at the start of the accepted step (valid from accept() to the next attempt).
    const S& step_start() const { return x_new_; }
    /// The size of the last attempted step.
    double last_step_size() const { return last_dt_; }

    /// Forget the carried xi and derivative: the next attempt recomputes them from its x.
    void reset() { have_xi_ = have_first_ = pending_first_ = dense_ready_ = extras_ready_ = false; }

    /// The fixed-step face.
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

    /// Iterative inverses (Newton) run so far.
    const solver_stats& solver_statistics() const { return stats_; }
    /// The carried xi.
    const X& xi() const { return xi_; }

   private:
    // The stage derivatives of the accepted step in stage order (an FSAL accept rotated k_0 and k_{s-1}).
    std::array<const double*, s> stage_derivatives() const {
        std::array<const double*, s> k{};
        for (std::size_t j = 0; j < s; ++j) k[j] = detail::reals(std::as_const(k_[j])).data();
        if constexpr (fsal) std::swap(k[0], k[s - 1]);
        return k;
    }

    // The continuous extension's extra stages of the accepted step (from its start x_new_ over last_dt_, ending
    // at t_end): derivatives k_extra_ and rates of xi rates_extra_, each stage from the stages before it.
    template <class F>
    void run_extra_stages(F& f, double t_end) {
        const double h = last_dt_, t0 = t_end - h;
        const std::array<const double*, s> k = stage_derivatives();
        const auto x0 = detail::reals(std::as_const(x_new_));
        for (std::size_t e = 0; e < E; ++e) {
            detail::resize_like(stage_, x_new_);
            detail::resize_like(k_extra_[e], x_new_);
            double* y = detail::reals(stage_).data();
            std::copy(x0.begin(), x0.end(), y);
            for (std::size_t j = 0; j < s + e; ++j) {
                const double a = T.a_extra[e][j];
                if (a == 0.0) continue;
                const double* kj = j < s ? k[j] : detail::reals(std::as_const(k_extra_[j - s])).data();
                for (std::size_t i = 0; i < x0.size(); ++i) y[i] += (h * a) * kj[i];
            }
            f(std::as_const(stage_), k_extra_[e], t0 + T.c_extra[e] * h);
            tr_.xi_rate(stage_, k_extra_[e], rates_extra_[e]);
        }
    }

    template <std::size_t I>
    static constexpr std::array<double, I> row = [] {
        std::array<double, I> r{};
        for (std::size_t j = 0; j < I; ++j) r[j] = T.a[I][j];
        return r;
    }();

    template <auto coeff, std::size_t... J>
    void combine(S& out, const S& x, double dt, std::index_sequence<J...> seq) {
        std::array<const double*, sizeof...(J)> kp{detail::reals(std::as_const(k_[J])).data()...};
        const auto xr = detail::reals(x);
        detail::combine_stages_for<coeff, S>(detail::reals(out).data(), xr.data(), kp, dt, xr.size(), seq);
    }

    std::array<S, s> k_{};
    S stage_{}, conv_{}, conv_hat_{}, x_new_{}, x_hat_{}, first_point_{}, last_x_{}, k_end_{}, p1_{};
    mutable S hint_{};
    X xi_{}, xi_new_{}, xi_hat_{}, acc_{}, acc_hat_{}, rate_end_{};
    mutable X xi_dense_{};
    std::array<X, s> rates_{};  // dxi/dt at every stage of the last attempt
    std::array<S, E> k_extra_{};   // the continuous extension's extra stages (after prepare_dense)
    std::array<X, E> rates_extra_{};
    S conv_low_{}, x_low_{};       // the second embedded solution (two_estimates)
    X acc_low_{}, xi_low_{};
    Tr tr_{};
    bool have_xi_ = false, have_first_ = false, stepped_ = false, pending_first_ = false, dense_ready_ = false;
    bool extras_ready_ = false;
    double last_dt_ = 0.0;
    mutable solver_stats stats_{};  // the dense output's inverses count too
};

/// Conservative Dormand-Prince 5(4) through a transform.
template <invariant_transform Tr>
using transformed_dp54 = transformed_embedded_rk<tableaus::dormand_prince_54, Tr>;

}  // namespace eci
