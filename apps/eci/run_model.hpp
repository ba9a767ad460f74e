// `eci run MODEL` as a sink of the library's run: turns the options into an eci::run_config, runs the model's
// compiled eci::solve_model (which checks, steps, lands on output times and monitors every invariant) and formats
// CSV rows and the summary.
#pragma once

#include <algorithm>
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

#include <eci/dynamic_sink.hpp>
#include <eci/solve.hpp>

#include "command.hpp"
#include "h5_series.hpp"
#include "output.hpp"
#include "run_plot.hpp"

namespace eci::cli {

/// What a run reports at its end.
struct run_summary {
    std::string model, method;
    int order = 0;
    bool conservative = false;  ///< the method keeps every invariant of the model (invariants_kept)
    std::vector<std::string> keeps;  ///< the invariants it keeps, when not all (empty for a spectral run)
    double dt = 0.0, t_end = 0.0;
    double t_start = 0.0;  ///< where the run began: 0, or a restart's checkpoint time
    run_stats stats{};
    double wall_seconds = 0.0;
    std::vector<invariant_record> invariants;
    /// Model-specific figures of merit at the end of the run (e.g. Kepler's Runge-Lenz turn), name and value.
    std::vector<std::pair<std::string, double>> figures;
    /// A sentence under the invariants' table for its reader, e.g. how a spectral run's forced and dissipated
    /// invariants kept to their budgets (the drift columns are then the physics' change). Text summary only.
    std::string invariants_note;
    /// Relaxation RK: the last state's true time minus its grid time t_end (it reached t_end + time_lag).
    std::optional<double> time_lag;
    bool adaptive = false;  ///< --rtol/--atol: adaptive step control (dt is then the first step)
    double rtol = 0.0, atol = 0.0;
    adaptive_stats adaptive_counts{};  ///< accepted and rejected steps, step sizes, dense outputs
    /// An interrupted run (Ctrl-C): the summary describes it up to t_stopped, its last output; the invariants'
    /// drifts are then over its outputs (every --every steps), and the step counts are given only if `counted`.
    bool interrupted = false;
    double t_stopped = 0.0;
    bool counted = true;
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

/// A model's columns computed from the state (Kepler's Cartesian position: derived_columns()), or none.
template <class Model>
constexpr auto derived_columns_of() {
    if constexpr (requires { Model::derived_columns(); })
        return Model::derived_columns();
    else
        return std::array<named_invariant<Model>, 0>{};
}

/// --plot's phase plane (the model's plot_plane), if it declares one: each of its two columns a state component (its
/// index among the real unknowns) or a derived column (-1 - its index there), found by name when this compiles.
template <class Model>
constexpr std::optional<std::array<int, 2>> plot_plane_columns() {
    if constexpr (requires { Model::plot_plane; }) {
        constexpr auto column = [](std::string_view name) {
            constexpr auto d = derived_columns_of<Model>();
            for (std::size_t i = 0; i < Model::component_names.size(); ++i)
                if (name == Model::component_names[i]) return int(i);
            for (std::size_t k = 0; k < d.size(); ++k)
                if (name == d[k].name) return -1 - int(k);
            return int(-1 - d.size());  // (none: refused below)
        };
        constexpr std::array<int, 2> c{column(Model::plot_plane.x), column(Model::plot_plane.y)};
        constexpr int none = -1 - int(derived_columns_of<Model>().size());
        static_assert(c[0] != none && c[1] != none, "plot_plane names a column the model does not have");
        return c;
    } else {
        return std::nullopt;
    }
}

/// Runs `model` from x (at t = 0) with `method` over `plan`; `columns` names the real unknowns (CSV header and
/// error messages). Returns the exit status (0); throws bad_input, run_error or interrupted, in which case no
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
    run_config cfg;
    cfg.component_name = [&columns](std::size_t i) { return columns[i]; };
    try {
        check_initial_state(model, x, cfg.component_name);
    } catch (const std::invalid_argument& e) {
        throw bad_input(e.what());
    }
    check_distinct_outputs(settings);

