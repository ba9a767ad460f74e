// Relaxation Runge-Kutta over any explicit tableau: the update d is scaled by gamma (and, for several invariants,
// combined with further search directions from embedded weights) so that the invariants keep their values.
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <stdexcept>
#include <string>
#include <tuple>
#include <type_traits>
#include <utility>
#include <vector>

#include "../concepts.hpp"
#include "../detail/state_ops.hpp"
#include "../invariants.hpp"
#include "../tableaus.hpp"
#include "explicit_rk.hpp"

namespace eci {

/// Which time the relaxed state belongs to: t + gamma tau (relaxation RK, RRK: the tableau's order is kept) or
/// t + tau (the incremental direction technique, IDT: one order lower, no change of the time grid).
enum class relaxation_time { rrk, idt };

/// Further search directions for multiple relaxation (Biswas & Ketcheson 2023): M weight vectors over the S
/// stages of a tableau, d_j = tau sum_i w_ji k_i. Weights summing to 1 are an embedded method (a direction that
/// advances time, as the main one does); weights summing to 0 are the difference of two methods, b - bhat (a
/// correction that does not advance time).
template <std::size_t S, std::size_t M>
struct search_directions {
    std::array<std::array<double, S>, M> weights;
};

namespace detail {

/// The direction of an embedded pair T: b - bhat, O(tau^(q+1)) with q the embedded order.
template <const auto& T>
constexpr auto pair_direction() {
    constexpr std::size_t s = std::remove_cvref_t<decltype(T)>::stages;
    search_directions<s, 1> d{};
    for (std::size_t i = 0; i < s; ++i) d.weights[0][i] = T.b[i] - T.bhat[i];
    return d;
}

}  // namespace detail

namespace directions {

/// No further direction: single-invariant relaxation.
template <std::size_t S>
inline constexpr search_directions<S, 0> none{};
/// RK4's stages give the explicit midpoint rule (0, 1, 0, 0), second order: one further direction.
inline constexpr search_directions<4, 1> rk4_midpoint{{{{0.0, 1.0, 0.0, 0.0}}}};
/// Two further directions from RK4's stages: the midpoint rule and (1/6, 2/3, 0, 1/6) (second order).
inline constexpr search_directions<4, 2> rk4_two{{{{0.0, 1.0, 0.0, 0.0}, {1.0 / 6.0, 2.0 / 3.0, 0.0, 1.0 / 6.0}}}};
/// The further direction of an embedded pair T (Biswas & Ketcheson's choice), for two invariants: b - bhat.
template <const auto& T>
inline constexpr auto from_pair = detail::pair_direction<T>();

}  // namespace directions

/// Options of the relaxation stepper (ARKODE's defaults for the band).
struct relaxation_options {
    double gamma_min = 0.8;   ///< smallest acceptable gamma (the time factor for multiple relaxation)
    double gamma_max = 1.2;   ///< largest acceptable gamma
    int max_iterations = 20;  ///< Newton iterations of the root solve before the step is rejected
};

/// Relaxation Runge-Kutta on the tableau T for the invariants `Inv` of a system with state S.
/// The new state is x + sum_j gamma_j d_j with d_0 = tau sum_i b_i k_i and d_j (j >= 1) from the search directions
/// D; the gammas solve I_k(x_new) = I_k(x) for every invariant k (count() must be 1 + the number of directions).
/// The state's time advances by gamma tau with gamma = sum_j gamma_j sigma_j, sigma_j the sum of direction j's
/// weights (1 for the main direction and an embedded method's, 0 for a difference b - bhat).
/// One quadratic invariant without further directions has Ketcheson's explicit gamma,
///   gamma = 2 sum_i b_i B(Y_i - x, k_i) tau / B(d, d);
/// otherwise Newton's method solves for the gammas, starting at (1, 0, ..., 0). The targets are I(x) of the step's
/// own start, as published: aiming at the run's first values instead would need gammas far from (1, 0) on small
/// steps (the directions differ by O(tau^q)), from which the driver's step halving could never recover.
/// gamma outside [gamma_min, gamma_max], a correction along the difference directions larger than the band lets
/// the main direction move (max|sum gamma_j d_j| > max(gamma_max - 1, 1 - gamma_min) max|d_0|, a sign that the
/// solve found a far root), or a solve that does not converge, rejects the step (x unchanged, counted).
///
/// With relaxation_time::rrk the relaxed state is at time t + gamma tau, off the driver's grid. To fit the
/// fixed-step drivers, each step aims at the next grid point: a step from nominal t to t + dt starts at the true
/// time t + lag and takes tau = dt - lag, so the state lags its grid point by lag = (gamma - 1) tau = O(dt^p),
/// never accumulated. time_lag() reports it; compare with a reference at t + time_lag().
template <const auto& T, state S, class Inv, relaxation_time R = relaxation_time::rrk,
          const auto& D = directions::none<std::remove_cvref_t<decltype(T)>::stages>>
    requires invariant_set<Inv, S> || model_invariant_source<Inv>
class relaxation_rk {
    static constexpr std::size_t s = T.stages;
    static constexpr std::size_t extra = std::tuple_size_v<decltype(D.weights)>;
    static_assert(std::tuple_size_v<std::remove_cvref_t<decltype(D.weights[0])>> == s || extra == 0,
                  "search directions must have one weight per stage of the tableau");
    // The sums of the directions' weights, exactly 1 (a method) or 0 (a difference of two) up to their rounding.
    static constexpr std::array<double, 1 + extra> weight_sums = [] {
        std::array<double, 1 + extra> r{};
        for (std::size_t i = 0; i < s; ++i) r[0] += T.b[i];
        for (std::size_t j = 0; j < extra; ++j)
            for (std::size_t i = 0; i < s; ++i) r[j + 1] += D.weights[j][i];
        return r;
    }();
    static_assert([] {
        for (double v : weight_sums)
            if (!((v > 1.0 - 1e-12 && v < 1.0 + 1e-12) || (v > -1e-12 && v < 1e-12))) return false;
        return true;
    }(), "every direction's weights must sum to 1 (a method) or to 0 (a difference of two)");
    // sigma_j: how far direction j advances time (1: a method; 0: a difference of two).
    static constexpr std::array<double, 1 + extra> sigma = [] {
        std::array<double, 1 + extra> r{};
        for (std::size_t j = 0; j <= extra; ++j) r[j] = weight_sums[j] > 0.5 ? 1.0 : 0.0;
        return r;
    }();
    // The stages any direction uses: the rest (an FSAL pair's last, with b = 0) are never evaluated.
    static constexpr std::size_t used_stages = [] {
        std::size_t n = 1;
        for (std::size_t i = 0; i < s; ++i) {
            bool used = T.b[i] != 0.0;
            for (std::size_t j = 0; j < extra; ++j) used = used || D.weights[j][i] != 0.0;
            if (used) n = i + 1;
        }
        return n;
    }();
    template <class I>
    static constexpr bool explicit_gamma = quadratic_invariant_set<I, S> && extra == 0;

