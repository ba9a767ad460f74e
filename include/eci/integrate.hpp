// Drivers: fixed steps to a step count or an end time, an observer (x, t, i) or (x, t) every k steps, run statistics,
// and the step reduction (public: step_with_reduction) that retries a failed step as two half steps.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <concepts>
#include <cstdint>
#include <limits>
#include <type_traits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>

#include "concepts.hpp"

namespace eci {

/// What a run did.
struct run_stats {
    std::uint64_t steps = 0;            ///< steps of the requested size (the output grid)
    std::uint64_t step_reductions = 0;  ///< failed steps that were retried as two half steps
    std::uint64_t rhs_evals = 0;        ///< right-hand-side evaluations, failed attempts included
    solver_stats solver{};              ///< iterative solves (Newton inverses, implicit fallbacks), if any
};

/// Options of the fixed-step drivers.
struct run_options {
    std::uint64_t every = 1;  ///< call the observer every `every` steps (and always at the start and the end)
    int max_halvings = 40;    ///< a step may be halved this often (dt * 2^-40) before the run stops
    /// false (a new run): the driver first calls the stepper's reset(); true: this run continues the trajectory
    /// the stepper is on (a run in segments), and its carried state (xi, residuals) is kept.
    bool resume = false;
};

/// Adds the counts of `more` (a later part of the same run) to `stats`.
inline void accumulate(run_stats& stats, const run_stats& more) {
    stats.steps += more.steps;
    stats.step_reductions += more.step_reductions;
    stats.rhs_evals += more.rhs_evals;
}

/// A step could not be completed even at the smallest allowed size. `stats` holds what the run did until then
/// (completed steps, reductions, evaluations, solves), so a failed run still reports its work.
class step_size_underflow : public std::runtime_error {
   public:
    step_size_underflow(double t, std::size_t component, double dt, run_stats partial = {})
        : std::runtime_error(message(t, component, dt)), time(t), component(component), dt(dt), stats(partial) {}
    double time;
    std::size_t component;
    double dt;
    run_stats stats;  ///< the run's statistics up to the failure

   private:
    static std::string message(double t, std::size_t component, double dt) {
        std::ostringstream os;
        os.precision(17);
        os << "step failed at t = " << t << " in component " << component << " even after halving the step to "
           << dt << " (negative radicand, non-invertible transform or non-finite state)";
        return os.str();
    }
};

namespace detail {

/// The drivers' view of a system: counts its evaluations, and exposes it (wrapped()) to steppers that need the
/// model's transform or Jacobian.
template <class F>
struct counting_system {
    F& f;
    std::uint64_t& count;

