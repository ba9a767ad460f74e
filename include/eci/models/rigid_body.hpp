// The rigid body of Biswas & Ketcheson (2023): Euler's equations u1' = (alpha - beta) u2 u3, u2' = (1 - alpha) u3 u1,
// u3' = (beta - 1) u1 u2 with two quadratic invariants G1 = |u|^2 and G2 = u1^2 + beta u2^2 + alpha u3^2.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>

#include "../invariants.hpp"
#include "description.hpp"
#include "invariant.hpp"

namespace eci {

/// Euler's equations of a free rigid body in Biswas & Ketcheson's scaling; the defaults (alpha = 1 + 1/sqrt(1.51),
/// beta = 1 - 0.51/sqrt(1.51)) with u(0) = (0, 1, 1) give u = (sqrt(1.51) sn(t), cn(t), dn(t)), m = 0.51
/// (rigid_body_exact.hpp). It is a three-wave system (eq. (1)) with M = (alpha - beta, 1 - alpha, beta - 1).
struct rigid_body {
    using state_type = std::array<double, 3>;

    double alpha = 1.0 + 1.0 / std::sqrt(1.51);
    double beta = 1.0 - 0.51 / std::sqrt(1.51);

    static constexpr std::string_view name = "rigid-body";  ///< `eci run rigid-body`
    static constexpr std::string_view description =
        "rigid body of Biswas & Ketcheson (2023), Euler's equations; quadratic invariants G1 = |u|^2, G2";
    static constexpr std::array<const char*, 3> component_names{"u1", "u2", "u3"};
    /// --plot's phase-plane panel: a closed curve on the sphere |u| = |u(0)|, seen along u3.
    static constexpr phase_plane plot_plane{"u1", "u2", false};

    /// The parameters (any finite values: G1 and G2 are invariant for all alpha, beta).
    static constexpr auto parameters() {
        return std::array<parameter<rigid_body>, 2>{{
            {"alpha", "coefficient alpha (G2 = u1^2 + beta u2^2 + alpha u3^2)", "",
             member_values<&rigid_body::alpha, rigid_body>},
            {"beta", "coefficient beta", "", member_values<&rigid_body::beta, rigid_body>},
        }};
    }
    /// The initial state, set as one vector.
    static constexpr auto initial_condition() {
        return std::array<state_field, 1>{{{"u", "initial state u1,u2,u3", "", 0, 3}}};
    }
    /// Biswas & Ketcheson's set-up, u(0) = (0, 1, 1) to t = 1000 with steps of 0.1: eci's C-RK4 (the default),
    /// and their multiple relaxation RK4.
    static std::array<preset<rigid_body>, 2> presets() {
        return {{{"standard", "Biswas & Ketcheson's set-up, C-RK4, dt 0.1 to t = 1000", {}, {0.0, 1.0, 1.0}, "c-rk4",
                  0.1, 1000.0},
                 {"multiple-relaxation", "the same with multiple relaxation RK4", {}, {0.0, 1.0, 1.0}, "mrrk-rk4", 0.1,
                  1000.0}}};
    }

    /// Biswas & Ketcheson's initial state (0, 1, 1).
    static constexpr state_type initial_state() { return {0.0, 1.0, 1.0}; }

    /// Throws std::invalid_argument unless alpha and beta are finite.
    void validate() const {
        detail::require_finite(alpha, "rigid body alpha");
        detail::require_finite(beta, "rigid body beta");
    }

    /// Throws std::invalid_argument if the run's scale is beyond double precision (as three_wave's check: it is one
    /// with M = (alpha - beta, 1 - alpha, beta - 1)): G1 = |u|^2 bounds every |u_i|^2 for all time, so if G1, G2 and
    /// the largest rate bound max|M| G1 are representable, the whole run is.
    void validate_state(const state_type& u) const {
        const bool moving = u[0] != 0.0 || u[1] != 0.0 || u[2] != 0.0;
        detail::require_representable(g1(u), "G1 = |u|^2 of this initial condition", moving);
        detail::require_representable(g2(u), "G2 = u1^2 + beta u2^2 + alpha u3^2 of this initial condition", false);
        const double m = std::max({std::abs(alpha - beta), std::abs(1.0 - alpha), std::abs(beta - 1.0)});
        detail::require_representable(m * g1(u), "the largest rate max|M| G1 (M = (alpha - beta, 1 - alpha, beta - 1))",
                                      false);
    }

    void operator()(const state_type& u, state_type& dudt, double /*t*/) const {
        dudt[0] = (alpha - beta) * u[1] * u[2];
        dudt[1] = (1.0 - alpha) * u[2] * u[0];
        dudt[2] = (beta - 1.0) * u[0] * u[1];
    }

    /// G1 = u1^2 + u2^2 + u3^2.
    double g1(const state_type& u) const { return u[0] * u[0] + u[1] * u[1] + u[2] * u[2]; }
    /// G2 = u1^2 + beta u2^2 + alpha u3^2.
    double g2(const state_type& u) const { return u[0] * u[0] + beta * u[1] * u[1] + alpha * u[2] * u[2]; }

    /// The invariants by name, in CSV column order.
    static constexpr auto invariants() {
        return std::array<named_invariant<rigid_body>, 2>{{{"g1", &rigid_body::g1}, {"g2", &rigid_body::g2}}};
    }

    /// G1 and G2 as a quadratic invariant set (for relaxation and projection).
    struct invariant_set {
        double alpha, beta;
        std::size_t count() const { return 2; }
        double inner(const state_type& a, const state_type& b, std::size_t i) const {
            const std::array<double, 3> w = weights(i);
            return w[0] * a[0] * b[0] + w[1] * a[1] * b[1] + w[2] * a[2] * b[2];
        }
        double value(const state_type& u, std::size_t i) const { return inner(u, u, i); }
        void gradient(const state_type& u, std::size_t i, state_type& g) const {
            const std::array<double, 3> w = weights(i);
            g = {2.0 * w[0] * u[0], 2.0 * w[1] * u[1], 2.0 * w[2] * u[2]};
        }
        std::array<double, 3> weights(std::size_t i) const {
            return i == 0 ? std::array<double, 3>{1.0, 1.0, 1.0} : std::array<double, 3>{1.0, beta, alpha};
        }
    };
    /// G1 and G2.
    invariant_set invariant_functions() const { return {alpha, beta}; }
};

}  // namespace eci
