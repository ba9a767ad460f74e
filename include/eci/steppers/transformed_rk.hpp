// Conservative Runge-Kutta through an invariant-linearizing transform xi = T(x) (paper §III.D, §IV, §V):
// conventional stages in x, the tableau's weights applied to dxi/dt, and the inverse of T on the branch of a hint.
#pragma once

#include <array>
#include <cmath>
#include <concepts>
#include <cstddef>
#include <limits>
#include <type_traits>
#include <utility>

#include "../concepts.hpp"
#include "../detail/state_ops.hpp"
#include "../tableaus.hpp"
#include "conservative_rk.hpp"

namespace eci {

/// The transform of §III.D, xi_k = psi_k^2 for every real unknown: with it transformed_rk over Heun's tableau
/// is C-PC, eq. (30). conservative_rk.hpp keeps a fused loop for this case (c_pc), which is faster on n-wave
/// systems; this instance exists to show that the two are one mechanism (tests/unit/test_transformed_pc.cpp).
template <state S>
struct square_transform {
    using state_type = S;
    using xi_type = S;  ///< the square of each real unknown, in the same layout

    /// xi_k = psi_k^2.
    void to_xi(const S& x, S& xi) const {
        detail::resize_like(xi, x);
        const auto a = detail::reals(x);
        const auto o = detail::reals(xi);
        for (std::size_t i = 0; i < a.size(); ++i) o[i] = a[i] * a[i];
    }
    /// d(psi_k^2)/dt = 2 psi_k S_k.
    void xi_rate(const S& x, const S& dxdt, S& rate) const {
        detail::resize_like(rate, x);
        const auto a = detail::reals(x);
        const auto k = detail::reals(dxdt);
        const auto o = detail::reals(rate);
        for (std::size_t i = 0; i < a.size(); ++i) o[i] = 2.0 * a[i] * k[i];
    }
    /// psi_k = sgn(hint_k) sqrt(xi_k), eq. (30b); a negative xi_k is the paper's negative radicand.
    step_result from_xi(const S& xi, const S& hint, S& x, solver_stats&) const {
        detail::resize_like(x, hint);
        const auto q = detail::reals(xi);
        const auto h = detail::reals(hint);
        const auto o = detail::reals(x);
        double bad = 0.0;
        for (std::size_t i = 0; i < q.size(); ++i) {
            bad += q[i] >= 0.0 && q[i] <= std::numeric_limits<double>::max() ? 0.0 : 1.0;  // inf: overflow
            o[i] = std::copysign(std::sqrt(q[i]), h[i]);
        }
        if (bad != 0.0) return step_result::failure(detail::first_index(q.size(), [&](std::size_t i) {
            return !(q[i] >= 0.0 && q[i] <= std::numeric_limits<double>::max());
        }));
        return step_result::success();
    }
};

/// Any explicit tableau T made conservative through the transform Tr: the stages Y_i and k_i = f(Y_i) are
/// conventional, xi(t+dt) = xi + dt sum_i b_i dxi/dt(Y_i), and x(t+dt) is T's inverse on the branch of the
/// conventional update (Sign = of_update) or of the last stage value (of_last_stage; for Heun that is the
/// predictor x~, which gives the paper's C-PC, eqs. (30), (42), (49)-(54)).
/// The transform is the system's own: `model_of(f).linearizing_transform()` at every step (a parameter-free
/// transform such as square_transform, for a system without one, is default-constructed), so it cannot describe
/// another system than the one being stepped. xi is carried from step to step, so the invariants (sums of xi
/// components) change only by the rounding of the additions, never by inversion error. reset() forgets it (the
/// drivers call it when a run starts); as a guard, a state this stepper did not produce also restarts it.
template <const auto& T, invariant_transform Tr, sign_rule Sign = sign_rule::of_update>
class transformed_rk {
    static constexpr std::size_t s = T.stages;

   public:
    using state_type = typename Tr::state_type;
    using xi_type = typename Tr::xi_type;
    static constexpr int order = T.order;