   public:
    /// RRK keeps the tableau's order; IDT loses one (Ranocha et al. 2020).
    static constexpr int order = R == relaxation_time::rrk ? T.order : T.order - 1;
    /// Whether the state's true time differs from its grid time (RRK; see time_lag()).
    static constexpr bool shifts_time = R == relaxation_time::rrk;
    /// Right-hand-side evaluations per attempted step.
    static constexpr std::size_t evaluations_per_step = used_stages;

    /// The stepper for the invariants `inv`; throws std::invalid_argument for a bad band or iteration limit.
    explicit relaxation_rk(Inv inv = {}, relaxation_options opt = {}) : inv_(std::move(inv)), opt_(opt) {
        if (!(opt_.gamma_min > 0.0 && opt_.gamma_min <= 1.0 && opt_.gamma_max >= 1.0) ||
            !std::isfinite(opt_.gamma_max))
            throw std::invalid_argument("relaxation: the gamma band must satisfy 0 < gamma_min <= 1 <= gamma_max");
        if (opt_.max_iterations < 1) throw std::invalid_argument("relaxation: max_iterations must be at least 1");
    }

    template <system<S> F>
    step_result step(F& f, S& x, double t, double dt) {
        return step_with(detail::invariants_for(inv_, f), f, x, t, dt);
    }

