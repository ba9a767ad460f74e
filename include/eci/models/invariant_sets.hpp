// The invariants of every eci model as an invariant_set (value and gradient, see invariants.hpp), which relaxation
// and projection need: invariants_of(model). Models added for them carry theirs as invariant_functions().
#pragma once

#include <array>
#include <cmath>
#include <complex>
#include <cstddef>
#include <vector>

#include "../invariants.hpp"
#include "../steppers/symplectic.hpp"
#include "exponential_entropy.hpp"
#include "kepler.hpp"
#include "kepler_cartesian.hpp"
#include "lotka_volterra.hpp"
#include "n_wave.hpp"
#include "nonlinear_oscillator.hpp"
#include "rigid_body.hpp"
#include "three_wave.hpp"

namespace eci {

/// Energy (4) and enstrophy (5) of the three-wave model, quadratic.
struct three_wave_invariants {
    std::array<double, 3> k2;  ///< K^2, P^2, Q^2
    std::size_t count() const { return 2; }
    /// B_E(a, b) = sum a b / 2, B_Z(a, b) = sum k^2 a b / 2.
    double inner(const three_wave::state_type& a, const three_wave::state_type& b, std::size_t i) const {
        double s = 0.0;
        for (std::size_t j = 0; j < 3; ++j) s += (i == 0 ? 1.0 : k2[j]) * a[j] * b[j];
        return 0.5 * s;
    }
    double value(const three_wave::state_type& x, std::size_t i) const { return inner(x, x, i); }
    void gradient(const three_wave::state_type& x, std::size_t i, three_wave::state_type& g) const {
        for (std::size_t j = 0; j < 3; ++j) g[j] = (i == 0 ? 1.0 : k2[j]) * x[j];
    }
};
/// Energy and enstrophy of the three-wave model.
inline three_wave_invariants invariants_of(const three_wave& m) { return {{m.K * m.K, m.P * m.P, m.Q * m.Q}}; }

/// Energy and enstrophy of an n-wave model (real or complex modes), quadratic.
template <scalar T>
struct n_wave_invariants {
    const n_wave<T>* model;
    std::size_t count() const { return 2; }
    double inner(const std::vector<T>& a, const std::vector<T>& b, std::size_t i) const {
        double s = 0.0;
        for (std::size_t j = 0; j < a.size(); ++j) {
            const double w = i == 0 ? 1.0 : model->wavenumber[j] * model->wavenumber[j];
            s += w * std::real(a[j] * std::conj(b[j]));
        }
        return 0.5 * s;
    }
    double value(const std::vector<T>& x, std::size_t i) const { return inner(x, x, i); }
    void gradient(const std::vector<T>& x, std::size_t i, std::vector<T>& g) const {
        for (std::size_t j = 0; j < x.size(); ++j)
            g[j] = (i == 0 ? 1.0 : model->wavenumber[j] * model->wavenumber[j]) * x[j];
    }
};
/// Energy and enstrophy of an n-wave model (which must outlive the set).
template <scalar T>
n_wave_invariants<T> invariants_of(const n_wave<T>& m) {
    return {&m};
}

/// The Lotka-Volterra Hamiltonian (37), not quadratic.
struct lotka_volterra_invariants {
    double mu;
    std::size_t count() const { return 1; }
    double value(const lotka_volterra::state_type& s, std::size_t) const { return lotka_volterra{mu}.hamiltonian(s); }
    /// dH/dx = 1 - 1/x, dH/dy = mu (1 - 1/y).
    void gradient(const lotka_volterra::state_type& s, std::size_t, lotka_volterra::state_type& g) const {
        g = {1.0 - 1.0 / s[0], mu * (1.0 - 1.0 / s[1])};
    }
};
/// H of the Lotka-Volterra model.
inline lotka_volterra_invariants invariants_of(const lotka_volterra& m) { return {m.mu}; }

/// The polar Kepler model's H (46) and Runge-Lenz vector (47). The three are dependent (|A|^2 = K^2 + 2 H ell^2/m):
/// keep H and one component at most (pick_invariants), or projection's Gram matrix is singular.
struct kepler_invariants {
    kepler model;
    std::size_t count() const { return 3; }
    double value(const kepler::state_type& s, std::size_t i) const {
        return i == 0 ? model.hamiltonian(s) : model.runge_lenz(s)[i - 1];
    }
    void gradient(const kepler::state_type& s, std::size_t i, kepler::state_type& g) const {
        const double m = model.m, K = model.K, ell = model.ell, r = s[0];
        if (i == 0) {
            g = {-ell * ell / (m * r * r * r) + K / (r * r), m * s[1], 0.0};
            return;
        }
        // A = (a c - b s, a s + b c), a = ell^2/(m r) - K, b = -ell v_r.
        const double a = ell * ell / (m * r) - K, b = -ell * s[1], ar = -ell * ell / (m * r * r);
        const double c = std::cos(s[2]), sn = std::sin(s[2]);
        if (i == 1)
            g = {ar * c, ell * sn, -a * sn - b * c};
        else
            g = {ar * sn, -ell * c, a * c - b * sn};
    }
};
/// H, A_x, A_y of the polar Kepler model.
inline kepler_invariants invariants_of(const kepler& m) { return {m}; }

/// The invariants of a model that carries them (rigid body, Kepler in Cartesian variables, the nonlinear
/// oscillator, the exponential entropy problem).
template <class Model>
    requires requires(const Model& m) { m.invariant_functions(); }
auto invariants_of(const Model& m) {
    return m.invariant_functions();
}

/// The invariants whose gradients are independent wherever the model is integrated, which projection and
/// multiple relaxation need (a dependent set makes their linear systems singular): all of invariants_of(model)
/// except for Kepler, where the Runge-Lenz vector depends on H and L (polar: H alone, ell being a parameter;
/// Cartesian: H and L).
template <class Model>
    requires requires(const Model& m) { invariants_of(m); }
auto independent_invariants_of(const Model& m) {
    return invariants_of(m);
}
/// H alone for the polar Kepler model.
inline invariant_subset<kepler_invariants> independent_invariants_of(const kepler& m) {
    return pick_invariants(invariants_of(m), {0});
}
/// H and L for Kepler in Cartesian variables.
inline invariant_subset<kepler_cartesian::invariant_set> independent_invariants_of(const kepler_cartesian& m) {
    return pick_invariants(invariants_of(m), {0, 1});
}

/// How many invariants independent_invariants_of(Model) has, known at compile time (0: the model offers none),
/// so that the registry offers multiple relaxation only where it has two.
template <class Model>
inline constexpr std::size_t independent_invariant_count = 0;
template <> inline constexpr std::size_t independent_invariant_count<three_wave> = 2;
template <> inline constexpr std::size_t independent_invariant_count<n_wave<double>> = 2;
template <> inline constexpr std::size_t independent_invariant_count<n_wave<std::complex<double>>> = 2;
template <> inline constexpr std::size_t independent_invariant_count<rigid_body> = 2;
template <> inline constexpr std::size_t independent_invariant_count<kepler_cartesian> = 2;
template <> inline constexpr std::size_t independent_invariant_count<lotka_volterra> = 1;
template <> inline constexpr std::size_t independent_invariant_count<kepler> = 1;
template <> inline constexpr std::size_t independent_invariant_count<nonlinear_oscillator> = 1;
template <> inline constexpr std::size_t independent_invariant_count<exponential_entropy> = 1;

/// A model whose Hamiltonian is separable, H = T(p) + V(q), with state (q, p): symplectic splittings apply.
template <class M>
concept separable_hamiltonian = requires {
    requires static_cast<bool>(M::separable_hamiltonian);
};

/// The drift rule of a separable model: dq/dt = p (no right-hand side needed) where the model says unit_mass.
template <class M>
inline constexpr drift_rule drift_rule_of = [] {
    if constexpr (requires { requires static_cast<bool>(M::unit_mass); })
        return drift_rule::momentum;
    else
        return drift_rule::from_system;
}();

}  // namespace eci
