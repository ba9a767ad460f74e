// The vocabulary of eci: states, systems, steppers and the outcome of one step, as C++20 concepts.
// A system is any callable f(x, dxdt, t), the Boost.Odeint signature, so an odeint system drops in unchanged.
#pragma once

#include <complex>
#include <concepts>
#include <span>
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
/// A stepper that carries state from step to step (transformed_rk's xi, c_pc_compensated's residual) also has
/// `reset()`, which forgets it; the drivers call it when a run starts (see carried_state below).
template <class St, class F, class S>
concept stepper = system<F, S> && requires(St& st, F& f, S& x, double t, double dt) {
    { st.step(f, x, t, dt) } -> std::same_as<step_result>;
    { St::order } -> std::convertible_to<int>;
};

/// A stepper with state carried between steps, and `reset()` to forget it.
template <class St>
concept carries_state = requires(St& st) { st.reset(); };

/// Forget a stepper's carried state, if it has any: the next step starts a new trajectory from its x.
template <class St>
void reset_carried_state(St& st) {
    if constexpr (carries_state<St>) st.reset();
}

/// A stepper that never reports success with a non-finite number in x (it fails the step instead) says so with
/// `static constexpr bool checks_finite = true`; the drivers then skip their own pass over the state.
template <class St>
concept checks_finite = requires { requires St::checks_finite; };

/// A stepper whose step evaluates the system a fixed number of times (no iteration within a step: the explicit
/// Runge-Kutta engines) says so with `static constexpr bool fixed_evaluations = true`; a run then polls its cancel
/// flag before each step only. Any other stepper (an implicit one's Newton iterations) is polled before every
/// evaluation too.
template <class St>
concept fixed_evaluations = requires { requires St::fixed_evaluations; };

/// A system that wraps another (the drivers' evaluation counter, a user's adaptor) exposes it as `wrapped()`,
/// so that a stepper reaches the model being integrated through any number of wrappers.
template <class F>
concept system_wrapper = requires(const F& f) { f.wrapped(); };

/// The model behind a system: f itself, or what its wrappers wrap. Steppers that need more than the right-hand
/// side (a transform, a Jacobian) take it from here, so they always see the parameters of the system they step.
template <class F>
constexpr const auto& model_of(const F& f) {
    if constexpr (system_wrapper<F>)
        return model_of(f.wrapped());
    else
        return f;
}

/// A system that can run the stages of an explicit Runge-Kutta step itself, as the engines would one evaluation at a
/// time and with the same bits (spectral::flow2d::run_stages: its column passes fused across the stages):
/// run_stages(s, a, dt, x, k, y, t) sets k[0] = f(x), k[i] = f(Y_i), Y_i = x + sum_{j<i} (dt a[i s + j]) k_j (the
/// nonzero terms in order: acc = x, then acc += (dt a_ij) k_j), the last Y_i in y; or returns false, having done
/// nothing, and the engine evaluates the stages itself (detail::stage_storage).
template <class F, class S>
concept runs_stages = requires(F& f, const double* a, const S& x, S* k, S& y) {
    { f.run_stages(1, a, 1.0, x, k, y, 0.0) } -> std::convertible_to<bool>;
};

/// A transform in which a system's invariants are sums of xi components. `to_xi(x, xi)` computes xi = T(x);
/// `xi_rate(x, dxdt, rate)` computes dxi/dt at x (dxdt = f(x) is given, so no extra right-hand side is needed);
/// `from_xi(xi, hint, x, stats)` inverts T on the branch of `hint`, recording any iterative solve in `stats`, and
/// reports a non-invertible xi as a failure (the driver then reduces the step, as for a negative radicand).
template <class Tr>
concept invariant_transform =
    state<typename Tr::state_type> && state<typename Tr::xi_type> &&
    requires(const Tr& tr, const typename Tr::state_type& x, typename Tr::state_type& x_out,
             const typename Tr::xi_type& xi, typename Tr::xi_type& xi_out, solver_stats& stats) {
        tr.to_xi(x, xi_out);
        tr.xi_rate(x, x, xi_out);
        { tr.from_xi(xi, x, x_out, stats) } -> std::same_as<step_result>;
    };

/// A model with a linearizing transform, `linearizing_transform()` (Lotka-Volterra's (39), Kepler's (50)): its
/// conservative methods run through the transformed engine.
template <class M>
concept linearizable = requires(const M& m) {
    { m.linearizing_transform() } -> invariant_transform;
};

/// A model with a Jacobian `jacobian(x)` returning J as rows (Kahan's method needs it).
template <class M>
concept has_jacobian = requires(const M& m, const typename M::state_type& x) { m.jacobian(x); };

/// A model whose invariants are sums of squares of its real unknowns (eqs. (4)-(5), errata item 9), on which
/// the conservative engine applies directly: every model without a linearizing transform, unless it opts out with
/// `static constexpr bool quadratic_invariants = false`.
template <class M>
concept quadratic_invariants = !linearizable<M> && !requires {
    requires !static_cast<bool>(M::quadratic_invariants);
};

/// A model that takes part in its own steps (the spectral flows, spectral/flow.hpp), through hooks the drivers
/// detect with these concepts; a model without them compiles to the same code as before. `begin_step(dt)`: before
/// every step of the grid (e.g. a stochastic forcing drawn once per step and held through retries and halvings).
template <class M>
concept begins_steps = requires(M& m, double dt) { m.begin_step(dt); };

/// `begin_attempt()` before and `end_attempt(accepted, dt, b)` after every attempt of a Runge-Kutta stepper, b
/// being the weights of the stepper's tableau: the model records a rate per stage and integrates them with dt b
/// when the attempt is accepted (a budget, exact for any tableau and any number of stages).
template <class M>
concept records_stages = requires(M& m, std::span<const double> b) {
    m.begin_attempt();
    m.end_attempt(true, 1.0, b);
};

/// `begin_retry()` after a failed first attempt of a step: true if the model has switched to another form of its
/// right-hand side in which the whole step is taken again (halved there if it fails) before the driver halves it;
/// `end_retry(completed)` when that step is over, or abandoned by an exception.
template <class M>
concept retries_attempts = requires(M& m) {
    { m.begin_retry() } -> std::convertible_to<bool>;
    m.end_retry(true);
};

}  // namespace eci
