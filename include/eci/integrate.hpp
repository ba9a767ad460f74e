// Fixed steps to a step count or an end time, through the one run loop (detail/run_loop.hpp) with the fixed-step
// controller: an observer (x, t, i) or (x, t) every k steps, run statistics, the model's quadratic invariants
// handed to the stepper's remedy, the step reduction (public: step_with_reduction) that retries a failed step as
// two half steps, a bound on the work of one step, a non-finite check of every step and a cancellation hook.
#pragma once

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstddef>
#include <concepts>
#include <cstdint>
#include <functional>
#include <limits>
#include <optional>
#include <ranges>
#include <span>
#include <type_traits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "concepts.hpp"
#include "invariants.hpp"
#include "steps.hpp"
#include "steppers/radicand_remedy.hpp"
#include "detail/run_loop.hpp"
#include "detail/state_ops.hpp"

namespace eci {

/// What a run did.
struct run_stats {
    std::uint64_t steps = 0;            ///< steps of the requested size (the output grid)
    std::uint64_t step_reductions = 0;  ///< failed steps that were retried as two half steps
    std::uint64_t rhs_evals = 0;        ///< right-hand-side evaluations, failed attempts included
    solver_stats solver{};              ///< iterative solves (Newton inverses, implicit fallbacks), if any
    std::uint64_t remedied_steps = 0;       ///< steps whose negative radicands were remedied without a halving
    std::uint64_t components_remedied = 0;  ///< real unknowns given the remedy, summed over those steps
    /// Of the step_reductions, those whose attempt the system stopped by reporting a non-finite rate
    /// (eci::non_finite_rate: a user's function returning inf or nan).
    std::uint64_t non_finite_rate_reductions = 0;
};

/// Thrown by a system that cannot give a finite rate at a state (a user's function returned inf or nan) and says
/// so with `static constexpr bool reports_non_finite_rate = true`. The drivers treat it as a failed attempt:
/// retried smaller (fixed steps) or rejected (adaptive), counted apart from negative radicands.
struct non_finite_rate {
    std::size_t component;  ///< the real unknown whose rate was not finite
    double value;           ///< that value (inf or nan)
};

/// Whether a system may throw eci::non_finite_rate (the drivers then catch it around each attempt; a system that
/// never does pays for no handler).
template <class F>
concept reports_non_finite_rate = requires { requires std::remove_cvref_t<F>::reports_non_finite_rate; };

/// Options of the fixed-step drivers.
struct run_options {
    /// The default of max_halvings, as a constant: a default argument `run_options{}.max_halvings` builds (and
    /// destroys: its std::function) a run_options at every call.
    static constexpr int default_max_halvings = 40;
    std::uint64_t every = 1;  ///< call the observer every `every` steps (and always at the start and the end)
    int max_halvings = default_max_halvings;  ///< a step may be halved this often (dt * 2^-40) before the run stops
    /// false (a new run): the driver first calls the stepper's reset(); true: this run continues the trajectory
    /// the stepper is on (a run in segments), and its carried state (xi, residuals) is kept.
    bool resume = false;
    /// Bound on the attempts (sub-steps, failed ones included) of one step of the grid: halving alone could
    /// otherwise spend up to 2^max_halvings sub-steps on one step (a state drifting into subnormal numbers).
    std::uint64_t max_substeps = std::uint64_t{1} << 16;
    /// Polled before every sub-step and every right-hand-side evaluation: when it reads true the driver
    /// throws eci::interrupted, leaving x at the last completed sub-step. Null: never cancelled.
    const std::atomic<bool>* cancel = nullptr;
    /// Asked after a failed attempt, before it is halved (a cascade of halvings can take long), and nowhere else:
    /// true throws eci::interrupted with x part-way through the step. Being asked at the same points on every
    /// process, it may be collective (MPI: a stop agreed by all). Empty: never asked.
    std::function<bool()> stop_between_attempts{};
    /// The run continues the grid t0 + i dt from step first_step (a restart from a checkpoint): step times and
    /// observer indices count from there, and the observer's cadence is on those indices (integrate_n_steps, and
    /// integrate_to, whose last step is still shortened to land on its end time).
    std::uint64_t first_step = 0;
};

/// Adds the counts of `more` (a later part of the same run) to `stats`.
inline void accumulate(run_stats& stats, const run_stats& more) {
    stats.steps += more.steps;
    stats.step_reductions += more.step_reductions;
    stats.rhs_evals += more.rhs_evals;
    stats.remedied_steps += more.remedied_steps;
    stats.components_remedied += more.components_remedied;
    stats.non_finite_rate_reductions += more.non_finite_rate_reductions;
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
    /// Set when the last attempt failed because the system reported a non-finite rate (its value).
    std::optional<double> non_finite_rate_value;

   private:
    static std::string message(double t, std::size_t component, double dt) {
        std::ostringstream os;
        os.precision(17);
        os << "step failed at t = " << t << " in component " << component << " even after halving the step to "
           << dt << " (negative radicand, non-invertible transform or non-finite state)";
        return os.str();
    }
};

/// One step of the grid needed more than run_options::max_substeps attempts.
class step_work_exceeded : public std::runtime_error {
   public:
    step_work_exceeded(double t, double dt, std::uint64_t attempts, double smallest)
        : std::runtime_error(message(t, dt, attempts, smallest)), time(t), dt(dt), attempts(attempts) {}
    double time;              ///< start of the step
    double dt;                ///< its size
    std::uint64_t attempts;   ///< sub-steps tried, failed ones included