    // The run: fixed steps of --dt, or adaptive control (--rtol/--atol) starting from it; rows every --every
    // steps or at the --output-dt times. Checked before any file is opened.
    try {
        cfg.adaptive = tolerances_from(settings.rtol, settings.atol);  // either given: both, the other's value
    } catch (const std::invalid_argument& e) {
        throw bad_input(std::string("--rtol/--atol: ") + e.what());
    }
    const bool adaptive = cfg.is_adaptive();
    cfg.dt = plan.dt;
    cfg.t_end = plan.t_end;
    if (plan.fixed_steps) cfg.steps = plan.steps;
    cfg.every = settings.every;
    cfg.update = settings.update == "paper" ? update_kind::paper : update_kind::conditioned;
    cfg.update_chosen = !settings.update.empty();
    cfg.cancel = cancel_flag();  // polled between sub-steps and right-hand-side evaluations
    if (adaptive) {
        if (plan.fixed_steps) throw bad_input("--steps counts fixed steps; an adaptive run (--rtol/--atol) ends at --t-end");
        try {
            check_adaptive_options(*cfg.adaptive, std::ranges::size(x));
        } catch (const std::invalid_argument& e) {
            throw bad_input(std::string("--rtol/--atol: ") + e.what());
        }
        // a first step the user gives lies within the span, as Python's first_step (solve_ivp's); the default --dt
        // may exceed a short span: the first step is then shortened to it
        try {
            if (settings.dt) check_first_step(*settings.dt, 0.0, plan.t_end, "--dt");
        } catch (const std::invalid_argument& e) {
            throw bad_input(e.what());
        }
    }
    cfg.output_dt = settings.output_dt;  // output times (adaptive) or every k steps (fixed): the library decides
    if (settings.output_mode == "dense") cfg.mode = output_mode::dense;
    if (settings.output_mode == "landing") cfg.mode = output_mode::landing;
    try {
        resolve_output_dt(cfg, {.output_dt = "--output-dt", .dt = "--dt", .tolerances = "--rtol/--atol"});
    } catch (const std::invalid_argument& e) {
        throw bad_input(e.what());
    }
    try {
        resolve_method_for<Model>(method.name, adaptive, "model " + info.name);
    } catch (const std::invalid_argument& e) {
        throw bad_input(e.what());
    }
    // as Python's solve (and SciPy's solve_ivp): an rtol below 100 eps is raised to it, with a warning
    if (adaptive) {
        const double asked = cfg.adaptive->rtol;
        if (raise_rtol(*cfg.adaptive))
            std::fprintf(stderr,
                         "eci: warning: the relative tolerance %s is below 100 eps; raised to %s, as SciPy's "
                         "solve_ivp does (below it the error estimate is round-off)\n",
                         shortest(asked).c_str(), shortest(min_rtol).c_str());
    }

    // Open every output before running: an unwritable path is bad input, reported before any work.
    check_plot_request(settings.plot);
    check_hdf5_request(settings.output);
    const bool hdf5 = is_hdf5_path(settings.output);  // --output FILE.h5: the rows as HDF5 datasets
    output_file csv = settings.output.empty() ? output_file()
                                              : output_file(settings.output, hdf5 ? "HDF5 output" : "CSV output");
    if (hdf5 && csv.temporary().empty())
        throw bad_input("--output '" + settings.output + "': HDF5 is written to a regular file, not a device or FIFO");
    output_file json =
        settings.summary_json.empty() ? output_file() : output_file(settings.summary_json, "summary JSON");
    output_file picture = settings.plot.empty() ? output_file() : output_file(settings.plot, "plot");

