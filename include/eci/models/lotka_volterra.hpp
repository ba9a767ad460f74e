// The Lotka-Volterra system, eqs. (36)-(42): the model, its Hamiltonian (37), its Jacobian (for Kahan's method)
// the transform (39) in which H is linear, with the Newton inverse on the branch of a hint (errata item 6), its
// parameter and the paper's set-up (Fig. 7).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <stdexcept>
#include <string>
#include <string_view>

#include "../concepts.hpp"
#include "../detail/format.hpp"
#include "description.hpp"

namespace eci {

namespace detail {

/// The outcome of one Newton inverse: the root, the iterations taken, and whether it converged on its branch.
struct newton_root {
    double value = 0.0;
    int iterations = 0;
    bool ok = false;
};

/// Solve (x - 1) - log x = target for x on the branch of `hint` (x >= 1 if hint >= 1, else 0 < x <= 1) by
/// Newton's method to full double precision. A negative target (below the minimum at x = 1), a non-finite one,
/// or no convergence within max_iterations is reported as !ok, never as a wrong root.
/// The upper branch iterates on x, the lower on w = log x (where the function is e^w - 1 - w, convex and
/// decreasing): on each branch Newton then converges from any start, monotonically after its first step.
inline newton_root invert_x_minus_log(double target, double hint, int max_iterations = 60) {
    constexpr double eps = std::numeric_limits<double>::epsilon();
    if (!(target >= 0.0) || !std::isfinite(target) || !(hint == hint)) return {};
    const double quadratic = std::sqrt(2.0 * target);  // |x - 1| ~ sqrt(2 target) near x = 1
    if (quadratic <= 0.5 * eps) return {1.0, 0, true};  // the root rounds to x = 1
    if (hint >= 1.0) {
        // The root is >= 1 + target (log x >= 0). A hint much closer to 1 than the root would make Newton's
        // first step huge (the slope vanishes at x = 1): start from the quadratic estimate instead.
        double x = hint - 1.0 >= 0.5 * quadratic ? hint : 1.0 + quadratic;
        x = std::max(x, 1.0 + target);
        for (int it = 1; it <= max_iterations; ++it) {
            const double u = x - 1.0;  // exact for x in [1, 2] (Sterbenz)
            const double lg = std::log(x);
            double next = x - (u - lg - target) * x / u;  // g / g', g'(x) = (x - 1) / x
            if (!(next >= 1.0)) next = 0.5 * (x + 1.0);  // only rounding can push it off the branch
            // Attainable precision: g carries rounding eps (u + log x + target), divided by g'.
            const double tol = 4.0 * eps * x * (1.0 + (lg + target) / u);
            const bool done = std::abs(next - x) <= tol;
            x = next;
            if (!std::isfinite(x)) return {x, it, false};
            if (done) return {x, it, true};
        }
        return {x, max_iterations, false};
    }
    double w = hint > 0.0 && 1.0 - hint >= 0.5 * quadratic ? std::log(hint) : -quadratic;
    for (int it = 1; it <= max_iterations; ++it) {
        const double em = std::expm1(w);  // e^w - 1 = x - 1, accurate near w = 0
        double next = w - (em - w - target) / em;
        if (!(next < 0.0)) next = 0.5 * w;  // only rounding can push it off the branch
        const double tol = 4.0 * eps * ((std::abs(em) + std::abs(w) + target) / std::abs(em) + std::abs(w));
        const bool done = std::abs(next - w) <= tol;
        w = next;
        if (!std::isfinite(w)) return {0.0, it, false};
        if (done) {
            const double x = std::exp(w);
            return {x, it, x > 0.0 && x <= 1.0};
        }
    }
    return {std::exp(w), max_iterations, false};
}

}  // namespace detail

/// Predator-prey equations (36): dx/dt = -mu x (1 - y), dy/dt = y (1 - x), for x, y > 0.
struct lotka_volterra {
    using state_type = std::array<double, 2>;

    double mu = 1.5;  ///< the paper's mu