   private:
    static std::string message(double t, double dt, std::uint64_t attempts, double smallest) {
        std::ostringstream os;
        os.precision(17);
        os << "the step at t = " << t << " (dt = " << dt << ") took more than " << attempts
           << " sub-steps (halved down to " << smallest << ") without finishing";
        return os.str();
    }
};

/// A stepper reported success but left a non-finite number in the state (a blow-up, or a stepper without a
/// check of its own); the state is not a result.
class non_finite_state : public std::runtime_error {
   public:
    non_finite_state(double t, std::size_t component)
        : std::runtime_error(message(t, component)), time(t), component(component) {}
    double time;            ///< end of the step that produced it
    std::size_t component;  ///< first real unknown that is not finite

   private:
    static std::string message(double t, std::size_t component) {
        std::ostringstream os;
        os.precision(17);
        os << "the state became non-finite at t = " << t << " in component " << component;
        return os.str();
    }
};

/// The run was cancelled through run_options::cancel.
class interrupted : public std::runtime_error {
   public:
    explicit interrupted(double t) : std::runtime_error(message(t)), time(t) {}
    double time;  ///< start of the sub-step that was not taken

   private:
    static std::string message(double t) {
        std::ostringstream os;
        os.precision(17);
        os << "interrupted at t = " << t;
        return os.str();
    }
};

/// Observer that does nothing.
struct no_observer {
    template <class S>
    void operator()(const S&, double, std::uint64_t) const {}
};

namespace detail {

/// What the drivers' views of a system (counting_system, held_count) share: the system, exposed (wrapped()) to
/// steppers that need the model's transform or Jacobian and (hooks()) for the hooks of a model that takes part in
/// its steps (concepts.hpp); and an evaluation, counted after the cancel flag is polled.
template <class F>
struct system_view {
    F& f;
    static constexpr bool reports_non_finite_rate = eci::reports_non_finite_rate<F>;
    const F& wrapped() const { return f; }
    F& hooks() const { return f; }

   protected:
    // (always inlined: in a translation unit that compiles every method of a model the inliner's budget runs out
    // before the wrappers, which then cost a call per evaluation in the CLI's runs)
    template <class S>
    [[gnu::always_inline]] void evaluate(const S& x, S& dxdt, double t, std::uint64_t& count,
                                         const std::atomic<bool>* cancel) const {
        if (cancel && cancel->load(std::memory_order_relaxed)) throw interrupted(t);  // (inside Newton iterations too)
        ++count;
        f(x, dxdt, t);
    }
    /// A model that runs a Runge-Kutta step's stages itself (flow2d::run_stages; detail::stage_storage asks),
    /// counted as `stages` evaluations, after the cancel flag is polled once.
    template <class S>
    bool evaluate_stages(int stages, const double* a, double dt, const S& x, S* k, S& y, double t,
                         std::uint64_t& count, const std::atomic<bool>* cancel) const {
        if (cancel && cancel->load(std::memory_order_relaxed)) throw interrupted(t);
        if (!f.run_stages(stages, a, dt, x, k, y, t)) return false;
        count += std::uint64_t(stages);
        return true;
    }
};

/// The drivers' view of a system: counts its evaluations into `count`.
template <class F>
struct counting_system : system_view<F> {
    std::uint64_t& count;
    const std::atomic<bool>* cancel = nullptr;  ///< polled before every evaluation