    // Columns computed from the state (Kepler's Cartesian position), written between the state and the invariants.
    constexpr auto derived = derived_columns_of<Model>();
    std::vector<std::string> invariant_names;  // (the plot's and the HDF5 file's)
    for (const auto& inv : Model::invariants()) invariant_names.emplace_back(inv.name);
    // --plot: the same outputs as the CSV's rows, drawn at the end
    std::optional<run_plot> plot;
    if (picture.get()) {
        std::vector<std::string> drawn;
        for (std::size_t i = 0; i < std::min(columns.size(), run_plot::max_components); ++i) drawn.push_back(columns[i]);
        plot.emplace(settings.plot, std::move(drawn), columns.size(), invariant_names,
                     "eci run " + info.name + ": " + std::string(method.name) +
                         (adaptive ? ", rtol " + title_number(cfg.adaptive->rtol) + ", atol " +
                                          title_number(cfg.adaptive->atol)
                                   : ", dt " + title_number(plan.dt)));
        if constexpr (plot_plane_columns<Model>().has_value())
            plot->set_phase_plane(std::string(Model::plot_plane.x), std::string(Model::plot_plane.y),
                                  Model::plot_plane.equal_axes);
    }
    run_summary summary;
    summary.model = info.name;
    summary.method = std::string(method.name);
    summary.order = method.order;
    // what the method keeps of this model's invariants (the registry's rule): "conservative" only if it keeps all
    summary.keeps = invariants_kept<Model>(method);
    summary.conservative = !summary.keeps.empty() && summary.keeps.size() == invariant_names.size();
    summary.dt = plan.dt;
    summary.t_end = plan.t_end;
    summary.adaptive = adaptive;
    summary.rtol = adaptive ? cfg.adaptive->rtol : 0.0;
    summary.atol = adaptive ? cfg.adaptive->atol : 0.0;

    // Relaxation RK's state at grid time t belongs to t + time_lag (each step aims at the grid, so the lag is
    // one step's O(dt^p), never accumulated): such a method's CSV gets a last column time_lag.
    const bool lagged = !adaptive && method_shifts_time<Model>(method.name);

    std::optional<h5_series> h5;
    if (hdf5) {
        std::vector<std::string> state_names, derived_names;
        if (columns.size() <= h5_series::max_named)
            for (std::size_t i = 0; i < columns.size(); ++i) state_names.push_back(columns[i]);
        for (const auto& d : derived) derived_names.emplace_back(d.name);
        std::vector<h5_series::attribute> attributes{{"model", info.name}, {"method", std::string(method.name)}};
        if (adaptive)
            attributes.insert(attributes.end(), {{"rtol", cfg.adaptive->rtol}, {"atol", cfg.adaptive->atol}});
        else
            attributes.push_back({"dt", plan.dt});
        h5.emplace(csv.temporary(), "HDF5 output '" + settings.output + "'",
                   std::vector<h5_series::group>{{"state", columns.size(), std::move(state_names)},
                                                 {"derived", derived.size(), std::move(derived_names)},
                                                 {"invariants", invariant_names.size(), invariant_names},
                                                 {"time_lag", lagged ? 1u : 0u, {}}},
                   std::move(attributes));
    }
    std::FILE* out = hdf5 ? nullptr : csv.get();
    if (out) {
        std::fputs("t", out);
        for (std::size_t i = 0; i < columns.size(); ++i) std::fprintf(out, ",%s", columns[i].c_str());
        for (const auto& d : derived) std::fprintf(out, ",%s", d.name);
        for (const auto& inv : Model::invariants()) std::fprintf(out, ",%s", inv.name);
        if (lagged) std::fputs(",time_lag", out);
        std::fputc('\n', out);
    }

