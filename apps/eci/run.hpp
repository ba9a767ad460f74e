// The one run loop every model adapter calls: checks the settings, picks the stepper through the registry,
// integrates with the library's drivers while tracking every invariant at every step, and writes CSV and summary.
#pragma once

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <complex>
#include <limits>
#include <cstdint>
#include <cstdio>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include <eci/integrate.hpp>
#include <eci/models/invariant.hpp>
#include <eci/registry.hpp>

#include "models.hpp"
#include "output.hpp"

namespace eci::cli {

/// One invariant's record over a run.
struct invariant_record {
    std::string name;
    double initial = 0.0;
    double final = 0.0;
    double max_abs_drift = 0.0;  ///< max over every step of |I(t) - I(0)|
    /// max_abs_drift / |I(0)|; infinite when I(0) = 0 and the invariant moved, NaN (JSON null) if it went NaN
    double max_rel_drift() const {
        if (max_abs_drift == 0.0) return 0.0;
        return max_abs_drift / std::abs(initial);
    }
};

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

/// The full name of the method `settings` asks for (or the model's default), checked against the registry and
/// the model's list; throws bad_input.
method_info resolve_method(const model_info& model, const run_settings& settings);

/// The step count and end time `settings` ask for (or the model's defaults); throws bad_input.
struct run_span {
    double dt;
    std::uint64_t steps;
    double t_end;
    bool fixed_steps;  ///< --steps given: n steps of dt; otherwise integrate_to(t_end)
};
/// Checks dt, t_end/steps and every; throws bad_input.
run_span resolve_span(const model_info& model, const run_settings& settings);

/// Prints the human-readable summary (stderr).
void print_summary(std::FILE* f, const run_summary& s);

/// Writes the JSON summary.
void write_summary_json(std::FILE* f, const run_summary& s);

/// Throws bad_input if two outputs would go to the same place.
void check_distinct_outputs(const run_settings& settings);

/// Every registered method that runs on any state of type S (what a model without steppers of its own offers).
template <class S>
std::vector<std::string> registry_methods_for() {
    const auto names = eci::method_names_for<S>();
    return {names.begin(), names.end()};
}

/// Dispatches a method name through the registry; a model with steppers of its own passes its own dispatcher.
template <class S>
struct registry_dispatch {
    template <class Fn>
    bool operator()(std::string_view name, Fn&& fn) const {
        return eci::with_method<S>(name, std::forward<Fn>(fn));
    }
};

namespace detail {

template <class S, class Fn>
void for_each_real(const S& x, Fn&& fn);

}  // namespace detail

/// Rejects (bad_input) an initial state whose arithmetic is beyond double precision from the start: a
/// subnormal component, an invariant or a rate that is not finite. (Each model's validate_state checks what
/// its dynamics will reach; this is the part every model shares.)
template <class Model>
void check_arithmetic_range(const Model& model, const typename Model::state_type& x,
                            const column_names& columns) {
    std::size_t i = 0;
    char buffer[32];
    detail::for_each_real(x, [&](double v) {
        if (v != 0.0 && std::abs(v) < std::numeric_limits<double>::min())
            throw bad_input("initial condition " + columns.at(i) + " = " + std::string(format_double(v, buffer)) +
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
    if (!eci::detail::all_finite(dxdt)) {
        const std::size_t c = eci::detail::first_non_finite(dxdt);
        throw bad_input("the rate of " + columns[c] +
                        " overflows at the initial condition: the parameters and initial condition are beyond "
                        "double precision");
    }
}

namespace detail {

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

}  // namespace detail

/// Runs `model` from x (at t = 0) with the settings; `columns` names the real unknowns (CSV header and error
/// messages); `dispatch(name, fn)` calls fn with the stepper named `name`. Returns the exit status (0); throws
/// bad_input, run_failure or interrupted, in which case no output file is left behind.
template <class Model, class Dispatch = registry_dispatch<typename Model::state_type>>
int run_model(const model_info& info, const Model& model, typename Model::state_type x,
              const column_names& columns, const run_settings& settings, Dispatch dispatch = {}) {
    using S = typename Model::state_type;
    const method_info method = resolve_method(info, settings);
    const run_span span = resolve_span(info, settings);
    // The initial state is kept only for a model that reports figures comparing it with the final one.
    constexpr bool keeps_x0 = requires(const Model& m, const S& a) { m.end_of_run_figures(a, a); };
    const S x0 = keeps_x0 ? x : S{};
    try {
        model.validate();
    } catch (const std::invalid_argument& e) {
        throw bad_input(std::string("invalid ") + info.name + " model: " + e.what());
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

    // Open both outputs before running: an unwritable path is bad input, reported before any work.
    output_file csv = settings.output.empty() ? output_file() : output_file(settings.output, "CSV output");
    output_file json =
        settings.summary_json.empty() ? output_file() : output_file(settings.summary_json, "summary JSON");

    constexpr auto invariants = Model::invariants();
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
    summary.dt = span.dt;
    summary.t_end = span.t_end;
    for (const auto& inv : invariants) summary.invariants.push_back({inv.name});

    std::FILE* out = csv.get();
    if (out) {
        std::fputs("t", out);
        for (std::size_t i = 0; i < columns.size(); ++i) std::fprintf(out, ",%s", columns[i].c_str());
        for (const auto& d : derived) std::fprintf(out, ",%s", d.name);
        for (const auto& inv : invariants) std::fprintf(out, ",%s", inv.name);
        std::fputc('\n', out);
    }

    progress_bar progress(span.steps);
    const std::uint64_t every = settings.every;
    const std::uint64_t last = span.steps;
    // Every step is observed (the drivers run with every = 1) so the drift is the true maximum; CSV rows are
    // thinned here, keeping the first and the last.
    auto observe = [&](const S& state, double t, std::uint64_t i) {
        std::array<double, invariants.size()> values{};
        for (std::size_t j = 0; j < invariants.size(); ++j) {
            const double v = (model.*invariants[j].value)(state);
            values[j] = v;
            invariant_record& r = summary.invariants[j];
            if (!std::isfinite(v)) {  // finite at the start (checked): a finite state whose invariant overflows
                char buffer[32];
                throw run_failure(std::string("the invariant ") + invariants[j].name + " overflowed at t = " +
                                  std::string(format_double(t, buffer)) + ": the solution blew up; try a smaller --dt");
            }
            if (i == 0) r.initial = v;
            r.final = v;
            const double d = std::abs(v - r.initial);
            if (d > r.max_abs_drift || std::isnan(d)) r.max_abs_drift = d;
        }
        if (out && (i % every == 0 || i == last)) {
            char buffer[32];
            std::string_view s = format_double(t, buffer);
            std::fwrite(s.data(), 1, s.size(), out);
            detail::for_each_real(state, [&](double v) {
                std::fputc(',', out);
                const std::string_view f = format_double(v, buffer);
                std::fwrite(f.data(), 1, f.size(), out);
            });
            for (const auto& d : derived) {
                std::fputc(',', out);
                const std::string_view f = format_double((model.*d.value)(state), buffer);
                std::fwrite(f.data(), 1, f.size(), out);
            }
            for (double v : values) {
                std::fputc(',', out);
                const std::string_view f = format_double(v, buffer);
                std::fwrite(f.data(), 1, f.size(), out);
            }
            std::fputc('\n', out);
        }
        progress.update(i, t);
        if (interrupt_requested()) {
            char buffer[32];
            throw_if_interrupted("at t = " + std::string(format_double(t, buffer)));
        }
    };

    const auto start = std::chrono::steady_clock::now();
    bool found = false;
    try {
        found = dispatch(method.name, [&](auto stepper) {
            run_options opt;
            opt.cancel = cancel_flag();  // polled between sub-steps and right-hand-side evaluations
            summary.stats = span.fixed_steps
                                ? integrate_n_steps(stepper, model, x, 0.0, span.dt, span.steps, observe, opt)
                                : integrate_to(stepper, model, x, 0.0, span.t_end, span.dt, observe, opt);
        });
    } catch (const step_size_underflow& e) {
        progress.finish();
        char t[32], h[32];
        const std::string column = columns[e.component];
        throw run_failure("step failed at t = " + std::string(format_double(e.time, t)) + " in component " +
                          column + " even with the step halved " + std::to_string(run_options{}.max_halvings) +
                          " times (dt = " + std::string(format_double(e.dt, h)) +
                          "): negative radicand, non-invertible transform or non-finite state");
    } catch (const step_work_exceeded& e) {
        progress.finish();
        throw run_failure(std::string(e.what()) +
                          ": the solution needs ever smaller steps here (a singularity, or numbers too small or "
                          "large for double precision); try a smaller --dt");
    } catch (const non_finite_state& e) {
        progress.finish();
        char t[32];
        const std::string column = columns[e.component];
        throw run_failure("the state became non-finite (" + column + ") at t = " +
                          std::string(format_double(e.time, t)) + ": the solution blew up; try a smaller --dt");
    } catch (const eci::interrupted& e) {
        progress.finish();
        char t[32];
        throw_if_interrupted("at t = " + std::string(format_double(e.time, t)));
        throw interrupted(e.what());
    }
    progress.finish();
    if (!found) throw bad_input("method '" + summary.method + "' has no stepper for model " + info.name);
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
