// eci.solve's one path into the library's run: the request as an eci::run_config, a sink that fills the NumPy
// arrays and polls Ctrl-C, eci::solve, and the report as SolveResult's dict (or eci's Python exceptions).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <numbers>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <eci/dynamic_sink.hpp>
#include <eci/solve.hpp>

#include "core.hpp"
#include "python_system.hpp"

namespace eci::python {

/// What eci.solve asks for, read from the settings dict the Python side builds: t_eval, output_dt, max_halvings,
/// and for adaptive control (key "adaptive" not None) rtol, atol, rtol_each, atol_each, min_step, max_step,
/// max_steps, t_eval_mode. `dt` is the fixed step or the first step.
struct python_request {
    run_config config;
    bool dense_output = false;  ///< record every step's dense output (result.sol)
    bool no_outputs = false;    ///< t_eval given and empty: no state recorded (SciPy: t of shape (0,))
    bool progress = false;      ///< a progress line on sys.stderr (eci.solve's progress=, resolved in Python)
    /// The event functions g(t, y) and, for each, whether it ends the run and which crossings count (SciPy's
    /// `terminal` and `direction`).
    std::vector<py::object> events;
    std::vector<std::uint64_t> terminal;  ///< the zero of each event that ends the run: 1 the first, 0 none
    std::vector<double> direction;
    bool sees_steps() const { return dense_output || !events.empty(); }
};

inline python_request request_from(double t0, double t1, double dt, const py::dict& settings) {
    python_request r;
    run_config& c = r.config;
    c.t0 = t0;
    c.t_end = t1;
    c.dt = dt;
    c.stop_on_invariant_overflow = true;
    if (!settings["t_eval"].is_none()) {
        c.times = settings["t_eval"].cast<std::vector<double>>();
        r.no_outputs = c.times.empty();  // (an empty run_config::times is "every step", the default)
    }
    if (settings.contains("output_dt") && !settings["output_dt"].is_none())
        c.output_dt = settings["output_dt"].cast<double>();  // resolved by eci::solve, as the CLI's --output-dt
    c.max_halvings = settings["max_halvings"].cast<int>();
    if (settings.contains("update") && !settings["update"].is_none()) {  // (None: not chosen)
        c.update = settings["update"].cast<std::string>() == "paper" ? update_kind::paper : update_kind::conditioned;
        c.update_chosen = true;
    }
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
    if (settings.contains("dense_output")) r.dense_output = settings["dense_output"].cast<bool>();
    if (settings.contains("progress")) r.progress = settings["progress"].cast<bool>();
    if (settings.contains("events") && !settings["events"].is_none())
        for (const py::handle e : settings["events"].cast<py::list>()) {
            const py::tuple t = e.cast<py::tuple>();
            r.events.push_back(py::reinterpret_borrow<py::object>(t[0]));
            r.terminal.push_back(t[1].cast<std::uint64_t>());
            r.direction.push_back(t[2].cast<double>());
        }
    return r;
}

/// Brent's root finder on [a, b] with g(a), g(b) of opposite signs (or one zero), to SciPy's tolerances for
/// events, xtol = rtol = 4 eps (scipy.optimize.brentq, whose algorithm this follows): the root to round-off.
template <class G>
double brent_root(G&& g, double a, double b, double fa, double fb) {
    constexpr double eps = std::numeric_limits<double>::epsilon();
    constexpr double xtol = 4.0 * eps, rtol = 4.0 * eps;
    if (fa == 0.0) return a;
    if (fb == 0.0) return b;
    double xpre = a, xcur = b, fpre = fa, fcur = fb, xblk = 0.0, fblk = 0.0, spre = 0.0, scur = 0.0;
    for (int i = 0; i < 100; ++i) {
        if (fpre != 0.0 && fcur != 0.0 && (std::signbit(fpre) != std::signbit(fcur))) {
            xblk = xpre;
            fblk = fpre;
            spre = scur = xcur - xpre;
        }
        if (std::abs(fblk) < std::abs(fcur)) {
            xpre = xcur, xcur = xblk, xblk = xpre;
            fpre = fcur, fcur = fblk, fblk = fpre;
        }
        const double delta = (xtol + rtol * std::abs(xcur)) / 2.0;
        const double sbis = (xblk - xcur) / 2.0;
        if (fcur == 0.0 || std::abs(sbis) < delta) return xcur;
        if (std::abs(spre) > delta && std::abs(fcur) < std::abs(fpre)) {
            double stry;
            if (xpre == xblk) {
                stry = -fcur * (xcur - xpre) / (fcur - fpre);  // interpolate
            } else {  // extrapolate
                const double dpre = (fpre - fcur) / (xpre - xcur), dblk = (fblk - fcur) / (xblk - xcur);
                stry = -fcur * (fblk * dblk - fpre * dpre) / (dblk * dpre * (fblk - fpre));
            }
            if (2.0 * std::abs(stry) < std::min(std::abs(spre), 3.0 * std::abs(sbis) - delta)) {
                spre = scur;  // good short step
                scur = stry;
            } else {
                spre = sbis;  // bisect
                scur = sbis;
            }
        } else {
            spre = sbis;
            scur = sbis;
        }
        xpre = xcur;
        fpre = fcur;
        xcur += std::abs(scur) > delta ? scur : (sbis > 0.0 ? delta : -delta);
        fcur = g(xcur);
    }
    return xcur;
}

/// What a run that sees its steps records besides the outputs: every step's dense output at dense_nodes points
/// (result.sol), and the events found (t_events, y_events).
template <class S>
struct step_record {
    using value_type = std::ranges::range_value_t<S>;
    /// Where each step's dense output is sampled, as fractions of the step: degree + 1 points determine the
    /// interpolant of that degree, of psi for the conventional pairs and of xi = psi^2 for the conservative ones,
    /// exactly. Degree <= 4 (DP54's continuous extension, the cubic Hermite): 0, 1/4, 1/2, 3/4, 1; degree 7 (DP853):
    /// the 8 Chebyshev-Lobatto points (1 - cos(j pi / 7)) / 2, whose Lagrange weights stay small (sum of their
    /// magnitudes below 3, so sol adds a few roundings at most).
    std::vector<double> dense_nodes;
    /// Where a conservative pair's conventional interpolant (whose sign each state takes) is sampled: the same but
    /// for the step's end, where the state is the conservative one and the conventional interpolant the
    /// conventional update (FSAL pairs), a different value: halfway between the last two nodes instead (at the
    /// start both are the step's first state).
    std::vector<double> sign_nodes;
    void choose_nodes(int degree) {
        if (!dense_nodes.empty()) return;
        const int d = std::max(degree, 4);
        if (d == 4) {
            dense_nodes = {0.0, 0.25, 0.5, 0.75, 1.0};
        } else {
            for (int j = 0; j <= d; ++j)
                dense_nodes.push_back(j == 0 ? 0.0 : j == d ? 1.0 : 0.5 * (1.0 - std::cos(j * std::numbers::pi / d)));
        }
        sign_nodes = dense_nodes;
        sign_nodes.back() = 0.5 * (dense_nodes[dense_nodes.size() - 2] + 1.0);
    }
    std::vector<double> t_start, t_end;
    std::vector<value_type> samples;  // per step, per node, the state
    std::vector<value_type> signs;    // squared: the conventional interpolant there, whose sign the state takes
    bool squared = false;             // the interpolant is of every real unknown's square (conservative)
    std::vector<std::vector<double>> t_events;
    std::vector<std::vector<value_type>> y_events;
};

/// The sink: every output into the arrays, Ctrl-C polled between steps; with dense output or events, every
/// accepted step too: its dense output sampled, and each event function's sign change located on it. A dynamic
/// sink, so that a model's compiled runs (solve_model, shared with the CLI) fill it as a plain system's run does.
template <class S>
class recording_sink final : public dynamic_sink<S> {
   public:
    using value_type = std::ranges::range_value_t<S>;
    recording_sink(recorded_output<S>* out, interrupt_check* interrupt, const python_request* req,
                   step_record<S>* steps)
        : out(out), interrupt(interrupt), req(req), steps(steps) {}
    recorded_output<S>* out;
    interrupt_check* interrupt;
    const python_request* req = nullptr;
    step_record<S>* steps = nullptr;
    std::vector<double> g_prev{};  // each event function at the last step's end
    std::vector<std::uint64_t> event_count{};  // each event's zeros so far
    S scratch{}, conventional{};

