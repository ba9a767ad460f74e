// The integration loop behind eci.solve, shared by the Python functions and the built-in models: fixed steps on the
// CLI's time grid with step reduction, output at every step or at t_eval, invariant drift, statistics and Ctrl-C.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <charconv>
#include <chrono>
#include <cmath>
#include <complex>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include <eci/concepts.hpp>
#include <eci/integrate.hpp>
#include <eci/registry.hpp>

namespace eci::python {

namespace py = pybind11;

/// v with 17 significant digits, as the CLI prints times and values.
inline std::string full_text(double v) {
    char buffer[32];
    const auto r = std::to_chars(buffer, buffer + sizeof buffer, v, std::chars_format::general, 17);
    return std::string(buffer, r.ptr);
}

/// The shortest text that reads back as v, as the CLI quotes rejected input.
inline std::string shortest_text(double v) {
    char buffer[32];
    const auto r = std::to_chars(buffer, buffer + sizeof buffer, v);
    return std::string(buffer, r.ptr);
}

/// fun(t, y) returned a non-finite value: thrown out of the stepper, which leaves x untouched, and turned into a
/// failed step (retried smaller, like a negative radicand) by advance().
struct non_finite_rhs {
    std::size_t component;  ///< the real unknown
    double value;
};

/// Steps rejected, by cause.
struct rejections {
    std::uint64_t step_failed = 0;     ///< negative radicand, non-invertible transform or unconverged implicit solve
    std::uint64_t non_finite_fun = 0;  ///< fun(t, y) returned inf or nan
};

/// Everything a run counts.
struct run_report {
    run_stats stats{};
    rejections rejected{};
    std::uint64_t t_eval_steps = 0;  ///< extra steps from the grid to t_eval points between grid times
};

/// A step failed even at the smallest step size: eci.StepSizeUnderflow in Python, with the statistics so far.
struct underflow_error : std::runtime_error {
    underflow_error(const std::string& what, double t, std::size_t component, std::string component_name, double dt,
                    bool non_finite, run_report report)
        : std::runtime_error(what), t(t), component(component), component_name(std::move(component_name)), dt(dt),
          non_finite(non_finite), report(report) {}
    double t;
    std::size_t component;
    std::string component_name;
    double dt;
    bool non_finite;
    run_report report;
};

/// Names the real unknowns of a state in messages: the model's component names, or y[i] / re y[i], im y[i].
struct component_namer {
    std::vector<std::string> names;  ///< empty: indexed names
    bool complex = false;

    std::string operator()(std::size_t i) const {
        if (i < names.size()) return names[i];
        if (!complex) return "y[" + std::to_string(i) + "]";
        return std::string(i % 2 ? "im" : "re") + " y[" + std::to_string(i / 2) + "]";
    }
};

/// Checks for Ctrl-C between steps. With the GIL held (a Python fun) that is one flag test per step; with the GIL
/// released (a built-in model) the GIL is taken back every 1-10 ms of run time, the stride in steps adapting so
/// that cheap steps do not pay for a clock read each.
class interrupt_check {
   public:
    explicit interrupt_check(bool gil_held) : gil_held_(gil_held), last_(std::chrono::steady_clock::now()) {}

    /// Called between steps: a counter on the fast path, so that it inlines into the step loop.
    void operator()() {
        if (gil_held_) return check_now();
        if (++count_ >= stride_) slow_path();
    }

   private:
    static void check_now() {
        if (PyErr_CheckSignals() != 0) throw py::error_already_set();
    }

    [[gnu::noinline]] void slow_path() {
        count_ = 0;
        const auto now = std::chrono::steady_clock::now();
        const auto elapsed = now - last_;
        last_ = now;
        if (elapsed < std::chrono::milliseconds(1) && stride_ < (std::uint64_t{1} << 24))
            stride_ *= 2;
        else if (elapsed > std::chrono::milliseconds(10) && stride_ > 1)
            stride_ /= 2;
        py::gil_scoped_acquire gil;
        check_now();
    }

    bool gil_held_;
    std::uint64_t count_ = 0, stride_ = 1;
    std::chrono::steady_clock::time_point last_;
};

/// One invariant's record over a run, as the CLI keeps it: measured after every step.
struct drift_record {
    std::string name;
    double initial = 0.0, final = 0.0, max_abs_drift = 0.0;

    void update(double v, bool first) {
        if (first) initial = v;
        final = v;
        const double d = std::abs(v - initial);
        if (d > max_abs_drift || std::isnan(d)) max_abs_drift = d;
    }
};

/// The sampled solution: times and states in the order they were recorded.
template <class S>
struct recorded_output {
    using value_type = std::ranges::range_value_t<S>;
    std::vector<double> t;
    std::vector<value_type> y;

