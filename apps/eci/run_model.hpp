// The one run every model goes through: checks the settings, picks the stepper through the registry, runs it
// with the library's eci::run (which monitors every invariant at every step) and writes CSV and summary.
#pragma once

#include <array>
#include <chrono>
#include <cmath>
#include <complex>
#include <cstdint>
#include <cstdio>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

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
};

/// The CSV column names of the real unknowns of a state of `size` modes: `prefix`0... for a real state,
/// re_`prefix`0, im_`prefix`0, ... for a complex one (the order in which step_result counts components).
std::vector<std::string> indexed_columns(std::string_view prefix, std::size_t size, bool complex);

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
std::string underflow_message(const step_size_underflow& e, const std::vector<std::string>& columns);

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

inline void write_csv_number(std::FILE* out, double v) {
    char buffer[32];
    const std::string_view f = format_double(v, buffer);
    std::fputc(',', out);
    std::fwrite(f.data(), 1, f.size(), out);
}

}  // namespace detail

/// Runs `model` from x (at t = 0) with `method` over `plan`; `columns` names the real unknowns (CSV header and
/// error messages). Returns the exit status (0); throws bad_input, run_failure or interrupted, in which case no
/// output file is left behind.
template <class Model>
int run_model(const model_info& info, const Model& model, typename Model::state_type x,
              const std::vector<std::string>& columns, const method_info& method, const run_plan& plan,
              const run_settings& settings) {
    using S = typename Model::state_type;
    const S x0 = x;
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
    check_distinct_outputs(settings);

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

    std::FILE* out = csv.get();
    if (out) {
        std::fputs("t", out);
        for (const std::string& c : columns) std::fprintf(out, ",%s", c.c_str());
        for (const auto& d : derived) std::fprintf(out, ",%s", d.name);
        for (const auto& inv : Model::invariants()) std::fprintf(out, ",%s", inv.name);
        std::fputc('\n', out);
    }

    progress_bar progress(plan.steps);
    const std::uint64_t every = settings.every, last = plan.steps;
    // eci::run observes every step (opt.every = 1): the CSV rows are thinned here, keeping the first and the
    // last, so that Ctrl-C and the progress bar are looked at every step whatever --every is.
    auto observe = [&](const S& state, double t, std::uint64_t i, const invariant_monitor<Model>& monitor) {
        if (out && (i % every == 0 || i == last)) {
            char buffer[32];
            const std::string_view s = format_double(t, buffer);
            std::fwrite(s.data(), 1, s.size(), out);
            detail::for_each_real(state, [&](double v) { detail::write_csv_number(out, v); });
            for (const auto& d : derived) detail::write_csv_number(out, (model.*d.value)(state));
            for (double v : monitor.values()) detail::write_csv_number(out, v);
            std::fputc('\n', out);
        }
        progress.update(i, t);
        if (interrupt_requested()) {
            char buffer[32];
            throw interrupted("interrupted at t = " + std::string(format_double(t, buffer)));
        }
    };

    const run_span span =
        plan.fixed_steps ? run_span::n_steps(plan.steps, plan.dt) : run_span::until(plan.t_end, plan.dt);
    const auto start = std::chrono::steady_clock::now();
    run_report report;
    const bool found = with_stepper<Model>(method.name, [&](auto stepper) {
        report = eci::run(stepper, model, x, span, observe, run_options{});
    });
    progress.finish();
    if (!found) throw bad_input("method '" + summary.method + "' has no stepper for model " + info.name);
    if (report.failure) throw run_failure(underflow_message(*report.failure, columns));
    summary.stats = report.stats;
    summary.invariants = report.invariants;
    summary.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if constexpr (requires { model.end_of_run_figures(x0, x); })
        for (const auto& [name, value] : model.end_of_run_figures(x0, x)) summary.figures.emplace_back(name, value);

    csv.commit();
    print_summary(stderr, summary);
    if (std::FILE* j = json.get()) write_summary_json(j, summary);
    json.commit();
    return 0;
}

}  // namespace eci::cli
