// Invariants as functions of the state (value and gradient): what relaxation Runge-Kutta and orthogonal projection
// need to keep them. Models offer theirs (models/invariant_sets.hpp); a user builds one from lambdas.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <concepts>
#include <cstdint>
#include <cstddef>
#include <initializer_list>
#include <stdexcept>
#include <string>
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
invariant_subset<Set> pick_invariants(Set set, std::initializer_list<std::size_t> which) {
    if (which.size() == 0) throw std::invalid_argument("pick at least one invariant");
    for (std::size_t i : which)
        if (i >= set.count())
            throw std::invalid_argument("invariant " + std::to_string(i) + " does not exist (the set has " +
                                        std::to_string(set.count()) + ")");
    return {std::move(set), std::vector<std::size_t>(which)};
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

/// A rounding scale of invariant i at x: |x| |grad I| (Euclidean norms over the real unknowns), the size of the
/// terms whose rounding makes up the error of evaluating I (for a homogeneous I of degree d it bounds d |I|). It
/// does not vanish where some terms do (the Runge-Lenz vector's zero component at an apsis).
template <state S, class Set>
double rounding_scale(const Set& inv, const S& x, std::size_t i, S& g) {
    inv.gradient(x, i, g);
    const auto a = reals(x), b = reals(std::as_const(g));
    double xx = 0.0, gg = 0.0;
    for (std::size_t j = 0; j < a.size(); ++j) xx += a[j] * a[j], gg += b[j] * b[j];
    return std::sqrt(xx * gg);
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

/// Invariant sources for the steppers' `Inv` parameter that take the invariants from the model being stepped
/// (model_of(f): found through the system's wrappers), so the registry can build such a stepper without the
/// model's parameters: every invariant of invariants_of(model), its first one, or independent_invariants_of(model)
/// (a set whose gradients are independent wherever the model is integrable: what projection and multiple
/// relaxation need). Those functions are in models/invariant_sets.hpp, which must be included where the stepper runs.
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
