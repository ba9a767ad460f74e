// The Kepler problem in Cartesian variables u = (q1, q2, p1, p2), H = |p|^2/2 - 1/|q|, as Ranocha & Ketcheson
// (2020) and Biswas & Ketcheson (2023) pose it: separable (symplectic methods apply), with H, the angular
// momentum L and the Runge-Lenz vector A as invariants; the exact solution through kepler_exact.hpp.
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <stdexcept>
#include <string>

#include "../detail/format.hpp"
#include "description.hpp"
#include "invariant.hpp"
#include "kepler.hpp"
#include "kepler_exact.hpp"

namespace eci {

/// q' = p, p' = -q / |q|^3 (unit mass and strength).
struct kepler_cartesian {
    using state_type = std::array<double, 4>;

    static constexpr std::string_view name = "kepler-cartesian";  ///< `eci run kepler-cartesian`
    static constexpr std::string_view description =
        "Kepler problem in Cartesian variables (q, p), H = |p|^2/2 - 1/|q|; invariants H, L, Runge-Lenz vector";
    static constexpr std::array<const char*, 4> component_names{"q1", "q2", "p1", "p2"};
    /// --plot's phase-plane panel: the orbit in the plane.
    static constexpr phase_plane plot_plane{"q1", "q2", true};

    /// No parameters (unit mass and strength).
    static constexpr auto parameters() { return std::array<parameter<kepler_cartesian>, 0>{}; }
    /// The initial state: position and momentum (validate_state() requires a bound orbit with L != 0).
    static constexpr auto initial_condition() {
        return std::array<state_field, 2>{{{"q", "initial position q1,q2", "not (0, 0)", 0, 2},
                                           {"p", "initial momentum p1,p2", "bound orbit, L != 0", 2, 2}}};
    }
    /// Ranocha & Ketcheson's set-up: eccentricity 0.5 to t = 300 pi; relaxation RK4 keeping H (default), and
    /// McLachlan's symplectic SB3A.
    static std::array<preset<kepler_cartesian>, 2> presets() {
        const state_type u0 = initial_state(0.5);
        const double T = 300.0 * 3.14159265358979323846;
        return {{{"standard", "e = 0.5 to t = 300 pi, relaxation RK4 (H kept), dt 0.025", {}, u0, "rrk-rk4", 0.025, T},
                 {"symplectic", "the same with the symplectic SB3A", {}, u0, "sb3a", 0.025, T}}};
    }
    /// No parameters to check.
    void validate() const {}
    /// H is not a sum of squares of the unknowns: C-RK methods do not keep it (they keep L only).
    static constexpr bool quadratic_invariants = false;
    /// H = T(p) + V(q) with q' = p: symplectic splittings apply, and their drifts need no right-hand side.
    static constexpr bool separable_hamiltonian = true;
    static constexpr bool unit_mass = true;

    /// Ranocha & Ketcheson's initial state of eccentricity e: (1 - e, 0, 0, sqrt((1 + e) / (1 - e))), at
    /// pericentre; the period is 2 pi. Throws std::invalid_argument unless 0 <= e < 1.
    static state_type initial_state(double e) {
        if (!(e >= 0.0 && e < 1.0))
            throw std::invalid_argument("Kepler eccentricity must be in [0, 1), got " + detail::shortest_text(e));
        return {1.0 - e, 0.0, 0.0, std::sqrt((1.0 + e) / (1.0 - e))};
    }

    /// Throws std::invalid_argument unless the state is finite, q != 0 and the orbit is bound with L != 0.
    void validate_state(const state_type& u) const {
        for (std::size_t i = 0; i < 4; ++i) detail::require_finite(u[i], std::string("Kepler ") + component_names[i]);
        if (u[0] == 0.0 && u[1] == 0.0) throw std::invalid_argument("Kepler position must not be (0, 0)");
        if (!(hamiltonian(u) < 0.0)) throw std::invalid_argument("Kepler orbit is unbound (H >= 0)");
        if (angular_momentum(u) == 0.0) throw std::invalid_argument("Kepler angular momentum must be nonzero");
    }

    void operator()(const state_type& u, state_type& dudt, double /*t*/) const {
        const double r2 = u[0] * u[0] + u[1] * u[1];
        const double r3 = r2 * std::sqrt(r2);
        dudt[0] = u[2];
        dudt[1] = u[3];
        dudt[2] = -u[0] / r3;
        dudt[3] = -u[1] / r3;
    }