    void record(double time, const S& x) {
        t.push_back(time);
        y.insert(y.end(), std::ranges::begin(x), std::ranges::end(x));
    }
};

/// What a run is asked to do. t_eval is sorted and inside [t0, t1]; without it every grid time is output.
struct run_request {
    double t0 = 0.0, t1 = 0.0, dt = 0.0;
    std::optional<std::vector<double>> t_eval;
    int max_halvings = run_options{}.max_halvings;
};

/// A system whose evaluation may throw non_finite_rhs (a Python fun); the built-in models never do, and their
/// steps then run without an exception handler around them.
template <class F>
concept checks_finite = requires { requires F::checks_finite; };

/// One attempt at a step: its result, and whether it failed on a non-finite value returned by fun.
struct attempt {
    step_result result;
    bool non_finite = false;
    double value = 0.0;
};

template <class St, class F, class S>
inline attempt try_step(St& stepper, F& f, S& x, double t, double h) {
    if constexpr (checks_finite<std::remove_cvref_t<F>>) {
        try {
            return {stepper.step(f, x, t, h)};
        } catch (const non_finite_rhs& e) {
            return {step_result::failure(e.component), true, e.value};
        }
    } else {
        return {stepper.step(f, x, t, h)};
    }
}

/// Retries the failed attempt `a` from (x, t) as two half steps, and so on until each part succeeds or has been
/// halved `left` times, as eci's drivers do; out of line, so that the successful step stays lean.
template <class St, class F, class S>
[[gnu::noinline]] void reduce(St& stepper, F& f, S& x, double t, double h, int left, attempt a, run_report& report,
                              const component_namer& name, int max_halvings) {
    if (left == 0) {
        detail::collect_solver_stats(stepper, report.stats);
        const std::size_t c = a.result.component;
        const std::string cause = a.non_finite ? "fun(t, y) returned " + full_text(a.value) + " in component " + name(c)
                                               : "negative radicand, non-invertible transform or non-finite state";
        throw underflow_error("step failed at t = " + full_text(t) + " in component " + name(c) +
                                  " even with the step halved " + std::to_string(max_halvings) + " times (dt = " +
                                  full_text(h) + "): " + cause,
                              t, c, name(c), h, a.non_finite, report);
    }
    ++(a.non_finite ? report.rejected.non_finite_fun : report.rejected.step_failed);
    ++report.stats.step_reductions;
    for (const double start : {t, t + 0.5 * h}) {
        const attempt half = try_step(stepper, f, x, start, 0.5 * h);
        if (!half.result) reduce(stepper, f, x, start, 0.5 * h, left - 1, half, report, name, max_halvings);
    }
}

/// Advances x by h; a failed step (reported by the stepper, or a non-finite value returned by a Python fun) is
/// retried smaller by reduce().
template <class St, class F, class S>
inline void advance(St& stepper, F& f, S& x, double t, double h, int max_halvings, run_report& report,
                    const component_namer& name) {
    const attempt a = try_step(stepper, f, x, t, h);
    if (!a.result) [[unlikely]]
        reduce(stepper, f, x, t, h, max_halvings, a, report, name, max_halvings);
}

/// The system the steppers see: f, with its evaluations counted. Steppers that need the model itself (its
/// transform, its Jacobian) reach it through wrapped().
template <class F>
struct counted_system {
    const F& f;
    run_report& report;
    static constexpr bool checks_finite = eci::python::checks_finite<F>;