    counting_system(F& f, std::uint64_t& count, const std::atomic<bool>* cancel = nullptr)
        : system_view<F>{f}, count(count), cancel(cancel) {}
    template <class S>
    [[gnu::always_inline]] void operator()(const S& x, S& dxdt, double t) const {
        this->evaluate(x, dxdt, t, count, cancel);
    }
    template <class S>
        requires runs_stages<F, S>
    bool run_stages(int stages, const double* a, double dt, const S& x, S* k, S& y, double t) const {
        return this->evaluate_stages(stages, a, dt, x, k, y, t, count, cancel);
    }
};

/// The model whose step hooks the drivers call: f, or the system a counting wrapper counts for.
template <class F>
constexpr auto& hook_target(F& f) {
    if constexpr (requires { f.hooks(); })
        return f.hooks();
    else
        return f;
}

/// The tableau of a Runge-Kutta stepper (explicit_rk, conservative_rk): its weights weigh a model's stage rates.
template <class St>
struct tableau_of {
    static constexpr const auto& value = St::tableau;
};

/// Whether every real unknown of x is finite: one pass over the exponent bits, vectorizable.
template <state S>
bool all_finite(const S& x) {
    const auto r = reals(x);
    return all_finite_reals(r.data(), r.size());
}

/// The first real unknown of x that is not finite (0 if all are).
template <state S>
std::size_t first_non_finite(const S& x) {
    const auto r = reals(x);
    return first_index(r.size(), [&](std::size_t i) { return !std::isfinite(r[i]); });
}

/// The step indices from `from` on that are multiples of `every`, asked in turn (due(i) for i = from, from + 1,
/// ...): i % every == 0 without a division at every step of a run.
class multiples_of {
   public:
    multiples_of(std::uint64_t every, std::uint64_t from) : every_(every) {
        const std::uint64_t q = from / every + (from % every != 0 ? 1 : 0);
        if (__builtin_mul_overflow(q, every, &next_)) next_ = std::numeric_limits<std::uint64_t>::max();
    }
    bool due(std::uint64_t i) {
        if (i != next_) return false;
        if (__builtin_add_overflow(next_, every_, &next_)) next_ = std::numeric_limits<std::uint64_t>::max();
        return true;
    }

   private:
    std::uint64_t every_;
    std::uint64_t next_;
};

/// After a successful step to time t: a non-finite x stops the run, unless the stepper checked that itself.
template <class St, state S>
void check_finite_after(const S& x, double t) {
    if constexpr (!checks_finite<St>)
        if (!all_finite(x)) throw non_finite_state(t, first_non_finite(x));
}

/// The run's cancel flag, or one never set: a run polls it without testing for null first.
inline const std::atomic<bool>* cancel_flag(const run_options& opt) {
    static const std::atomic<bool> never{false};
    return opt.cancel ? opt.cancel : &never;
}

inline void poll_cancel(const run_options& opt, double t) {
    if (opt.cancel && opt.cancel->load(std::memory_order_relaxed)) throw interrupted(t);
}

/// Before halving a failed attempt: the front end's stop (run_options::stop_between_attempts).
inline void poll_stop(const run_options& opt, double t) {
    if (opt.stop_between_attempts && opt.stop_between_attempts()) throw interrupted(t);
}

/// stepper.step, or with `Local` (x is the run loop's working copy: steps_in_registers) stepper.step_local.
template <bool Local, class St, class F, class S>
[[gnu::always_inline]] inline step_result step_once(St& stepper, F& f, S& x, double t, double dt) {
    if constexpr (Local)
        return stepper.step_local(f, x, t, dt);
    else
        return stepper.step(f, x, t, dt);
}

template <bool Local, class St, class F, class S>
[[gnu::always_inline]] inline step_result attempt_unhooked(St& stepper, F& f, S& x, double t, double dt,
                                                        std::optional<double>& rate) {
    if constexpr (reports_non_finite_rate<F>) {
        try {
            return step_once<Local>(stepper, f, x, t, dt);
        } catch (const non_finite_rate& e) {
            rate = e.value;
            return step_result::failure(e.component);
        }
    } else {
        return step_once<Local>(stepper, f, x, t, dt);
    }
}

/// One attempt of stepper.step; a non-finite rate reported by the system (eci::non_finite_rate) is a failed
/// attempt whose value is kept in `rate` (left as is otherwise). A model that records its stages (concepts.hpp)
/// is told where the attempt begins and ends, and given the tableau's weights.
template <bool Local, class St, class F, class S>
[[gnu::always_inline]] inline step_result attempt_step(St& stepper, F& f, S& x, double t, double dt,
                                                    std::optional<double>& rate) {
    if constexpr (records_stages<std::remove_reference_t<decltype(hook_target(f))>>) {
        auto& m = hook_target(f);
        static_assert(requires { St::tableau.b; },
                      "a model that records its rates per stage is stepped by a Runge-Kutta stepper with a tableau");
        m.begin_attempt();
        std::optional<step_result> r;
        try {
            r = attempt_unhooked<Local>(stepper, f, x, t, dt, rate);
        } catch (...) {
            m.end_attempt(false, dt, std::span<const double>{});
            throw;
        }
        m.end_attempt(bool(*r), dt, std::span<const double>(tableau_of<St>::value.b));
        return *r;
    } else {
        return attempt_unhooked<Local>(stepper, f, x, t, dt, rate);
    }
}

/// An attempt of the fixed-step controller: a step of dt at halving depth `depth` (0: the whole step). Where it
/// starts the controller computes from its position (fixed_control::time_of).
struct fixed_attempt {
    double dt;
    int depth;
};

/// Whether a stepper takes a small state in registers (step_local: explicit_rk and conservative_rk on a
/// small_real_array): the fixed-step run then steps a copy of the state held by the run loop's position, written
/// back to the run's state after every accepted attempt (a store off the step's chain of dependent arithmetic).
template <class St, class F>
concept steps_in_registers = requires { requires St::template in_registers<F>; };

/// The state a fixed-step run steps: the run's own, or (steps_in_registers) a copy in the run loop's position.
template <class S, bool Copy>
struct working_state {
    S* x;
    S& get() { return *x; }
    void publish(S&) const {}
};
template <class S>
struct working_state<S, true> {
    S x;
    S& get() { return x; }
    void publish(S& to) const { to = x; }
};

/// The fixed-step run's counting_system: the count is held by value in the run loop's position (a copy of this), so
/// that it stays in a register across a run of a small system (through a reference it was stored at every
/// evaluation), and stored at `home` (the run's statistics) where it is read: when the run ends, before an
/// observer that takes the statistics sees them and before a failed attempt (fixed_control::sync). A run that
/// throws from within a step (eci::interrupted, a model's exception) returns no statistics, so none is stored then.
/// PollsEach: whether the cancel flag is polled before every evaluation (else the run polls it before each step).
template <class F, bool PollsEach = true>
struct held_count : system_view<F> {
    std::uint64_t* home;
    const std::atomic<bool>* cancel;
    mutable std::uint64_t count;

