// Ketcheson's "Ranocha problem", a nonlinear oscillator u' = (-u2, u1) / |u|^2: |u|^2 is invariant, and the
// solution rotates at the constant rate 1 / |u(0)|^2. Relaxation's test of a quadratic invariant.
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <stdexcept>

#include "description.hpp"
#include "invariant.hpp"

namespace eci {

/// u' = (-u2, u1) / (u1^2 + u2^2).
struct nonlinear_oscillator {
    using state_type = std::array<double, 2>;

    static constexpr std::string_view name = "nonlinear-oscillator";  ///< `eci run nonlinear-oscillator`
    static constexpr std::string_view description =
        "Ketcheson's \"Ranocha problem\" u' = (-u2, u1)/|u|^2; invariant |u|^2, exact solution a rotation";
    static constexpr std::array<const char*, 2> component_names{"u1", "u2"};
    /// --plot's phase-plane panel: the rotation: a circle of radius |u(0)|.
    static constexpr phase_plane plot_plane{"u1", "u2", true};

    /// No parameters.
    static constexpr auto parameters() { return std::array<parameter<nonlinear_oscillator>, 0>{}; }
    /// The initial state, set as one vector.
    static constexpr auto initial_condition() {
        return std::array<state_field, 1>{{{"u", "initial state u1,u2", "not (0, 0)", 0, 2}}};
    }
    /// Ketcheson's set-up: u(0) = (1, 0), tau = 0.1 to t = 10, relaxation RK4.
    static std::array<preset<nonlinear_oscillator>, 1> presets() {
        return {{{"standard", "u(0) = (1, 0), relaxation RK4, dt 0.1 to t = 10", {}, {1.0, 0.0}, "rrk-rk4", 0.1,
                  10.0}}};
    }
    /// No parameters to check.
    void validate() const {}

    /// Ketcheson's initial state (1, 0).
    static constexpr state_type initial_state() { return {1.0, 0.0}; }

    /// Throws std::invalid_argument unless u is finite and nonzero (the field is singular at the origin).
    void validate_state(const state_type& u) const {
        detail::require_finite(u[0], "oscillator u1");
        detail::require_finite(u[1], "oscillator u2");
        if (u[0] == 0.0 && u[1] == 0.0) throw std::invalid_argument("oscillator state must not be (0, 0)");
    }

    void operator()(const state_type& u, state_type& dudt, double /*t*/) const {
        const double r2 = u[0] * u[0] + u[1] * u[1];
        dudt[0] = -u[1] / r2;
        dudt[1] = u[0] / r2;
    }

    /// |u|^2.
    double norm2(const state_type& u) const { return u[0] * u[0] + u[1] * u[1]; }

    /// The invariants by name, in CSV column order.
    static constexpr auto invariants() {
        return std::array<named_invariant<nonlinear_oscillator>, 1>{{{"norm2", &nonlinear_oscillator::norm2}}};
    }

    /// The exact state at t from u0 at t = 0: rotation by t / |u0|^2.
    static state_type exact(const state_type& u0, double t) {
        const double w = t / (u0[0] * u0[0] + u0[1] * u0[1]);
        const double c = std::cos(w), s = std::sin(w);
        return {c * u0[0] - s * u0[1], s * u0[0] + c * u0[1]};
    }

    /// |u|^2 as a quadratic invariant set.
    struct invariant_set {
        std::size_t count() const { return 1; }
        double inner(const state_type& a, const state_type& b, std::size_t) const { return a[0] * b[0] + a[1] * b[1]; }
        double value(const state_type& u, std::size_t i) const { return inner(u, u, i); }
        void gradient(const state_type& u, std::size_t, state_type& g) const { g = {2.0 * u[0], 2.0 * u[1]}; }
    };
    /// |u|^2.
    invariant_set invariant_functions() const { return {}; }
};

}  // namespace eci