    /// The true time of the last state produced minus its grid time (0 for IDT or before the first step).
    double time_lag() const { return R == relaxation_time::rrk && have_last_ ? lag_ : 0.0; }
    /// The last accepted gamma: the time factor sum_j gamma_j sigma_j (gamma_0 for one invariant).
    double gamma() const { return last_gamma_; }
    /// Accepted and rejected steps, and the Newton iterations.
    const invariant_stats& statistics() const { return stats_; }
    /// The Newton iterations (what the drivers collect into run_stats::solver).
    const solver_stats& solver_statistics() const { return stats_.solver; }
    /// The invariants kept (the source tag when they are the model's).
    const Inv& invariants() const { return inv_; }
    /// Forget the time lag: the next step starts on its grid time.
    void reset() { have_last_ = false; }

   private:
    template <class I, class F>
    step_result step_with(const I& inv, F& f, S& x, double t, double dt) {
        constexpr double eps = std::numeric_limits<double>::epsilon();
        const std::size_t m = inv.count();
        if (m != 1 + extra)
            throw std::invalid_argument("relaxation: " + std::to_string(m) + " invariants need " +
                                        std::to_string(m - 1) + " further search directions, the stepper has " +
                                        std::to_string(extra));
        const bool same_run = have_last_ && x == last_x_;
        // The drivers compute grid times as t0 + i dt, which may differ from the last t + dt by a rounding.
        const bool continuing = same_run && std::abs(t - expected_t_) <= 4.0 * eps * (std::abs(t) + dt);

        const double lag = R == relaxation_time::rrk && continuing ? lag_ : 0.0;
        // Aim at the grid point t + dt; should the lag be a large part of dt (a shortened last step), take dt.
        const bool aim = dt - lag > 0.5 * dt;
        const double tau = aim ? dt - lag : dt;
        const double ta = t + lag;

        st_.prepare(x);
        for (auto& d : d_) detail::resize_like(d, x);
        detail::resize_like(w_, x);
        detail::resize_like(g_, x);
        if constexpr (explicit_gamma<I>) detail::resize_like(diff_, x);
        // sum_i b_i B(Y_i - x, k_i) times p, with tau = p m (detail::split_step): of the size of B(d, d), where the
        // unscaled sum, |d| |S| with a quadratic S, over- or underflows within the cube root of the range; the same
        // bits as the unscaled form wherever that is representable (each term is p times it exactly)
        double production = 0.0;
        [[maybe_unused]] const detail::step_split sp = detail::split_step(tau);
        st_.template run_stages<used_stages>(f, x, ta, tau, [&](std::size_t i, const S& y, const S& k) {
            if constexpr (explicit_gamma<I>) {
                if (T.b[i] == 0.0 || i == 0) return;  // Y_0 = x
                const auto yr = detail::reals(y), xr = detail::reals(x);
                const auto dr = detail::reals(diff_);
                for (std::size_t j = 0; j < dr.size(); ++j) dr[j] = (yr[j] - xr[j]) * sp.p;
                production += T.b[i] * inv.inner(std::as_const(diff_), k, 0);
            } else {
                (void)i, (void)y, (void)k;
            }
        });
        form_direction(d_[0], T.b, tau);
        for (std::size_t j = 0; j < extra; ++j) form_direction(d_[j + 1], D.weights[j], tau);

        std::array<double, 1 + extra> gamma{};
        gamma[0] = 1.0;
        if constexpr (explicit_gamma<I>) {
            const double dd = inv.inner(std::as_const(d_[0]), std::as_const(d_[0]), 0);
            gamma[0] = dd != 0.0 ? 2.0 * sp.m * production / dd : 1.0;  // d = 0: nothing moves, any gamma will do
        } else if (!solve_gammas(inv, x, gamma)) {
            ++stats_.rejected_solver;
            return step_result::failure(0);
        }
        double total = 0.0;  // the time factor: tau becomes total * tau
        for (std::size_t j = 0; j <= extra; ++j) total += gamma[j] * sigma[j];
        if (!(total >= opt_.gamma_min && total <= opt_.gamma_max) || !correction_within_band(gamma)) {
            ++stats_.rejected_band;
            return step_result::failure(0);
        }
        combine(x, gamma, w_);
        using std::swap;
        swap(x, w_);
        ++stats_.accepted;
        last_gamma_ = total;
        if constexpr (R == relaxation_time::rrk)
            lag_ = aim ? (total - 1.0) * tau : lag + (total - 1.0) * dt;  // (t + lag + total tau) - (t + dt)
        have_last_ = true;
        expected_t_ = t + dt;
        last_x_ = x;
        return step_result::success();
    }