    static constexpr std::string_view name = "lotka-volterra";  ///< `eci run lotka-volterra`
    static constexpr std::string_view description =
        "predator-prey equations (36); invariant the Hamiltonian (37); c-pc is eq. (42)";
    static constexpr std::array<const char*, 2> component_names{"x", "y"};
    /// --plot's phase-plane panel: the predator-prey cycle.
    static constexpr phase_plane plot_plane{"x", "y", false};

    /// The parameter, with what validate() requires of it.
    static constexpr auto parameters() {
        return std::array<parameter<lotka_volterra>, 1>{
            {{"mu", "the parameter mu of eq. (36)", "", member_values<&lotka_volterra::mu, lotka_volterra>}}};
    }
    /// The initial state, one option per component (validate_state() requires both positive).
    static constexpr auto initial_condition() {
        return std::array<state_field, 2>{{{"x", "initial x", "> 0", 0, 1}, {"y", "initial y", "> 0", 1, 1}}};
    }
    /// The paper's set-up: Fig. 7, mu = 1.5 from (1, 0.4), 8e5 steps of 0.02 (`eci run lotka-volterra`'s default).
    static std::array<preset<lotka_volterra>, 1> presets() {
        return {{{"fig7", "Fig. 7: PC against C-PC, mu = 1.5 from (1, 0.4), 8e5 steps of 0.02", {1.5}, {1.0, 0.4},
                  "c-pc", 0.02, 16000.0}}};
    }

    /// Throws std::invalid_argument unless mu is positive and finite.
    void validate() const {
        detail::require_normal(mu, "Lotka-Volterra mu");
        if (!(mu > 0.0))
            throw std::invalid_argument("Lotka-Volterra mu must be positive, got " + detail::shortest_text(mu));
    }
    /// Throws std::invalid_argument unless x and y are positive and finite (H, eq. (37), needs log x, log y).
    void validate_state(const state_type& s) const {
        detail::require_finite(s[0], "Lotka-Volterra x");
        detail::require_finite(s[1], "Lotka-Volterra y");
        if (!(s[0] > 0.0))
            throw std::invalid_argument("Lotka-Volterra x must be positive, got " + detail::shortest_text(s[0]));
        if (!(s[1] > 0.0))
            throw std::invalid_argument("Lotka-Volterra y must be positive, got " + detail::shortest_text(s[1]));
        // The orbit is the level set g(x) + mu g(y) = c of H, eq. (37) (g(x) = x - 1 - log x): it reaches
        // g(x) = c where y = 1, i.e. x ~ e^-(c+1), and g(y) = c / mu where x = 1. Beyond c ~ 700 those are
        // below the smallest normal double (e^-708): the run could only stall in subnormal arithmetic.
        const double c = g(s[0]) + mu * g(s[1]);
        constexpr double limit = 700.0;
        if (!(c <= limit) || !(c / mu <= limit))
            throw std::invalid_argument(
                "the Lotka-Volterra orbit through (" + detail::shortest_text(s[0]) + ", " + detail::shortest_text(s[1]) +
                ") with mu = " + detail::shortest_text(mu) + " reaches " + (c / mu > c ? "y" : "x") + " ~ e^-" +
                detail::shortest_text(std::floor(std::max(c, c / mu) + 1.0)) +
                ", beyond double precision (e^-708); start closer to the equilibrium (1, 1)");
    }

    void operator()(const state_type& s, state_type& dsdt, double /*t*/) const {
        dsdt[0] = -mu * s[0] * (1.0 - s[1]);  // eq. (36a)
        dsdt[1] = s[1] * (1.0 - s[0]);        // eq. (36b)
    }

    /// The Jacobian of (36), for Kahan's linearly implicit method.
    std::array<std::array<double, 2>, 2> jacobian(const state_type& s) const {
        return {{{-mu * (1.0 - s[1]), mu * s[0]}, {-s[1], 1.0 - s[0]}}};
    }

    /// H, eq. (37), written as 1 + mu + g(x) + mu g(y), g(x) = (x - 1) - log x, so that no digits are lost
    /// near the equilibrium x = y = 1.
    double hamiltonian(const state_type& s) const {
        return (1.0 + mu) + (g(s[0]) + mu * g(s[1]));
    }

    /// The invariants by name, in CSV column order.
    static constexpr auto invariants() {
        return std::array<named_invariant<lotka_volterra>, 1>{{{"hamiltonian", &lotka_volterra::hamiltonian}}};
    }

