// The one run every model goes through: checks the settings, picks the stepper through the registry, runs it
// with the library's eci::run (which monitors every invariant at every step) and writes CSV and summary.
#pragma once

#include <array>
#include <chrono>
#include <cmath>
#include <complex>
#include <limits>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include <eci/adaptive.hpp>
#include <eci/registry.hpp>
#include <eci/run.hpp>

#include "command.hpp"
#include "output.hpp"

namespace eci::cli {

/// What a run reports at its end.
struct run_summary {
    std::string model, method;
    int order = 0;
    bool conservative = false;
    double dt = 0.0, t_end = 0.0;
    run_stats stats{};
    double wall_seconds = 0.0;
    std::vector<invariant_record> invariants;
    /// Model-specific figures of merit at the end of the run (e.g. Kepler's Runge-Lenz turn), name and value.
    std::vector<std::pair<std::string, double>> figures;
    /// Relaxation RK: the last state's true time minus its grid time t_end (it reached t_end + time_lag).
    std::optional<double> time_lag;
    bool adaptive = false;  ///< --rtol/--atol: adaptive step control (dt is then the first step)
    double rtol = 0.0, atol = 0.0;
    adaptive_stats adaptive_counts{};  ///< accepted and rejected steps, step sizes, dense outputs
};

/// The names of a state's real unknowns (CSV header, error messages), made one at a time when asked for: a run
/// of 10^7 modes without --output builds none of them.
class column_names {
   public:
    /// A fixed list (a model's component_names).
    column_names(std::vector<std::string> names) : fixed_(std::move(names)), size_(fixed_.size()) {}
    /// `prefix`0, `prefix`1, ... for `modes` real modes; re_`prefix`0, im_`prefix`0, ... for complex ones.
    column_names(std::string prefix, std::size_t modes, bool complex)
        : prefix_(std::move(prefix)), size_(complex ? 2 * modes : modes), complex_(complex) {}
    /// How many real unknowns there are.
    std::size_t size() const { return size_; }
    /// The name of real unknown i ("?" if there is none).
    std::string operator[](std::size_t i) const {
        if (i >= size_) return "?";
        if (!fixed_.empty()) return fixed_[i];
        if (!complex_) return prefix_ + std::to_string(i);
        return (i % 2 ? "im_" : "re_") + prefix_ + std::to_string(i / 2);
    }
    /// The same as operator[].
    std::string at(std::size_t i) const { return (*this)[i]; }

