// The one run: a model (or a plain system), a method name and one run configuration -- the span, a fixed step or
// a step controller, output times, checks, limits, a cancel flag -- in; one report out. Front ends attach a sink
// (CSV rows, NumPy arrays, a timer) and decide nothing about stepping, output times or defaults.
#pragma once

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <concepts>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <limits>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include "adaptive.hpp"
#include "detail/format.hpp"
#include "integrate.hpp"
#include "memory.hpp"
#include "registry.hpp"
#include "run.hpp"

namespace eci {

/// Everything a run is asked to do.
struct run_config {
    double t0 = 0.0;     ///< start time
    /// End time (fixed steps: the last step is shortened to land on it). Adaptive runs go backward in time when
    /// it is before t0 (dt, dt_min and dt_max are then sizes); fixed steps run forward only.
    double t_end = 0.0;
    /// Fixed steps only: take exactly this many steps of dt from t0 (t_end is then t0 + steps * dt).
    std::optional<std::uint64_t> steps;
    /// Fixed steps: the run continues the grid t0 + i dt from step first_step (a restart from a checkpoint), so
    /// it ends at t0 + (first_step + steps) dt, or with `steps` unset at t_end (the last step shortened to land
    /// on it); output indices count from there, and `every` is on them.
    std::uint64_t first_step = 0;
    /// The fixed step, or an adaptive run's first step: 0 lets the run choose it (choose_first_step, Hairer,
    /// Norsett & Wanner's rule; its evaluations are counted in the run's).
    double dt = 0.0;
    /// A step controller around the method's embedded pair (rtol, atol, limits); none: fixed steps of dt.
    std::optional<adaptive_options> adaptive;

    /// Without `times`: output every `every` steps (adaptive: accepted steps), and always the first and the last.
    std::uint64_t every = 1;
    /// Output at these times instead (sorted in the run's direction, within the span); the run still goes on to
    /// t_end (or to where the sink's step() stops it). Fixed steps
    /// reach a time between two grid points by a side step from the earlier one (the grid run is untouched);
    /// adaptive runs land a step on it or interpolate, as `mode` says.
    std::vector<double> times;
    output_mode mode = output_mode::automatic;  ///< adaptive runs with `times`
    /// Output every `output_dt` of time instead of `every` / `times`: resolve_output_dt turns it into output times
    /// t0, t0 + h, ..., t_end (adaptive) or into `every` (fixed steps, of which h must be a whole number). solve()
    /// resolves it (with setting_names' defaults in its messages); a front end that wants its own option names in
    /// the messages, or the refusal before it opens files, calls resolve_output_dt itself first.
    std::optional<double> output_dt;

    int max_halvings = run_options::default_max_halvings;  ///< fixed steps: halvings of one failed step
    /// A conservative Runge-Kutta method (fixed steps, or an adaptive pair with plain xi) on a system with declared
    /// invariants and at least remedy_options::min_unknowns real unknowns: the conditioned update (default) or the
    /// paper's update (docs/methods.md "Zero crossings without loss of accuracy", "Adaptive pairs").
    update_kind update = update_kind::conditioned;
    /// Whether `update` was chosen (a front end's --update, update=): solve() then refuses a method that has no
    /// update to choose (a conventional, relaxation, projection or symplectic method) rather than ignore it.
    bool update_chosen = false;
    std::uint64_t max_substeps = run_options{}.max_substeps;  ///< fixed steps: attempts for one step of the grid
    /// A monitored invariant that becomes non-finite ends the run (invariant_overflow): the solution blew up.
    bool stop_on_invariant_overflow = true;
    /// Polled between steps and right-hand-side evaluations; when it reads true the run throws eci::interrupted.
    const std::atomic<bool>* cancel = nullptr;
    /// Fixed steps: asked after a failed attempt, before it is halved, and nowhere else; true throws
    /// eci::interrupted (x part-way through the step). May be collective (MPI: asked at the same points on
    /// every process). Stops between steps are the sink's (progress may throw).
    std::function<bool()> stop_between_attempts{};
    /// Names real unknown i in messages (a CSV column, "y[i]"); empty: "x[i]" (re/im for complex states).
    std::function<std::string(std::size_t)> component_name;
    /// The bytes a sink keeps in memory per output (Python's arrays: the state and its time); 0: it keeps none. A
    /// fixed-step run whose outputs would not fit in this machine's memory is then refused before its first step
    /// (check_stored_outputs), rather than failing part-way (std::bad_alloc, the OOM killer).
    std::size_t output_bytes = 0;