    template <class S>
    void operator()(const S& x, S& dxdt, double t) const {
        ++count;
        f(x, dxdt, t);
    }
    const F& wrapped() const { return f; }
};

/// A step, retried as two half steps on failure (recursively, halvings_left more times); eci::step_with_reduction
/// is the public form.
template <class St, class F, class S>
void advance_with_reduction(St& stepper, F& f, S& x, double t, double dt, int halvings_left, run_stats& stats) {
    const step_result r = stepper.step(f, x, t, dt);
    if (r) return;
    if (halvings_left == 0) throw step_size_underflow(t, r.component, dt, stats);
    ++stats.step_reductions;
    advance_with_reduction(stepper, f, x, t, 0.5 * dt, halvings_left - 1, stats);
    advance_with_reduction(stepper, f, x, t + 0.5 * dt, 0.5 * dt, halvings_left - 1, stats);
}

template <class St>
void collect_solver_stats(const St& stepper, run_stats& stats) {
    if constexpr (requires { stepper.solver_statistics(); }) stats.solver = stepper.solver_statistics();
}

/// Calls an observer as (x, t, i) or, odeint-style, as (x, t).
template <class Observer, class S>
void notify(Observer& observe, const S& x, double t, std::uint64_t i) {
    if constexpr (std::invocable<Observer&, const S&, double, std::uint64_t>)
        observe(x, t, i);
    else if constexpr (std::invocable<Observer&, const S&, double>)
        observe(x, t);
    else
        static_assert(std::invocable<Observer&, const S&, double>, "an observer takes (x, t, i) or (x, t)");
}

template <class St, class F, class S, class Observer>
run_stats run_n_steps(St& stepper, F& f, S& x, double t0, double dt, std::uint64_t n, Observer& observe,
                      const run_options& opt) {
    run_stats stats;
    const counting_system<F> counted{f, stats.rhs_evals};
    notify(observe, std::as_const(x), t0, std::uint64_t{0});
    try {
        for (std::uint64_t i = 1; i <= n; ++i) {
            advance_with_reduction(stepper, counted, x, t0 + double(i - 1) * dt, dt, opt.max_halvings, stats);
            ++stats.steps;
            if (i % opt.every == 0 || i == n) notify(observe, std::as_const(x), t0 + double(i) * dt, i);
        }
    } catch (step_size_underflow& e) {
        collect_solver_stats(stepper, e.stats);
        throw;
    }
    collect_solver_stats(stepper, stats);
    return stats;
}

inline void check_step(double dt) {
    if (!(dt > 0.0) || !std::isfinite(dt)) throw std::invalid_argument("time step must be a positive finite number");
}

}  // namespace detail

/// One step of size dt from (x, t), as the drivers take it: a failed step is retried as two half steps, each
/// of which may be halved again, up to `max_halvings` times. Adds the step, its reductions and its right-hand
/// side evaluations to `stats`; throws step_size_underflow (x then holds the last state reached) if even the
/// smallest step fails. For loops of one's own that need the drivers' robustness step by step.
template <state S, system<S> F, stepper<F, S> St>
void step_with_reduction(St& stepper, F&& f, S& x, double t, double dt, run_stats& stats,
                         int max_halvings = run_options{}.max_halvings) {
    const detail::counting_system<std::remove_reference_t<F>> counted{f, stats.rhs_evals};
    detail::advance_with_reduction(stepper, counted, x, t, dt, max_halvings, stats);
    ++stats.steps;
}

/// Observer that does nothing.
struct no_observer {
    template <class S>
    void operator()(const S&, double, std::uint64_t) const {}
};

/// Take `n` steps of size dt from (x, t0). The observer sees (x, t, step index), or (x, t), at step 0, every
/// `opt.every` steps and at step n. Times are t0 + i dt, never accumulated, so they stay on the grid. The
/// stepper's carried state is reset first unless `opt.resume`.
template <state S, system<S> F, stepper<F, S> St, class Observer = no_observer>
run_stats integrate_n_steps(St& stepper, F&& f, S& x, double t0, double dt, std::uint64_t n, Observer&& observe = {},
                            run_options opt = {}) {
    detail::check_step(dt);
    if (opt.every == 0) throw std::invalid_argument("observer interval must be at least 1");
    if (!opt.resume) reset_carried_state(stepper);
    return detail::run_n_steps(stepper, f, x, t0, dt, n, observe, opt);
}

/// The number of steps of size dt that reach t_end from t0; a last step that would overshoot by more than
/// round-off is shortened (see integrate_to).
inline std::uint64_t steps_to_reach(double t0, double t_end, double dt) {
    const double q = (t_end - t0) / dt;
    return static_cast<std::uint64_t>(std::ceil(q - 1e-9 * std::max(1.0, q)));
}

/// Step from t0 to t_end with steps of dt; the last step is shortened to land on t_end exactly. Observer,
/// options and reset as for integrate_n_steps.
template <state S, system<S> F, stepper<F, S> St, class Observer = no_observer>
run_stats integrate_to(St& stepper, F&& f, S& x, double t0, double t_end, double dt, Observer&& observe = {},
                       run_options opt = {}) {
    if (!(t_end >= t0) || !std::isfinite(t_end)) throw std::invalid_argument("end time must be finite and >= start");
    detail::check_step(dt);
    if (opt.every == 0) throw std::invalid_argument("observer interval must be at least 1");
    if (!opt.resume) reset_carried_state(stepper);
    const std::uint64_t n = steps_to_reach(t0, t_end, dt);
    if (n == 0) {
        detail::notify(observe, std::as_const(x), t0, std::uint64_t{0});
        return {};
    }
    const double last = t_end - (t0 + double(n - 1) * dt);
    if (std::abs(last - dt) <= 1e-12 * dt) {
        // t0 + n dt may miss t_end by round-off (3 * 0.1 != 0.3): the last observation reports t_end itself.
        auto observe_end = [&](const S& s, double t, std::uint64_t i) {
            detail::notify(observe, s, i == n ? t_end : t, i);
        };
        return detail::run_n_steps(stepper, f, x, t0, dt, n, observe_end, opt);
    }
    // The grid holds n - 1 full steps, then one shorter step to t_end.
    auto observe_full = [&](const S& s, double t, std::uint64_t i) {
        if (i % opt.every == 0 || i == 0) detail::notify(observe, s, t, i);
    };
    run_stats stats = detail::run_n_steps(stepper, f, x, t0, dt, n - 1, observe_full, opt);
    no_observer none;
    try {
        accumulate(stats, detail::run_n_steps(stepper, f, x, t0 + double(n - 1) * dt, last, 1, none, opt));
    } catch (step_size_underflow& e) {
        accumulate(e.stats, stats);
        throw;
    }
    detail::collect_solver_stats(stepper, stats);
    detail::notify(observe, std::as_const(x), t_end, n);
    return stats;
}

}  // namespace eci