    template <class S>
    void operator()(const S& x, S& dxdt, double t) const {
        ++report.stats.rhs_evals;
        f(x, dxdt, t);
    }
    const F& wrapped() const { return f; }
};

/// Integrates from (x, t0) to t1 on the grid of `eci run`: times t0 + i dt, the last step shortened to land on t1
/// exactly (integrate_to's arithmetic, so the states are bit for bit the CLI's). measure(x, first) runs at the start
/// and after every step; out records every grid state, or, with t_eval, the states at those times (a point between
/// two grid times is reached by one extra step from the earlier one, with a copy of the stepper, leaving the grid
/// run untouched).
template <class S, class F, class St, class Measure>
void run_grid(St& stepper, F& f, S& x, const run_request& req, Measure&& measure, interrupt_check& interrupt,
              recorded_output<S>& out, run_report& report, const component_namer& name) {
    counted_system<std::remove_cvref_t<F>> counted{f, report};
    // As eci's drivers: a model's declared quadratic invariants go to the stepper's negative-radicand remedy, so
    // the states stay bit for bit the CLI's.
    detail::attach_quadratic_invariants(stepper, f, x);
    const remedy_stats remedy_before = detail::remedy_counters(stepper);
    // Without t_eval every grid time is output; with it, `next` is the next output time (infinity after the last).
    constexpr double never = std::numeric_limits<double>::infinity();
    const bool every_step = !req.t_eval;
    const std::vector<double> empty;
    const std::vector<double>& te = req.t_eval ? *req.t_eval : empty;
    std::size_t k = 0;
    double next = te.empty() ? never : te[0];
    auto emit = [&](double t) {
        if (every_step) return out.record(t, x);
        for (; next == t; next = ++k < te.size() ? te[k] : never) out.record(t, x);
    };
    measure(std::as_const(x), true);
    emit(req.t0);
    const std::uint64_t n = steps_to_reach(req.t0, req.t1, req.dt);
    const double last = n ? req.t1 - (req.t0 + double(n - 1) * req.dt) : 0.0;
    const bool full_last = std::abs(last - req.dt) <= 1e-12 * req.dt;  // as integrate_to decides
    for (std::uint64_t i = 1; i <= n; ++i) {
        interrupt();
        const double start = req.t0 + double(i - 1) * req.dt;
        const double h = (i < n || full_last) ? req.dt : last;
        const double end = i == n ? req.t1 : req.t0 + double(i) * req.dt;
        for (; next < end; next = ++k < te.size() ? te[k] : never) {
            St side = stepper;
            S xs = x;
            advance(side, counted, xs, start, next - start, req.max_halvings, report, name);
            ++report.t_eval_steps;
            measure(std::as_const(xs), false);
            out.record(next, xs);
        }
        advance(stepper, counted, x, start, h, req.max_halvings, report, name);
        ++report.stats.steps;
        measure(std::as_const(x), false);
        if (every_step || next == end) emit(end);
    }
    detail::collect_solver_stats(stepper, report.stats);
    detail::collect_remedy_stats(stepper, remedy_before, report.stats);
}

/// The statistics as the Python dict `result.stats`.
inline py::dict stats_dict(const run_report& r) {
    py::dict rejected;
    rejected["step_failed"] = r.rejected.step_failed;
    rejected["non_finite_fun"] = r.rejected.non_finite_fun;
    rejected["error_estimate"] = 0;  // fixed steps: no error control
    py::dict d;
    d["steps"] = r.stats.steps;
    d["t_eval_steps"] = r.t_eval_steps;
    d["rejected_steps"] = rejected;
    d["rhs_evals"] = r.stats.rhs_evals;
    d["remedied_steps"] = r.stats.remedied_steps;
    d["components_remedied"] = r.stats.components_remedied;
    d["solver_solves"] = r.stats.solver.solves;
    d["solver_iterations"] = r.stats.solver.iterations;
    d["solver_max_iterations"] = r.stats.solver.max_iterations;
    return d;
}

/// The drift records as the dict `result.invariants`: name -> initial, final, max_abs_drift, max_rel_drift.
inline py::dict drift_dict(const std::vector<drift_record>& records) {
    py::dict d;
    for (const drift_record& r : records) {
        py::dict e;
        e["initial"] = r.initial;
        e["final"] = r.final;
        e["max_abs_drift"] = r.max_abs_drift;
        // as the CLI's summary: 0 if it never moved, infinite if it moved from 0
        e["max_rel_drift"] = r.max_abs_drift == 0.0 ? 0.0 : r.max_abs_drift / std::abs(r.initial);
        d[py::str(r.name)] = e;
    }
    return d;
}

/// The registry's entry for `name`, or ValueError with the CLI's message.
inline method_info resolve_method(const std::string& name, const std::vector<std::string>& available,
                                  const std::string& what) {
    const auto m = find_method(name);
    auto joined = [](const auto& names) {
        std::string s;
        for (const auto& n : names) s += (s.empty() ? "" : ", ") + std::string(n);
        return s;
    };
    if (!m) {
        std::vector<std::string_view> all;
        for (const method_info& i : eci::methods) all.push_back(i.name);
        throw std::invalid_argument("unknown method '" + name + "' (methods: " + joined(all) + ")");
    }
    bool found = false;
    for (const std::string& a : available) found = found || a == name;
    if (!found)
        throw std::invalid_argument("method '" + name + "' is not available for " + what + " (available: " +
                                    joined(available) + ")");
    return *m;
}

/// The result of a run as the dict eci.solve turns into a SolveResult: t, y (n x m, SciPy's layout), stats,
/// invariants and the method's registry entry.
template <class S>
py::dict result_dict(recorded_output<S>& out, std::size_t n, const run_report& report,
                     const std::vector<drift_record>& drift, const method_info& method) {
    using value_type = typename recorded_output<S>::value_type;
    const auto m = static_cast<py::ssize_t>(out.t.size());
    // The arrays take the recorded vectors over (no copy: a long run's output is most of its memory).
    auto handed_over = [](auto&& v) {
        using V = std::remove_cvref_t<decltype(v)>;
        auto* owned = new V(std::move(v));
        return std::pair{owned, py::capsule(owned, [](void* p) { delete static_cast<V*>(p); })};
    };
    auto [tv, t_owner] = handed_over(std::move(out.t));
    auto [yv, y_owner] = handed_over(std::move(out.y));
    const py::array_t<double> t({m}, tv->data(), t_owner);
    const py::array_t<value_type> rows({m, static_cast<py::ssize_t>(n)}, yv->data(), y_owner);
    py::dict d;
    d["t"] = t;
    d["y"] = rows.attr("T");  // y[:, i] is the state at t[i]
    d["stats"] = stats_dict(report);
    d["invariants"] = drift_dict(drift);
    d["method"] = std::string(method.name);
    d["order"] = method.order;
    d["conservative"] = method.conservative;
    return d;
}

}  // namespace eci::python
