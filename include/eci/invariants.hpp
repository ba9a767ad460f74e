// Invariants as functions of the state (value and gradient): what relaxation Runge-Kutta and orthogonal projection
// need to keep them. A model declares its own in its header, either by the weights of its quadratic invariants
// (quadratic_invariant_weight) or as a set of functions (invariant_functions); invariants_of(model) gives either as
// an invariant set. A user builds one from lambdas.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <concepts>
#include <cstdint>
#include <cstddef>
#include <initializer_list>
#include <limits>
#include <ranges>
#include <span>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "concepts.hpp"
#include "detail/state_ops.hpp"

namespace eci {

/// A set of `count()` scalar invariants of a system with state S: `value(x, i)` is invariant i at x and
/// `gradient(x, i, g)` writes its gradient with respect to the real unknowns of x into g (sized like x; for a
/// complex state, the pair (d/d re, d/d im) of each mode).
template <class I, class S>
concept invariant_set = state<S> && requires(const I& inv, const S& x, std::size_t i, S& g) {
    { inv.count() } -> std::convertible_to<std::size_t>;
    { inv.value(x, i) } -> std::convertible_to<double>;
    inv.gradient(x, i, g);
};

/// An invariant set whose members are quadratic forms: `inner(a, b, i)` is a symmetric bilinear form B_i with
/// value(x, i) = B_i(x, x). Relaxation then has its explicit gamma (Ketcheson 2019) and needs no root solve.
template <class I, class S>
concept quadratic_invariant_set = invariant_set<I, S> && requires(const I& inv, const S& a, std::size_t i) {
    { inv.inner(a, a, i) } -> std::convertible_to<double>;
};

/// Invariants given as two callables: value(x, i) -> double and gradient(x, i, g).
template <state S, class Value, class Gradient>
struct invariant_functions {
    using state_type = S;
    std::size_t n;
    Value value_fn;
    Gradient gradient_fn;

    /// How many invariants.
    std::size_t count() const { return n; }
    /// Invariant i at x.
    double value(const S& x, std::size_t i) const { return value_fn(x, i); }
    /// Gradient of invariant i at x, into g.
    void gradient(const S& x, std::size_t i, S& g) const { gradient_fn(x, i, g); }
};

/// Quadratic invariants given as two callables: inner(a, b, i) (symmetric, bilinear) and gradient(x, i, g).
template <state S, class Inner, class Gradient>
struct quadratic_invariant_functions {
    using state_type = S;
    std::size_t n;
    Inner inner_fn;
    Gradient gradient_fn;

    /// How many invariants.
    std::size_t count() const { return n; }
    /// B_i(a, b).
    double inner(const S& a, const S& b, std::size_t i) const { return inner_fn(a, b, i); }
    /// Invariant i at x, B_i(x, x).
    double value(const S& x, std::size_t i) const { return inner_fn(x, x, i); }
    /// Gradient of invariant i at x (2 B_i(x, .)), into g.
    void gradient(const S& x, std::size_t i, S& g) const { gradient_fn(x, i, g); }
};

/// A user's invariants from lambdas: `make_invariants<S>(count, value, gradient)`.
template <state S, class Value, class Gradient>
auto make_invariants(std::size_t count, Value value, Gradient gradient) {
    if (count == 0) throw std::invalid_argument("an invariant set needs at least one invariant");
    return invariant_functions<S, Value, Gradient>{count, std::move(value), std::move(gradient)};
}

/// A user's quadratic invariants from lambdas: `make_quadratic_invariants<S>(count, inner, gradient)`.
template <state S, class Inner, class Gradient>
auto make_quadratic_invariants(std::size_t count, Inner inner, Gradient gradient) {
    if (count == 0) throw std::invalid_argument("an invariant set needs at least one invariant");
    return quadratic_invariant_functions<S, Inner, Gradient>{count, std::move(inner), std::move(gradient)};
}

/// Some members of an invariant set, in the order given (e.g. single-invariant relaxation of one of two).
template <class Set>
struct invariant_subset {
    Set set;
    std::vector<std::size_t> pick;

