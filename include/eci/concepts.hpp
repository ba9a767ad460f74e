// The vocabulary of eci: states, systems, steppers and the outcome of one step, as C++20 concepts.
// A system is any callable f(x, dxdt, t), the Boost.Odeint signature, so an odeint system drops in unchanged.
#pragma once

#include <complex>
#include <concepts>
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <ranges>
#include <type_traits>

namespace eci {

/// A scalar eci integrates: a real number, or a complex one treated as two real unknowns (paper §III.C).
template <class T>
concept scalar = std::same_as<T, double> || std::same_as<T, std::complex<double>>;

/// A state: a contiguous, sized, copyable range of scalars (std::vector, std::array, ...).
template <class S>
concept state = std::ranges::contiguous_range<S> && std::ranges::sized_range<S> && std::copyable<S> &&
                scalar<std::ranges::range_value_t<S>>;

/// A system: the right-hand side f(x, dxdt, t) writing dx/dt into dxdt.
template <class F, class S>
concept system = state<S> && std::invocable<F&, const S&, S&, double>;

/// The outcome of one step. A failed step (a negative radicand, a transform that cannot be inverted, an
/// implicit solve that does not converge) is a normal outcome: the state is left as it was and the driver
/// retries with smaller steps. `component` names the first real unknown that failed.
struct step_result {
    bool ok = true;
    std::size_t component = 0;

    static constexpr step_result success() { return {}; }
    static constexpr step_result failure(std::size_t component) { return {false, component}; }
    explicit constexpr operator bool() const { return ok; }
};

/// Counts of the iterative solves a stepper makes (Newton inverses, implicit fallbacks).
struct solver_stats {
    std::uint64_t solves = 0;      ///< how many iterative solves ran
    std::uint64_t iterations = 0;  ///< their iterations, summed
    int max_iterations = 0;        ///< the most any one solve needed

    void record(int iterations_of_one_solve) {
        ++solves;
        iterations += static_cast<std::uint64_t>(iterations_of_one_solve);
        max_iterations = std::max(max_iterations, iterations_of_one_solve);
    }
    double mean_iterations() const { return solves ? double(iterations) / double(solves) : 0.0; }
};

/// A stepper: `step(f, x, t, dt)` advances x in place, or leaves it untouched and reports failure.
template <class St, class F, class S>
concept stepper = system<F, S> && requires(St& st, F& f, S& x, double t, double dt) {
    { st.step(f, x, t, dt) } -> std::same_as<step_result>;
    { St::order } -> std::convertible_to<int>;
};

}  // namespace eci
