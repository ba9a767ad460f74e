// The three-wave model, eq. (1): three real modes of the truncated Euler equations, with energy (4) and
// enstrophy (5), its parameters and the paper's set-ups. The coupling coefficients must satisfy eqs. (2) and (3),
// which make both invariants exact.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <stdexcept>
#include <string>
#include <string_view>

#include "description.hpp"

namespace eci {

/// dpsi_K/dt = M_K psi_P psi_Q and cyclically, eq. (1).
struct three_wave {
    using state_type = std::array<double, 3>;

    double K = std::sqrt(3.0);  ///< wavenumber magnitudes
    double P = 3.0;
    double Q = std::sqrt(6.0);
    std::array<double, 3> M{1.0, 1.0, -2.0};  ///< coupling coefficients M_K, M_P, M_Q

    static constexpr std::string_view name = "three-wave";  ///< `eci run three-wave`
    static constexpr std::string_view description =
        "three real modes of the truncated Euler equations, eq. (1); invariants energy, enstrophy";
    static constexpr std::array<const char*, 3> component_names{"psi_K", "psi_P", "psi_Q"};
    /// --plot's phase-plane panel: a closed curve (the intersection of the two invariants' ellipsoids, seen along
    /// psi_K), which a drifting method leaves as a band.
    static constexpr phase_plane plot_plane{"psi_P", "psi_Q", false};

    /// The parameters, with what validate() requires of them.
    static constexpr auto parameters() {
        return std::array<parameter<three_wave>, 4>{{
            {"K", "wavenumber magnitude K", "", member_values<&three_wave::K, three_wave>},
            {"P", "wavenumber magnitude P", "", member_values<&three_wave::P, three_wave>},
            {"Q", "wavenumber magnitude Q", "", member_values<&three_wave::Q, three_wave>},
            {"M", "coupling coefficients M_K,M_P,M_Q", "obeying eqs. (2)-(3)",
             member_values<&three_wave::M, three_wave>},
        }};
    }
    /// The initial state, set as one vector.
    static constexpr auto initial_condition() {
        return std::array<state_field, 1>{{{"psi", "initial condition psi_K,psi_P,psi_Q", "", 0, 3}}};
    }
    /// The paper's set-ups (the first is `eci run three-wave`'s default). The paper does not state the time span
    /// of Figs. 1-4 and 6; t in [0, 10] shows about three periods.
    static std::array<preset<three_wave>, 4> presets() {
        const double r = std::sqrt(1.5);
        return {{
            {"standard", "Figs. 1-4's initial condition, C-PC with dt 0.01 to t = 10", {}, {r, 0.0, r}, "c-pc", 0.01,
             10.0},
            {"fig1", "Fig. 1: Euler against C-Euler, dt 0.02 to t = 10", {}, {r, 0.0, r}, "c-euler", 0.02, 10.0},
            {"fig2", "Figs. 2-4 and 6: PC against C-PC, dt 0.2 to t = 10", {}, {r, 0.0, r}, "c-pc", 0.2, 10.0},
            {"fig5", "Fig. 5: the initial condition of the single-step errors, one step of the largest tau 0.1", {},
             {r, 1.0, r}, "c-pc", 0.1, 0.1},
        }};
    }

    /// Throws std::invalid_argument if eq. (2) or (3) fails beyond round-off, a parameter is not finite or a
    /// wavenumber magnitude (K, P, Q) is negative.
    void validate() const {
        const char* names[] = {"K", "P", "Q", "M_K", "M_P", "M_Q"};
        const double values[] = {K, P, Q, M[0], M[1], M[2]};
        for (int i = 0; i < 6; ++i) detail::require_normal(values[i], std::string("three-wave ") + names[i]);
        for (int i = 0; i < 3; ++i)  // (the equations hold only their squares: a sign would pass unnoticed)
            if (values[i] < 0.0)
                throw std::invalid_argument(std::string("three-wave ") + names[i] +
                                            " is a wavenumber's magnitude and must not be negative, got " +
                                            detail::shortest_text(values[i]));
        detail::require_cancellation(M[0] + M[1] + M[2], std::abs(M[0]) + std::abs(M[1]) + std::abs(M[2]),
                                     "M_K + M_P + M_Q (eq. 2)");
        const double k2 = K * K, p2 = P * P, q2 = Q * Q;
        // Squares and their products with M must be representable, or eq. (3) would compare inf with inf.
        detail::require_representable(k2, "K^2", K != 0.0);
        detail::require_representable(p2, "P^2", P != 0.0);
        detail::require_representable(q2, "Q^2", Q != 0.0);
        detail::require_representable(k2 * M[0], "K^2 M_K", K != 0.0 && M[0] != 0.0);
        detail::require_representable(p2 * M[1], "P^2 M_P", P != 0.0 && M[1] != 0.0);
        detail::require_representable(q2 * M[2], "Q^2 M_Q", Q != 0.0 && M[2] != 0.0);
        detail::require_cancellation(k2 * M[0] + p2 * M[1] + q2 * M[2],
                                     std::abs(k2 * M[0]) + std::abs(p2 * M[1]) + std::abs(q2 * M[2]),
                                     "K^2 M_K + P^2 M_P + Q^2 M_Q (eq. 3)");
    }

    /// Throws std::invalid_argument if the state's scale is beyond double precision: energy (4) and enstrophy
    /// (5) bound every |psi| for all time, so if they and the largest rate, max|M| 2E, are representable, the
    /// whole run is; if a mode is nonzero but E underflows, the run could only produce zeros.
    void validate_state(const state_type& x) const {
        for (int i = 0; i < 3; ++i) detail::require_normal(x[i], std::string("three-wave ") + component_names[i]);
        const bool moving = x[0] != 0.0 || x[1] != 0.0 || x[2] != 0.0;
        detail::require_representable(energy(x), "the energy (4) of this initial condition", moving);
        detail::require_representable(enstrophy(x), "the enstrophy (5) of this initial condition", false);
        const double m = std::max({std::abs(M[0]), std::abs(M[1]), std::abs(M[2])});
        detail::require_representable(m * 2.0 * energy(x), "the largest rate max|M| 2E", false);
    }

    void operator()(const state_type& x, state_type& dxdt, double /*t*/) const {
        dxdt[0] = M[0] * x[1] * x[2];
        dxdt[1] = M[1] * x[2] * x[0];
        dxdt[2] = M[2] * x[0] * x[1];
    }

    /// E, eq. (4).
    double energy(const state_type& x) const { return 0.5 * (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]); }
    /// Z, eq. (5).
    double enstrophy(const state_type& x) const {
        return 0.5 * (K * K * x[0] * x[0] + P * P * x[1] * x[1] + Q * Q * x[2] * x[2]);
    }

    /// E and Z as quadratic invariants sum_k w_jk psi_k^2, j in the order of invariants(): w_0k = 1/2 and
    /// w_1k = k^2 / 2 (K, P, Q). Relaxation and projection, and the conservative steppers' remedy (which on three
    /// modes never applies: one failing mode is not isolated), take them from here.
    double quadratic_invariant_weight(std::size_t j, std::size_t k) const {
        const double wavenumber = k == 0 ? K : k == 1 ? P : Q;
        return j == 0 ? 0.5 : 0.5 * wavenumber * wavenumber;
    }

    /// The invariants by name, in CSV column order.
    static constexpr auto invariants() {
        return std::array<named_invariant<three_wave>, 2>{
            {{"energy", &three_wave::energy}, {"enstrophy", &three_wave::enstrophy}}};
    }
};

}  // namespace eci