    held_count(F& f, std::uint64_t* home, const std::atomic<bool>* cancel = nullptr)
        : system_view<F>{f}, home(home), cancel(cancel), count(*home) {}
    template <class S>
    [[gnu::always_inline]] void operator()(const S& x, S& dxdt, double t) const {
        this->evaluate(x, dxdt, t, count, PollsEach ? cancel : nullptr);
    }
    template <class S>
        requires runs_stages<F, S>
    bool run_stages(int stages, const double* a, double dt, const S& x, S* k, S& y, double t) const {
        return this->evaluate_stages(stages, a, dt, x, k, y, t, count, PollsEach ? cancel : nullptr);
    }
    void store() const { *home = count; }
};

/// The system a fixed-step run's attempts evaluate, held by its position: F itself (by address), or a copy of a
/// held_count.
template <class F>
struct run_system {
    F* f;
    static run_system of(F& f) { return {&f}; }
    F& attempt() const { return *f; }
    void attempted(F&) {}
    void store() const {}
};
template <class F, bool P>
struct run_system<const held_count<F, P>> {
    held_count<F, P> h;
    static run_system of(const held_count<F, P>& c) {
        run_system r{c};
        r.h.count = *c.home;  // from where the count stands (one held_count serves solve's every side step)
        return r;
    }
    // A copy for each attempt, its count taken back after: a stepper's cold paths (conservative_rk's step_apart)
    // take the system by reference, and given the position's own, the whole position stayed in memory (three-wave
    // C-PC 195 -> 177 instructions per step, C-RK4 344 -> 292).
    held_count<F, P> attempt() const { return h; }
    void attempted(const held_count<F, P>& a) { h.count = a.count; }
    void store() const { h.store(); }
};

/// The system a fixed-step run of stepper St evaluates: F counted, and polled for a cancellation before every
/// evaluation unless St's steps evaluate a fixed number of times (then propose polls before each step: one poll
/// per RK4 step instead of five, a tenth of a three-wave step).
template <class St, class F>
using run_count = held_count<F, !fixed_evaluations<St>>;

/// The fixed-step controller of run_loop: steps first + 1 .. first + n of the grid t0 + k dt, the last of size
/// `last` (dt, unless integrate_to shortens it to land on its end time). A failed attempt is first offered to a
/// model that retries the whole step in another form (retries_attempts), then replaced by two half steps, depth
/// first (an explicit stack of at most max_halvings + 1 depths): at most opt.max_substeps attempts per step of the
/// grid. With `announce`, the model's begin_step(size) precedes each step (begins_steps).
template <class St, class F, class S, bool Copy = steps_in_registers<St, F>>
class fixed_control {
    using model = std::remove_reference_t<decltype(hook_target(std::declval<F&>()))>;

   public:
    /// Where the run is: the step of the grid being taken (k), its size, and the state stepped; with what
    /// every step reads or counts that the controller would hold in memory (the system, whose evaluation count a
    /// held_count keeps here, the cancel flag, whether the step is being halved), so that a run keeps it in
    /// registers. (The grid's constants stay members: in the position they took three more of a small state's
    /// step's floating-point registers, and the state itself went to memory.)
    struct position {
        std::uint64_t k;
        double size;
        working_state<S, Copy> state;
        run_system<F> system;
        const std::atomic<bool>* cancel;  // never null (cancel_flag)
        bool halving;  // the step is being taken in pieces
        /// The index of the last complete step of the grid.
        std::uint64_t completed() const { return k - 1; }
    };