    /// How many invariants are picked.
    std::size_t count() const { return pick.size(); }
    /// The picked invariant i at x.
    template <state S>
    double value(const S& x, std::size_t i) const {
        return set.value(x, pick[i]);
    }
    /// Its gradient.
    template <state S>
    void gradient(const S& x, std::size_t i, S& g) const {
        set.gradient(x, pick[i], g);
    }
    /// Its bilinear form, when the set is quadratic.
    template <state S>
    double inner(const S& a, const S& b, std::size_t i) const
        requires requires(const Set& s) { s.inner(a, b, i); }
    {
        return set.inner(a, b, pick[i]);
    }
};

/// The members `which` of `set`; throws std::invalid_argument for an index out of range or an empty pick.
template <class Set>
invariant_subset<Set> pick_invariants(Set set, std::span<const std::size_t> which) {
    if (which.empty()) throw std::invalid_argument("pick at least one invariant");
    for (std::size_t i : which)
        if (i >= set.count())
            throw std::invalid_argument("invariant " + std::to_string(i) + " does not exist (the set has " +
                                        std::to_string(set.count()) + ")");
    return {std::move(set), std::vector<std::size_t>(which.begin(), which.end())};
}
/// The same, with the members listed in place: pick_invariants(set, {0, 2}).
template <class Set>
invariant_subset<Set> pick_invariants(Set set, std::initializer_list<std::size_t> which) {
    return pick_invariants(std::move(set), std::span<const std::size_t>(which.begin(), which.size()));
}

namespace detail {

/// Sum over the real unknowns of a * b.
template <state S>
double dot(const S& a, const S& b) {
    const auto x = reals(a), y = reals(b);
    double s = 0.0;
    for (std::size_t i = 0; i < x.size(); ++i) s += x[i] * y[i];
    return s;
}

/// A rounding scale of invariant i at x: |x_I| |grad I| (Euclidean norms over the real unknowns; x_I: the unknowns
/// I depends on at x, where its gradient is not 0), the size of the terms whose rounding makes up the error of
/// evaluating I (for a homogeneous I of degree d it bounds d |I|). It does not vanish where some terms do (the
/// Runge-Lenz vector's zero component at an apsis). An unknown that I does not depend on adds nothing: Kepler's
/// unwrapped angle grows without bound over a run, and in |x| it made the energy's scale grow with it, so that a
/// projection stopped at a tolerance that let the energy drift with the run's length (2.8e-11 at t = 10500).
template <state S, class Set>
double rounding_scale(const Set& inv, const S& x, std::size_t i, S& g) {
    inv.gradient(x, i, g);
    const auto a = reals(x), b = reals(std::as_const(g));
    double xx = 0.0, gg = 0.0;
    for (std::size_t j = 0; j < a.size(); ++j)
        if (b[j] != 0.0) xx += a[j] * a[j], gg += b[j] * b[j];
    // |x|^2 |grad I|^2 is of the scale of I^2: beyond the range where I is near its ends (a quadratic I at |x| ~
    // 2^300), there the product of the norms
    const double p = xx * gg;
    return p >= std::numeric_limits<double>::min() && p <= std::numeric_limits<double>::max()
               ? std::sqrt(p)
               : std::sqrt(xx) * std::sqrt(gg);
}

/// Solve the m x m system A y = r in place (Gaussian elimination, partial pivoting); false if A is singular
/// to working precision. A is row-major and is destroyed.
inline bool solve_small(std::vector<double>& A, std::vector<double>& r, std::size_t m) {
    for (std::size_t c = 0; c < m; ++c) {
        std::size_t p = c;
        for (std::size_t i = c + 1; i < m; ++i)
            if (std::abs(A[i * m + c]) > std::abs(A[p * m + c])) p = i;
        double col = 0.0;
        for (std::size_t i = 0; i < m; ++i) col = std::max(col, std::abs(A[i * m + c]));
        if (!(std::abs(A[p * m + c]) > 1e-14 * col) || !(col > 0.0)) return false;
        if (p != c) {
            for (std::size_t j = 0; j < m; ++j) std::swap(A[c * m + j], A[p * m + j]);
            std::swap(r[c], r[p]);
        }
        for (std::size_t i = c + 1; i < m; ++i) {
            const double l = A[i * m + c] / A[c * m + c];
            for (std::size_t j = c; j < m; ++j) A[i * m + j] -= l * A[c * m + j];
            r[i] -= l * r[c];
        }
    }
    for (std::size_t c = m; c-- > 0;) {
        double s = r[c];
        for (std::size_t j = c + 1; j < m; ++j) s -= A[c * m + j] * r[j];
        r[c] = s / A[c * m + c];
    }
    for (double v : r)
        if (!std::isfinite(v)) return false;
    return true;
}

}  // namespace detail

/// The weights of quadratic invariants I_j = sum_k w_jk |psi_k|^2: one row per invariant, one weight per state
/// element (a complex mode's weight applies to both its parts). The conservative steppers' remedy for negative
/// radicands takes them (radicand_remedy::set_quadratic_invariants); a system whose weights are data (a Python
/// fun's, the spectral flows') returns them from a member `quadratic_invariant_weights()`.
using quadratic_weights = std::vector<std::vector<double>>;

/// A model that declares its invariants as quadratic forms by their weights, I_j(psi) = sum_k w_jk |psi_k|^2:
/// a member `double quadratic_invariant_weight(std::size_t j, std::size_t k) const` for each invariant j of
/// `invariants()` (in that order) and each element k of the state. Value, gradient and bilinear form
/// (invariants_of), and the remedy's weights (quadratic_weights_of) follow from them.
template <class M>
concept declares_quadratic_weights = requires(const M& m, std::size_t j) {
    typename M::state_type;
    { m.quadratic_invariant_weight(j, j) } -> std::convertible_to<double>;
    { M::invariants().size() } -> std::convertible_to<std::size_t>;
};

/// A model that declares its invariants as an invariant set of its own (values and gradients, an `inner` when they
/// are quadratic): a member `invariant_functions()`, whose members are those of `invariants()`, in that order.
template <class M>
concept declares_invariant_functions = requires(const M& m) {
    typename M::state_type;
    { m.invariant_functions() } -> invariant_set<typename M::state_type>;
    { M::invariants().size() } -> std::convertible_to<std::size_t>;
};

/// A model that declares its invariants as functions of the state, in either way: relaxation and projection run
/// on it. A model that declares none is refused them, with that reason (resolve_method_for).
template <class M>
concept declares_invariants = declares_quadratic_weights<M> || declares_invariant_functions<M>;

/// A model that names the invariants whose gradients are independent wherever it is integrated (projection and
/// multiple relaxation solve linear systems in them, singular for a dependent set), as indices into invariants():
/// `static constexpr std::array<std::size_t, N> independent_invariants{...};`. Without it, all are independent.
template <class M>
concept names_independent_invariants = requires {
    { M::independent_invariants.size() } -> std::convertible_to<std::size_t>;
    { M::independent_invariants[0] } -> std::convertible_to<std::size_t>;
};

namespace detail {
/// Re(a conj(b)): the real inner product of two elements of a state (a * b for real ones).
inline double real_product(double a, double b) { return a * b; }
inline double real_product(const std::complex<double>& a, const std::complex<double>& b) {
    return std::real(a * std::conj(b));
}
}  // namespace detail

/// The invariant set of a model that declares quadratic weights: B_j(a, b) = sum_k w_jk Re(a_k conj(b_k)),
/// I_j(x) = B_j(x, x), grad I_j = (2 w_jk x_k)_k. It holds the model by value when the model is trivially
/// copyable (a few parameters), else by address (n-wave's tables): such a model must outlive the set.
template <declares_quadratic_weights M>
class weighted_invariants {
   public:
    using state_type = typename M::state_type;

