// C-Euler (paper §III.A): eq. (16) mode by mode where no mode is at or near zero; where one is, an implicit
// midpoint step, which also conserves every quadratic invariant and carries the mode through zero, so the
// spurious fixed point of (16) at psi_k = 0 never traps the solution.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <ranges>
#include <utility>

#include "../concepts.hpp"
#include "../detail/state_ops.hpp"
#include "implicit_midpoint.hpp"
#include "radicand_remedy.hpp"

namespace eci {

/// Conservative Euler. Explicit steps use sigma_k = sgn(psi_k), valid when psi_k (psi_k + 2 tau S_k) > 0
/// (Euler predicts no sign change within 2 tau, the paper's chi test) and |psi_k| > tau |S_k| for every mode
/// (from Figure 1's start this cuts the error on [0, 10] threefold); otherwise the step is the implicit
/// midpoint rule, solved by fixed-point iteration to round-off. Non-convergence fails the step.
/// Isolated near-zero modes are remedied instead (radicand_remedy.hpp) when the model's invariants are known.
template <state S>
class conservative_euler : public radicand_remedy {
   public:
    static constexpr int order = 1;
    /// Bound on the fixed-point iterations of one implicit step.
    int max_iterations = 60;

    template <system<S> F>
    step_result step(F& f, S& x, double t, double dt) {
        // The explicit step uses the implicit stepper's derivative and iterate buffers: no buffer of its own.
        implicit_.prepare(x);
        f(x, implicit_.k_, t);
        const auto xr = detail::reals(std::as_const(x));
        const double* k = detail::reals(std::as_const(implicit_.k_)).data();
        double* y = detail::reals(implicit_.y_).data();
        const std::size_t n = xr.size();
        double near_zero = 0.0;
        for (std::size_t i = 0; i < n; ++i) {
            const double rad = xr[i] * (xr[i] + 2.0 * dt * k[i]);  // eq. (16): psi chi, chi = psi + 2 tau S
            // Near zero: Euler predicts a sign change within 2 tau (the paper's chi test), or the step would move
            // the mode by more than its own size, where (16)'s error in psi_k, O(tau^2 / psi_k), becomes O(tau).
            // An overflowing radicand (rad > DBL_MAX) goes to the implicit step too, which fails it if it must.
            near_zero += (rad > 0.0 && rad <= std::numeric_limits<double>::max() &&
                          std::abs(xr[i]) > dt * std::abs(k[i]))
                             ? 0.0
                             : 1.0;
            y[i] = std::copysign(std::sqrt(rad), xr[i]);
        }
        // A few near-zero modes among many take Euler's own update, and the rescale of radicand_remedy.hpp makes
        // the step exact again: no implicit solve for the whole state.
        if (near_zero == 0.0 || remedy_near_zero(y, xr.data(), k, dt, n)) {
            using std::swap;
            swap(x, implicit_.y_);
            return step_result::success();
        }
        implicit_.max_iterations = max_iterations;
        return implicit_.iterate(f, x, t, dt);  // implicit_.k_ still holds f(x)
    }

    /// Statistics of the implicit steps taken so far.
    const solver_stats& solver_statistics() const { return implicit_.solver_statistics(); }

    static constexpr std::size_t buffer_count() { return implicit_midpoint<S>::buffer_count(); }

   private:
    static constexpr std::size_t per = sizeof(std::ranges::range_value_t<S>) / sizeof(double);

    bool remedy_near_zero(double* y, const double* x, const double* k, double dt, std::size_t n) {
        auto near = [&](std::size_t i) {
            const double rad = x[i] * (x[i] + 2.0 * dt * k[i]);
            return !(rad > 0.0 && std::abs(x[i]) > dt * std::abs(k[i]));
        };
        auto fix = [&](std::size_t i) -> std::pair<double, double> {
            return {x[i] + dt * k[i], x[i] * (x[i] + 2.0 * dt * k[i])};  // Euler, eq. (7); eq. (16)'s radicand
        };
        return try_remedy<per>(y, x, n, near, fix, [&](const auto& c) { rescale<per>(y, n, c); });
    }

    implicit_midpoint<S> implicit_;
};

/// C-Euler under its registry name.
template <state S> using c_euler = conservative_euler<S>;

}  // namespace eci