    fixed_control(St& stepper, F& f, S& x, double t0, double dt, std::uint64_t first, std::uint64_t n, double last,
                  bool announce, const run_options& opt, run_stats& stats)
        : stepper_(stepper), f_(f), x_(x), t0_(t0), dt_(dt), last_(last), first_(first),
          end_(first + n), announce_(announce), opt_(opt), stats_(stats) {}

    /// Takes the steps, calling on_step(position) after each; a model's retry in progress is ended if the run throws.
    template <class OnStep>
    void run(OnStep&& on_step) {
        if constexpr (retries_attempts<model>) {
            try {
                run_loop(*this, on_step);
            } catch (...) {
                end_retries();
                throw;
            }
        } else {
            run_loop(*this, on_step);
        }
    }

    /// The same for a run whose first step's whole attempt was taken outside (advance_with_reduction) and failed
    /// with `r` (`rate`: the system's non-finite rate, if that was the cause): it is rejected as the loop would
    /// have rejected it, and the loop goes on from there.
    template <class OnStep>
    void run_after_failed(const step_result& r, std::optional<double> rate, OnStep&& on_step) {
        auto at = start();
        rate_ = rate;
        try {
            reject({at.size, 0}, r, at);
            run_loop_from(*this, at, on_step);
        } catch (...) {
            end_retries();
            throw;
        }
    }

    position start() const {
        const double size = end_ == first_ + 1 ? last_ : dt_;
        auto system = run_system<F>::of(f_);
        if constexpr (Copy)
            return {first_ + 1, size, {x_}, system, cancel_flag(opt_), false};
        else
            return {first_ + 1, size, {&x_}, system, cancel_flag(opt_), false};
    }

    /// Stores what the position counts where the run's statistics read it: the evaluations (a held_count's), and
    /// the last complete step of the grid (completed()).
    void sync(const position& at) {
        at.system.store();
        completed_ = at.completed();
    }
    void leave(const position& at) { sync(at); }
    /// The last complete step of the grid when the run last synced (ended, observed, or failed an attempt).
    std::uint64_t completed() const { return completed_; }

    bool more(const position& at) const { return at.k <= end_; }

    fixed_attempt propose(const position& at) {
        if (!at.halving) [[likely]] {
            if constexpr (begins_steps<model>)
                if (announce_ && retries_ == 0) hook_target(f_).begin_step(at.size);
            if (at.cancel->load(std::memory_order_relaxed)) throw interrupted(start_of(at));
            return {at.size, 0};
        }
        return propose_piece(start_of(at), at.size);
    }

    // (always inlined, as the attempt's wrappers above: a conservative stepper's step made the inliner stop at this
    // call, which then took the position's address)
    [[gnu::always_inline]] step_result attempt(const fixed_attempt& a, position& at) {
        if constexpr (reports_non_finite_rate<F>) rate_.reset();  // else never set
        auto&& system = at.system.attempt();
        const step_result r = attempt_step<Copy>(stepper_, system, at.state.get(), time_of(a, at), a.dt, rate_);
        at.system.attempted(system);
        return r;
    }

    static bool acceptable(const step_result& r) { return bool(r); }

    bool accept(const fixed_attempt& a, const step_result&, position& at) {
        at.state.publish(x_);
        check_finite_after<St>(x_, time_of(a, at) + a.dt);
        if (at.halving) [[unlikely]] {  // a piece of a halved step (propose tested the same flag)
            if (!piece_taken(a)) return false;
            at.halving = false;
        }
        if constexpr (retries_attempts<model>)
            for (; retries_ > 0; --retries_) hook_target(f_).end_retry(true);
        ++at.k;
        if (at.k == end_) at.size = last_;  // (every earlier step is of size dt)
        return true;
    }

    void reject(const fixed_attempt& a, const step_result& r, position& at) {
        sync(at);  // (a step_size_underflow carries the run's statistics)
        if (reject_attempt(a, r, time_of(a, at))) at.halving = true;
    }

   private:
    // A model's retry in progress when the run throws is ended.
    void end_retries() {
        if constexpr (retries_attempts<model>)
            for (; retries_ > 0; --retries_) hook_target(f_).end_retry(false);
    }

    // The start of step k of the grid, t0 + (k - 1) dt (k <= max_grid_steps, run_grid's check: exact as signed),
    // and of an attempt (a piece of a halved step starts offset_ later). Computed where each use needs it, not
    // carried in the position or the attempt: a system that ignores t (three-wave) then computes it only on the cold
    // paths that report it (carried, it cost a three-wave PC step in a run's loop 3 %).
    double start_of(const position& at) const { return t0_ + double(std::int64_t(at.k - 1)) * dt_; }
    double time_of(const fixed_attempt& a, const position& at) const {
        const double t = start_of(at);
        return a.depth == 0 ? t : t + offset_;
    }

