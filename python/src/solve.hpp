// eci.solve's one path into the library's run: the request as an eci::run_config, a sink that fills the NumPy
// arrays and polls Ctrl-C, eci::solve, and the report as SolveResult's dict (or eci's Python exceptions).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <eci/solve.hpp>

#include "core.hpp"
#include "python_system.hpp"

namespace eci::python {

/// What eci.solve asks for, read from the settings dict the Python side builds: t_eval, max_halvings, and for
/// adaptive control (key "adaptive" not None) rtol, atol, rtol_each, atol_each, min_step, max_step, max_steps,
/// t_eval_mode. `dt` is the fixed step or the first step.
struct python_request {
    run_config config;
};

inline python_request request_from(double t0, double t1, double dt, const py::dict& settings) {
    python_request r;
    run_config& c = r.config;
    c.t0 = t0;
    c.t_end = t1;
    c.dt = dt;
    c.stop_on_invariant_overflow = true;
    if (!settings["t_eval"].is_none()) c.times = settings["t_eval"].cast<std::vector<double>>();
    c.max_halvings = settings["max_halvings"].cast<int>();
    const py::object a = settings["adaptive"];
    if (!a.is_none()) {
        adaptive_options o;
        o.rtol = a["rtol"].cast<double>();
        o.atol = a["atol"].cast<double>();
        o.rtol_each = a["rtol_each"].cast<std::vector<double>>();
        o.atol_each = a["atol_each"].cast<std::vector<double>>();
        o.dt_min = a["min_step"].cast<double>();
        o.dt_max = a["max_step"].cast<double>();
        o.max_attempts = a["max_steps"].cast<std::uint64_t>();
        const std::string mode = a["t_eval_mode"].cast<std::string>();
        c.mode = mode == "dense" ? output_mode::dense : mode == "landing" ? output_mode::landing : output_mode::automatic;
        c.adaptive = o;
    }
    return r;
}

/// The sink: every output into the arrays, Ctrl-C polled between steps.
template <class S>
struct recording_sink {
    recorded_output<S>* out;
    interrupt_check* interrupt;
    void output(const S& x, const output_point& p) { out->record(p.t, x); }
    void progress(double, std::uint64_t) { (*interrupt)(); }
};

/// The statistics of a run as `result.stats`.
inline py::dict stats_dict(const solve_report& r) {
    const std::uint64_t non_finite =
        r.adaptive ? r.adaptive->rejected_non_finite_rate : r.stats.non_finite_rate_reductions;
    py::dict rejected;
    rejected["step_failed"] = r.stats.step_reductions - non_finite;
    rejected["non_finite_fun"] = non_finite;
    rejected["error_estimate"] = r.adaptive ? r.adaptive->rejected_error : 0;  // fixed steps: no error control
    py::dict d;
    d["steps"] = r.stats.steps;
    d["t_eval_steps"] = r.side_steps;
    d["rejected_steps"] = rejected;
    d["rhs_evals"] = r.stats.rhs_evals;
    d["remedied_steps"] = r.stats.remedied_steps;
    d["components_remedied"] = r.stats.components_remedied;
    d["solver_solves"] = r.stats.solver.solves;
    d["solver_iterations"] = r.stats.solver.iterations;
    d["solver_max_iterations"] = r.stats.solver.max_iterations;
    if (r.adaptive) {
        const adaptive_stats& s = *r.adaptive;
        d["adaptive"] = true;
        d["dt_smallest"] = s.accepted ? s.dt_smallest : 0.0;
        d["dt_largest"] = s.dt_largest;
        d["dense_points"] = s.dense_points;
        d["landed_points"] = s.landed_points;
        d["dense_fallbacks"] = s.dense_fallbacks;
    }
    return d;
}

/// The drift records as the dict `result.invariants`: name -> initial, final, max_abs_drift, max_rel_drift.
inline py::dict drift_dict(const std::vector<invariant_record>& records) {
    py::dict d;
    for (const invariant_record& r : records) {
        py::dict e;
        e["initial"] = r.initial;
        e["final"] = r.final;
        e["max_abs_drift"] = r.max_abs_drift;
        e["max_rel_drift"] = r.max_rel_drift();  // as the CLI's summary: 0 if it never moved, inf if it moved from 0
        d[py::str(r.name)] = e;
    }
    return d;
}

/// A run that stopped early as eci's Python exception (GIL held).
[[noreturn]] inline void throw_failure(const solve_report& r, const component_namer& name) {
    const run_failure& f = *r.failure;
    const std::string component = name(f.component);
    const py::module_ errors = py::module_::import("eci._errors");
    auto raise = [&](const char* cls_name, const std::string& message, const std::string& cause) {
        const py::object cls = errors.attr(cls_name);
        const py::object exc = cls(message, f.t, f.component, component, f.dt, cause, stats_dict(r));
        PyErr_SetObject(cls.ptr(), exc.ptr());
        return py::error_already_set();
    };
    switch (f.kind) {
        case run_failure_kind::step_failed: {
            const bool rate = f.non_finite_rate_value.has_value();
            const std::string cause = rate ? "fun(t, y) returned " + full_text(*f.non_finite_rate_value) +
                                                 " in component " + component
                                           : "negative radicand, non-invertible transform or non-finite state";
            const std::string head = f.message.substr(0, f.message.find("): ") + 3);
            throw raise("StepSizeUnderflow", head + cause, rate ? "non_finite_fun" : "step_failed");
        }
        case run_failure_kind::step_too_small: {
            const char* cause = f.last_rejection == rejection::non_finite_rate ? "non_finite_fun"
                                : f.last_rejection == rejection::step_failed   ? "step_failed"
                                                                                : "error_estimate";
            throw raise("StepSizeUnderflow",
                        f.message + " [component " + component + ", last rejection: " + cause + "]", cause);
        }
        case run_failure_kind::too_many_steps: throw raise("TooManySteps", f.message, "too_many_steps");
        case run_failure_kind::work_exceeded: throw raise("StepSizeUnderflow", f.message, "work_exceeded");
        case run_failure_kind::non_finite_state:
            throw raise("NonFiniteSolution", f.message + ": the solution blew up", "non_finite_state");
        case run_failure_kind::invariant_overflow:
            throw raise("NonFiniteSolution", f.message, "invariant_overflow");
    }
    throw std::logic_error("unknown run failure");
}

/// Runs `method` on f from x through eci::solve with the request, with the GIL released unless `release` is
/// false (a Python fun or Python invariants need it held), and returns the SolveResult dict.
template <class Dispatch, class F, class S>
py::dict run_python(const F& f, S& x, const std::string& method, python_request req,
                    std::vector<extra_invariant<S>> extra, const component_namer& namer, const std::string& what,
                    bool release) {
    req.config.component_name = namer;
    recorded_output<S> out;
    solve_report report;
    {
        std::optional<py::gil_scoped_release> unlocked;
        if (release) unlocked.emplace();
        interrupt_check interrupt(!release);
        recording_sink<S> sink{&out, &interrupt};
        report = solve<Dispatch>(f, x, method, req.config, sink, std::move(extra), what);
    }
    if (report.failure) throw_failure(report, namer);
    py::dict d;
    add_arrays(d, out, std::ranges::size(x));
    d["stats"] = stats_dict(report);
    d["invariants"] = drift_dict(report.invariants);
    add_method(d, report.method);
    return d;
}

/// The Python callables given as invariants=, as extra invariants of a run on S (the GIL must be held).
template <class S>
std::vector<extra_invariant<S>> python_extra_invariants(std::vector<py::object> functions,
                                                        const std::vector<std::string>& names) {
    using T = std::ranges::range_value_t<S>;
    std::vector<extra_invariant<S>> v;
    for (std::size_t j = 0; j < functions.size(); ++j) {
        v.push_back({names[j], [fn = std::move(functions[j]), name = names[j]](const S& x) {
                         const py::object r = fn(to_numpy(std::vector<T>(std::ranges::begin(x), std::ranges::end(x))));
                         try {
                             return r.cast<double>();
                         } catch (const py::cast_error&) {
                             throw py::type_error("invariant " + name + " returned " + std::string(py::repr(r)) +
                                                  ", expected a real number");
                         }
                     }});
    }
    return v;
}

}  // namespace eci::python