    template <system<state_type> F>
    step_result step(F& f, state_type& x, double t, double dt) {
        const Tr tr = transform_of(model_of(f));
        if (!have_xi_ || !(x == last_x_)) {
            tr.to_xi(x, xi_);
            have_xi_ = true;
        }
        st_.prepare(x);
        detail::resize_like(xi_new_, xi_);
        detail::resize_like(rate_, xi_);
        detail::resize_like(rate_sum_, xi_);
        const auto acc = detail::reals(rate_sum_);
        for (double& a : acc) a = 0.0;
        // The conventional stages in x (the engine of explicit_rk.hpp), and the rate of xi at each stage.
        st_.run_stages(f, x, t, dt, [&](std::size_t i, const state_type& y, const state_type& k) {
            if (T.b[i] == 0.0) return;
            tr.xi_rate(y, k, rate_);
            const auto r = detail::reals(std::as_const(rate_));
            for (std::size_t m = 0; m < acc.size(); ++m) acc[m] += T.b[i] * r[m];
        });
        // Trapezoid (or the tableau's quadrature) in xi: eq. (42c,d), eqs. (51)-(52).
        const auto xo = detail::reals(std::as_const(xi_));
        const auto xn = detail::reals(xi_new_);
        for (std::size_t m = 0; m < xn.size(); ++m) xn[m] = xo[m] + dt * acc[m];
        const state_type* hint = s > 1 ? &st_.stage : &x;  // the last stage: the predictor x~ for C-PC
        if constexpr (Sign == sign_rule::of_update) {
            detail::resize_like(update_, x);
            std::array<const double*, s> kp{};
            for (std::size_t j = 0; j < s; ++j) kp[j] = detail::reals(std::as_const(st_.k[j])).data();
            const auto xr = detail::reals(std::as_const(x));
            detail::combine_stages_for<T.b, state_type>(detail::reals(update_).data(), xr.data(), kp, dt, xr.size(),
                                                        std::make_index_sequence<s>{});
            hint = &update_;
        }
        const step_result r = tr.from_xi(std::as_const(xi_new_), *hint, x_new_, stats_);
        if (!r) return r;
        using std::swap;
        swap(x, x_new_);
        swap(xi_, xi_new_);
        last_x_ = x;
        return r;
    }

    /// Iterative inverses (Newton) run so far: count, total and maximum iterations.
    const solver_stats& solver_statistics() const { return stats_; }
    /// The carried xi, T(x) of the last state this stepper produced (or was started from).
    const xi_type& xi() const { return xi_; }
    /// Forget the carried xi: the next step recomputes it from its x.
    void reset() { have_xi_ = false; }
    /// The transform of the system `m` (a model with a linearizing transform, or any system for a parameter-free Tr).
    template <class M>
    static Tr transform_of(const M& m) {
        if constexpr (linearizable<M>) {
            static_assert(std::same_as<std::remove_cvref_t<decltype(m.linearizing_transform())>, Tr>,
                          "transformed_rk<T, Tr>: the system's linearizing_transform() is not a Tr");
            return m.linearizing_transform();
        } else {
            static_assert(std::is_empty_v<Tr>, "transformed_rk<T, Tr>: a Tr with parameters must come from the "
                                               "system's linearizing_transform()");
            return Tr{};
        }
    }

   private:
    detail::stage_storage<T, state_type> st_;
    state_type update_{}, x_new_{}, last_x_{};
    xi_type xi_{}, xi_new_{}, rate_{}, rate_sum_{};
    bool have_xi_ = false;
    solver_stats stats_{};
};

/// C-PC through a transform: Heun's tableau, inverse on the branch of the predictor x~ (paper §IV, §V).
template <invariant_transform Tr>
using transformed_pc = transformed_rk<tableaus::heun, Tr, sign_rule::of_last_stage>;
/// Conservative midpoint rule through a transform (second order).
template <invariant_transform Tr>
using transformed_rk2 = transformed_rk<tableaus::midpoint, Tr, sign_rule::of_update>;
/// Conservative classical Runge-Kutta through a transform (fourth order).
template <invariant_transform Tr>
using transformed_rk4 = transformed_rk<tableaus::rk4, Tr, sign_rule::of_update>;

}  // namespace eci