    // A failed attempt: a model's retry, or the step's halving begun or continued (true when it begins), or
    // step_size_underflow. Out of line and by value (a failed attempt is rare): inlined into the loop, or taking
    // the result by reference, the result was built in memory at every step.
    [[gnu::noinline]] bool reject_attempt(fixed_attempt a, step_result r, double t) {
        if (a.depth == 0) {
            if constexpr (retries_attempts<model>)
                if (hook_target(f_).begin_retry()) {  // the whole step again in the model's other form
                    ++retries_;
                    return false;
                }
            if (opt_.max_halvings <= 0) throw underflow(a, r, t);
            poll_stop(opt_, t);
            count_reduction();
            pending_.assign({1, 1});  // depths of the pieces still to take, the next one last
            offset_ = 0.0;
            attempts_ = 1;
            smallest_ = a.dt;
            return true;
        }
        if (a.depth >= opt_.max_halvings) throw underflow(a, r, t);
        poll_stop(opt_, t);
        count_reduction();
        pending_.push_back(a.depth + 1);
        pending_.push_back(a.depth + 1);
        return false;
    }
    // A piece of a halved step taken: whether it completes the step of the grid.
    bool piece_taken(const fixed_attempt& a) {
        offset_ += a.dt;  // sum of pieces taken: multiples of size 2^-depth, exact
        return pending_.empty();
    }
    /// The next piece of a step of the grid (from t, of size `size`) being taken in pieces.
    fixed_attempt propose_piece(double t, double size) {
        const int depth = pending_.back();
        pending_.pop_back();
        const double h = std::ldexp(size, -depth);
        smallest_ = std::min(smallest_, h);
        if (++attempts_ > opt_.max_substeps) throw step_work_exceeded(t, size, opt_.max_substeps, smallest_);
        const double ts = t + offset_;
        poll_cancel(opt_, ts);
        return {h, depth};
    }
    step_size_underflow underflow(const fixed_attempt& a, const step_result& r, double t) const {
        step_size_underflow e(t, r.component, a.dt, stats_);
        e.non_finite_rate_value = rate_;
        return e;
    }
    void count_reduction() {
        ++stats_.step_reductions;
        if (rate_) ++stats_.non_finite_rate_reductions;
        rate_.reset();
    }