    /// H as an invariant set (for relaxation and projection; not quadratic).
    struct invariant_set {
        double mu;
        std::size_t count() const { return 1; }
        double value(const state_type& s, std::size_t) const { return lotka_volterra{mu}.hamiltonian(s); }
        /// dH/dx = 1 - 1/x, dH/dy = mu (1 - 1/y).
        void gradient(const state_type& s, std::size_t, state_type& g) const {
            g = {1.0 - 1.0 / s[0], mu * (1.0 - 1.0 / s[1])};
        }
    };
    /// H.
    invariant_set invariant_functions() const { return {mu}; }

    /// The transform (39), shifted by its minimum: xi_1 = (x - 1) - log x, xi_2 = mu ((y - 1) - log y), so
    /// H = 1 + mu + xi_1 + xi_2 and both components are >= 0, with 0 at the branch point (errata item 6).
    struct transform {
        using state_type = lotka_volterra::state_type;
        using xi_type = std::array<double, 2>;
        double mu = 1.5;
        int max_iterations = 60;  ///< bound on the Newton iterations of one inverse

        void to_xi(const state_type& s, xi_type& xi) const { xi = {g(s[0]), mu * g(s[1])}; }
        /// eq. (40): dxi_1/dt = mu (x - 1)(y - 1) = -dxi_2/dt, exact negatives so that H is conserved.
        void xi_rate(const state_type& s, const state_type& /*dsdt*/, xi_type& rate) const {
            const double r = mu * (s[0] - 1.0) * (s[1] - 1.0);
            rate = {r, -r};
        }
        /// x and y by Newton on the branches of the hint (the predictor (42a,b) in C-PC); xi_1 < 0 or xi_2 < 0
        /// (the paper's xi_1 < 1, xi_2 < mu) means the step was too large.
        step_result from_xi(const xi_type& xi, const state_type& hint, state_type& s, solver_stats& stats) const {
            const detail::newton_root x = detail::invert_x_minus_log(xi[0], hint[0], max_iterations);
            if (x.iterations > 0) stats.record(x.iterations);
            if (!x.ok) return step_result::failure(0);
            const detail::newton_root y = detail::invert_x_minus_log(xi[1] / mu, hint[1], max_iterations);
            if (y.iterations > 0) stats.record(y.iterations);
            if (!y.ok) return step_result::failure(1);
            s = {x.value, y.value};
            return step_result::success();
        }
    };

    /// The y on the level curve H(x, y) = h (eq. (37)) at x, on the branch of `hint` (y >= 1 if hint >= 1, else
    /// y <= 1): by the Newton inverse of (39). Where no y reaches h (x beyond the curve's extremes) the branch
    /// point y = 1. Throws std::invalid_argument unless x > 0 and h >= H(x, 1) is finite.
    double y_on_level(double x, double h, double hint) const {
        const double level = h - 1.0 - mu;  // = xi_1 + xi_2
        const double rest = std::max(0.0, level - g(x)) / mu;  // (y - 1) - log y
        const detail::newton_root y = detail::invert_x_minus_log(rest, hint);
        if (!y.ok || !(x > 0.0)) throw std::invalid_argument("Lotka-Volterra level curve: no y for this x and H");
        return y.value;
    }
    /// The two x at which the level curve H(x, y) = h crosses y = 1: its left and right extremes.
    std::array<double, 2> x_extremes_of_level(double h) const {
        const double level = h - 1.0 - mu;  // = xi_1 + xi_2 >= 0
        const detail::newton_root lo = detail::invert_x_minus_log(level, 0.5);
        const detail::newton_root hi = detail::invert_x_minus_log(level, 2.0);
        if (!lo.ok || !hi.ok) throw std::invalid_argument("Lotka-Volterra level curve: H below its minimum 1 + mu");
        return {lo.value, hi.value};
    }

    /// The transform (39) for this model's mu.
    transform linearizing_transform() const { return {mu}; }

   private:
    // (x - 1) - log x, accurate to eps |x - 1| absolute (x - 1 is exact near 1, log x is correctly rounded).
    static double g(double x) { return (x - 1.0) - std::log(x); }
};

}  // namespace eci