   private:
    std::vector<std::string> fixed_;
    std::string prefix_;
    std::size_t size_ = 0;
    bool complex_ = false;
};

/// The CSV column names of the real unknowns of a state of `size` modes: `prefix`0... for a real state,
/// re_`prefix`0, im_`prefix`0, ... for a complex one (the order in which step_result counts components).
column_names indexed_columns(std::string_view prefix, std::size_t size, bool complex);

/// The method `name` from the registry, checked against the model's list; throws bad_input.
method_info resolve_method(const model_info& model, const std::string& name);

/// The step, the step count and the end time the settings ask for, or the defaults; throws bad_input.
struct run_plan {
    double dt;
    std::uint64_t steps;
    double t_end;
    bool fixed_steps;  ///< --steps given: n steps of dt; otherwise integrate to t_end
};
/// Checks dt, t_end/steps and every; throws bad_input.
run_plan resolve_plan(double default_dt, double default_t_end, const run_settings& settings);

/// Throws bad_input if two outputs would go to the same place.
void check_distinct_outputs(const run_settings& settings);

/// Prints the human-readable summary (stderr).
void print_summary(std::FILE* f, const run_summary& s);

/// Writes the JSON summary.
void write_summary_json(std::FILE* f, const run_summary& s);

/// The message of a run that stopped because a step failed at every size.
std::string underflow_message(const step_size_underflow& e, const column_names& columns);

namespace detail {

/// Whether stepper St's states belong to a time other than their grid time (relaxation RK: t + time_lag()).
template <class St>
constexpr bool shifts_time() {
    if constexpr (requires { St::shifts_time; })
        return St::shifts_time;
    else
        return false;
}

template <class S, class Fn>
void for_each_real(const S& x, Fn&& fn) {
    for (const auto& v : x) {
        if constexpr (std::is_same_v<std::remove_cvref_t<decltype(v)>, std::complex<double>>) {
            fn(v.real());
            fn(v.imag());
        } else {
            fn(static_cast<double>(v));
        }
    }
}

inline void write_csv_number(std::FILE* out, double v) {
    char buffer[32];
    const std::string_view f = format_double(v, buffer);
    std::fputc(',', out);
    std::fwrite(f.data(), 1, f.size(), out);
}

}  // namespace detail

/// Rejects (bad_input) an initial state whose arithmetic is beyond double precision from the start: a
/// subnormal component, an invariant or a rate that is not finite. (Each model's validate_state checks what
/// its dynamics will reach; this is the part every model shares.)
template <class Model>
void check_arithmetic_range(const Model& model, const typename Model::state_type& x, const column_names& columns) {
    std::size_t i = 0;
    char buffer[32];
    detail::for_each_real(x, [&](double v) {
        if (v != 0.0 && std::abs(v) < std::numeric_limits<double>::min())
            throw bad_input("initial condition " + columns[i] + " = " + std::string(format_double(v, buffer)) +
                            " is subnormal (below 2.2e-308): its products underflow to 0");
        ++i;
    });
    for (const auto& inv : Model::invariants()) {
        const double v = (model.*inv.value)(x);
        if (!std::isfinite(v))
            throw bad_input(std::string("the initial ") + inv.name + " is " + std::string(format_double(v, buffer)) +
                            ": the initial condition and parameters are beyond double precision");
    }
    typename Model::state_type dxdt = x;
    model(x, dxdt, 0.0);
    if (!eci::detail::all_finite(dxdt))
        throw bad_input("the rate of " + columns[eci::detail::first_non_finite(dxdt)] +
                        " overflows at the initial condition: the parameters and initial condition are beyond "
                        "double precision");
}

/// Runs `model` from x (at t = 0) with `method` over `plan`; `columns` names the real unknowns (CSV header and
/// error messages). Returns the exit status (0); throws bad_input, run_failure or interrupted, in which case no
/// output file is left behind.
template <class Model>
int run_model(const model_info& info, const Model& model, typename Model::state_type x,
              const column_names& columns, const method_info& method, const run_plan& plan,
              const run_settings& settings) {
    using S = typename Model::state_type;
    // The initial state is kept only for a model that reports figures comparing it with the final one.
    constexpr bool keeps_x0 = requires(const Model& m, const S& a) { m.end_of_run_figures(a, a); };
    const S x0 = keeps_x0 ? x : S{};
    try {
        model.validate();
    } catch (const std::invalid_argument& e) {
        throw bad_input("invalid " + info.name + " model: " + e.what());
    }
    {
        std::size_t i = 0;
        detail::for_each_real(x, [&](double v) {
            if (!std::isfinite(v)) throw bad_input("initial condition " + columns.at(i) + " is not finite");
            ++i;
        });
    }
    if constexpr (requires { model.validate_state(x); }) {  // a domain, e.g. Lotka-Volterra's x, y > 0
        try {
            model.validate_state(x);
        } catch (const std::invalid_argument& e) {
            throw bad_input(std::string("invalid initial condition: ") + e.what());
        }
    }
    check_arithmetic_range(model, x, columns);
    check_distinct_outputs(settings);

    // Adaptive control (--rtol/--atol) and output times (--output-dt): checked before any file is opened.
    const bool adaptive = settings.rtol.has_value() || settings.atol.has_value();
    adaptive_options tolerances;
    if (adaptive) {
        if (plan.fixed_steps) throw bad_input("--steps counts fixed steps; an adaptive run (--rtol/--atol) ends at --t-end");
        tolerances.rtol = settings.rtol.value_or(*settings.atol);
        tolerances.atol = settings.atol.value_or(*settings.rtol);
        try {
            eci::detail::check_options(tolerances, std::ranges::size(x));
        } catch (const std::invalid_argument& e) {
            throw bad_input(std::string("--rtol/--atol: ") + e.what());
        }
        bool found = false;
        std::string names;
        for (const method_info& m : adaptive_methods_for<Model>()) {
            found = found || m.name == method.name;
            names += (names.empty() ? "" : ", ") + std::string(m.name);
        }
        if (!found)
            throw bad_input("method " + std::string(method.name) + " has no error estimate for --rtol/--atol; adaptive "
                            "methods for " + info.name + ": " + names);
    }
    std::vector<double> output_times;
    std::uint64_t every = settings.every;
    if (settings.output_dt) {
        const double h = *settings.output_dt;
        if (!(h > 0.0) || !std::isfinite(h))
            throw bad_input("--output-dt must be a positive finite number, not " + shortest(h));
        if (plan.t_end / h > 1e9) throw bad_input("--output-dt " + shortest(h) + " asks for too many rows");
        if (adaptive) {
            output_times.push_back(0.0);  // the initial state, as fixed-step runs write it
            for (std::uint64_t k = 1; double(k) * h < plan.t_end * (1.0 - 1e-12); ++k) output_times.push_back(double(k) * h);
            output_times.push_back(plan.t_end);
        } else {
            // fixed steps: rows every k steps, so --output-dt must be a whole number of --dt
            const double k = std::round(h / plan.dt);
            if (!(k >= 1.0) || std::abs(h / plan.dt - k) > 1e-9 * k)
                throw bad_input("--output-dt " + shortest(h) + " is not a multiple of --dt " + shortest(plan.dt) +
                                " (with fixed steps; --rtol/--atol lifts that)");
            every = std::uint64_t(k);
        }
    }

    // Open both outputs before running: an unwritable path is bad input, reported before any work.
    output_file csv = settings.output.empty() ? output_file() : output_file(settings.output, "CSV output");
    output_file json =
        settings.summary_json.empty() ? output_file() : output_file(settings.summary_json, "summary JSON");

    // Columns computed from the state (Kepler's Cartesian position), written between the state and the invariants.
    constexpr auto derived = [] {
        if constexpr (requires { Model::derived_columns(); })
            return Model::derived_columns();
        else
            return std::array<named_invariant<Model>, 0>{};
    }();
    run_summary summary;
    summary.model = info.name;
    summary.method = std::string(method.name);
    summary.order = method.order;
    summary.conservative = method.conservative;
    summary.dt = plan.dt;
    summary.t_end = plan.t_end;
    summary.adaptive = adaptive;
    summary.rtol = tolerances.rtol;
    summary.atol = tolerances.atol;

    // Relaxation RK's state at grid time t belongs to t + time_lag() (each step aims at the grid, so the lag is
    // one step's O(dt^p), never accumulated): such a method's CSV gets a last column time_lag.
    bool lagged = false;
    if (!adaptive)
        with_stepper<Model>(method.name, [&](auto st) { lagged = detail::shifts_time<decltype(st)>(); });
    std::function<double()> time_lag;  // set to the running stepper's time_lag() when lagged

    std::FILE* out = csv.get();
    if (out) {
        std::fputs("t", out);
        for (std::size_t i = 0; i < columns.size(); ++i) std::fprintf(out, ",%s", columns[i].c_str());
        for (const auto& d : derived) std::fprintf(out, ",%s", d.name);
        for (const auto& inv : Model::invariants()) std::fprintf(out, ",%s", inv.name);
        if (lagged) std::fputs(",time_lag", out);
        std::fputc('\n', out);
    }

    auto write_row = [&](const S& state, double t, std::span<const double> invariant_values) {
        char buffer[32];
        const std::string_view s = format_double(t, buffer);
        std::fwrite(s.data(), 1, s.size(), out);
        detail::for_each_real(state, [&](double v) { detail::write_csv_number(out, v); });
        for (const auto& d : derived) detail::write_csv_number(out, (model.*d.value)(state));
        for (double v : invariant_values) detail::write_csv_number(out, v);
        if (time_lag) detail::write_csv_number(out, time_lag());
        std::fputc('\n', out);
    };
    // Finite at the start (checked): a finite state whose invariant overflows is no result.
    auto require_finite_invariants = [&](double t, const invariant_monitor<Model>& monitor) {
        for (std::size_t j = 0; j < monitor.values().size(); ++j) {
            if (std::isfinite(monitor.values()[j])) continue;
            char buffer[32];
            throw run_failure(std::string("the invariant ") + monitor.records()[j].name + " overflowed at t = " +
                              std::string(format_double(t, buffer)) + ": the solution blew up; try a smaller --dt");
        }
    };
    if (adaptive) {
        // Rows at every `every` accepted steps (and the end), or at the --output-dt times.
        auto observe = [&](const S& state, double t, std::uint64_t i, const invariant_monitor<Model>& monitor) {
            require_finite_invariants(t, monitor);
            if (out && (!output_times.empty() || i % every == 0 || t == plan.t_end)) write_row(state, t, monitor.values());
            if (interrupt_requested()) {
                char buffer[32];
                throw_if_interrupted("at t = " + std::string(format_double(t, buffer)));
            }
        };
        const auto start = std::chrono::steady_clock::now();
        adaptive_report report;
        with_adaptive_stepper<Model>(method.name, [&](auto stepper) {
            report = run_adaptive(stepper, model, x, 0.0, plan.t_end, plan.dt, tolerances, output_times, observe);
        });
        if (report.failure) {
            const std::size_t c = report.failure->component;
            throw run_failure(std::string(report.failure->what()) + " [component " +
                              (c < columns.size() ? columns[c] : std::string("?")) + "]");
        }
        summary.adaptive_counts = report.stats;
        summary.stats.steps = report.stats.accepted;
        summary.stats.step_reductions = report.stats.rejected_radicand;
        summary.stats.rhs_evals = report.stats.rhs_evals;
        summary.invariants = report.invariants;
        summary.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        if constexpr (requires { model.end_of_run_figures(x0, x); })
            for (const auto& [name, value] : model.end_of_run_figures(x0, x)) summary.figures.emplace_back(name, value);
        // Both outputs complete before either replaces anything: committed together, or neither.
        if (std::FILE* j = json.get()) write_summary_json(j, summary);
        commit_outputs({&csv, &json});
        print_summary(stderr, summary);
        return 0;
    }

    progress_bar progress(plan.steps);
    const std::uint64_t last = plan.steps;
    // eci::run observes every step (opt.every = 1): the CSV rows are thinned here, keeping the first and the
    // last, so that Ctrl-C and the progress bar are looked at every step whatever --every is.
    auto observe = [&](const S& state, double t, std::uint64_t i, const invariant_monitor<Model>& monitor) {
        require_finite_invariants(t, monitor);
        if (out && (i % every == 0 || i == last)) write_row(state, t, monitor.values());
        progress.update(i, t);
        if (interrupt_requested()) {
            char buffer[32];
            throw_if_interrupted("at t = " + std::string(format_double(t, buffer)));
        }
    };

    const run_span span =
        plan.fixed_steps ? run_span::n_steps(plan.steps, plan.dt) : run_span::until(plan.t_end, plan.dt);
    const auto start = std::chrono::steady_clock::now();
    run_report report;
    run_options opt;
    opt.cancel = cancel_flag();  // polled between sub-steps and right-hand-side evaluations
    bool found = false;
    try {
        found = with_stepper<Model>(method.name, [&](auto stepper) {
            if constexpr (detail::shifts_time<decltype(stepper)>()) time_lag = [&stepper] { return stepper.time_lag(); };
            report = eci::run(stepper, model, x, span, observe, opt);
            if (time_lag) summary.time_lag = time_lag();
            time_lag = nullptr;  // the stepper ends with this scope
        });
    } catch (const step_work_exceeded& e) {
        progress.finish();
        throw run_failure(std::string(e.what()) +
                          ": the solution needs ever smaller steps here (a singularity, or numbers too small or "
                          "large for double precision); try a smaller --dt");
    } catch (const non_finite_state& e) {
        progress.finish();
        char t[32];
        throw run_failure("the state became non-finite (" + columns[e.component] + ") at t = " +
                          std::string(format_double(e.time, t)) + ": the solution blew up; try a smaller --dt");
    } catch (const eci::interrupted& e) {
        progress.finish();
        char t[32];
        throw_if_interrupted("at t = " + std::string(format_double(e.time, t)));
        throw interrupted(e.what());
    }
    progress.finish();
    if (!found) throw bad_input("method '" + summary.method + "' has no stepper for model " + info.name);
    if (report.failure) throw run_failure(underflow_message(*report.failure, columns));
    summary.stats = report.stats;
    summary.invariants = report.invariants;
    summary.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if constexpr (requires { model.end_of_run_figures(x0, x); })
        for (const auto& [name, value] : model.end_of_run_figures(x0, x)) summary.figures.emplace_back(name, value);

    // Both outputs complete before either replaces anything: committed together, or neither.
    if (std::FILE* j = json.get()) write_summary_json(j, summary);
    commit_outputs({&csv, &json});
    print_summary(stderr, summary);
    return 0;
}

}  // namespace eci::cli