    explicit weighted_invariants(const M& m) : model_(hold(m)) {}

    /// How many invariants: those of invariants().
    static constexpr std::size_t count() { return M::invariants().size(); }
    /// B_j(a, b).
    double inner(const state_type& a, const state_type& b, std::size_t j) const {
        const M& m = model();
        double s = 0.0;
        for (std::size_t k = 0; k < std::ranges::size(a); ++k)
            s += m.quadratic_invariant_weight(j, k) * detail::real_product(a[k], b[k]);
        return s;
    }
    /// I_j(x) = B_j(x, x).
    double value(const state_type& x, std::size_t j) const { return inner(x, x, j); }
    /// grad I_j at x, into g.
    void gradient(const state_type& x, std::size_t j, state_type& g) const {
        const M& m = model();
        for (std::size_t k = 0; k < std::ranges::size(x); ++k) g[k] = (2.0 * m.quadratic_invariant_weight(j, k)) * x[k];
    }

   private:
    static constexpr bool by_value = std::is_trivially_copyable_v<M>;
    std::conditional_t<by_value, M, const M*> model_;

    static auto hold(const M& m) {
        if constexpr (by_value)
            return m;
        else
            return &m;
    }
    const M& model() const {
        if constexpr (by_value)
            return model_;
        else
            return *model_;
    }
};

/// The invariants a model declares, as an invariant set: its invariant_functions(), or the set its quadratic
/// weights define (weighted_invariants, which refers to m).
template <declares_invariants M>
auto invariants_of(const M& m) {
    if constexpr (declares_invariant_functions<M>)
        return m.invariant_functions();
    else
        return weighted_invariants<M>(m);
}

/// The invariants of invariants_of(m) whose gradients are independent (what projection and multiple relaxation
/// need): those the model names in independent_invariants, else all.
template <declares_invariants M>
auto independent_invariants_of(const M& m) {
    if constexpr (names_independent_invariants<M>)
        return pick_invariants(invariants_of(m), std::span<const std::size_t>(M::independent_invariants));
    else
        return invariants_of(m);
}

/// How many invariants independent_invariants_of(M) has, known at compile time (0: the model declares none), so
/// that the registry offers relaxation and projection where there is one and multiple relaxation where there are
/// two.
template <class M>
inline constexpr std::size_t independent_invariant_count = [] {
    if constexpr (!declares_invariants<M>)
        return std::size_t{0};
    else if constexpr (names_independent_invariants<M>)
        return std::size_t{M::independent_invariants.size()};
    else
        return std::size_t{M::invariants().size()};
}();

/// The weights of the quadratic invariants a system declares, for a state of `elements` elements: from its
/// quadratic_invariant_weight(j, k), or its quadratic_invariant_weights() (weights as data).
template <class M>
    requires declares_quadratic_weights<M> || requires(const M& m) {
        { m.quadratic_invariant_weights() } -> std::convertible_to<quadratic_weights>;
    }
quadratic_weights quadratic_weights_of(const M& m, std::size_t elements) {
    if constexpr (declares_quadratic_weights<M>) {
        quadratic_weights w(M::invariants().size(), std::vector<double>(elements));
        for (std::size_t j = 0; j < w.size(); ++j)
            for (std::size_t k = 0; k < elements; ++k) w[j][k] = m.quadratic_invariant_weight(j, k);
        return w;
    } else {
        return m.quadratic_invariant_weights();
    }
}

/// Invariant sources for the steppers' `Inv` parameter that take the invariants from the model being stepped
/// (model_of(f): found through the system's wrappers), so the registry can build such a stepper without the
/// model's parameters: every invariant of invariants_of(model), its first one, or independent_invariants_of(model).
struct all_model_invariants {
    template <class M>
    static auto of(const M& m) {
        return invariants_of(m);
    }
};
/// The first invariant of invariants_of(model) (energy, H, G1, ...): single-invariant relaxation.
struct first_model_invariant {
    template <class M>
    static auto of(const M& m) {
        return pick_invariants(invariants_of(m), {0});
    }
};
/// independent_invariants_of(model).
struct independent_model_invariants {
    template <class M>
    static auto of(const M& m) {
        return independent_invariants_of(m);
    }
};

/// Whether Inv is one of the model-invariant sources above.
template <class Inv>
concept model_invariant_source = std::same_as<Inv, all_model_invariants> || std::same_as<Inv, first_model_invariant> ||
                                 std::same_as<Inv, independent_model_invariants>;

namespace detail {

/// The invariants a stepper with source Inv uses on system f: its own (stored) set, or the model's.
template <class Inv, class F>
decltype(auto) invariants_for(const Inv& stored, const F& f) {
    if constexpr (model_invariant_source<Inv>)
        return Inv::of(model_of(f));
    else
        return (stored);
}

}  // namespace detail

/// Why steps of a relaxation or projection stepper were rejected, and how many were accepted.
struct invariant_stats {
    std::uint64_t accepted = 0;            ///< steps taken
    std::uint64_t rejected_band = 0;       ///< relaxation: gamma outside the acceptable band
    std::uint64_t rejected_solver = 0;     ///< root solve / projection that did not converge (or a singular system)
    solver_stats solver{};                 ///< the iterations of every solve (accepted or not)

    /// All rejected steps.
    std::uint64_t rejected() const { return rejected_band + rejected_solver; }
};

}  // namespace eci
