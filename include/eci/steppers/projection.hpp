// Orthogonal projection after any stepper onto the level set of a system's invariants (Hairer, Lubich & Wanner,
// Geometric Numerical Integration, IV.4, Algorithm 4.2): simplified Newton with the invariants' gradients.
#pragma once

#include <cmath>
#include <cstddef>
#include <limits>
#include <stdexcept>
#include <utility>
#include <vector>

#include "../concepts.hpp"
#include "../detail/state_ops.hpp"
#include "../invariants.hpp"

namespace eci {

/// Any stepper Base followed by the orthogonal projection onto {y : I_k(y) = I_k(x_0)}, x_0 the state a run
/// started from (carried, so the invariants do not random-walk). With G the gradients at the unprojected y~,
/// y = y~ + G^T lambda and lambda by simplified Newton: lambda += -(G G^T)^{-1} (I(y) - I(x_0)). A projection that
/// does not converge within max_iterations, or a singular G G^T (dependent invariants), rejects the step (x
/// unchanged, counted); the driver then halves it. A failure of Base is passed on as it is.
template <class Base, state S, class Inv>
    requires invariant_set<Inv, S> || model_invariant_source<Inv>
class orthogonal_projection {
   public:
    static constexpr int order = Base::order;

    /// The projection onto the invariants `inv` after steps of `base`.
    explicit orthogonal_projection(Inv inv = {}, Base base = {}, int max_iterations = 10)
        : inv_(std::move(inv)), base_(std::move(base)), max_iterations_(max_iterations) {
        if (max_iterations_ < 0) throw std::invalid_argument("projection: max_iterations must not be negative");
    }

    template <system<S> F>
    step_result step(F& f, S& x, double t, double dt) {
        return step_with(detail::invariants_for(inv_, f), f, x, t, dt);
    }

    /// Accepted and rejected steps, and the Newton iterations of the projections.
    const invariant_stats& statistics() const { return stats_; }
    /// The Newton iterations (what the drivers collect into run_stats::solver).
    const solver_stats& solver_statistics() const { return stats_.solver; }
    /// The values projected onto (those of the state the run started from).
    const std::vector<double>& targets() const { return target_; }
    /// Forget the targets: the next step takes them from its x.
    void reset() { have_target_ = false; }
    /// The stepper before projection.
    const Base& base() const { return base_; }

   private:
    template <class I, class F>
    step_result step_with(const I& inv, F& f, S& x, double t, double dt) {
        const std::size_t m = inv.count();
        if (!have_target_ || !(x == last_x_)) {
            target_.resize(m);
            for (std::size_t k = 0; k < m; ++k) target_[k] = inv.value(x, k);
            have_target_ = true;
        }
        detail::resize_like(y_, x);
        detail::resize_like(z_, x);
        {
            const auto xr = detail::reals(std::as_const(x));
            const auto y0 = detail::reals(y_);
            for (std::size_t i = 0; i < xr.size(); ++i) y0[i] = xr[i];
        }
        const step_result r = base_.step(f, y_, t, dt);
        if (!r) return r;
        // (viewed after the step: a stepper may swap the state's buffer with one of its own, as explicit_rk does
        // for a vector state; a view taken before read the state as it was, and the projection undid the step)
        const auto yr = detail::reals(std::as_const(y_));

        // G at y~, G G^T, and each invariant's rounding scale there.
        grad_.resize(m);
        gram_.assign(m * m, 0.0);
        scale_.assign(m, 0.0);
        for (std::size_t k = 0; k < m; ++k) {
            detail::resize_like(grad_[k], x);
            scale_[k] = std::abs(target_[k]) + detail::rounding_scale(inv, std::as_const(y_), k, grad_[k]);
        }
        for (std::size_t k = 0; k < m; ++k)
            for (std::size_t j = 0; j <= k; ++j)
                gram_[k * m + j] = gram_[j * m + k] = detail::dot(std::as_const(grad_[k]), std::as_const(grad_[j]));

        constexpr double eps = std::numeric_limits<double>::epsilon();
        lambda_.assign(m, 0.0);
        const auto zr = detail::reals(z_);
        for (std::size_t i = 0; i < zr.size(); ++i) zr[i] = yr[i];
        int it = 0;
        bool converged = false;
        for (;;) {
            // Converged when every residual is at the rounding of the invariant's evaluation.
            bool small = true;
            res_.resize(m);
            for (std::size_t k = 0; k < m; ++k) {
                res_[k] = inv.value(std::as_const(z_), k) - target_[k];
                if (!(std::abs(res_[k]) <= 4.0 * eps * scale_[k])) small = false;
            }
            if (small) {
                converged = true;
                break;
            }
            if (it == max_iterations_) break;
            ++it;
            work_ = gram_;
            if (!detail::solve_small(work_, res_, m)) break;
            for (std::size_t k = 0; k < m; ++k) lambda_[k] -= res_[k];
            for (std::size_t i = 0; i < zr.size(); ++i) zr[i] = yr[i];
            for (std::size_t k = 0; k < m; ++k) {
                const auto g = detail::reals(std::as_const(grad_[k]));
                for (std::size_t i = 0; i < zr.size(); ++i) zr[i] += lambda_[k] * g[i];
            }
        }
        stats_.solver.record(it);
        if (!converged) {
            ++stats_.rejected_solver;
            return step_result::failure(0);
        }
        ++stats_.accepted;
        using std::swap;
        swap(x, z_);
        last_x_ = x;
        return step_result::success();
    }

    Inv inv_;
    Base base_;
    int max_iterations_;
    S y_{}, z_{}, last_x_{};
    std::vector<S> grad_;
    std::vector<double> target_, gram_, work_, scale_, lambda_, res_;
    bool have_target_ = false;
    invariant_stats stats_{};
};

}  // namespace eci
