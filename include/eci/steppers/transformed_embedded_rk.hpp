// Adaptive conservative Runge-Kutta through an invariant-linearizing transform xi = T(x) (Lotka-Volterra, Kepler):
// conventional stages in x, xi advanced by b and by bhat, both inverted; their difference is the error estimate.
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
/// Protocol as embedded_rk (attempt / accept / reset / step); no dense output.
template <const auto& T, invariant_transform Tr>
class transformed_embedded_rk {
    static constexpr std::size_t s = std::remove_cvref_t<decltype(T)>::stages;
    static constexpr bool fsal = is_fsal(T);
    using S = typename Tr::state_type;
    using X = typename Tr::xi_type;

   public:
    using state_type = S;
    static constexpr int order = T.order;
    static constexpr bool has_error_estimate = true;
    static constexpr int embedded_order = T.embedded_order;
    static constexpr bool is_conservative = true;
    static constexpr bool first_same_as_last = fsal;

    template <system<S> F>
    attempt_result attempt(F& f, const S& x, double t, double dt, const error_weights* w = nullptr,
                           bool track_worst = false) {
        // The transform is the system's own, taken from the model behind f at every attempt (as transformed_rk).
        const Tr tr = transformed_rk<T, Tr>::transform_of(model_of(f));
        for (auto& ki : k_) detail::resize_like(ki, x);
        for (S* b : {&stage_, &conv_, &conv_hat_, &x_new_, &x_hat_, &first_point_}) detail::resize_like(*b, x);
        if (!have_xi_) {
            tr.to_xi(x, xi_);
            have_xi_ = true;
        }
        if (!have_first_) {
            f(x, k_[0], t);
            first_point_ = x;
            have_first_ = true;
        }
        for (X* b : {&rate_, &acc_, &acc_hat_, &xi_new_, &xi_hat_}) detail::resize_like(*b, xi_);
        auto acc = detail::reals(acc_), acc_hat = detail::reals(acc_hat_);
        std::fill(acc.begin(), acc.end(), 0.0);
        std::fill(acc_hat.begin(), acc_hat.end(), 0.0);
        auto add_rate = [&](std::size_t i, const S& y, const S& k) {
            if (T.b[i] == 0.0 && T.bhat[i] == 0.0) return;
            tr.xi_rate(y, k, rate_);
            const auto r = detail::reals(std::as_const(rate_));
            for (std::size_t m = 0; m < acc.size(); ++m) acc[m] += T.b[i] * r[m], acc_hat[m] += T.bhat[i] * r[m];
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
        if (w == nullptr) return res;
        const step_result rh = tr.from_xi(std::as_const(xi_hat_), std::as_const(conv_hat_), x_hat_, stats_);
        if (!rh) return {true, rh.component, std::numeric_limits<double>::infinity()};
        const auto a = detail::reals(std::as_const(x_new_)), b = detail::reals(std::as_const(x_hat_));
        double sq = 0.0, worst = -1.0;
        for (std::size_t i = 0; i < a.size(); ++i) {
            const double rt = w->rtol_each ? w->rtol_each[i] : w->rtol;
            const double at = w->atol_each ? w->atol_each[i] : w->atol;
            const double ratio = (a[i] - b[i]) / (at + rt * std::max(std::abs(xr[i]), std::abs(a[i])));
            sq += ratio * ratio;
            if (track_worst && !(std::abs(ratio) <= worst)) worst = std::abs(ratio), res.component = i;
        }
        res.error = std::sqrt(sq / double(a.size()));
        return res;
    }

    void accept(S& x) {
        using std::swap;
        swap(x, x_new_);
        swap(xi_, xi_new_);
        if constexpr (fsal) {
            swap(k_[0], k_[s - 1]);
            first_point_ = stage_;  // the conventional update, where k_[0] was taken
        } else {
            have_first_ = false;
        }
    }

    /// Forget the carried xi and derivative: the next attempt recomputes them from its x.
    void reset() { have_xi_ = have_first_ = false; }

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
        detail::combine_stages<coeff>(detail::reals(out).data(), xr.data(), kp, dt, xr.size(), seq);
    }

    std::array<S, s> k_{};
    S stage_{}, conv_{}, conv_hat_{}, x_new_{}, x_hat_{}, first_point_{}, last_x_{};
    X xi_{}, xi_new_{}, xi_hat_{}, rate_{}, acc_{}, acc_hat_{};
    bool have_xi_ = false, have_first_ = false, stepped_ = false;
    solver_stats stats_{};
};

/// Conservative Dormand-Prince 5(4) through a transform.
template <invariant_transform Tr>
using transformed_dp54 = transformed_embedded_rk<tableaus::dormand_prince_54, Tr>;

}  // namespace eci
