// Adaptive step control behind eci.solve(..., rtol=, atol=): the library's integrate_adaptive / _at (so the states
// are `eci run --rtol`'s bit for bit), rejections by cause, Ctrl-C between attempts, failures as Python errors.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <eci/adaptive.hpp>

#include "core.hpp"
#include "python_system.hpp"

namespace eci::python {

/// What an adaptive run is asked to do; `options` holds eci.solve's rtol, atol, min_step, max_step, max_steps.
struct adaptive_request {
    double t0 = 0.0, t1 = 0.0, first_step = 0.0;
    std::optional<std::vector<double>> t_eval;  ///< sorted, inside [t0, t1]
    adaptive_options options;
    output_mode mode = output_mode::automatic;
};

/// Why attempts were rejected, beyond the library's two counters, and the last rejection's cause.
struct attempt_monitor {
    interrupt_check* interrupt = nullptr;
    non_finite_flag* flag = nullptr;  ///< a Python fun's; null for a built-in model
    std::uint64_t non_finite_rejections = 0;
    std::string last_cause = "error_estimate";
};

/// The adaptive stepper St, also checking Ctrl-C before each attempt and classifying each rejection. Numerics are
/// St's own; a default-constructed copy (the dense output's fallback) has no monitor and never attempts.
template <class St>
struct monitored_stepper : St {
    attempt_monitor* monitor = nullptr;