    // The CLI's sink: CSV rows, the progress bar, Ctrl-C between steps. The run itself is the model's compiled
    // solve_model (src/models), which Python's eci.solve runs as well.
    class csv_sink final : public dynamic_sink<S> {
       public:
        csv_sink(std::FILE* out, const Model& model, const decltype(derived)& columns_derived, std::uint64_t steps,
                 double t_end, run_plot* plot, h5_series* h5)
            : bar(steps, 4096, t_end), out_(out), model_(model), derived_(columns_derived), plot_(plot), h5_(h5) {}
        void output(const S& state, const output_point& p) override {
            // what an interrupted run's summary says: its outputs (the CSV's rows, written or not) up to the last
            records.resize(p.invariants.size());
            for (std::size_t k = 0; k < records.size(); ++k) records[k].record(p.invariants[k], outputs == 0);
            last_t = p.t;
            if (p.stats) last_stats = *p.stats;
            ++outputs;
            if (plot_) {
                // the first components and, in the same pass, the phase plane's (a component at its index, a
                // derived column by its function)
                constexpr auto plane = plot_plane_columns<Model>();
                std::array<double, run_plot::max_components> first{};
                std::array<double, 2> at{};
                std::size_t count = 0, i = 0;
                detail::for_each_real(state, [&](double v) {
                    if (count < first.size()) first[count++] = v;
                    if constexpr (plane.has_value())
                        for (std::size_t a = 0; a < 2; ++a)
                            if ((*plane)[a] == int(i)) at[a] = v;
                    ++i;
                });
                if constexpr (plane.has_value()) {
                    for (std::size_t a = 0; a < 2; ++a)
                        if ((*plane)[a] < 0) at[a] = (model_.*derived_[std::size_t(-1 - (*plane)[a])].value)(state);
                    plot_->add(p.t, std::span<const double>(first.data(), count), p.invariants, at);
                } else {
                    plot_->add(p.t, std::span<const double>(first.data(), count), p.invariants);
                }
            }
            if (h5_) {
                state_.clear();
                detail::for_each_real(state, [&](double v) { state_.push_back(v); });
                std::array<double, std::tuple_size_v<std::remove_cvref_t<decltype(derived_)>>> d{};
                for (std::size_t k = 0; k < d.size(); ++k) d[k] = (model_.*derived_[k].value)(state);
                const double lag = p.time_lag ? *p.time_lag : 0.0;
                const std::array<std::span<const double>, 4> row{std::span<const double>(state_),
                                                                 std::span<const double>(d), p.invariants,
                                                                 std::span<const double>(&lag, 1)};
                h5_->add(p.t, row);
            }
            if (!out_) return;
            char buffer[32];
            const std::string_view s = format_double(p.t, buffer);
            std::fwrite(s.data(), 1, s.size(), out_);
            detail::for_each_real(state, [&](double v) { detail::write_csv_number(out_, v); });
            for (const auto& d : derived_) detail::write_csv_number(out_, (model_.*d.value)(state));
            for (double v : p.invariants) detail::write_csv_number(out_, v);
            if (p.time_lag) detail::write_csv_number(out_, *p.time_lag);
            std::fputc('\n', out_);
        }
        void progress(double t, std::uint64_t i) override {
            if (t != t0) stepped = true;
            bar.update(i, t);
            if (interrupt_requested()) {
                char buffer[32];
                throw_if_interrupted("at t = " + std::string(format_double(t, buffer)));
            }
        }
        progress_bar bar;
        std::uint64_t outputs = 0;
        std::vector<invariant_record> records;  ///< the invariants at the outputs
        double last_t = 0.0, t0 = 0.0;
        std::optional<run_stats> last_stats;  ///< fixed steps: the run's counts at the last output
        bool stepped = false;                 ///< whether the run has taken a step

       private:
        std::FILE* out_;
        const Model& model_;
        const decltype(derived)& derived_;
        run_plot* plot_;
        h5_series* h5_;
        std::vector<double> state_;  ///< a state's real unknowns, for an HDF5 row
    } sink{out, model, derived, adaptive ? 0 : plan.steps, plan.t_end, plot ? &*plot : nullptr, h5 ? &*h5 : nullptr};