    void output(const S& x, const output_point& p) override {
        if (!req || !req->no_outputs) {
            out->record(p.t, x, p.time_lag);
            out->record_invariants(p.invariants);  // (measured at every output anyway: kept, not recomputed)
        }
    }
    void progress(double t, std::uint64_t) override { (*interrupt)(t); }
    bool observes_steps() const override { return req && req->sees_steps(); }

    double event_value(std::size_t j, double t, const S& x) const {
        const py::object r = req->events[j](t, to_numpy(std::vector<value_type>(std::ranges::begin(x), std::ranges::end(x))));
        try {
            return r.cast<double>();
        } catch (const py::cast_error&) {
            throw py::type_error("event " + std::to_string(j) + " returned " + std::string(py::repr(r)) +
                                 ", expected a real number");
        }
    }

    std::optional<double> accepted(step_view<S>& s) override {
        if (req->dense_output) {
            steps->squared = s.dense_of_squares();
            steps->choose_nodes(s.dense_degree());
            steps->t_start.push_back(s.t_start());
            steps->t_end.push_back(s.t_end());
            auto node_time = [&](double theta) {
                return theta == 0.0 ? s.t_start() : theta == 1.0 ? s.t_end()
                                                  : s.t_start() + theta * (s.t_end() - s.t_start());
            };
            for (double theta : steps->dense_nodes) {
                s.at(node_time(theta), scratch);
                steps->samples.insert(steps->samples.end(), std::ranges::begin(scratch), std::ranges::end(scratch));
            }
            if (steps->squared)
                for (double theta : steps->sign_nodes) {
                    s.at(node_time(theta), scratch, &conventional);
                    steps->signs.insert(steps->signs.end(), std::ranges::begin(conventional),
                                        std::ranges::end(conventional));
                }
        }
        const std::size_t m = req->events.size();
        if (m == 0) return std::nullopt;
        if (g_prev.empty()) {
            g_prev.resize(m);
            event_count.assign(m, 0);
            steps->t_events.resize(m);
            steps->y_events.resize(m);
            for (std::size_t j = 0; j < m; ++j) g_prev[j] = event_value(j, s.t_start(), s.start_state());
        }
        // SciPy's rules (find_active_events, handle_events): a crossing from <= 0 to >= 0 is up, from >= 0 to
        // <= 0 down; each active one located by Brent on the dense output and counted; when an event has reached
        // its terminal count, the first such root (in the run's direction) ends the run and later roots are dropped.
        std::vector<std::pair<double, std::size_t>> roots;
        std::vector<double> g_new(m);
        for (std::size_t j = 0; j < m; ++j) {
            g_new[j] = event_value(j, s.t_end(), s.end_state());
            const double g = g_prev[j], gn = g_new[j], dir = req->direction[j];
            const bool up = g <= 0.0 && gn >= 0.0, down = g >= 0.0 && gn <= 0.0;
            if (!((up && dir > 0.0) || (down && dir < 0.0) || ((up || down) && dir == 0.0))) continue;
            auto on_dense = [&](double t) {
                s.at(t, scratch);
                return event_value(j, t, scratch);
            };
            roots.emplace_back(brent_root(on_dense, s.t_start(), s.t_end(), g, gn), j);
        }
        g_prev = g_new;
        const bool forward = s.t_end() > s.t_start();
        std::optional<double> stop;
        for (const auto& r : roots) ++event_count[r.second];
        const auto ends = [&](const auto& r) {
            return req->terminal[r.second] > 0 && event_count[r.second] >= req->terminal[r.second];
        };
        if (std::ranges::any_of(roots, ends)) {
            std::stable_sort(roots.begin(), roots.end(), [&](const auto& a, const auto& b) {
                return forward ? a.first < b.first : a.first > b.first;
            });
            std::size_t k = 0;
            while (!ends(roots[k])) ++k;
            roots.resize(k + 1);
            stop = roots.back().first;
        }
        for (const auto& [t, j] : roots) {
            s.at(t, scratch);
            steps->t_events[j].push_back(t);
            steps->y_events[j].insert(steps->y_events[j].end(), std::ranges::begin(scratch), std::ranges::end(scratch));
        }
        return stop;
    }
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

/// A run that stopped early, as SciPy reports it (status -1 and a message, no exception): the dict
/// result["failure"], with the kind of eci's exception that describes it (StepSizeUnderflow, TooManySteps,
/// NonFiniteSolution), the message, the cause, and where.
inline py::dict failure_dict(const solve_report& r, const component_namer& name) {
    const run_failure& f = *r.failure;
    const std::string component = name(f.component);
    py::dict d;
    auto raise = [&](const char* cls_name, const std::string& message, const std::string& cause) {
        d["kind"] = cls_name;
        d["message"] = message;
        d["t"] = f.t;
        d["component"] = f.component;
        d["component_name"] = component;
        d["dt"] = f.dt;
        d["cause"] = cause;
        return d;
    };
    switch (f.kind) {
        case run_failure_kind::step_failed: {
            const bool rate = f.non_finite_rate_value.has_value();
            const std::string cause = rate ? "fun(t, y) returned " + full_text(*f.non_finite_rate_value) +
                                                 " in component " + component
                                           : "negative radicand, non-invertible transform or non-finite state";
            const std::string head = f.message.substr(0, f.message.find("): ") + 3);
            return raise("StepSizeUnderflow", head + cause, rate ? "non_finite_fun" : "step_failed");
        }
        case run_failure_kind::step_too_small: {
            const char* cause = f.last_rejection == rejection::non_finite_rate ? "non_finite_fun"
                                : f.last_rejection == rejection::step_failed   ? "step_failed"
                                                                                : "error_estimate";
            // (a rate that stayed non-finite at every size: said as the fixed steps say it, not left to the bracket)
            const std::string rate = f.last_rejection == rejection::non_finite_rate
                                         ? ": fun(t, y) returned a non-finite value in component " + component
                                         : "";
            return raise("StepSizeUnderflow",
                         f.message + rate + " [component " + component + ", last rejection: " + cause + "]", cause);
        }
        case run_failure_kind::too_many_steps: return raise("TooManySteps", f.message, "too_many_steps");
        case run_failure_kind::work_exceeded: return raise("StepSizeUnderflow", f.message, "work_exceeded");
        case run_failure_kind::non_finite_state:
            return raise("NonFiniteSolution", f.message + ": the solution blew up", "non_finite_state");
        case run_failure_kind::invariant_overflow:
            return raise("NonFiniteSolution", f.message, "invariant_overflow");
    }
    throw std::logic_error("unknown run failure");
}

/// eci::solve for a system on which only registry entry Entry is ever asked for (Kahan's method with a Python jac):
/// the same checks, messages and report, with Entry's stepper the only one compiled (solve() compiles every method
/// that runs on Dispatch, per state size). The method is resolved before the settings are checked (solve() checks
/// them first): a request wrong in both is refused for its method.
template <class Dispatch, class Entry, class F, class S, class Sink>
solve_report solve_entry(const F& f, S& x, std::string_view method, const run_config& cfg, Sink& sink,
                         std::vector<extra_invariant<S>> extra, std::string_view what) {
    const method_info m = resolve_method_for<Dispatch>(method, cfg.is_adaptive(), what);
    if (m.name != Entry::info.name)
        throw std::invalid_argument("method '" + std::string(method) + "' is not available for " + std::string(what) +
                                    " (available: " + std::string(Entry::info.name) + ")");
    stepper_for<Entry, Dispatch> stepper;
    apply_update(stepper, cfg, m.name, what);  // (Kahan's method has no update: one chosen is refused, as solve()'s)
    solve_report report = solve_with(stepper, f, x, cfg, sink, std::move(extra));
    report.method = m;
    return report;
}

/// Runs a request with the GIL released unless `release` is false (a Python fun or Python invariants need it
/// held) and returns the SolveResult dict: run(sink, cfg) is the run itself (eci::solve, or a model's compiled
/// solve_model), filling the recording sink.
template <class S>
py::dict run_recorded(S& x, python_request req, const component_namer& namer, bool release, std::size_t invariants,
                      const std::function<solve_report(recording_sink<S>&, const run_config&)>& run) {
    req.config.component_name = namer;
    // the arrays keep every output (the state, its time and each invariant's value there, result.invariant_values):
    // a fixed-step run whose outputs cannot fit is refused before it starts
    req.config.output_bytes = req.no_outputs ? 0
                                             : std::ranges::size(x) * sizeof(std::ranges::range_value_t<S>) +
                                                   (1 + invariants) * sizeof(double);
    recorded_output<S> out;
    step_record<S> steps;
    solve_report report;
    if (req.sees_steps() && !req.config.adaptive)
        throw std::invalid_argument("dense_output and events need adaptive step control (rtol/atol, no dt)");
    release = release && !req.sees_steps();  // events are Python callables
    std::optional<progress_display> progress;  // (erased when destroyed, the GIL held again)
    if (req.progress) progress.emplace(req.config.t0, req.config.t_end);
    {
        std::optional<py::gil_scoped_release> unlocked;
        if (release) unlocked.emplace();
        interrupt_check interrupt(!release, progress ? &*progress : nullptr);
        recording_sink<S> sink(&out, &interrupt, &req, &steps);
        report = run(sink, std::as_const(req.config));
    }
    const std::size_t n = std::ranges::size(x);
    py::dict d;
    add_arrays(d, out, n);
    d["stats"] = stats_dict(report);
    d["invariants"] = drift_dict(report.invariants);
    d["invariant_values"] = invariant_values_dict(out, record_names(report.invariants));
    add_method(d, report.method);
    d["failure"] = report.failure ? py::object(failure_dict(report, namer)) : py::object(py::none());
    d["stopped_at"] = report.stopped_at ? py::object(py::float_(*report.stopped_at)) : py::object(py::none());
    using value_type = std::ranges::range_value_t<S>;
    if (req.dense_output) {
        steps.choose_nodes(4);  // a run without a step: the nodes are not used
        const auto m = static_cast<py::ssize_t>(steps.t_start.size());
        const auto k = static_cast<py::ssize_t>(steps.dense_nodes.size());
        py::array_t<value_type> samples({m, k, static_cast<py::ssize_t>(n)});
        std::copy(steps.samples.begin(), steps.samples.end(), samples.mutable_data());
        py::dict dense;
        dense["t_start"] = py::array_t<double>(m, steps.t_start.data());
        dense["t_end"] = py::array_t<double>(m, steps.t_end.data());
        dense["nodes"] = py::array_t<double>(k, steps.dense_nodes.data());
        dense["samples"] = samples;
        dense["squared"] = steps.squared;
        py::array_t<value_type> signs({steps.squared ? m : 0, k, static_cast<py::ssize_t>(n)});
        std::copy(steps.signs.begin(), steps.signs.end(), signs.mutable_data());
        dense["signs"] = signs;
        dense["sign_nodes"] = py::array_t<double>(k, steps.sign_nodes.data());
        d["dense"] = dense;
    }
    if (!req.events.empty()) {
        py::list te, ye;
        for (std::size_t j = 0; j < req.events.size(); ++j) {
            const bool any = j < steps.t_events.size();
            const auto c = static_cast<py::ssize_t>(any ? steps.t_events[j].size() : 0);
            te.append(py::array_t<double>(c, any ? steps.t_events[j].data() : nullptr));
            py::array_t<value_type> y({c, static_cast<py::ssize_t>(n)});
            if (c) std::copy(steps.y_events[j].begin(), steps.y_events[j].end(), y.mutable_data());
            ye.append(y);
        }
        d["t_events"] = te;
        d["y_events"] = ye;
    }
    return d;
}

/// Runs `method` on f from x through eci::solve (run_recorded). Entry: a registry entry, the only method f is run
/// with (solve_entry), or void for every method that runs on Dispatch.
template <class Dispatch, class Entry = void, class F, class S>
py::dict run_python(const F& f, S& x, const std::string& method, python_request req,
                    std::vector<extra_invariant<S>> extra, const component_namer& namer, const std::string& what,
                    bool release) {
    const std::size_t invariants = extra.size();  // (a Python fun's are all extra: its own, its quadratic ones)
    return run_recorded<S>(x, std::move(req), namer, release, invariants,
                           [&](recording_sink<S>& sink, const run_config& cfg) {
        if constexpr (std::is_void_v<Entry>)
            return solve<Dispatch>(f, x, method, cfg, sink, std::move(extra), what);
        else
            return solve_entry<Dispatch, Entry>(f, x, method, cfg, sink, std::move(extra), what);
    });
}

/// Runs `method` on a model of the list from x through its compiled runs (solve_model, shared with the CLI, so
/// the same bits as `eci run`), with run_recorded.
template <class Model>
py::dict run_python_model(const Model& model, typename Model::state_type& x, const std::string& method,
                          python_request req, std::vector<extra_invariant<typename Model::state_type>> extra,
                          const component_namer& namer, const std::string& what, bool release) {
    using S = typename Model::state_type;
    const std::size_t invariants = std::size(Model::invariants()) + extra.size();
    py::dict d = run_recorded<S>(x, std::move(req), namer, release, invariants,
                                 [&](recording_sink<S>& sink, const run_config& cfg) {
        return solve_model<Model>(model, x, method, cfg, sink, std::move(extra), what);
    });
    if (const auto m = find_method(d["method"].cast<std::string>()))  // (what the CLI's summary says of it)
        d["keeps"] = py::cast(invariants_kept<Model>(*m));
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
