// ARKODE's conserved exponential entropy problem u' = -e^v, v' = e^u: e^u + e^v is invariant (not quadratic).
// Its transform xi = (e^u, e^v), the kind a user writes for their own system, makes eci's C-RK methods apply.
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <stdexcept>

#include "../concepts.hpp"
#include "description.hpp"
#include "invariant.hpp"

namespace eci {

/// u' = -e^v, v' = e^u (SUNDIALS ARKODE's ark_conserved_exp_entropy_erk example).
struct exponential_entropy {
    using state_type = std::array<double, 2>;

    static constexpr std::string_view name = "exp-entropy";  ///< `eci run exp-entropy`
    static constexpr std::string_view description =
        "ARKODE's conserved exponential entropy u' = -e^v, v' = e^u; invariant e^u + e^v (c-* through xi = e^u, e^v)";
    static constexpr std::array<const char*, 2> component_names{"u", "v"};
    /// --plot's phase-plane panel: the level curve e^u + e^v = const.
    static constexpr phase_plane plot_plane{"u", "v", true};

    /// No parameters.
    static constexpr auto parameters() { return std::array<parameter<exponential_entropy>, 0>{}; }
    /// The initial state, set as one vector.
    static constexpr auto initial_condition() {
        return std::array<state_field, 1>{{{"uv", "initial state u,v", "", 0, 2}}};
    }
    /// ARKODE's set-up: (u, v)(0) = (1, 0.5) to t = 5; C-RK4 through the transform (default), and relaxation RK4.
    static std::array<preset<exponential_entropy>, 2> presets() {
        return {{{"standard", "(1, 0.5) to t = 5, C-RK4 through xi = (e^u, e^v), dt 0.01", {}, {1.0, 0.5}, "c-rk4",
                  0.01, 5.0},
                 {"relaxation", "the same with relaxation RK4 (root solve for gamma)", {}, {1.0, 0.5}, "rrk-rk4", 0.01,
                  5.0}}};
    }
    /// No parameters to check.
    void validate() const {}

    /// ARKODE's initial state (1, 0.5).
    static constexpr state_type initial_state() { return {1.0, 0.5}; }

    /// Throws std::invalid_argument unless the state is finite and the entropy e^u + e^v (positive: it scales both
    /// rates, e^u and e^v, for all time) neither overflows nor underflows.
    void validate_state(const state_type& s) const {
        detail::require_finite(s[0], "exponential entropy u");
        detail::require_finite(s[1], "exponential entropy v");
        detail::require_representable(entropy(s), "the entropy e^u + e^v of this initial condition");
    }

    void operator()(const state_type& s, state_type& dsdt, double /*t*/) const {
        dsdt[0] = -std::exp(s[1]);
        dsdt[1] = std::exp(s[0]);
    }

    /// The entropy e^u + e^v.
    double entropy(const state_type& s) const { return std::exp(s[0]) + std::exp(s[1]); }

    /// The invariants by name, in CSV column order.
    static constexpr auto invariants() {
        return std::array<named_invariant<exponential_entropy>, 1>{{{"entropy", &exponential_entropy::entropy}}};
    }

    /// The exact state at t from s0 at t = 0. With a = e^u and C = e^u + e^v, a' = -a (C - a) (logistic):
    /// a = C a0 / (a0 + b0 e^{C t}), so u = log C + u0 - log(a0 + b0 e^{C t}) and v = log C + v0 + C t - log(...).
    static state_type exact(const state_type& s0, double t) {
        const double a0 = std::exp(s0[0]), b0 = std::exp(s0[1]), C = a0 + b0;
        const double l = std::log(a0 + b0 * std::exp(C * t));
        return {std::log(C) + s0[0] - l, std::log(C) + s0[1] + C * t - l};
    }

    /// The entropy as an invariant set (value and gradient; not quadratic, so relaxation solves for gamma).
    struct invariant_set {
        std::size_t count() const { return 1; }
        double value(const state_type& s, std::size_t) const { return std::exp(s[0]) + std::exp(s[1]); }
        void gradient(const state_type& s, std::size_t, state_type& g) const { g = {std::exp(s[0]), std::exp(s[1])}; }
    };
    /// e^u + e^v.
    invariant_set invariant_functions() const { return {}; }

    /// xi = (e^u, e^v): the entropy is xi_1 + xi_2, and dxi/dt = (-e^u e^v, e^u e^v) are exact negatives, so any
    /// tableau applied to dxi/dt keeps it to round-off (transformed_rk). The inverse is (log xi_1, log xi_2); a
    /// non-positive xi component means the step was too large.
    struct transform {
        using state_type = exponential_entropy::state_type;
        using xi_type = std::array<double, 2>;

        void to_xi(const state_type& s, xi_type& xi) const { xi = {std::exp(s[0]), std::exp(s[1])}; }
        void xi_rate(const state_type& s, const state_type& /*dsdt*/, xi_type& rate) const {
            const double r = std::exp(s[0] + s[1]);
            rate = {-r, r};
        }
        step_result from_xi(const xi_type& xi, const state_type& /*hint*/, state_type& s, solver_stats&) const {
            if (!(xi[0] > 0.0) || !std::isfinite(xi[0])) return step_result::failure(0);
            if (!(xi[1] > 0.0) || !std::isfinite(xi[1])) return step_result::failure(1);
            s = {std::log(xi[0]), std::log(xi[1])};
            return step_result::success();
        }
    };
    /// The transform xi = (e^u, e^v).
    transform linearizing_transform() const { return {}; }
};

}  // namespace eci