    // What a stopped run keeps, as its message says it: "; kept: CSV output 'o.csv' (rows to t = 1.5), summary JSON
    // 's.json'" (`rows`: how far the rows go, if not to the end), or nothing.
    const auto kept_outputs = [&](const std::string& rows) {
        std::string kept;
        if (csv.replaces()) kept += std::string(hdf5 ? "HDF5" : "CSV") + " output '" + settings.output + "'" + rows;
        if (json.replaces())
            kept += (kept.empty() ? "" : ", ") + std::string("summary JSON '") + settings.summary_json + "'";
        return kept.empty() ? kept : "; kept: " + kept;
    };
    const auto start = std::chrono::steady_clock::now();
    solve_report report;
    std::string stop;  // an interrupt's message
    try {
        report = solve_model<Model>(model, x, method.name, cfg, sink, {}, "model " + info.name);
    } catch (const eci::interrupted& e) {  // (the library's poll, between steps or evaluations)
        char t[32];
        stop = interrupt_message("at t = " + std::string(format_double(e.time, t)));
    } catch (const interrupted& e) {  // (the sink's, between steps)
        stop = e.what();
    } catch (const std::invalid_argument& e) {
        sink.bar.finish();
        throw bad_input(e.what());
    }
    sink.bar.finish();
    if (!stop.empty()) {
        // Stopped by Ctrl-C: the outputs as they stand, complete up to the last output, are kept (the CSV's rows
        // are whole: a row is written between steps, never cut by the signal). Nothing is kept by a run stopped
        // before its first step, or by SIGPIPE (an output that failed).
        if (!interrupt_keeps_outputs() || !sink.stepped || sink.outputs == 0) throw interrupted(stop);
        summary.interrupted = true;
        summary.t_stopped = sink.last_t;
        summary.counted = sink.last_stats.has_value();
        if (sink.last_stats) summary.stats = *sink.last_stats;
        summary.invariants = sink.records;
        const auto names = Model::invariants();
        for (std::size_t k = 0; k < names.size() && k < summary.invariants.size(); ++k)
            summary.invariants[k].name = names[k].name;
        summary.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        const std::string kept = kept_outputs(" (rows to t = " + shortest(sink.last_t) + ")");
        try {
            if (std::FILE* j = json.get()) write_summary_json(j, summary);
            if (h5) h5->close();
            // (no picture: the plotting program is stopped by the same signal)
            commit_outputs({&csv, &json}, nullptr, true);
        } catch (const std::exception& e) {
            throw interrupted(stop + "; " + e.what());
        }
        throw interrupted(stop + kept + (plot ? "; no plot (it is drawn for a finished run)" : ""));
    }
    if (report.failure) {
        const eci::run_failure& f = *report.failure;
        switch (f.kind) {
            case run_failure_kind::step_too_small:
            case run_failure_kind::too_many_steps:
                throw run_error(f.message + " [component " + columns[f.component] + "]");
            case run_failure_kind::work_exceeded:
                throw run_error(f.message +
                                  ": the solution needs ever smaller steps here (a singularity, or numbers too small or "
                                  "large for double precision); try a smaller --dt");
            case run_failure_kind::non_finite_state:
            case run_failure_kind::invariant_overflow:
                throw run_error(f.message + (f.kind == run_failure_kind::non_finite_state ? ": the solution blew up" : "") +
                                  "; try a smaller --dt");
            case run_failure_kind::step_failed:
                throw run_error(f.message);
        }
    }
    summary.stats = report.stats;
    if (report.adaptive) summary.adaptive_counts = *report.adaptive;
    summary.time_lag = report.time_lag;
    summary.invariants = report.invariants;
    summary.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if constexpr (requires { model.end_of_run_figures(x0, x); })
        for (const auto& [name, value] : model.end_of_run_figures(x0, x)) summary.figures.emplace_back(name, value);

    // Every output complete before any replaces anything: committed together, or none. A picture that could not be
    // drawn loses nothing else: the other outputs are committed and the run fails with the reason.
    if (std::FILE* j = json.get()) write_summary_json(j, summary);
    if (h5) h5->close();
    const bool drawn = !plot || plot->draw(picture);
    // Ctrl-C after the last step, while the picture was drawn (which stops the plotting program) or after: the
    // finished run's outputs are whole and kept, as a stopped run's are (the commit's own rule discarded them)
    const bool late_stop = interrupt_requested() && interrupt_keeps_outputs();
    const std::string kept = late_stop ? kept_outputs("") : std::string();  // (before the commit, which takes them)
    const bool others = csv.get() || json.get();
    if (drawn)
        commit_outputs({&csv, &json, &picture}, nullptr, late_stop);
    else
        commit_outputs({&csv, &json}, nullptr, late_stop);
    print_summary(stderr, summary);
    if (late_stop)
        throw interrupted(interrupt_message(drawn ? "after the run had finished"
                                                  : "while the plot was drawn, after the run had finished") +
                          kept + (drawn ? "" : "; no plot"));
    if (!drawn)
        throw run_error("the plot '" + settings.plot + "' could not be drawn by " + plotting_program() +
                        (plot->failure().empty() ? "" : " (" + plot->failure() + ")") +
                        (others ? "; the other outputs were written" : ""));
    return 0;
}

}  // namespace eci::cli