    template <class F, class S>
    attempt_result attempt(F& f, const S& x, double t, double dt, const error_weights* w = nullptr,
                           bool track_worst = false) {
        (*monitor->interrupt)();
        if (monitor->flag) monitor->flag->seen = false;
        const attempt_result r = St::attempt(f, x, t, dt, w, track_worst);
        const bool accepted = r.ok && std::isfinite(r.error) && r.error <= 1.0;
        if (!accepted && !track_worst) {  // track_worst: the library re-attempting only to name the component
            if (monitor->flag && monitor->flag->seen) {
                ++monitor->non_finite_rejections;
                monitor->last_cause = "non_finite_fun";
            } else {
                monitor->last_cause = r.ok && std::isfinite(r.error) ? "error_estimate" : "step_failed";
            }
        }
        return r;
    }
};

/// An adaptive run stopped (step below the minimum, or too many steps): eci.StepSizeUnderflow or eci.TooManySteps.
struct adaptive_error : std::runtime_error {
    adaptive_error(const std::string& what, bool too_many, double t, std::size_t component,
                   std::string component_name, double dt, std::string cause, py::dict stats)
        : std::runtime_error(what), too_many(too_many), t(t), component(component),
          component_name(std::move(component_name)), dt(dt), cause(std::move(cause)), stats(std::move(stats)) {}
    bool too_many;
    double t;
    std::size_t component;
    std::string component_name;
    double dt;
    std::string cause;
    py::dict stats;  // built with the GIL held (see run_adaptive_grid's caller)
};

/// The statistics of an adaptive run as `result.stats`: the fixed-step keys (steps = accepted steps) plus the
/// adaptive ones.
inline py::dict adaptive_stats_dict(const adaptive_stats& s, const attempt_monitor& m) {
    py::dict rejected;
    rejected["error_estimate"] = s.rejected_error;
    rejected["step_failed"] = s.rejected_radicand - m.non_finite_rejections;
    rejected["non_finite_fun"] = m.non_finite_rejections;
    py::dict d;
    d["steps"] = s.accepted;
    d["t_eval_steps"] = 0;
    d["rejected_steps"] = rejected;
    d["rhs_evals"] = s.rhs_evals;
    d["remedied_steps"] = 0;
    d["components_remedied"] = 0;
    d["solver_solves"] = 0;
    d["solver_iterations"] = 0;
    d["solver_max_iterations"] = 0;
    d["adaptive"] = true;
    d["dt_smallest"] = s.accepted ? s.dt_smallest : 0.0;
    d["dt_largest"] = s.dt_largest;
    d["dense_points"] = s.dense_points;
    d["landed_points"] = s.landed_points;
    d["dense_fallbacks"] = s.dense_fallbacks;
    return d;
}

/// What run_adaptive_grid leaves for the result (built into Python objects once the GIL is held again).
struct adaptive_outcome {
    adaptive_stats stats;
    attempt_monitor monitor;
    std::optional<adaptive_failure> failure;
};

/// Integrates x from req.t0 to req.t1 with the adaptive stepper St on f: output at every accepted step, or at the
/// t_eval times (dense output or landing steps, req.mode). measure(x, first) runs at t0 and at every output state
/// (as `eci run --rtol` monitors). A failure is returned in the outcome, not thrown (the GIL may be released).
template <class St, class F, class S, class Measure>
adaptive_outcome run_adaptive_grid(const St&, F& f, S& x, const adaptive_request& req, Measure&& measure,
                                   interrupt_check& interrupt, recorded_output<S>& out, non_finite_flag* flag) {
    adaptive_outcome outcome;
    outcome.monitor.interrupt = &interrupt;
    outcome.monitor.flag = flag;
    monitored_stepper<St> stepper;
    stepper.monitor = &outcome.monitor;
    measure(std::as_const(x), true);
    try {
        if (!req.t_eval) {
            auto observe = [&](const S& s, double t, std::uint64_t i) {
                if (i > 0) measure(s, false);
                out.record(t, s);
            };
            outcome.stats = integrate_adaptive(stepper, f, x, req.t0, req.t1, req.first_step, req.options, observe);
        } else {
            // the run goes on to t1 whatever the last t_eval time (as solve_ivp); only t_eval's times are recorded
            std::vector<double> times = *req.t_eval;
            const std::size_t wanted = times.size();
            if (times.empty() || times.back() < req.t1) times.push_back(req.t1);
            auto observe = [&](const S& s, double t, std::uint64_t i) {
                if (t > req.t0) measure(s, false);
                if (i < wanted) out.record(t, s);
            };
            outcome.stats = integrate_adaptive_at(stepper, f, x, req.t0, times, req.first_step, req.options, observe,
                                                  req.mode);
        }
    } catch (const adaptive_failure& e) {
        outcome.stats = e.stats;
        outcome.failure = e;
    }
    return outcome;
}

/// The outcome's failure as the Python exception's C++ side (GIL held), naming the component.
inline void throw_if_failed(const adaptive_outcome& o, const component_namer& name) {
    if (!o.failure) return;
    const adaptive_failure& e = *o.failure;
    const bool too_many = e.why == adaptive_failure::reason::too_many_steps;
    const std::string component = name(e.component);
    const std::string cause = too_many ? "too_many_steps" : o.monitor.last_cause;
    throw adaptive_error(std::string(e.what()) + (too_many ? "" : " [component " + component + ", last rejection: " +
                                                                      cause + "]"),
                         too_many, e.time, e.component, component, e.dt, cause,
                         adaptive_stats_dict(e.stats, o.monitor));
}

/// The registered methods that run adaptively on Model, as strings.
template <class Model>
std::vector<std::string> adaptive_method_names() {
    std::vector<std::string> v;
    for (const method_info& m : adaptive_methods_for<Model>()) v.emplace_back(m.name);
    return v;
}

/// The registry's entry for an adaptive run of `name`, or ValueError naming the methods with an error estimate.
inline method_info resolve_adaptive_method(const std::string& name, const std::vector<std::string>& available,
                                           const std::string& what) {
    const auto m = find_method(name);
    if (m) {
        for (const std::string& a : available)
            if (a == name) return *m;
        std::string names;
        for (const std::string& a : available) names += (names.empty() ? "" : ", ") + a;
        throw std::invalid_argument("method " + name + " has no error estimate for rtol/atol; adaptive methods for " +
                                    what + ": " + names);
    }
    return resolve_method(name, available, what);  // unknown: the registry's message
}

/// eci.solve's adaptive settings (a dict built by the Python side) as an adaptive_request.
inline adaptive_request adaptive_request_from(double t0, double t1, double first_step,
                                              std::optional<std::vector<double>> t_eval, const py::dict& a) {
    adaptive_request r;
    r.t0 = t0, r.t1 = t1, r.first_step = first_step, r.t_eval = std::move(t_eval);
    adaptive_options& o = r.options;
    o.rtol = a["rtol"].cast<double>();
    o.atol = a["atol"].cast<double>();
    o.rtol_each = a["rtol_each"].cast<std::vector<double>>();
    o.atol_each = a["atol_each"].cast<std::vector<double>>();
    o.dt_min = a["min_step"].cast<double>();
    o.dt_max = a["max_step"].cast<double>();
    o.max_attempts = a["max_steps"].cast<std::uint64_t>();
    const std::string mode = a["t_eval_mode"].cast<std::string>();
    r.mode = mode == "dense" ? output_mode::dense : mode == "landing" ? output_mode::landing : output_mode::automatic;
    return r;
}

}  // namespace eci::python
