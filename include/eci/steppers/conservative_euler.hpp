// C-Euler (paper §III.A): eq. (16) mode by mode where no mode is at or near zero; where one is, an implicit
// midpoint step, which also conserves every quadratic invariant and carries the mode through zero, so the
// spurious fixed point of (16) at psi_k = 0 never traps the solution.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <utility>

#include "../concepts.hpp"
#include "../detail/state_ops.hpp"

namespace eci {

/// Conservative Euler. Explicit steps use sigma_k = sgn(psi_k), valid when psi_k (psi_k + 2 tau S_k) > 0
/// (Euler predicts no sign change within 2 tau, the paper's chi test) and |psi_k| > tau |S_k| for every mode
/// (from Figure 1's start this cuts the error on [0, 10] threefold); otherwise the step is the implicit
/// midpoint rule, solved by fixed-point iteration to round-off. Non-convergence fails the step.
template <state S>
class conservative_euler {
   public:
    static constexpr int order = 1;
    /// Bound on the fixed-point iterations of one implicit step.
    int max_iterations = 60;

    template <system<S> F>
    step_result step(F& f, S& x, double t, double dt) {
        detail::resize_like(k_, x);
        detail::resize_like(y_, x);
        f(x, k_, t);
        const auto xr = detail::reals(std::as_const(x));
        const double* k = detail::reals(std::as_const(k_)).data();
        double* y = detail::reals(y_).data();
        const std::size_t n = xr.size();
        double near_zero = 0.0;
        for (std::size_t i = 0; i < n; ++i) {
            const double rad = xr[i] * (xr[i] + 2.0 * dt * k[i]);  // eq. (16): psi chi, chi = psi + 2 tau S
            // Near zero: Euler predicts a sign change within 2 tau (the paper's chi test), or the step would move
            // the mode by more than its own size, where (16)'s error in psi_k, O(tau^2 / psi_k), becomes O(tau).
            near_zero += (rad > 0.0 && std::abs(xr[i]) > dt * std::abs(k[i])) ? 0.0 : 1.0;
            y[i] = std::copysign(std::sqrt(rad), xr[i]);
        }
        if (near_zero == 0.0) {
            using std::swap;
            swap(x, y_);
            return step_result::success();
        }
        return implicit_midpoint_step(f, x, t, dt);
    }

    /// Statistics of the implicit steps taken so far.
    const solver_stats& solver_statistics() const { return solver_; }

    static constexpr std::size_t buffer_count() { return 3; }

   private:
    // y = x + dt f((x + y)/2) by fixed-point iteration from the Euler guess; k_ holds f(x) on entry.
    template <class F>
    step_result implicit_midpoint_step(F& f, S& x, double t, double dt) {
        detail::resize_like(mid_, x);
        const auto xr = detail::reals(std::as_const(x));
        const std::size_t n = xr.size();
        double* y = detail::reals(y_).data();
        double* m = detail::reals(mid_).data();
        const double* k = detail::reals(std::as_const(k_)).data();
        for (std::size_t i = 0; i < n; ++i) y[i] = xr[i] + dt * k[i];
        constexpr double eps = std::numeric_limits<double>::epsilon();
        double previous = std::numeric_limits<double>::infinity();
        std::size_t worst = 0;  // the unknown that moved most in the last iteration: the one that failed
        for (int it = 1; it <= max_iterations; ++it) {
            for (std::size_t i = 0; i < n; ++i) m[i] = 0.5 * (xr[i] + y[i]);
            f(std::as_const(mid_), k_, t + 0.5 * dt);
            double change = 0.0, scale = 0.0;
            for (std::size_t i = 0; i < n; ++i) {
                const double next = xr[i] + dt * k[i];
                const double d = std::abs(next - y[i]);
                // Unlike std::max, this keeps a NaN, so that a non-finite iterate never passes as converged.
                if (!(d <= change) && change == change) {
                    change = d;
                    worst = i;
                }
                scale = std::max(scale, std::abs(next));
                y[i] = next;
            }
            // Converged when the update is at round-off, or has stopped shrinking once near it.
            const bool at_roundoff = change <= 2.0 * eps * scale;
            const bool stalled = change >= previous && change <= 1e3 * eps * scale;
            if (at_roundoff || stalled) {
                solver_.record(it);
                using std::swap;
                swap(x, y_);
                return step_result::success();
            }
            if (!(change == change)) break;  // NaN: no point iterating
            previous = change;
        }
        solver_.record(max_iterations);
        return step_result::failure(worst);
    }

    S k_{}, y_{}, mid_{};
    solver_stats solver_{};
};

/// C-Euler under its registry name.
template <state S> using c_euler = conservative_euler<S>;

}  // namespace eci
