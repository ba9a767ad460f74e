// The implicit midpoint rule y = x + tau f((x + y)/2, t + tau/2), solved by fixed-point iteration to round-off:
// like the conservative methods it conserves every quadratic invariant, at the price of an implicit solve per step.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <utility>

#include "../concepts.hpp"
#include "../detail/state_ops.hpp"

namespace eci {

template <state S>
class conservative_euler;

/// The implicit midpoint rule (second order, symplectic). Each step iterates y <- x + tau f((x + y)/2) from
/// the explicit Euler guess until the update is at round-off; a solve that does not converge fails the step.
template <state S>
class implicit_midpoint {
   public:
    static constexpr int order = 2;
    /// Bound on the fixed-point iterations of one step.
    int max_iterations = 100;

    template <system<S> F>
    step_result step(F& f, S& x, double t, double dt) {
        prepare(x);
        f(x, k_, t);
        return iterate(f, x, t, dt);
    }

    /// Statistics of the implicit solves so far: iterations (= right-hand-side evaluations beyond the first) per step.
    const solver_stats& solver_statistics() const { return solver_; }

    /// How many state-sized buffers this stepper holds (derivative, iterate, midpoint).
    static constexpr std::size_t buffer_count() { return 3; }

   private:
    friend class conservative_euler<S>;  // C-Euler's fallback near zero; it shares these buffers

    void prepare(const S& x) {
        detail::resize_like(k_, x);
        detail::resize_like(y_, x);
        detail::resize_like(mid_, x);
    }

    // The solve, with k_ = f(x, t) on entry.
    template <class F>
    step_result iterate(F& f, S& x, double t, double dt) {
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
            // NaN or infinity: no point iterating, and an infinite scale would pass any test below.
            if (!std::isfinite(change) || !std::isfinite(scale)) break;
            // Converged when the update is at round-off, or has stopped shrinking once close to it (the last
            // bits of a contraction can cycle instead of settling).
            const bool at_roundoff = change <= 2.0 * eps * scale;
            const bool stalled = change >= previous && change <= 1e3 * eps * scale;
            if (at_roundoff || stalled) {
                solver_.record(it);
                using std::swap;
                swap(x, y_);
                return step_result::success();
            }
            previous = change;
        }
        solver_.record(max_iterations);
        return step_result::failure(worst);
    }

    S k_{}, y_{}, mid_{};
    solver_stats solver_{};
};

}  // namespace eci