    /// Whether the run is adaptive.
    bool is_adaptive() const { return adaptive.has_value(); }
    /// The end time the run reaches.
    double end_time() const { return steps ? t0 + double(first_step + *steps) * dt : t_end; }
};

/// How a front end names its settings in the library's messages about them: Python's keywords by default, the
/// CLI's options ("--output-dt", "--dt", "--rtol/--atol"). The sentences are the library's, the same for both.
struct setting_names {
    std::string_view output_dt = "output_dt";
    std::string_view dt = "dt";
    std::string_view tolerances = "rtol/atol";  ///< empty: the run has no step control (spectral equations)
};

/// The most outputs an output_dt may ask for: its output times are built before the first step (8 bytes each), so
/// that a typo is an error at once rather than gigabytes and a long wait.
inline constexpr double max_output_dt_rows = 1e7;

/// Resolves cfg.output_dt (if set; then cleared): an adaptive run gets the output times t0, t0 + h, t0 + 2h, ...
/// (those more than 1e-12 of the span before its end) and its end; a fixed-step run an output every k = h / dt
/// steps, h being a whole number of dt to 1e-9 k. Throws std::invalid_argument, one line naming the settings as
/// `names` says: h not positive and finite, more than max_output_dt_rows outputs, not a multiple of dt, given
/// together with output times. Call it with cfg's span, step and step control set.
inline void resolve_output_dt(run_config& cfg, const setting_names& names = {}) {
    if (!cfg.output_dt) return;
    const double h = *cfg.output_dt;
    const std::string name(names.output_dt);
    if (!(h > 0.0) || !std::isfinite(h))
        throw std::invalid_argument(name + " must be a positive finite number, not " + detail::shortest_text(h));
    if (!cfg.times.empty())
        throw std::invalid_argument(name + " and output times exclude each other: give one of them");
    const double t_end = cfg.end_time();
    const double span = std::abs(t_end - cfg.t0);
    if (span / h > max_output_dt_rows)
        throw std::invalid_argument(name + " " + detail::shortest_text(h) + " to t = " + detail::shortest_text(t_end) +
                                    " asks for " + detail::shortest_text(std::floor(span / h)) +
                                    " rows, more than 10^7: give a larger " + name);
    if (cfg.adaptive) {
        const double direction = t_end < cfg.t0 ? -1.0 : 1.0;
        cfg.times.push_back(cfg.t0);  // the initial state, as fixed-step runs write it
        for (std::uint64_t k = 1; double(k) * h < span * (1.0 - 1e-12); ++k)
            cfg.times.push_back(cfg.t0 + direction * (double(k) * h));
        cfg.times.push_back(t_end);
    } else {
        const double k = std::round(h / cfg.dt);
        const std::string why = names.tolerances.empty()
                                    ? std::string(" (fixed steps)")
                                    : " (with fixed steps; " + std::string(names.tolerances) + " lifts that)";
        if (!(k >= 1.0) || !std::isfinite(k) || std::abs(h / cfg.dt - k) > 1e-9 * k)
            throw std::invalid_argument(name + " " + detail::shortest_text(h) + " is not a multiple of " +
                                        std::string(names.dt) + " " + detail::shortest_text(cfg.dt) + why);
        cfg.every = std::uint64_t(k);
    }
    cfg.output_dt.reset();
}

/// The tolerances of a run given rtol, atol or both: the one not given takes the other's value (`eci run --rtol R`
/// is rtol = atol = R). Neither given: std::nullopt, fixed steps. Each given value is checked here, under its own
/// name, before the other takes it (detail::check_tolerance); the rest by check_adaptive_options.
inline std::optional<adaptive_options> tolerances_from(std::optional<double> rtol, std::optional<double> atol) {
    if (!rtol && !atol) return std::nullopt;
    adaptive_options o;
    if (rtol) detail::check_tolerance("rtol", *rtol);
    if (atol) detail::check_tolerance("atol", *atol);
    o.rtol = rtol.value_or(*atol);
    o.atol = atol.value_or(*rtol);
    return o;
}

/// The smallest relative tolerance an adaptive run is given, 100 eps, as SciPy's solve_ivp: below it the error
/// estimate is the step's own round-off, and the controller shrinks the step until the run's budget runs out
/// (`eci run three-wave --method dp54 --rtol 1e-30` took its 5e7 attempts, 8 s, to fail). The front ends raise a
/// smaller one to it and warn (raise_rtol), the CLI and Python alike.
inline constexpr double min_rtol = 100 * std::numeric_limits<double>::epsilon();

/// Raises o.rtol and every o.rtol_each below min_rtol to it (rtol = 0 with atol > 0 as well, as solve_ivp does);
/// returns whether it raised any.
inline bool raise_rtol(adaptive_options& o) {
    bool raised = o.rtol < min_rtol;
    o.rtol = std::max(o.rtol, min_rtol);
    for (double& r : o.rtol_each) raised = raised || r < min_rtol, r = std::max(r, min_rtol);
    return raised;
}

/// An adaptive run's first step (the CLI's --dt, Python's first_step), when the user gives it: positive, finite
/// and at most the span |t_end - t0|, as solve_ivp requires. Throws std::invalid_argument naming it `name`.
inline void check_first_step(double h, double t0, double t_end, std::string_view name) {
    if (!(h > 0.0) || !std::isfinite(h))
        throw std::invalid_argument(std::string(name) + " must be a positive finite number, not " +
                                    detail::shortest_text(h));
    const double span = std::abs(t_end - t0);
    if (h > span)
        throw std::invalid_argument(std::string(name) + " " + detail::shortest_text(h) +
                                    " exceeds the span of the run, " + detail::shortest_text(span));
}

/// Why a run stopped before its end.
enum class run_failure_kind {
    step_failed,         ///< a step failed at every size (negative radicand, non-invertible transform, rate)
    step_too_small,      ///< adaptive: the step fell below the minimum
    too_many_steps,      ///< adaptive: the attempt budget ran out
    work_exceeded,       ///< fixed steps: one step of the grid took more than max_substeps attempts
    non_finite_state,    ///< a step left a non-finite state
    invariant_overflow,  ///< a monitored invariant became non-finite
};

/// A run that stopped before its end: what, where, and the library's one-line message.
struct run_failure {
    run_failure_kind kind;
    double t = 0.0;              ///< where the run could not go on
    std::size_t component = 0;   ///< the real unknown (or, for invariant_overflow, the invariant) responsible
    double dt = 0.0;             ///< the step that was refused
    std::string message;         ///< one line, naming the component by run_config::component_name
    /// step_failed / step_too_small: the last attempt failed on a non-finite rate (its value), or the adaptive
    /// controller's last rejection.
    std::optional<double> non_finite_rate_value;
    rejection last_rejection = rejection::step_failed;
};

/// What a run reports, also when it stopped early.
struct solve_report {
    method_info method{};                      ///< the registry's entry of the method that ran
    run_stats stats{};                         ///< steps (adaptive: accepted), reductions, evaluations, solves
    std::optional<adaptive_stats> adaptive;    ///< the controller's statistics, for adaptive runs
    std::uint64_t side_steps = 0;              ///< fixed steps: extra steps to output times between grid points
    std::vector<invariant_record> invariants;  ///< each monitored invariant (the model's, then the extra ones)
    double t = 0.0;                            ///< the time of the last state reached
    std::optional<double> time_lag;            ///< relaxation RK: the last state belongs to t + time_lag
    std::optional<run_failure> failure;        ///< why the run stopped early
    /// The time at which the sink's step() stopped the run (a terminal event), if it did.
    std::optional<double> stopped_at;
    bool completed() const { return !failure.has_value(); }
};

/// One output of a run, as a sink sees it.
struct output_point {
    double t;                             ///< the time of the state
    std::uint64_t index;                  ///< step index (fixed: on the grid; adaptive: accepted steps) or time index
    std::span<const double> invariants;   ///< the monitored invariants' values at this state
    std::optional<double> time_lag;       ///< relaxation RK: the state belongs to t + time_lag
    const run_stats* stats = nullptr;     ///< fixed steps: the run's statistics so far
};

/// A sink: output(x, point) at every output; optionally progress(t, steps) after every step (adaptive: before
/// every attempt), which may throw to stop the run (Ctrl-C). Fixed steps also show every step of the grid to a
/// sink with after_step(x, point), before output and progress (a per-step record: budgets, drifts, blow-up). An
/// adaptive run also shows every accepted step with its dense output (eci::accepted_step) to a sink whose
/// observes_steps() is true, through step(s) ->
/// std::optional<double>: a time within that step at which to stop the run (an event), or none. Output times are
/// then taken from the dense output of the steps (as SciPy's solve_ivp does), whatever cfg.mode says.
template <class K, class S>
concept run_sink = requires(K& k, const S& x, const output_point& p) { k.output(x, p); };

/// A sink that keeps nothing.
struct no_sink {
    template <class S>
    void output(const S&, const output_point&) {}
};

namespace detail {

/// "a, b, c": the names of a method list in one sentence.
template <class Names>
std::string joined_names(const Names& names) {
    std::string s;
    for (const auto& n : names) s.append(s.empty() ? "" : ", ").append(std::string_view(n));
    return s;
}

/// The registry's entry for `name`, or std::invalid_argument "unknown method 'x' (methods: ...)".
inline method_info known_method(std::string_view name) {
    if (const std::optional<method_info> m = find_method(name)) return *m;
    std::vector<std::string_view> all;
    for (const method_info& i : eci::methods) all.push_back(i.name);
    throw std::invalid_argument("unknown method '" + std::string(name) + "' (methods: " + joined_names(all) + ")");
}

}  // namespace detail

/// The registry entry of `method` among those that run on Dispatch (fixed or adaptive), or std::invalid_argument
/// naming what is available: "unknown method 'x' (methods: ...)", "method 'x' is not available for WHAT
/// (available: ...)" (with the reason before the list when Dispatch lacks a declaration the method needs, as
/// relaxation needs invariants: missing_declaration), "method x has no error estimate for rtol/atol; adaptive
/// methods for WHAT: ...".
template <class Dispatch>
method_info resolve_method_for(std::string_view method, bool adaptive, std::string_view what) {
    const method_info m = detail::known_method(method);
    std::vector<std::string_view> fixed;
    for (const method_info& i : methods_for<Dispatch>()) fixed.push_back(i.name);
    if (std::ranges::find(fixed, method) == fixed.end()) {
        std::string message = "method '";
        message.append(method).append("' is not available for ").append(what);
        if (const std::string_view reason = missing_declaration<Dispatch>(m); !reason.empty())
            message.append(": ").append(reason);
        throw std::invalid_argument(message.append(" (available: ").append(detail::joined_names(fixed)).append(")"));
    }
    if (adaptive) {
        std::vector<std::string_view> pairs;
        for (const method_info& i : adaptive_methods_for<Dispatch>()) pairs.push_back(i.name);
        if (std::ranges::find(pairs, method) == pairs.end())
            throw std::invalid_argument("method " + std::string(method) +
                                        " has no error estimate for rtol/atol; adaptive methods for " +
                                        std::string(what) + ": " + detail::joined_names(pairs));
    }
    return m;
}

/// The registry's entry for `name` among the method names `available` (a model whose methods are a list, as the
/// spectral equations' eci::ns2d_methods()), or std::invalid_argument with resolve_method_for's messages: the
/// spectral command and Python's spectral models refuse a method in one sentence.
template <class Names>
method_info resolve_named_method(std::string_view name, const Names& available, std::string_view what) {
    const method_info m = detail::known_method(name);
    for (const auto& a : available)
        if (std::string_view(a) == name) return m;
    throw std::invalid_argument("method '" + std::string(name) + "' is not available for " + std::string(what) +
                                " (available: " + detail::joined_names(available) + ")");
}

/// The pairs a run with a tolerance and no method named prefers, in this order, where they run adaptively on the
/// model: Dormand-Prince 5(4), SciPy's RK45 pair, conservative first (default_adaptive_method_for).
inline constexpr std::array<std::string_view, 2> preferred_adaptive_methods{"c-dp54", "dp54"};

/// The method an adaptive run on Dispatch (a model type) takes when its user names none: the first of
/// preferred_adaptive_methods that runs adaptively on it, else its first conservative adaptive method, else its
/// first adaptive method in the registry's order; none if no method has an error estimate on it.
template <class Dispatch>
std::optional<method_info> default_adaptive_method_for() {
    const std::vector<method_info> pairs = adaptive_methods_for<Dispatch>();
    for (std::string_view preferred : preferred_adaptive_methods)
        for (const method_info& m : pairs)
            if (m.name == preferred) return m;
    for (const method_info& m : pairs)
        if (m.conservative) return m;
    if (!pairs.empty()) return pairs.front();
    return std::nullopt;
}

/// The method a run on Dispatch (a model type) takes when its user names none: the one rule of every front end
/// (`eci run MODEL` without --method, Python's eci.solve(model) without method=). Fixed steps: `model_default`, the
/// model's own (its preset's method); adaptive (a tolerance given): default_adaptive_method_for, or
/// std::invalid_argument "WHAT has no method with an error estimate for rtol/atol; it runs fixed steps only".
template <class Dispatch>
std::string default_method_for(std::string_view model_default, bool adaptive, std::string_view what) {
    if (!adaptive) return std::string(model_default);
    if (const std::optional<method_info> m = default_adaptive_method_for<Dispatch>()) return std::string(m->name);
    throw std::invalid_argument(std::string(what) +
                                " has no method with an error estimate for rtol/atol; it runs fixed steps only");
}

namespace detail {

/// "x[i]", or "re x[i]" / "im x[i]" for a complex state's parts.
template <class S>
std::string default_component_name(std::size_t i) {
    if constexpr (std::is_same_v<std::ranges::range_value_t<S>, std::complex<double>>)
        return std::string(i % 2 ? "im" : "re") + " x[" + std::to_string(i / 2) + "]";
    else
        return "x[" + std::to_string(i) + "]";
}

template <class S>
std::string name_of(const run_config& cfg, std::size_t i) {
    return cfg.component_name ? cfg.component_name(i) : default_component_name<S>(i);
}

/// Whether stepper St's states belong to a time other than their grid time (relaxation RK: t + time_lag()).
template <class St>
constexpr bool stepper_shifts_time() {
    if constexpr (requires { St::shifts_time; })
        return St::shifts_time;
    else
        return false;
}

/// The span's checks, with the messages every front end shows.
inline void check_config(const run_config& c) {
    if (!std::isfinite(c.t0)) throw std::invalid_argument("start time must be finite");
    if (c.adaptive) {
        if (c.steps) throw std::invalid_argument("a step count is for fixed steps; an adaptive run ends at its end time");
        if (!(c.dt >= 0.0) || !std::isfinite(c.dt))  // 0: chosen by choose_first_step
            throw std::invalid_argument("initial step must be a positive finite number");
        if (!std::isfinite(c.t_end)) throw std::invalid_argument("end time must be finite");
    } else {
        check_step(c.dt);
        if (!c.steps && std::isfinite(c.t_end) && c.t_end < c.t0)
            throw std::invalid_argument("end time is before the start: fixed steps run forward only (an adaptive "
                                        "run goes backward)");
        if (!c.steps && (!(c.t_end >= c.t0) || !std::isfinite(c.t_end)))
            throw std::invalid_argument("end time must be finite and >= start");
    }
    if (!c.adaptive) {
        // (the counts compared as integers: as doubles, 2^53 + 1 steps read as 2^53)
        constexpr std::uint64_t most = max_grid_steps;
        if (c.steps && (*c.steps > most || c.first_step > most - *c.steps))
            throw std::invalid_argument("steps " + std::to_string(*c.steps) +
                                        (c.first_step ? " from step " + std::to_string(c.first_step) : "") +
                                        " is too many (at most 2^53)");
        if (!c.steps && (c.t_end - c.t0) / c.dt > double(max_grid_steps))
            throw std::invalid_argument("(t_end - t0) / dt is " + detail::shortest_text((c.t_end - c.t0) / c.dt) +
                                        " steps, too many (at most 2^53)");
        // The grid's times t0 + i dt round to the doubles near them, which far from 0 are far apart: the times the
        // system sees, the outputs' and the last step (shortened to land on t_end: t_end - t_{n-1}) would be off by
        // that much. Refused where that is beyond 2^-10 of a step and 2^-30 of the span (at t0 = 1e16, doubles 2
        // apart, dt = 0.5 ended 0.5 short of t0 + 160, and status 0), unless every grid time is a double (t0 and dt
        // multiples of that spacing). (A span to t_end = 1e12 at dt = 0.01, a run to be stopped by a signal, would
        // reach such times only after 1e14 steps, and then lose 1e-16 of its span: taken.)
        const double far = std::max(std::abs(c.t0), std::abs(c.end_time()));
        const double spacing = far - std::nextafter(far, 0.0);  // (the widest between the grid's times)
        if (std::isfinite(far) && spacing > c.dt * 0x1p-10 && spacing > (c.end_time() - c.t0) * 0x1p-30 &&
            !(std::fmod(c.dt, spacing) == 0.0 && std::fmod(c.t0, spacing) == 0.0))
            throw std::invalid_argument("the step " + detail::shortest_text(c.dt) + " is too small for times near " +
                                        detail::shortest_text(far) + ", where doubles are " +
                                        detail::shortest_text(spacing) +
                                        " apart: the grid's times would be off by more than 2^-10 of a step "
                                        "(count time from 0: a start time nearer 0)");
    }
    if (c.every == 0) throw std::invalid_argument("output interval must be at least 1");
    // (a step of the grid halved more than 1074 times is below the smallest double at dt <= 1; a bound of 0
    // sub-steps would stop every failed step at once, a negative one report "halved -1 times")
    if (c.max_halvings < 0 || c.max_halvings > 1074)
        throw std::invalid_argument("max_halvings must be from 0 to 1074, not " + std::to_string(c.max_halvings));
    if (c.max_substeps == 0) throw std::invalid_argument("max_substeps must be at least 1");
    if (c.first_step != 0 && (c.adaptive || !c.times.empty()))
        throw std::invalid_argument("first_step continues a run of fixed steps, without output times");
    if (c.first_step != 0 && !c.steps && !c.adaptive && c.first_step > steps_to_reach(c.t0, c.t_end, c.dt))
        throw std::invalid_argument("first_step " + std::to_string(c.first_step) + " is beyond the end time's step " +
                                    std::to_string(steps_to_reach(c.t0, c.t_end, c.dt)));
    const double t_end = c.end_time();
    const bool forward = !(t_end < c.t0);
    const double lo = forward ? c.t0 : t_end, hi = forward ? t_end : c.t0;
    for (std::size_t i = 0; i < c.times.size(); ++i)
        if (!std::isfinite(c.times[i]) || c.times[i] < lo || c.times[i] > hi ||
            (i > 0 && (forward ? c.times[i] < c.times[i - 1] : c.times[i] > c.times[i - 1])))
            throw std::invalid_argument("output times must be finite, sorted in the direction of the run and "
                                        "within the span");
}

/// The outputs a checked fixed-step run gives: one per output time, else the first, every `every`-th step and the
/// last; none for an adaptive run (its step count is not known before it runs).
inline std::optional<double> fixed_step_outputs(const run_config& c) {
    if (c.adaptive) return std::nullopt;
    if (!c.times.empty()) return double(c.times.size());
    const std::uint64_t steps = c.steps ? *c.steps : steps_to_reach(c.t0, c.t_end, c.dt) - c.first_step;
    return double(steps / c.every) + 1.0 + (steps % c.every != 0 ? 1.0 : 0.0);
}

/// Refuses a fixed-step run whose outputs a sink keeping c.output_bytes each could not hold in this machine's memory:
/// std::invalid_argument "storing the solution at N times needs about X GiB of memory, more than this machine's Y
/// GiB". A run that fits is never refused.
inline void check_stored_outputs(const run_config& c) {
    if (c.output_bytes == 0) return;
    if (const std::optional<double> n = fixed_step_outputs(c))
        check_fits_in_memory(*n * double(c.output_bytes),
                             "storing the solution at " + detail::shortest_text(*n) + " times");
}

/// An observer (x, t), (x, t, i) or (x, t, i, monitor) as a sink: eci::run and eci::run_adaptive.
template <class Model, class Observer>
struct observer_sink {
    Observer& observe;
    const invariant_monitor<Model>& monitor;
    void output(const typename Model::state_type& x, const output_point& p) {
        if constexpr (std::invocable<Observer&, const typename Model::state_type&, double, std::uint64_t,
                                     const invariant_monitor<Model>&>)
            observe(x, p.t, p.index, monitor);
        else
            detail::notify(observe, x, p.t, p.index);
    }
};

/// Thrown inside a run when a monitored invariant overflowed (caught by solve, reported as a failure).
struct invariant_overflowed {
    double t;
    std::size_t index;
};

/// Adaptive stepper St that lets the sink poll between attempts (Ctrl-C, a cancel flag). The numerics are St's.
template <class St, class Poll>
struct polled_stepper : St {
    Poll* poll = nullptr;  ///< null for the dense output's default-constructed fallback, which never attempts

