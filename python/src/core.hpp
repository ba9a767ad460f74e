// What the Python side of a run shares: numbers as the CLI prints them, component names, Ctrl-C polling, the
// recorded output and its hand-over to NumPy.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <complex>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include <eci/concepts.hpp>
#include <eci/format.hpp>
#include <eci/progress.hpp>
#include <eci/integrate.hpp>
#include <eci/registry.hpp>
#include <eci/run.hpp>

namespace eci::python {

namespace py = pybind11;

// Numbers in messages as the CLI and Python's own code quote them: eci::full_text (17 digits), eci::shortest_text
// (the shortest text, laid out as Python's repr) from <eci/format.hpp>.
using eci::full_text;
using eci::shortest_text;

// NavierStokes2D's fixed-step loop (models_ns2d.cpp) still counts and fails with these; every other run goes through
// eci::solve (solve.hpp) and its solve_report.

/// Steps rejected, by cause.
struct rejections {
    std::uint64_t step_failed = 0;     ///< negative radicand, non-invertible transform or unconverged implicit solve
    std::uint64_t non_finite_fun = 0;  ///< fun(t, y) returned inf or nan
};

/// Everything a run counts.
struct step_counts {
    run_stats stats{};
    rejections rejected{};
    std::uint64_t t_eval_steps = 0;  ///< extra steps from the grid to t_eval points between grid times
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

/// eci.solve's progress= line on sys.stderr, `eci run`'s pace and text (eci/progress.hpp): "[####....]  45.0%  t =
/// 4.5  12 s left", from a second into the run, at most ten times a second, erased when it is destroyed. The run
/// sets its position at every step without the GIL (a store); draw_if_due is called with the GIL held
/// (interrupt_check, which takes it every 1-10 ms of run time), and it is destroyed with the GIL held: made outside
/// the run's release of the GIL, so that it is erased after any end of the run (a KeyboardInterrupt, a failure).
class progress_display {
   public:
    progress_display(double t0, double t1) : t0_(t0), t1_(t1) {}
    progress_display(const progress_display&) = delete;
    progress_display& operator=(const progress_display&) = delete;
    ~progress_display() {
        if (shown_) write("\r\033[K");
    }
    void set(double t) { t_ = t; }
    void draw_if_due() {
        if (!pace_.due()) return;
        const double span = t1_ - t0_;
        const double fraction = span != 0.0 ? (t_ - t0_) / span : 1.0;
        shown_ = write("\r" + progress_text(fraction, t_, pace_.elapsed())) || shown_;
    }

   private:
    // sys.stderr as it is now (a notebook's stream, a redirected file); false where there is none to write to
    static bool write(const std::string& s) {
        try {
            const py::object err = py::module_::import("sys").attr("stderr");
            if (err.is_none()) return false;
            err.attr("write")(s);
            err.attr("flush")();
            return true;
        } catch (const py::error_already_set&) {  // a closed or odd stream: the run goes on without its line
            return false;
        }
    }
    double t0_, t1_, t_ = 0.0;
    bool shown_ = false;
    eci::progress_pace pace_;
};

/// Checks for Ctrl-C between steps. With the GIL held (a Python fun) that is one flag test per step; with the GIL
/// released (a built-in model) the GIL is taken back every 1-10 ms of run time, the stride in steps adapting so
/// that cheap steps do not pay for a clock read each.
class interrupt_check {
   public:
    explicit interrupt_check(bool gil_held, progress_display* progress = nullptr)
        : gil_held_(gil_held), progress_(progress), last_(std::chrono::steady_clock::now()) {}

    /// The same at a step reaching t, which the progress line (if any) shows when it is next drawn.
    void operator()(double t) {
        if (progress_) progress_->set(t);
        (*this)();
    }

    /// Called between steps: a counter on the fast path, so that it inlines into the step loop. With the GIL held
    /// it is also let go for an instant every 5-10 ms: between outputs a run may call no Python code at all (a
    /// built-in model with Python invariants, evaluated at its outputs), and every other Python thread (a timer that
    /// would signal, a progress display) stood still until the run ended.
    void operator()() {
        if (gil_held_) {
            check_now();
            if (++count_ >= stride_) yield_gil();
            return;
        }
        if (++count_ >= stride_) slow_path();
    }

   private:
    static void check_now() {
        if (PyErr_CheckSignals() != 0) throw py::error_already_set();
    }
    void draw_progress() {
        if (progress_) progress_->draw_if_due();
    }

    // The stride in steps adapted so that `elapsed` between calls stays within [low, high].
    void adapt(std::chrono::milliseconds low, std::chrono::milliseconds high) {
        count_ = 0;
        const auto now = std::chrono::steady_clock::now();
        const auto elapsed = now - last_;
        last_ = now;
        if (elapsed < low && stride_ < (std::uint64_t{1} << 24))
            stride_ *= 2;
        else if (elapsed > high && stride_ > 1)
            stride_ /= 2;
    }

    [[gnu::noinline]] void slow_path() {
        adapt(std::chrono::milliseconds(1), std::chrono::milliseconds(10));
        py::gil_scoped_acquire gil;
        check_now();
        draw_progress();
    }

    [[gnu::noinline]] void yield_gil() {
        adapt(std::chrono::milliseconds(5), std::chrono::milliseconds(10));
        {
            py::gil_scoped_release release;  // (a thread waiting for the GIL takes it here)
        }
        check_now();
        draw_progress();
    }