    // d = tau sum_i w_i k_i.
    template <class W>
    void form_direction(S& d, const W& w, double tau) {
        const auto o = detail::reals(d);
        for (double& v : o) v = 0.0;
        for (std::size_t i = 0; i < s; ++i) {
            if (w[i] == 0.0) continue;
            const auto k = detail::reals(std::as_const(st_.k[i]));
            const double c = tau * w[i];
            for (std::size_t j = 0; j < o.size(); ++j) o[j] += c * k[j];
        }
    }

    // The correction along the difference directions, sum_j gamma_j d_j over sigma_j = 0, moves the state no
    // further than the band lets the main direction move: max|correction| <= max(gamma_max - 1, 1 - gamma_min)
    // max|d_0|. On a regular step it is O(tau^(p+1)), far inside.
    bool correction_within_band(const std::array<double, 1 + extra>& gamma) const {
        if constexpr (extra == 0) {
            return true;
        } else {
            bool any = false;
            for (std::size_t j = 1; j <= extra; ++j) any = any || sigma[j] == 0.0;
            if (!any) return true;
            const auto d0 = detail::reals(std::as_const(d_[0]));
            double main = 0.0, corr = 0.0;
            for (std::size_t i = 0; i < d0.size(); ++i) {
                double c = 0.0;
                for (std::size_t j = 1; j <= extra; ++j)
                    if (sigma[j] == 0.0) c += gamma[j] * detail::reals(std::as_const(d_[j]))[i];
                main = std::max(main, std::abs(d0[i]));
                corr = std::max(corr, std::abs(c));
            }
            return corr <= std::max(opt_.gamma_max - 1.0, 1.0 - opt_.gamma_min) * main;
        }
    }

    // out = x + sum_j gamma_j d_j.
    void combine(const S& x, const std::array<double, 1 + extra>& gamma, S& out) const {
        const auto xr = detail::reals(x);
        const auto o = detail::reals(out);
        for (std::size_t i = 0; i < o.size(); ++i) o[i] = xr[i];
        for (std::size_t j = 0; j <= extra; ++j) {
            const auto d = detail::reals(std::as_const(d_[j]));
            for (std::size_t i = 0; i < o.size(); ++i) o[i] += gamma[j] * d[i];
        }
    }

    // Newton on I_k(x + sum_j gamma_j d_j) - I_k(x) = 0, Jacobian J_kj = grad I_k . d_j at the current point.
    // Converged when every residual is at the rounding of the invariant's evaluation (4 eps times its scale),
    // or when the Newton step is at the rounding of gamma; the gammas then hold to what double can resolve.
    template <class I>
    bool solve_gammas(const I& inv, const S& x, std::array<double, 1 + extra>& gamma) {
        constexpr std::size_t m = 1 + extra;
        constexpr double eps = std::numeric_limits<double>::epsilon();
        std::array<double, m> scale{};
        std::array<double, m> target{};
        for (std::size_t k = 0; k < m; ++k) target[k] = inv.value(x, k);
        for (std::size_t k = 0; k < m; ++k) scale[k] = std::abs(target[k]) + detail::rounding_scale(inv, x, k, g_);
        jac_.assign(m * m, 0.0);
        res_.assign(m, 0.0);
        int it = 0;
        bool converged = false, polishing = false, at_rounding = false;
        std::array<double, m> within = gamma;  // the last gammas whose residuals were within tolerance
        for (;;) {
            combine(x, gamma, w_);
            bool small = true;
            for (std::size_t k = 0; k < m; ++k) {
                res_[k] = inv.value(std::as_const(w_), k) - target[k];
                if (!(std::abs(res_[k]) <= 4.0 * eps * scale[k])) small = false;
            }
            if (small) {
                // Within tolerance, one more Newton step (quadratic convergence) brings the residual down to the
                // evaluation's own rounding, so the per-step errors random-walk at about eps rather than 4 eps.
                if (polishing || it == opt_.max_iterations) {
                    converged = true;
                    break;
                }
                within = gamma;
                polishing = true;
            } else if (polishing) {
                // The polish made things worse (an ill-conditioned Jacobian, as where the directions nearly
                // coincide on small steps): keep the gammas that were within tolerance.
                gamma = within;
                combine(x, gamma, w_);
                converged = true;
                break;
            } else if (at_rounding) {
                converged = true;  // Newton has stopped moving: the residual is what double resolves here
                break;
            } else if (it == opt_.max_iterations) {
                break;
            }
            ++it;
            for (std::size_t k = 0; k < m; ++k) {
                inv.gradient(std::as_const(w_), k, g_);
                for (std::size_t j = 0; j < m; ++j) jac_[k * m + j] = detail::dot(std::as_const(g_), d_[j]);
            }
            if (!detail::solve_small(jac_, res_, m)) {
                converged = polishing;  // a singular Jacobian at a point already within tolerance is no failure
                break;
            }
            double step = 0.0, size = 0.0;
            for (std::size_t j = 0; j < m; ++j) {
                gamma[j] -= res_[j];
                step = std::max(step, std::abs(res_[j]));
                size = std::max(size, std::abs(gamma[j]));
            }
            if (!std::isfinite(size)) {
                if (polishing) continue;  // restored above
                break;
            }
            at_rounding = step <= 4.0 * eps * std::max(1.0, size);
        }
        stats_.solver.record(it);
        return converged;
    }