    /// H = |p|^2 / 2 - 1 / |q|.
    double hamiltonian(const state_type& u) const {
        return 0.5 * (u[2] * u[2] + u[3] * u[3]) - 1.0 / std::hypot(u[0], u[1]);
    }
    /// L = q1 p2 - q2 p1.
    double angular_momentum(const state_type& u) const { return u[0] * u[3] - u[1] * u[2]; }
    /// x component of the Runge-Lenz vector A = p x L - q / |q|.
    double runge_lenz_x(const state_type& u) const {
        return u[3] * angular_momentum(u) - u[0] / std::hypot(u[0], u[1]) + 0.0;  // + 0.0: no "-0" in the output
    }
    /// y component of the Runge-Lenz vector.
    double runge_lenz_y(const state_type& u) const {
        return -u[2] * angular_momentum(u) - u[1] / std::hypot(u[0], u[1]) + 0.0;
    }

    /// The invariants by name, in CSV column order.
    static constexpr auto invariants() {
        return std::array<named_invariant<kepler_cartesian>, 4>{
            {{"hamiltonian", &kepler_cartesian::hamiltonian},
             {"angular_momentum", &kepler_cartesian::angular_momentum},
             {"runge_lenz_x", &kepler_cartesian::runge_lenz_x},
             {"runge_lenz_y", &kepler_cartesian::runge_lenz_y}}};
    }

    /// The same orbit in the polar variables of eci::kepler (m = K = 1, ell = L): (r, v_r, theta).
    static std::pair<kepler, kepler::state_type> to_polar(const state_type& u) {
        const double r = std::hypot(u[0], u[1]);
        const double L = u[0] * u[3] - u[1] * u[2];
        return {kepler{1.0, 1.0, L}, {r, (u[0] * u[2] + u[1] * u[3]) / r, std::atan2(u[1], u[0])}};
    }
    /// Cartesian state of a polar one with angular momentum ell.
    static state_type from_polar(const kepler::state_type& s, double ell) {
        const double c = std::cos(s[2]), sn = std::sin(s[2]);
        return {s[0] * c, s[0] * sn, s[1] * c - ell / s[0] * sn, s[1] * sn + ell / s[0] * c};
    }

    /// H, L, A_x, A_y with their gradients (for relaxation and projection; L is quadratic but H is not, so the
    /// set has no `inner`). |A|^2 = 1 + 2 H L^2: at most three are independent, and with H and L kept, A_x is
    /// locally dependent on them where A_y = 0 (an axis along x, as for initial_state(e)): keep A_y there.
    struct invariant_set {
        std::size_t count() const { return 4; }
        double value(const state_type& u, std::size_t i) const {
            const kepler_cartesian k;
            switch (i) {
                case 0: return k.hamiltonian(u);
                case 1: return k.angular_momentum(u);
                case 2: return k.runge_lenz_x(u);
                default: return k.runge_lenz_y(u);
            }
        }
        void gradient(const state_type& u, std::size_t i, state_type& g) const {
            const double q1 = u[0], q2 = u[1], p1 = u[2], p2 = u[3];
            const double r = std::hypot(q1, q2), r3 = r * r * r, L = q1 * p2 - q2 * p1;
            switch (i) {
                case 0: g = {q1 / r3, q2 / r3, p1, p2}; break;
                case 1: g = {p2, -p1, -q2, q1}; break;
                case 2: g = {p2 * p2 - 1.0 / r + q1 * q1 / r3, -p1 * p2 + q1 * q2 / r3, -p2 * q2, L + p2 * q1}; break;
                default: g = {-p1 * p2 + q1 * q2 / r3, p1 * p1 - 1.0 / r + q2 * q2 / r3, -L + p1 * q2, -p1 * q1}; break;
            }
        }
    };
    /// H, L, A_x, A_y.
    invariant_set invariant_functions() const { return {}; }
    /// H and L, what projection and multiple relaxation keep. |A| depends on them (above); A's direction does not
    /// and is not kept (A_y would be, along an x axis, but its gradient degenerates as A turns: docs/methods.md).
    static constexpr std::array<std::size_t, 2> independent_invariants{0, 1};
};

/// The exact Cartesian state of a bound Kepler orbit at any time (Kepler's equation, through kepler_exact).
class kepler_cartesian_exact {
   public:
    /// Throws std::invalid_argument for an invalid state (see kepler_cartesian::validate_state).
    explicit kepler_cartesian_exact(const kepler_cartesian::state_type& u0)
        : polar_(kepler_cartesian::to_polar(u0)), exact_(polar_.first, polar_.second) {
        kepler_cartesian{}.validate_state(u0);
    }
    /// The state at time t (u0 was at t = 0).
    kepler_cartesian::state_type operator()(double t) const {
        return kepler_cartesian::from_polar(exact_(t), polar_.first.ell);
    }
    /// The orbital period.
    double period() const { return exact_.period(); }

   private:
    std::pair<kepler, kepler::state_type> polar_;
    kepler_exact exact_;
};

}  // namespace eci