    bool gil_held_;
    progress_display* progress_;
    std::uint64_t count_ = 0, stride_ = 1;
    std::chrono::steady_clock::time_point last_;
};

/// The sampled solution: times and states in the order they were recorded.
template <class S>
struct recorded_output {
    using value_type = std::ranges::range_value_t<S>;
    std::vector<double> t;
    std::vector<value_type> y;
    std::vector<double> time_lag;  // relaxation RK: each output's state belongs to t + time_lag (else empty)
    /// Each monitored invariant's value at each output (result.invariant_values), in the monitor's order: the
    /// values the run measured there anyway (output_point::invariants), kept.
    std::vector<std::vector<double>> invariants;

    void record(double time, const S& x, std::optional<double> lag = std::nullopt) {
        t.push_back(time);
        y.insert(y.end(), std::ranges::begin(x), std::ranges::end(x));
        if (lag) time_lag.resize(t.size() - 1, 0.0), time_lag.push_back(*lag);
    }
    /// The invariants' values at the output just recorded.
    void record_invariants(std::span<const double> v) {
        if (invariants.size() < v.size()) invariants.resize(v.size());
        for (std::size_t k = 0; k < v.size(); ++k) invariants[k].push_back(v[k]);
    }
};

/// The invariants' values at every output as result.invariant_values: name -> array over t (taken over, no
/// copy). `names` in the order recorded; an invariant never recorded (a run without outputs) gets an empty array.
template <class S>
py::dict invariant_values_dict(recorded_output<S>& out, const std::vector<std::string>& names) {
    py::dict d;
    out.invariants.resize(names.size());
    for (std::size_t k = 0; k < names.size(); ++k) {
        auto* owned = new std::vector<double>(std::move(out.invariants[k]));
        const py::capsule owner(owned, [](void* p) { delete static_cast<std::vector<double>*>(p); });
        d[py::str(names[k])] = py::array_t<double>({static_cast<py::ssize_t>(owned->size())}, owned->data(), owner);
    }
    return d;
}

/// The names of drift records, in their order.
inline std::vector<std::string> record_names(const std::vector<invariant_record>& records) {
    std::vector<std::string> v;
    for (const invariant_record& r : records) v.push_back(r.name);
    return v;
}

/// NavierStokes2D's statistics as the Python dict `result.stats`.
inline py::dict stats_dict(const step_counts& r) {
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

/// The drift records as the dict `result.invariants`: name -> initial, final, max_abs_drift, max_rel_drift (the
/// library's, as the CLI's summary reports it: 0 if it never moved, nan where a relative drift means nothing).
inline py::dict drift_dict(const std::vector<invariant_record>& records) {
    py::dict d;
    for (const invariant_record& r : records) {
        py::dict e;
        e["initial"] = r.initial;
        e["final"] = r.final;
        e["max_abs_drift"] = r.max_abs_drift;
        e["max_rel_drift"] = r.max_rel_drift();
        d[py::str(r.name)] = e;
    }
    return d;
}

/// The recorded output as the arrays (t, and y: n x m, SciPy's layout), taking the recorded vectors over (no copy:
/// a long run's output is most of its memory).
template <class S>
void add_arrays(py::dict& d, recorded_output<S>& out, std::size_t n) {
    using value_type = typename recorded_output<S>::value_type;
    const auto m = static_cast<py::ssize_t>(out.t.size());
    auto handed_over = [](auto&& v) {
        using V = std::remove_cvref_t<decltype(v)>;
        auto* owned = new V(std::move(v));
        return std::pair{owned, py::capsule(owned, [](void* p) { delete static_cast<V*>(p); })};
    };
    // relaxation RK's states belong to t + time_lag (the CLI's time_lag column); None for every other method
    if (!out.time_lag.empty()) {
        out.time_lag.resize(out.t.size(), 0.0);
        d["time_lag"] = py::array_t<double>(m, out.time_lag.data());
    } else {
        d["time_lag"] = py::none();
    }
    auto [tv, t_owner] = handed_over(std::move(out.t));
    auto [yv, y_owner] = handed_over(std::move(out.y));
    const py::array_t<double> t({m}, tv->data(), t_owner);
    const py::array_t<value_type> rows({m, static_cast<py::ssize_t>(n)}, yv->data(), y_owner);
    d["t"] = t;
    d["y"] = rows.attr("T");  // y[:, i] is the state at t[i]
}

/// The method's registry entry into the result dict, and `keeps`: the invariants of a built-in model the method
/// keeps by construction (eci::invariants_kept, the CLI summary's), None for a Python fun.
inline void add_method(py::dict& d, const method_info& method, std::optional<std::vector<std::string>> keeps = {}) {
    d["method"] = std::string(method.name);
    d["order"] = method.order;
    d["conservative"] = method.conservative;
    d["keeps"] = keeps ? py::object(py::cast(*keeps)) : py::object(py::none());
}

/// NavierStokes2D's result as the dict eci.solve turns into a SolveResult.
template <class S>
py::dict result_dict(recorded_output<S>& out, std::size_t n, const step_counts& report,
                     const std::vector<invariant_record>& drift, const method_info& method) {
    py::dict d;
    add_arrays(d, out, n);
    d["stats"] = stats_dict(report);
    d["invariants"] = drift_dict(drift);
    std::vector<std::string> keeps;  // a conservative method keeps E and Z (without forcing and dissipation)
    if (method.family == method_family::conservative)
        for (const invariant_record& r : drift) keeps.push_back(r.name);
    add_method(d, method, keeps);
    return d;
}

}  // namespace eci::python
