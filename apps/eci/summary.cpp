// The model-independent half of `eci run`: checking the method and time settings, and the summary it prints
// (stderr) and writes (JSON).
#include "run_model.hpp"

#include <eci/format.hpp>

#include <charconv>
#include <cmath>
#include <filesystem>
#include <limits>

namespace eci::cli {

namespace {

std::string number(double v) {
    char buffer[32];
    return std::string(format_double(v, buffer));
}

}  // namespace

std::string shortest(double v) { return eci::shortest_text(v); }

column_names indexed_columns(std::string_view prefix, std::size_t size, bool complex) {
    return column_names(std::string(prefix), size, complex);
}

run_plan resolve_plan(double default_dt, double default_t_end, const run_settings& settings) {
    run_plan span{};
    span.dt = settings.dt.value_or(default_dt);
    if (!(span.dt > 0.0) || !std::isfinite(span.dt))
        throw bad_input("--dt must be a positive finite number, not " + shortest(span.dt));
    if (settings.every == 0) throw bad_input("--every must be at least 1");
    if (settings.t_end && settings.steps) throw bad_input("--t-end and --steps cannot be used together");
    // More than max_grid_steps (2^53): the time grid t0 + i dt is no longer exact (and the run would never end).
    if (settings.steps) {
        span.fixed_steps = true;
        span.steps = *settings.steps;
        if (span.steps > max_grid_steps)
            throw bad_input("--steps " + std::to_string(span.steps) + " is too many (at most 2^53)");
        span.t_end = double(span.steps) * span.dt;
        return span;
    }
    span.t_end = settings.t_end.value_or(default_t_end);
    if (!(span.t_end >= 0.0) || !std::isfinite(span.t_end))
        throw bad_input("--t-end must be a finite number >= 0, not " + shortest(span.t_end));
    // An adaptive run's --dt is only its first step (the library's check_config counts no grid for it, as Python's
    // first_step): t_end / dt says nothing of its steps, and a tiny first step is no reason to refuse it
    if (settings.rtol || settings.atol) return span;
    if (span.t_end / span.dt > double(max_grid_steps))
        throw bad_input("--t-end / --dt is " + shortest(span.t_end / span.dt) + " steps, too many");
    span.steps = steps_to_reach(0.0, span.t_end, span.dt);
    return span;
}

void check_distinct_outputs(const run_settings& settings) {
    // symlinks followed, dangling ones too, and hard links; "-", /dev/stdout and /dev/fd/1 are one stream
    check_distinct_files(
        {{"--output", settings.output}, {"--summary-json", settings.summary_json}, {"--plot", settings.plot}});
}

std::string underflow_message(const step_size_underflow& e, const column_names& columns) {
    char t[32], h[32];
    const std::string column = columns[e.component];
    return "step failed at t = " + std::string(format_double(e.time, t)) + " in component " + column +
           " even with the step halved " + std::to_string(run_options{}.max_halvings) +
           " times (dt = " + std::string(format_double(e.dt, h)) +
           "): negative radicand, non-invertible transform or non-finite state";
}

namespace {

// What the method keeps of the model's invariants: all ("conservative"), some by name, or none ("conventional").
std::string kept_text(const run_summary& s) {
    if (s.conservative) return "conservative";
    if (s.keeps.empty()) return "conventional";
    std::string t = "keeps ";
    for (std::size_t i = 0; i < s.keeps.size(); ++i) t += (i ? ", " : "") + s.keeps[i];
    return t;
}

}  // namespace

void print_summary(std::FILE* f, const run_summary& s) {
    std::fprintf(f, "eci run %s: method %s (order %d, %s), dt %s, t %s to %s\n", s.model.c_str(), s.method.c_str(),
                 s.order, kept_text(s).c_str(), shortest(s.dt).c_str(), shortest(s.t_start).c_str(),
                 shortest(s.t_end).c_str());
    if (s.adaptive) {
        const adaptive_stats& a = s.adaptive_counts;
        std::fprintf(f, "  adaptive, rtol %s, atol %s (dt is the first step)\n", shortest(s.rtol).c_str(),
                     shortest(s.atol).c_str());
        std::fprintf(f, "  accepted steps %llu, rejected %llu by error and %llu by negative radicand or transform, "
                        "rhs evals %llu, wall time %.3g s\n",
                     static_cast<unsigned long long>(a.accepted), static_cast<unsigned long long>(a.rejected_error),
                     static_cast<unsigned long long>(a.rejected_radicand),
                     static_cast<unsigned long long>(a.rhs_evals), s.wall_seconds);
        std::fprintf(f, "  step size %s to %s; outputs: %llu dense, %llu landed, %llu dense refused\n",
                     number(a.accepted ? a.dt_smallest : 0.0).c_str(), number(a.dt_largest).c_str(),
                     static_cast<unsigned long long>(a.dense_points), static_cast<unsigned long long>(a.landed_points),
                     static_cast<unsigned long long>(a.dense_fallbacks));
    } else {
        std::fprintf(f, "  steps %llu, step reductions %llu, rhs evals %llu, wall time %.3g s\n",
                     static_cast<unsigned long long>(s.stats.steps),
                     static_cast<unsigned long long>(s.stats.step_reductions),
                     static_cast<unsigned long long>(s.stats.rhs_evals), s.wall_seconds);
    }
    if (s.time_lag)  // relaxation RK: the state belongs to t + time lag (docs/comparison.md)
        std::fprintf(f, "  time reached %s (relaxation: t_end + time lag %s)\n", number(s.t_end + *s.time_lag).c_str(),
                     number(*s.time_lag).c_str());
    // steps the remedy completed without halving, and the unknowns it gave the conventional update (a negative or
    // ill-conditioned radicand; at fixed steps of order 3 and up, and in the pairs on real unknowns, every one):
    // said so, since the count alone read like trouble (docs/methods.md)
    if (s.stats.remedied_steps > 0)
        std::fprintf(f,
                     "  remedied steps %llu, components remedied %llu (their conventional update, then one exact "
                     "rescale of the state: docs/methods.md)\n",
                     static_cast<unsigned long long>(s.stats.remedied_steps),
                     static_cast<unsigned long long>(s.stats.components_remedied));
    int name_width = 12;  // (the column as wide as the longest name: angular_momentum, runge_lenz_turn...)
    for (const invariant_record& r : s.invariants) name_width = std::max(name_width, int(r.name.size()));
    std::fprintf(f, "  %-*s %-24s %-24s %-13s %s\n", name_width, "invariant", "initial", "final", "max abs drift",
                 "max rel drift");
    for (const invariant_record& r : s.invariants) {
        char rel[32] = "n/a";
        if (const double d = r.max_rel_drift(); !std::isnan(d)) std::snprintf(rel, sizeof rel, "%.3e", d);
        std::fprintf(f, "  %-*s %-24s %-24s %-13.3e %s\n", name_width, r.name.c_str(), number(r.initial).c_str(),
                     number(r.final).c_str(), r.max_abs_drift, rel);
    }
    if (!s.invariants_note.empty()) std::fprintf(f, "  %s\n", s.invariants_note.c_str());
    if (s.stats.solver.solves > 0)
        std::fprintf(f, "  iterative solves %llu, iterations mean %.3g, max %d\n",
                     static_cast<unsigned long long>(s.stats.solver.solves), s.stats.solver.mean_iterations(),
                     s.stats.solver.max_iterations);
    // A figure beyond the range of double says so (the JSON writes null): the palinstrophy of a Charney-Hasegawa-
    // Mima field with --deformation 1.7e308 is ~1e310 while its E and Z, and the run, are finite (long CLI fuzz,
    // seed 843848237).
    for (const auto& [name, value] : s.figures)
        std::fprintf(f, "  %s %s\n", name.c_str(),
                     std::isfinite(value) ? number(value).c_str() : std::isnan(value) ? "n/a" : "overflow");
}

void write_summary_json(std::FILE* f, const run_summary& s) {
    auto key = [&](const char* k) { std::fprintf(f, "  \"%s\": ", k); };
    std::fputs("{\n", f);
    key("model"), write_json_string(f, s.model), std::fputs(",\n", f);
    key("method"), write_json_string(f, s.method), std::fputs(",\n", f);
    key("order"), std::fprintf(f, "%d,\n", s.order);
    key("conservative"), std::fputs(s.conservative ? "true,\n" : "false,\n", f);
    key("keeps"), std::fputc('[', f);  // the invariants the method keeps (all of them where conservative)
    std::vector<std::string> kept = s.keeps;
    if (s.conservative && kept.empty())
        for (const invariant_record& r : s.invariants) kept.push_back(r.name);
    for (std::size_t i = 0; i < kept.size(); ++i) {
        if (i) std::fputs(", ", f);
        write_json_string(f, kept[i]);
    }
    std::fputs("],\n", f);
    key("dt"), write_json_number(f, s.dt), std::fputs(",\n", f);
    key("t_end"), write_json_number(f, s.t_end), std::fputs(",\n", f);
    if (s.interrupted) {  // stopped by a signal: what it reached, its last output
        key("interrupted"), std::fputs("true,\n", f);
        key("t_stopped"), write_json_number(f, s.t_stopped), std::fputs(",\n", f);
    }
    if (s.counted) {
        key("steps"), std::fprintf(f, "%llu,\n", static_cast<unsigned long long>(s.stats.steps));
        key("step_reductions"), std::fprintf(f, "%llu,\n", static_cast<unsigned long long>(s.stats.step_reductions));
        key("rhs_evals"), std::fprintf(f, "%llu,\n", static_cast<unsigned long long>(s.stats.rhs_evals));
        key("remedied_steps"), std::fprintf(f, "%llu,\n", static_cast<unsigned long long>(s.stats.remedied_steps));
        key("components_remedied"),
            std::fprintf(f, "%llu,\n", static_cast<unsigned long long>(s.stats.components_remedied));
    }
    key("wall_seconds"), write_json_number(f, s.wall_seconds), std::fputs(",\n", f);
    if (s.time_lag) {
        key("time_lag"), write_json_number(f, *s.time_lag), std::fputs(",\n", f);
        key("t_reached"), write_json_number(f, s.t_end + *s.time_lag), std::fputs(",\n", f);
    }
    if (s.adaptive) {
        key("adaptive"), std::fputs("true,\n", f);
        key("rtol"), write_json_number(f, s.rtol), std::fputs(",\n", f);
        key("atol"), write_json_number(f, s.atol), std::fputs(",\n", f);
    }
    if (s.adaptive && s.counted) {
        const adaptive_stats& a = s.adaptive_counts;
        key("accepted_steps"), std::fprintf(f, "%llu,\n", static_cast<unsigned long long>(a.accepted));
        key("rejected_error"), std::fprintf(f, "%llu,\n", static_cast<unsigned long long>(a.rejected_error));
        key("rejected_radicand"), std::fprintf(f, "%llu,\n", static_cast<unsigned long long>(a.rejected_radicand));
        key("dt_smallest"), write_json_number(f, a.accepted ? a.dt_smallest : 0.0), std::fputs(",\n", f);
        key("dt_largest"), write_json_number(f, a.dt_largest), std::fputs(",\n", f);
        key("dense_outputs"), std::fprintf(f, "%llu,\n", static_cast<unsigned long long>(a.dense_points));
        key("landed_outputs"), std::fprintf(f, "%llu,\n", static_cast<unsigned long long>(a.landed_points));
        key("dense_refused"), std::fprintf(f, "%llu,\n", static_cast<unsigned long long>(a.dense_fallbacks));
    }
    if (s.stats.solver.solves > 0) {
        key("solver");
        std::fprintf(f, "{\"solves\": %llu, \"iterations\": %llu, \"iterations_mean\": ",
                     static_cast<unsigned long long>(s.stats.solver.solves),
                     static_cast<unsigned long long>(s.stats.solver.iterations));
        write_json_number(f, s.stats.solver.mean_iterations());
        std::fprintf(f, ", \"iterations_max\": %d},\n", s.stats.solver.max_iterations);
    }
    for (const auto& [name, value] : s.figures) key(name.c_str()), write_json_number(f, value), std::fputs(",\n", f);
    key("invariants");
    std::fputs("{", f);
    for (std::size_t i = 0; i < s.invariants.size(); ++i) {
        const invariant_record& r = s.invariants[i];
        std::fputs(i ? ",\n    " : "\n    ", f);
        write_json_string(f, r.name);
        std::fputs(": {\"initial\": ", f), write_json_number(f, r.initial);
        std::fputs(", \"final\": ", f), write_json_number(f, r.final);
        std::fputs(", \"max_abs_drift\": ", f), write_json_number(f, r.max_abs_drift);
        std::fputs(", \"max_rel_drift\": ", f), write_json_number(f, r.max_rel_drift());
        std::fputs("}", f);
    }
    std::fputs("\n  }\n}\n", f);
}

}  // namespace eci::cli
