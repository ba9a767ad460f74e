// Symplectic splitting methods for separable Hamiltonians H = T(p) + V(q): alternating drifts q += a_l tau dH/dp
// and kicks p += -b_l tau dH/dq, coefficients as data. Stormer-Verlet (order 2) and McLachlan's SB3A (order 4).
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <span>
#include <stdexcept>
#include <tuple>
#include <utility>

#include "../concepts.hpp"
#include "../detail/state_ops.hpp"

namespace eci {

/// A splitting method: per stage l, the drift a_l then the kick b_l (zero coefficients are skipped).
template <std::size_t N>
struct splitting_coefficients {
    int order;
    std::array<double, N> a;  ///< drift weights (position updates)
    std::array<double, N> b;  ///< kick weights (momentum updates)
};

namespace splittings {

/// Stormer-Verlet, drift-kick-drift (position Verlet): second order.
inline constexpr splitting_coefficients<2> stormer_verlet{2, {0.5, 0.5}, {1.0, 0.0}};

/// McLachlan's symmetric SB3A method (1995), fourth order; the coefficients Boost.Odeint's
/// symplectic_rkn_sb3a_mclachlan uses, in the same layout (a_2 and b_2 complete the sums to 1/2 and 1).
inline constexpr splitting_coefficients<6> mclachlan_sb3a = [] {
    constexpr double a0 = 0.40518861839525227722, a1 = -0.28714404081652408900;
    constexpr double b0 = -3.0 / 73.0, b1 = 17.0 / 59.0;
    constexpr double a2 = 0.5 - (a0 + a1), b2 = 1.0 - 2.0 * (b0 + b1);
    return splitting_coefficients<6>{4, {a0, a1, a2, a2, a1, a0}, {b0, b1, b2, b1, b0, 0.0}};
}();

}  // namespace splittings

/// How a drift gets dq/dt: from the system (any separable H), or as p itself (H = |p|^2/2 + V(q), the Nystrom
/// case: drifts then cost no right-hand side, as in Boost.Odeint's symplectic_rkn steppers given only the force).
enum class drift_rule { from_system, momentum };

/// A splitting method with coefficients C for a separable Hamiltonian system whose state is (q, p): the first
/// half of the real unknowns are positions, the second half momenta. The system f(x, dxdt, t) must give
/// dq/dt depending on p only and dp/dt on q only (separable, autonomous); each drift or kick evaluates f once
/// (the first drift of a step reuses the last evaluation of the step before). Never fails. With
/// drift_rule::momentum, dq/dt = p is checked at every kick (std::invalid_argument if the system says otherwise).
template <const auto& C, state S, drift_rule Drift = drift_rule::from_system>
class symplectic_splitting {
    static constexpr std::size_t stages = std::tuple_size_v<decltype(C.a)>;

   public:
    static constexpr int order = C.order;
    static constexpr bool fixed_evaluations = true;  ///< one evaluation per stage

    template <system<S> F>
    step_result step(F& f, S& x, double t, double dt) {
        const auto xr = detail::reals(x);
        const std::size_t n = xr.size();
        if (n % 2 != 0) throw std::invalid_argument("symplectic splitting: the state must be (q, p), of even size");
        const std::size_t h = n / 2;
        detail::resize_like(k_, x);
        const auto k = detail::reals(k_);
        // k_ holds f at the last evaluation: its q half is v(p) while p is unchanged since (v_ok), its p half the
        // force while q is unchanged since (force_ok). A step ending with a drift leaves v(p) valid for the next.
        bool v_ok = v_ok_ && x == last_x_, force_ok = false;
        double tq = t;  // the time positions have reached
        auto evaluate = [&] {
            f(std::as_const(x), k_, tq);
            v_ok = force_ok = true;
        };
        for (std::size_t l = 0; l < stages; ++l) {
            if (C.a[l] != 0.0) {
                const double c = C.a[l] * dt;
                if constexpr (Drift == drift_rule::from_system) {
                    if (!v_ok) evaluate();
                    for (std::size_t i = 0; i < h; ++i) xr[i] += c * k[i];
                } else {
                    for (std::size_t i = 0; i < h; ++i) xr[i] += c * xr[h + i];
                }
                force_ok = false;
                tq += c;
            }
            if (C.b[l] != 0.0) {
                if (!force_ok) evaluate();
                if constexpr (Drift == drift_rule::momentum) check_momentum(xr, k, h);
                const double c = C.b[l] * dt;
                for (std::size_t i = h; i < n; ++i) xr[i] += c * k[i];
                v_ok = false;
            }
        }
        v_ok_ = Drift == drift_rule::from_system && v_ok;
        last_x_ = x;
        return step_result::success();
    }

   private:
    static void check_momentum(std::span<double> x, std::span<double> k, std::size_t h) {
        constexpr double eps = std::numeric_limits<double>::epsilon();
        for (std::size_t i = 0; i < h; ++i)
            if (!(std::abs(k[i] - x[h + i]) <= 4.0 * eps * std::abs(x[h + i])))
                throw std::invalid_argument("symplectic splitting with drift_rule::momentum needs dq/dt = p");
    }

    S k_{}, last_x_{};
    bool v_ok_ = false;
};

/// Stormer-Verlet for any separable H (state (q, p)).
template <state S>
using stormer_verlet = symplectic_splitting<splittings::stormer_verlet, S>;
/// McLachlan's fourth-order SB3A for any separable H (state (q, p)).
template <state S>
using sb3a = symplectic_splitting<splittings::mclachlan_sb3a, S>;

/// A model whose Hamiltonian is separable, H = T(p) + V(q), with state (q, p): symplectic splittings apply. It
/// says so with `static constexpr bool separable_hamiltonian = true;`.
template <class M>
concept separable_hamiltonian = requires {
    requires static_cast<bool>(M::separable_hamiltonian);
};

/// The drift rule of a separable model: dq/dt = p (no right-hand side needed) where the model says
/// `static constexpr bool unit_mass = true;`.
template <class M>
inline constexpr drift_rule drift_rule_of = [] {
    if constexpr (requires { requires static_cast<bool>(M::unit_mass); })
        return drift_rule::momentum;
    else
        return drift_rule::from_system;
}();

}  // namespace eci