    Inv inv_;
    relaxation_options opt_;
    detail::stage_storage<T, S> st_;
    std::array<S, 1 + extra> d_{};
    S w_{}, g_{}, diff_{}, last_x_{};
    std::vector<double> jac_, res_;
    double lag_ = 0.0, expected_t_ = 0.0, last_gamma_ = 1.0;
    bool have_last_ = false;
    invariant_stats stats_{};
};

/// Relaxation RK4 (RRK: time advanced by gamma tau) for the invariants Inv.
template <state S, class Inv>
using rrk4 = relaxation_rk<tableaus::rk4, S, Inv, relaxation_time::rrk>;
/// RK4 with the incremental direction technique (time advanced by tau; third order).
template <state S, class Inv>
using idt_rk4 = relaxation_rk<tableaus::rk4, S, Inv, relaxation_time::idt>;
/// Multiple relaxation RK4 for two invariants (further direction: the midpoint rule in RK4's stages).
template <state S, class Inv>
using mrrk4_2 = relaxation_rk<tableaus::rk4, S, Inv, relaxation_time::rrk, directions::rk4_midpoint>;
/// Multiple relaxation RK4 for three invariants.
template <state S, class Inv>
using mrrk4_3 = relaxation_rk<tableaus::rk4, S, Inv, relaxation_time::rrk, directions::rk4_two>;

/// Multiple relaxation on the embedded pair T for two invariants (Biswas & Ketcheson): directions b and b - bhat.
template <const auto& T, state S, class Inv>
using mrrk_pair = relaxation_rk<T, S, Inv, relaxation_time::rrk, directions::from_pair<T>>;
/// Relaxation on Dormand-Prince 5(4)'s fifth-order weights (one invariant; six evaluations, the FSAL stage unused).
template <state S, class Inv>
using rrk_dp54 = relaxation_rk<tableaus::dormand_prince_54, S, Inv, relaxation_time::rrk>;
/// Relaxation on Bogacki-Shampine 3(2)'s third-order weights (one invariant; three evaluations).
template <state S, class Inv>
using rrk_bs32 = relaxation_rk<tableaus::bogacki_shampine_32, S, Inv, relaxation_time::rrk>;
/// Multiple relaxation on Dormand-Prince 5(4) for two invariants (directions b and b - bhat; seven evaluations).
template <state S, class Inv>
using mrrk_dp54 = mrrk_pair<tableaus::dormand_prince_54, S, Inv>;
/// Multiple relaxation on Bogacki-Shampine 3(2) for two invariants (directions b and b - bhat; four evaluations).
template <state S, class Inv>
using mrrk_bs32 = mrrk_pair<tableaus::bogacki_shampine_32, S, Inv>;

}  // namespace eci