    template <class F, class S>
    attempt_result attempt(F& f, const S& x, double t, double dt, const error_weights* w = nullptr,
                           bool track_worst = false) {
        if (poll && !track_worst) (*poll)(t);
        return St::attempt(f, x, t, dt, w, track_worst);
    }
};

/// An adaptive run whose sink sees every accepted step (sink.step, events) and whose outputs at times come from
/// the steps' dense output. The monitor sees every step's end and every output.
template <class St, class F, class S, class Monitor, class Sink, class Check>
adaptive_stats run_steps_seen(St& st, const F& f, S& x, const run_config& cfg, const std::vector<double>& times,
                              std::size_t wanted, Monitor& monitor, solve_report& report, Sink& sink,
                              Check& check_overflow) {
    const double t_end = cfg.end_time();
    const bool forward = !(t_end < cfg.t0);
    std::size_t next = 0;
    std::uint64_t accepted = 0;
    S tmp = x;
    auto emit = [&](const S& s, double t, std::uint64_t i) {
        monitor.record(s);
        check_overflow(t);
        sink.output(s, output_point{t, i, monitor.values(), std::nullopt});
    };
    report.t = cfg.t0;
    if (times.empty()) emit(x, cfg.t0, 0);
    monitor.record(x);
    for (; next < wanted && times[next] == cfg.t0; ++next) emit(x, cfg.t0, next);
    auto on_step = [&](auto& step) -> std::optional<double> {
        ++accepted;
        const std::optional<double> stop = sink.step(step);
        const double t_last = stop ? *stop : step.t_end();
        for (; next < wanted && reached(times[next], t_last, forward); ++next) {
            step.at(times[next], tmp);
            emit(std::as_const(tmp), times[next], next);
        }
        if (stop) {
            step.at(*stop, tmp);
            if (times.empty()) emit(std::as_const(tmp), *stop, accepted);
            report.t = *stop;
            report.stopped_at = *stop;
        } else {
            report.t = step.t_end();
            if (times.empty() && (accepted % cfg.every == 0 || step.t_end() == t_end))
                emit(step.end_state(), step.t_end(), accepted);
            else
                monitor.record(step.end_state()), check_overflow(step.t_end());
        }
        return stop;
    };
    return integrate_adaptive_steps(st, f, x, cfg.t0, t_end, cfg.dt, *cfg.adaptive, on_step);
}

}  // namespace detail

/// Whether the registered method `name` on Dispatch gives states that belong to a later time than their grid time
/// (relaxation RK: t + time_lag), so that an output has a time_lag to show.
template <class Dispatch>
bool method_shifts_time(std::string_view name) {
    bool shifts = false;
    with_stepper<Dispatch>(name, [&](auto st) { shifts = detail::stepper_shifts_time<decltype(st)>(); });
    return shifts;
}

namespace detail {

/// The initial state's checks every run makes (check_run_inputs) and the front ends' check_initial_state begins
/// with: each real unknown finite (if `finite`), then the model's domain and size (validate_state, e.g.
/// Lotka-Volterra's x, y > 0, an n-wave state's one element per mode). std::invalid_argument, one line.
template <class Model, class S>
void check_finite_in_domain(const Model& model, const S& x, const std::function<std::string(std::size_t)>& name,
                            bool finite) {
    if (finite) {
        const auto r = reals(x);
        for (std::size_t i = 0; i < r.size(); ++i)
            if (!std::isfinite(r[i]))
                throw std::invalid_argument("initial condition " + (name ? name(i) : default_component_name<S>(i)) +
                                            " is not finite");
    }
    if constexpr (requires { model.validate_state(x); }) {
        try {
            model.validate_state(x);
        } catch (const std::invalid_argument& e) {
            throw std::invalid_argument(std::string("invalid initial condition: ") + e.what());
        }
    }
}

}  // namespace detail

/// Rejects an initial state whose arithmetic is beyond double precision from the start, with one line naming the
/// component: a non-finite or subnormal component, the model's own domain (validate_state), an invariant or a
/// rate that is not finite. std::invalid_argument.
template <class Model, class S>
void check_initial_state(const Model& model, const S& x, const std::function<std::string(std::size_t)>& name) {
    auto named = [&](std::size_t i) { return name ? name(i) : detail::default_component_name<S>(i); };
    const auto r = detail::reals(x);
    detail::check_finite_in_domain(model, x, name, true);
    char buffer[32];
    for (std::size_t i = 0; i < r.size(); ++i)
        if (r[i] != 0.0 && std::abs(r[i]) < std::numeric_limits<double>::min())
            throw std::invalid_argument("initial condition " + named(i) + " = " +
                                        std::string(detail::format_double(r[i], buffer)) +
                                        " is subnormal (below 2.2e-308): its products underflow to 0");
    if constexpr (has_named_invariants<Model>) {
        for (const auto& inv : Model::invariants()) {
            const double v = (model.*inv.value)(x);
            if (!std::isfinite(v))
                throw std::invalid_argument(std::string("the initial ") + inv.name + " is " +
                                            std::string(detail::format_double(v, buffer)) +
                                            ": the initial condition and parameters are beyond double precision");
        }
        S dxdt = x;
        model(x, dxdt, 0.0);
        if (!detail::all_finite(dxdt))
            throw std::invalid_argument("the rate of " + named(detail::first_non_finite(dxdt)) +
                                        " overflows at the initial condition: the parameters and initial condition "
                                        "are beyond double precision");
    }
}

namespace detail {

/// A conservative method steps psi^2 (or the model's transform of the state): a state whose every component is so
/// small that its square is subnormal (|psi| below 2^-511, 1.5e-154), or so large that it overflows (above 2^511,
/// 6.7e153), is beyond what it can represent, and a run would silently end at 0 or fail at its first step. One line
/// naming the largest component, std::invalid_argument. (A single small component beside larger ones is the
/// method's round-off on a negligible mode: not refused.)
template <class S>
void check_conservative_scale(const S& x, std::string_view method) {
    const auto r = reals(x);
    double largest = 0.0;
    for (const double v : r) largest = std::max(largest, std::abs(v));
    if (largest == 0.0 || (largest >= 0x1p-511 && largest <= 0x1p511)) return;
    throw std::invalid_argument("the initial state's largest component is " + shortest_text(largest) + ": its square " +
                                (largest < 1.0 ? "underflows" : "overflows") + ", and method " + std::string(method) +
                                " steps squares (|psi| from 1.5e-154 to 6.7e153); rescale the variables or use a "
                                "conventional method");
}

/// What every run checks of its system and initial state before a step, whichever front end calls it (the CLI and
/// Python check the same first, with their own wording, before they open files): the model's parameters
/// (validate()), a finite state, and the model's domain and size (validate_state()). std::invalid_argument. Without
/// it a library caller's state of the wrong size for an n-wave model corrupted the heap, and an invalid model (a
/// three-wave M violating eq. (2), Kepler's r < 0) ran to a misleading "step failed". (Not the front ends'
/// checks of scale, a subnormal component or an overflowing invariant: a restarted field may hold such modes.) A
/// state spread over processes is checked by its front end, collectively.
template <class F, class S>
void check_run_inputs(const F& f, const S& x, const run_config& cfg, std::string_view what) {
    using M = std::remove_cvref_t<decltype(hook_target(f))>;
    if constexpr (requires(const M& m) { m.validate(); }) {
        try {
            hook_target(f).validate();
        } catch (const std::invalid_argument& e) {
            throw std::invalid_argument("invalid " + std::string(what == "this system" ? "model" : what) + ": " +
                                        e.what());
        }
    }
    check_finite_in_domain(hook_target(f), x, cfg.component_name, !distributed_model<F>);
}

/// The configuration a run goes by: `requested` checked, and its output_dt resolved (on a copy, with the default
/// setting names in the messages) if it has one.
inline std::optional<run_config> resolved_config(const run_config& requested) {
    check_config(requested);
    std::optional<run_config> resolved;
    if (requested.output_dt) {
        resolve_output_dt(resolved.emplace(requested));
        check_config(*resolved);
    }
    check_stored_outputs(resolved ? *resolved : requested);
    return resolved;
}

/// Throws invariant_overflowed (at t) if the run stops on an overflowing invariant and one has overflowed.
template <class Monitor>
void stop_if_overflowed(const run_config& cfg, const Monitor& monitor, double t) {
    if (!cfg.stop_on_invariant_overflow) return;
    if (const auto j = monitor.overflowed()) throw invariant_overflowed{t, *j};
}

/// A monitored invariant that overflowed, as the report's failure.
template <class Monitor>
void overflow_failure(solve_report& report, const Monitor& monitor, const invariant_overflowed& e) {
    // inf: the solution blew up; NaN: it may also have left where the invariant is defined (Kepler's r through 0)
    const bool nan = std::isnan(monitor.values()[e.index]);
    report.failure = run_failure{run_failure_kind::invariant_overflow, e.t, e.index, 0.0,
                                 "the invariant " + monitor.records()[e.index].name +
                                     (nan ? " is undefined (NaN) at t = " : " overflowed at t = ") +
                                     detail::full_text(e.t) +
                                     (nan ? ": the state left where the model is defined, or blew up"
                                          : ": the solution blew up"),
                                 std::nullopt, rejection::step_failed};
}

/// The adaptive run of solve_with: `stepper` (an embedded pair, as built) under cfg's step controller, the sink
/// polled between attempts. cfg.dt == 0: the first step by choose_first_step. The stepper ends as the run left it.
template <class St, class F, class S, class Sink, class Monitor>
solve_report run_adaptive_on(St& stepper, F& f, S& x, const run_config& given, Sink& sink, Monitor& monitor) {
    solve_report report;
    report.t = given.t0;
    std::uint64_t first_step_evals = 0;
    std::optional<run_config> chosen;
    if (given.dt == 0.0) {
        const first_step_choice c = choose_first_step(f, std::as_const(x), given.t0, given.end_time(), St::order,
                                                      *given.adaptive);
        chosen.emplace(given).dt = c.dt;
        first_step_evals = c.rhs_evals;
    }
    const run_config& cfg = chosen ? *chosen : given;
    const double t_end = cfg.end_time();
    constexpr bool has_progress = requires(double t, std::uint64_t i) { sink.progress(t, i); };
    auto check_overflow = [&](double t) { stop_if_overflowed(cfg, monitor, t); };
    try {
        // Output times: the requested ones, then t_end (run to, not output) if they stop short of it.
        std::vector<double> times = cfg.times;
        const std::size_t wanted = times.size();
        const bool forward = !(t_end < cfg.t0);
        if (!times.empty() && (forward ? times.back() < t_end : times.back() > t_end)) times.push_back(t_end);
        auto observe = [&](const S& s, double t, std::uint64_t i) {
            monitor.record(s);
            report.t = t;
            check_overflow(t);
            const bool out = times.empty() ? (i % cfg.every == 0 || t == t_end) : i < wanted;
            if (out) sink.output(s, output_point{t, i, monitor.values(), std::nullopt});
        };
        auto poll = [&](double t) {
            if (cfg.cancel && cfg.cancel->load(std::memory_order_relaxed)) throw interrupted(t);
            if constexpr (has_progress) sink.progress(t, report.adaptive ? report.adaptive->accepted : 0);
        };
        bool steps_seen = false;
        if constexpr (requires { sink.observes_steps(); }) steps_seen = sink.observes_steps();
        // The stepper runs inside a polled_stepper: moved in, and moved back when the run ends (also when it throws),
        // so that its buffers exist once, not twice, during the run and at its end.
        detail::polled_stepper<St, decltype(poll)> st{std::move(stepper)};
        st.poll = &poll;
        adaptive_stats stats;
        auto run = [&]() -> adaptive_stats {
            if constexpr (requires { sink.observes_steps(); })
                if (steps_seen)
                    return detail::run_steps_seen(st, f, x, cfg, times, wanted, monitor, report, sink, check_overflow);
            return times.empty() ? integrate_adaptive(st, f, x, cfg.t0, t_end, cfg.dt, *cfg.adaptive, observe)
                                 : integrate_adaptive_at(st, f, x, cfg.t0, times, cfg.dt, *cfg.adaptive, observe,
                                                         cfg.mode);
        };
        struct give_back {  // the stepper as the run left it, also when the run throws
            St& to;
            St& from;
            ~give_back() { to = std::move(from); }
        } back{stepper, st};
        try {
            stats = run();
        } catch (const adaptive_failure& e) {
            stats = e.stats;
            const bool too_many = e.why == adaptive_failure::reason::too_many_steps;
            report.failure = run_failure{too_many ? run_failure_kind::too_many_steps : run_failure_kind::step_too_small,
                                         e.time, e.component, e.dt, e.what(), std::nullopt, e.last_rejection};
        }
        stats.rhs_evals += first_step_evals;
        report.adaptive = stats;
        report.stats.steps = stats.accepted;
        report.stats.step_reductions = stats.rejected_radicand;
        report.stats.non_finite_rate_reductions = stats.rejected_non_finite_rate;
        report.stats.rhs_evals = stats.rhs_evals;
    } catch (const detail::invariant_overflowed& e) {
        overflow_failure(report, monitor, e);
    }
    report.invariants = monitor.records();
    return report;
}

/// The fixed-step run of solve_with: `stepper` (as built) on the grid of cfg, side steps to output times between
/// grid points. The stepper ends as the run left it.
template <class St, class F, class S, class Sink, class Monitor>
solve_report run_fixed_on(St& stepper, F& f, S& x, const run_config& cfg, Sink& sink, Monitor& monitor) {
    solve_report report;
    report.t = cfg.t0;
    constexpr bool has_progress = requires(double t, std::uint64_t i) { sink.progress(t, i); };
    constexpr bool has_after_step = requires(const output_point& p) { sink.after_step(std::as_const(x), p); };
    auto fail = [&](run_failure_kind kind, double t, std::size_t component, double dt, std::string message) {
        report.failure = run_failure{kind, t, component, dt, std::move(message), std::nullopt, rejection::step_failed};
    };
    auto check_overflow = [&](double t) { stop_if_overflowed(cfg, monitor, t); };
    try {
        const run_span span = cfg.steps ? run_span::n_steps(cfg.first_step + *cfg.steps, cfg.dt, cfg.t0)
                                        : run_span::until(cfg.t_end, cfg.dt, cfg.t0);
        run_options opt;
        opt.max_halvings = cfg.max_halvings;
        opt.max_substeps = cfg.max_substeps;
        opt.cancel = cfg.cancel;
        opt.stop_between_attempts = cfg.stop_between_attempts;
        opt.first_step = cfg.first_step;
        // (a lambda the compiler sees through: called at every step, a std::function cost a tenth of a CLI step)
        auto lag = [&stepper]() -> std::optional<double> {
            if constexpr (detail::stepper_shifts_time<St>())
                return stepper.time_lag();
            else
                return std::nullopt;
        };
        // Output times between grid points: a side step from the earlier grid state, with copies of the
        // stepper and the state, so that the grid run is untouched.
        run_stats side{};
        // (a held_count, as the grid run's: the steppers' code is instantiated for one system type, not two)
        const detail::run_count<St, F> side_f{f, &side.rhs_evals, cfg.cancel};
        std::size_t next = 0;
        const std::uint64_t last = span.steps;
        auto grid_time = [&](std::uint64_t i) { return i >= last ? span.t_end : span.t0 + double(i) * span.dt; };
        detail::multiples_of rows(cfg.every, cfg.first_step);  // i % cfg.every == 0
        auto observe = [&](const S& s, double t, std::uint64_t i, const run_stats& st) {
            monitor.record(s);
            report.t = t;
            check_overflow(t);
            if constexpr (has_after_step)
                if (i != cfg.first_step) sink.after_step(s, output_point{t, i, monitor.values(), lag(), &st});
            if (cfg.times.empty()) {
                if (rows.due(i) || i == last || i == cfg.first_step)  // (due(i) asked for every i, in turn)
                    sink.output(s, output_point{t, i, monitor.values(), lag(), &st});
            } else {
                for (; next < cfg.times.size() && cfg.times[next] == t; ++next)
                    sink.output(s, output_point{t, next, monitor.values(), lag()});
                const double t_next = grid_time(i + 1);
                for (; i < last && next < cfg.times.size() && cfg.times[next] < t_next; ++next) {
                    St side_stepper = stepper;
                    S xs = s;
                    detail::advance_with_reduction(side_stepper, side_f, xs, t, cfg.times[next] - t, opt, side);
                    ++report.side_steps;
                    monitor.record(xs);
                    check_overflow(cfg.times[next]);
                    // (a relaxation step's state belongs to its time plus the side step's own lag, as on the grid)
                    std::optional<double> side_lag;
                    if constexpr (detail::stepper_shifts_time<St>()) side_lag = side_stepper.time_lag();
                    sink.output(std::as_const(xs), output_point{cfg.times[next], next, monitor.values(), side_lag});
                }
            }
            if constexpr (has_progress) sink.progress(t, i);
        };
        opt.every = 1;  // the monitor sees every step; the sink's cadence is decided above
        try {
            report.stats = span.to_end_time ? integrate_to(stepper, f, x, span.t0, span.t_end, span.dt, observe, opt)
                                            : integrate_n_steps(stepper, f, x, span.t0, span.dt,
                                                                span.steps - cfg.first_step, observe, opt);
        } catch (const step_size_underflow& e) {
            report.stats = e.stats;
            const std::string name = detail::name_of<S>(cfg, e.component);
            const std::string cause = e.non_finite_rate_value
                                          ? "the rate of " + name + " is " + detail::full_text(*e.non_finite_rate_value)
                                          : std::string("negative radicand, non-invertible transform or non-finite state");
            fail(run_failure_kind::step_failed, e.time, e.component, e.dt,
                 "step failed at t = " + detail::full_text(e.time) + " in component " + name +
                     " even with the step halved " + std::to_string(cfg.max_halvings) + " times (dt = " +
                     detail::full_text(e.dt) + "): " + cause);
            report.failure->non_finite_rate_value = e.non_finite_rate_value;
        } catch (const step_work_exceeded& e) {
            fail(run_failure_kind::work_exceeded, e.time, 0, e.dt, e.what());
        } catch (const non_finite_state& e) {
            fail(run_failure_kind::non_finite_state, e.time, e.component, 0.0,
                 "the state became non-finite (" + detail::name_of<S>(cfg, e.component) + ") at t = " +
                     detail::full_text(e.time));
        }
        // Side steps add their evaluations, reductions and solves, not steps of the grid.
        report.stats.rhs_evals += side.rhs_evals;
        report.stats.step_reductions += side.step_reductions;
        report.stats.non_finite_rate_reductions += side.non_finite_rate_reductions;
        if constexpr (detail::stepper_shifts_time<St>()) report.time_lag = stepper.time_lag();
    } catch (const detail::invariant_overflowed& e) {
        overflow_failure(report, monitor, e);
    }
    report.invariants = monitor.records();
    return report;
}

}  // namespace detail

/// The one run, on a stepper already built (solve() builds it from a registry name; eci::run and
/// eci::run_adaptive hand theirs): the system f from x over `cfg`, every state recorded by `monitor` (the model's
/// invariants and any extra ones), every output handed to `sink`. cfg.adaptive: `stepper` must be an embedded pair
/// (adaptive_stepper), run under the step controller, its first step cfg.dt or, for 0, choose_first_step's; else
/// fixed steps of cfg.dt. The stepper is run as it is (solve() sets its update from cfg.update) and ends as the
/// run left it. Bad settings throw std::invalid_argument before any step; a run that cannot go on returns with
/// `failure` set and x at the last state reached; a cancelled run throws eci::interrupted; whatever the sink
/// throws propagates. The report's `method` is left empty (solve() fills it).
template <class St, class F_, class S, class Sink>
solve_report solve_with(St& stepper, F_&& system, S& x, const run_config& requested, Sink&& sink,
                        invariant_monitor<std::remove_cvref_t<F_>, S>& monitor) {
    using F = std::remove_reference_t<F_>;
    F& f = system;
    const std::optional<run_config> resolved = detail::resolved_config(requested);
    const run_config& cfg = resolved ? *resolved : requested;
    detail::check_run_inputs(std::as_const(f), std::as_const(x), cfg, "this system");
    if (cfg.adaptive) {
        if constexpr (adaptive_stepper<St, F&, S>)
            return detail::run_adaptive_on(stepper, f, x, cfg, sink, monitor);
        else
            throw std::invalid_argument("this stepper has no error estimate for rtol/atol");
    } else {
        if constexpr (eci::stepper<St, F&, S>)
            return detail::run_fixed_on(stepper, f, x, cfg, sink, monitor);
        else
            throw std::invalid_argument("this stepper does not take fixed steps");
    }
}

/// solve_with, monitoring the model's invariants (if it declares them) and `extra`.
template <class St, class F_, class S, class Sink>
solve_report solve_with(St& stepper, F_&& system, S& x, const run_config& cfg, Sink&& sink,
                        std::vector<extra_invariant<S>> extra = {}) {
    invariant_monitor<std::remove_cvref_t<F_>, S> monitor(system, std::move(extra));
    return solve_with(stepper, system, x, cfg, sink, monitor);
}

/// Sets a stepper's update to cfg.update (a conservative stepper with a choice of update), or refuses an update
/// chosen (cfg.update_chosen) for a stepper without one, std::invalid_argument naming `method` and `what`: solve()'s
/// rule, for a caller that builds its stepper itself.
template <class St>
void apply_update(St& stepper, const run_config& cfg, std::string_view method, std::string_view what) {
    if constexpr (requires { stepper.remedy.update; })
        stepper.remedy.update = cfg.update;
    else if (cfg.update_chosen)
        throw std::invalid_argument("update chooses the form of the conservative update on quadratic invariants (c-pc, "
                                    "c-rk2, c-rk4, a c- pair); method " + std::string(method) + " has none on " +
                                    std::string(what));
}

/// Runs `method` (a registry name) on the system f from x over `cfg`, monitoring the model's invariants (and
/// `extra`) at every step, and hands every output to `sink`: solve_with on the stepper the registry builds for
/// Dispatch (the model; for a plain function, its state type), with its update set to cfg.update. Bad settings
/// (and an unknown or unavailable method) throw std::invalid_argument before any step; a run that cannot go on
/// returns with `failure` set and x at the last state reached; a cancelled run throws eci::interrupted; whatever
/// the sink throws propagates.
template <class Dispatch, class F_, class S, class Sink>
solve_report solve(F_&& system, S& x, std::string_view method, const run_config& requested, Sink&& sink,
                   std::vector<extra_invariant<S>> extra = {}, std::string_view what = "this system") {
    using F = std::remove_reference_t<F_>;  // const for a const system; a model with step hooks is not
    F& f = system;
    const std::optional<run_config> resolved = detail::resolved_config(requested);
    const run_config& cfg = resolved ? *resolved : requested;
    detail::check_run_inputs(std::as_const(f), std::as_const(x), cfg, what);
    const method_info m = resolve_method_for<Dispatch>(method, cfg.is_adaptive(), what);
    if (m.family == method_family::conservative) detail::check_conservative_scale(x, m.name);
    invariant_monitor<std::remove_cv_t<F>, S> monitor(f, std::move(extra));
    solve_report report;
    report.t = cfg.t0;
    auto build = [&](auto stepper) {
        apply_update(stepper, cfg, m.name, what);
        return stepper;
    };
    if (cfg.adaptive) {
        with_adaptive_stepper<Dispatch>(m.name, [&](auto stepper) {
            auto st = build(stepper);
            report = detail::run_adaptive_on(st, f, x, cfg, sink, monitor);
        });
    } else {
        const bool found = with_stepper<Dispatch>(m.name, [&](auto stepper) {
            auto st = build(stepper);
            report = detail::run_fixed_on(st, f, x, cfg, sink, monitor);
        });
        if (!found)
            throw std::invalid_argument("method '" + std::string(method) + "' has no stepper for " + std::string(what));
    }
    report.method = m;
    return report;
}

/// Runs `stepper` on `model` from x over `span`: solve_with, the observer as its sink. The model's invariants are
/// monitored at every step (so the drift is the true maximum, whatever opt.every); a monitored invariant that
/// overflows does not stop the run (it is recorded, NaN kept). The observer sees (x, t, i, monitor), (x, t, i)
/// or (x, t) at step 0, every opt.every steps and at the last; it may throw to stop the run (the CLI's Ctrl-C).
/// A run that cannot go on (a step failing even at the smallest size, too much work, a non-finite state) ends
/// without an exception: the report then holds `failure`, and the statistics and drifts up to the last completed
/// step; x is the state reached. opt.first_step continues the grid (a restart); opt.resume is not supported (a
/// run starts afresh).
template <has_named_invariants Model, class St, class Observer = no_observer>
    requires stepper<St, const Model&, typename Model::state_type>
solve_report run(St& stepper, const Model& model, typename Model::state_type& x, const run_span& span,
                 Observer&& observe = {}, run_options opt = {}) {
    if (opt.every == 0) throw std::invalid_argument("observer interval must be at least 1");
    if (opt.resume) throw std::invalid_argument("eci::run starts a run afresh; resume a run with integrate_n_steps");
    run_config cfg;
    cfg.t0 = span.t0;
    cfg.dt = span.dt;
    if (span.to_end_time)
        cfg.t_end = span.t_end;
    else
        cfg.steps = span.steps;
    // steps first_step + 1 .. first_step + span.steps of the grid (a restart); check_config refuses it with an end time
    cfg.first_step = opt.first_step;
    cfg.every = opt.every;
    cfg.max_halvings = opt.max_halvings;
    cfg.max_substeps = opt.max_substeps;
    cfg.cancel = opt.cancel;
    cfg.stop_between_attempts = opt.stop_between_attempts;
    cfg.stop_on_invariant_overflow = false;
    invariant_monitor<Model> monitor(model);
    auto sink = detail::observer_sink<Model, Observer>{observe, monitor};
    return solve_with(stepper, model, x, cfg, sink, monitor);
}

/// Runs an adaptive `stepper` on `model` from x (at t0) to t_end (or, with output times, to the last of them) with
/// first step dt0 (0: choose_first_step's), monitoring the model's invariants: solve_with, the observer as its
/// sink. Without output times the observer sees every accepted step; with them, exactly those times (by `mode`).
/// The observer may be (x, t), (x, t, i) or (x, t, i, monitor) and may throw to stop the run. A run that stops
/// early (minimum step, step budget) reports `failure` with the statistics (report.adaptive) and drifts up to
/// there; x is the state reached. A monitored invariant that overflows does not stop the run.
template <has_named_invariants Model, class St, class Observer = no_observer>
solve_report run_adaptive(St& stepper, const Model& model, typename Model::state_type& x, double t0, double t_end,
                          double dt0, const adaptive_options& options, const std::vector<double>& times = {},
                          Observer&& observe = {}, output_mode mode = output_mode::automatic) {
    run_config cfg;
    cfg.t0 = t0;
    cfg.t_end = times.empty() ? t_end : times.back();  // with output times the run ends at the last one
    cfg.dt = dt0;
    cfg.adaptive = options;
    cfg.times = times;
    cfg.mode = mode;
    cfg.stop_on_invariant_overflow = false;
    invariant_monitor<Model> monitor(model);
    auto sink = detail::observer_sink<Model, Observer>{observe, monitor};
    return solve_with(stepper, model, x, cfg, sink, monitor);
}

}  // namespace eci