    St& stepper_;
    F& f_;
    S& x_;
    double t0_, dt_, last_;
    std::uint64_t first_, end_;  // the steps of the grid are first + 1 .. end
    std::uint64_t completed_ = first_;
    bool announce_;
    const run_options& opt_;
    run_stats& stats_;
    std::optional<double> rate_;  // the non-finite rate that failed the last attempt, if that was the cause
    int retries_ = 0;             // the model's retries of this step in progress
    std::vector<int> pending_;
    double offset_ = 0.0;
    std::uint64_t attempts_ = 0;
    double smallest_ = 0.0;
};

/// A step's whole attempt as the fixed-step controller's first attempt takes it (the system's non-finite rate a
/// failure, kept in `rate`; a held count stored; an accepted state checked finite): x advanced on success, left as
/// it was on failure. advance_with_reduction and step_with_reduction take it before building a controller, which
/// only a failed step needs: built for every step, it cost a three-wave step taken one call at a time ~100
/// instructions (PC 63 -> 165, 2x odeint's Heun; bench/step_bench.cpp's three_wave rows).
template <class St, class F, class S>
[[gnu::always_inline]] inline step_result attempt_whole_step(St& stepper, F& f, S& x, double t, double dt,
                                                             std::optional<double>& rate) {
    const step_result r = attempt_step<false>(stepper, f, x, t, dt, rate);
    if constexpr (requires { f.store(); }) f.store();
    if (r) [[likely]] check_finite_after<St>(x, t + dt);
    return r;
}

/// A step whose whole attempt (attempt_whole_step) failed with `r`: the fixed-step controller halves it from there.
/// Out of line: it is rare, and inlined it made a small system's step too large a caller for its stages to be
/// inlined.
template <class St, class F, class S>
[[gnu::noinline]] void halve_failed_step(St& stepper, F& f, S& x, double t, double dt, const run_options& opt,
                                         run_stats& stats, step_result r, std::optional<double> rate) {
    fixed_control<St, F, S, false> control(stepper, f, x, t, dt, 0, 1, dt, false, opt, stats);
    control.run_after_failed(r, rate, [](const auto&) {});
}

/// One step of the grid from t to t + dt (eci::step_with_reduction is the public form): the fixed-step controller
/// over a single step, halving a failed attempt; the whole step attempted first without it (attempt_whole_step).
template <class St, class F, class S>
void advance_with_reduction(St& stepper, F& f, S& x, double t, double dt, const run_options& opt, run_stats& stats) {
    poll_cancel(opt, t);
    std::optional<double> rate;
    const step_result r = attempt_whole_step(stepper, f, x, t, dt, rate);
    if (!r) [[unlikely]] halve_failed_step(stepper, f, x, t, dt, opt, stats, r, rate);
}

/// The same with the default bounds and `max_halvings` (for tests that take a step without counting it).
template <class St, class F, class S>
void advance_with_reduction(St& stepper, F& f, S& x, double t, double dt, int max_halvings, run_stats& stats) {
    run_options opt;
    opt.max_halvings = max_halvings;
    advance_with_reduction(stepper, f, x, t, dt, opt, stats);
}

/// step_with_reduction's failed step: halved by the controller, at most `max_halvings` times, its attempts counted
/// into stats (through a counting_system: a type of its own, so that the whole attempt's system, a held_count, has
/// one caller of the stepper's step and it is inlined there).
template <class St, class G, class S>
[[gnu::noinline]] void halve_failed_step(St& stepper, G& f, S& x, double t, double dt, int max_halvings,
                                         run_stats& stats, step_result r, std::optional<double> rate) {
    run_options opt;
    opt.max_halvings = max_halvings;
    const counting_system<G> counted{f, stats.rhs_evals};
    halve_failed_step(stepper, counted, x, t, dt, opt, stats, r, rate);
}

template <class St>
void collect_solver_stats(const St& stepper, run_stats& stats) {
    if constexpr (requires { stepper.solver_statistics(); }) stats.solver = stepper.solver_statistics();
}

/// Gives a conservative stepper the quadratic invariants the system declares (quadratic_weights_of: a model's
/// quadratic_invariant_weight(j, k), or weights as data), which its remedy for negative radicands needs; a system
/// that declares none (a plain lambda) changes nothing. Throws std::invalid_argument if the weights do not have
/// one entry per element of x.
template <class St, class F, class S>
void attach_quadratic_invariants(St& stepper, const F& f, const S& x) {
    if constexpr (requires {
                      stepper.set_quadratic_invariants(quadratic_weights_of(f, std::size_t{0}));
                  }) {
        quadratic_weights w = quadratic_weights_of(f, std::ranges::size(x));
        for (const auto& row : w)
            if (row.size() != std::ranges::size(x))
                throw std::invalid_argument("quadratic_invariant_weights() gives " + std::to_string(row.size()) +
                                            " weights for a state of " + std::to_string(std::ranges::size(x)) +
                                            " elements");
        stepper.set_quadratic_invariants(std::move(w));
    }
}

/// The stepper's remedy counters (zero for a stepper without the remedy).
template <class St>
remedy_stats remedy_counters(const St& stepper) {
    if constexpr (requires { stepper.remedy_statistics(); })
        return stepper.remedy_statistics();
    else
        return {};
}

/// Sets stats' remedy counts to what the stepper's remedy did since `before` (set, not added: an observer that
/// reads the statistics sees them so far, and the run's end sets them again).
template <class St>
void collect_remedy_stats(const St& stepper, const remedy_stats& before, run_stats& stats) {
    const remedy_stats after = remedy_counters(stepper);
    stats.remedied_steps = after.remedied_steps - before.remedied_steps;
    stats.components_remedied = after.components_remedied - before.components_remedied;
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

/// The same, or as (x, t, i, stats) with the run's statistics so far if the observer takes them.
template <class Observer, class S>
void notify(Observer& observe, const S& x, double t, std::uint64_t i, const run_stats& stats) {
    if constexpr (std::invocable<Observer&, const S&, double, std::uint64_t, const run_stats&>)
        observe(x, t, i, stats);
    else
        notify(observe, x, t, i);
}

/// The fixed-step run: steps first + 1 .. first + n of the grid t0 + k dt (first = opt.first_step), the last of
/// size `last`, through the fixed-step controller. The observer sees the first state, every opt.every steps and
/// the last (at time t_end if given, else on the grid). A shortened last step (last != dt) is observed with the
/// run's complete statistics.
template <class St, class F, class S, class Observer>
run_stats run_grid(St& stepper, F& f, S& x, double t0, double dt, std::uint64_t n, double last,
                   std::optional<double> t_end, Observer& observe, const run_options& opt) {
    constexpr std::uint64_t most = max_grid_steps;  // (steps.hpp)
    if (n > most || opt.first_step > most - n)
        throw std::invalid_argument("steps " + std::to_string(opt.first_step + 1) + " .. " +
                                    (n > most ? std::string("beyond 2^53") : std::to_string(opt.first_step + n)) +
                                    " of the grid t0 + k dt: at most 2^53 steps");
    run_stats stats;
    const run_count<St, F> counted{f, &stats.rhs_evals, opt.cancel};
    attach_quadratic_invariants(stepper, f, x);
    const remedy_stats before = remedy_counters(stepper);
    const std::uint64_t first = opt.first_step, end = first + n;
    const bool shortened = last != dt;
    notify(observe, std::as_const(x), first == 0 ? t0 : t0 + double(first) * dt, first, stats);
    fixed_control<St, const run_count<St, F>, S> control(stepper, counted, x, t0, dt, first, n, last, true, opt,
                                                           stats);
    multiples_of observed(opt.every, first + 1);  // the steps observed, k % opt.every == 0
    // The steps taken and the evaluations are counted by the run's position, and stored into stats where they are
    // read (control.sync): before an observer that takes them sees them, when the run ends, and in a
    // step_size_underflow.
    constexpr bool observes = !std::is_same_v<std::remove_cvref_t<Observer>, no_observer>;
    constexpr bool reads_stats = std::invocable<Observer&, const S&, double, std::uint64_t, const run_stats&>;
    try {
        control.run([&, end](const auto& at) {  // (end by value: one load fewer per step)
            const std::uint64_t k = at.completed();
            if (k == end) {
                control.sync(at);
                stats.steps = k - first;
                if (shortened) {
                    collect_solver_stats(stepper, stats);
                    collect_remedy_stats(stepper, before, stats);
                }
                notify(observe, std::as_const(x), t_end ? *t_end : t0 + double(k) * dt, k, stats);
            } else if (observes && observed.due(k)) {
                if constexpr (reads_stats) {
                    control.sync(at);
                    stats.steps = k - first;
                    collect_remedy_stats(stepper, before, stats);  // (a stopped run's summary reports them)
                }
                notify(observe, std::as_const(x), t0 + double(k) * dt, k, stats);
            }
        });
    } catch (step_size_underflow& e) {
        e.stats.steps = control.completed() - first;
        collect_solver_stats(stepper, e.stats);
        collect_remedy_stats(stepper, before, e.stats);
        throw;
    }
    stats.steps = control.completed() - first;
    collect_solver_stats(stepper, stats);
    if (!shortened) collect_remedy_stats(stepper, before, stats);
    return stats;
}

inline void check_step(double dt) {
    if (!(dt > 0.0) || !std::isfinite(dt)) throw std::invalid_argument("time step must be a positive finite number");
}

}  // namespace detail

/// One step of size dt from (x, t), as the drivers take it: a failed step is retried as two half steps, each
/// of which may be halved again, up to `max_halvings` times. Adds the step, its reductions and its right-hand
/// side evaluations to `stats`; throws step_size_underflow (x then holds the last state reached) if even the
/// smallest step fails. For loops of one's own that need the drivers' robustness step by step; such a loop gives
/// a conservative stepper the model's invariants itself (stepper.set_quadratic_invariants), for the remedy.
template <state S, system<S> F, stepper<F, S> St>
void step_with_reduction(St& stepper, F&& f, S& x, double t, double dt, run_stats& stats,
                         int max_halvings = run_options::default_max_halvings) {
    using G = std::remove_reference_t<F>;
    const remedy_stats before = detail::remedy_counters(stepper);
    if constexpr (begins_steps<G>) f.begin_step(dt);
    const detail::held_count<G, false> counted{f, &stats.rhs_evals};
    std::optional<double> rate;
    const step_result r = detail::attempt_whole_step(stepper, counted, x, t, dt, rate);
    if (!r) [[unlikely]] detail::halve_failed_step(stepper, f, x, t, dt, max_halvings, stats, r, rate);
    ++stats.steps;
    const remedy_stats after = detail::remedy_counters(stepper);  // (added: stats sums the caller's steps)
    stats.remedied_steps += after.remedied_steps - before.remedied_steps;
    stats.components_remedied += after.components_remedied - before.components_remedied;
}

/// Take `n` steps of size dt from (x, t0). The observer sees (x, t, step index), or (x, t), at step 0, every
/// `opt.every` steps and at step n. Times are t0 + i dt, never accumulated, so they stay on the grid. The
/// stepper's carried state is reset first unless `opt.resume`.
template <state S, system<S> F, stepper<F, S> St, class Observer = no_observer>
run_stats integrate_n_steps(St& stepper, F&& f, S& x, double t0, double dt, std::uint64_t n, Observer&& observe = {},
                            run_options opt = {}) {
    detail::check_step(dt);
    if (opt.every == 0) throw std::invalid_argument("observer interval must be at least 1");
    if (!opt.resume) reset_carried_state(stepper);
    return detail::run_grid(stepper, f, x, t0, dt, n, dt, std::nullopt, observe, opt);
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
    const std::uint64_t n = steps_to_reach(t0, t_end, dt), first = opt.first_step;
    if (first > n)
        throw std::invalid_argument("first_step " + std::to_string(first) + " is beyond the end time's step " +
                                    std::to_string(n));
    if (n == first) {  // nothing left to take: the state is the end's (t0 itself, or a restart at the end)
        detail::notify(observe, std::as_const(x), n == 0 ? t0 : t_end, n, run_stats{});
        return {};
    }
    // The grid holds n - 1 full steps, then one to t_end: of size dt if t0 + n dt misses t_end by round-off only
    // (3 * 0.1 != 0.3; the last observation reports t_end itself), else shortened.
    const double last = last_step_to_reach(t0, t_end, dt, n);
    return detail::run_grid(stepper, f, x, t0, dt, n - first, last, t_end, observe, opt);
}

}  // namespace eci
