// The run, owned by the library: a monitor of a model's named invariants (initial, final, largest drift, NaN
// kept), and run(), which integrates, monitors every step and returns a report, also when a step underflows.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <concepts>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "concepts.hpp"
#include "integrate.hpp"
#include "models/invariant.hpp"

namespace eci {

/// One invariant's record over a run.
struct invariant_record {
    std::string name;            ///< the model's name for it (a CSV column)
    double initial = 0.0;        ///< I(t0)
    double final = 0.0;          ///< I at the last state recorded
    double max_abs_drift = 0.0;  ///< max over every recorded state of |I(t) - I(t0)|; NaN once it went NaN
    /// max_abs_drift / |I(t0)|: 0 if it never moved, infinite if I(t0) = 0 and it moved, NaN if it went NaN.
    double max_rel_drift() const {
        if (max_abs_drift == 0.0) return 0.0;
        return max_abs_drift / std::abs(initial);
    }
};

/// A model whose invariants are listed by name, `static constexpr auto invariants()` (see models/invariant.hpp).
template <class M>
concept has_named_invariants = requires {
    typename M::state_type;
    M::invariants();
};

/// Watches a model's named invariants along a run: record(x) at every state (the first one fixes I(t0)).
/// The one place eci measures drift; the CLI, the figures, the benchmarks and the tests all read it.
template <has_named_invariants Model>
class invariant_monitor {
    static constexpr auto list = Model::invariants();

   public:
    using state_type = typename Model::state_type;

    /// A monitor of `model`'s invariants (the model must outlive it).
    explicit invariant_monitor(const Model& model) : model_(&model) {
        for (const auto& inv : list) records_.push_back({inv.name});
    }

    /// Evaluates every invariant at x and updates its record.
    void record(const state_type& x) {
        for (std::size_t j = 0; j < list.size(); ++j) {
            const double v = (model_->*list[j].value)(x);
            values_[j] = v;
            invariant_record& r = records_[j];
            if (!started_) r.initial = v;
            r.final = v;
            const double d = std::abs(v - r.initial);
            if (d > r.max_abs_drift || std::isnan(d)) r.max_abs_drift = d;  // a NaN, once seen, stays
        }
        started_ = true;
    }
    /// The monitor as an observer (x, t, i).
    void operator()(const state_type& x, double, std::uint64_t) { record(x); }

    /// The records, in the model's invariants() order.
    const std::vector<invariant_record>& records() const { return records_; }
    /// The invariants' values at the last recorded state, in the same order.
    std::span<const double> values() const { return values_; }
    /// The largest max_rel_drift() over all invariants, a NaN counted as infinite (a run that blew up).
    double worst_rel_drift() const {
        double w = 0.0;
        for (const invariant_record& r : records_) {
            const double d = r.max_rel_drift();
            w = std::isnan(d) ? std::numeric_limits<double>::infinity() : std::max(w, d);
            if (std::isinf(w)) break;
        }
        return w;
    }
    /// Forget everything: the next record() is a new initial state.
    void restart() {
        for (invariant_record& r : records_) r = {r.name};
        started_ = false;
    }

   private:
    const Model* model_;
    std::vector<invariant_record> records_;
    std::array<double, list.size()> values_{};
    bool started_ = false;
};

/// How far a run goes: `steps` steps of dt from t0, or from t0 to t_end with the last step shortened to land
/// on it (see integrate_to). Build it with n_steps() or until(), which check their arguments.
struct run_span {
    double t0 = 0.0;
    double dt = 0.0;
    std::uint64_t steps = 0;  ///< steps on the output grid (the index of the last observation)
    double t_end = 0.0;       ///< the end time
    bool to_end_time = false;

    /// n steps of dt from t0.
    static run_span n_steps(std::uint64_t n, double dt, double t0 = 0.0) {
        detail::check_step(dt);
        return {t0, dt, n, t0 + double(n) * dt, false};
    }
    /// From t0 to t_end in steps of dt.
    static run_span until(double t_end, double dt, double t0 = 0.0) {
        if (!(t_end >= t0) || !std::isfinite(t_end))
            throw std::invalid_argument("end time must be finite and >= start");
        detail::check_step(dt);
        return {t0, dt, steps_to_reach(t0, t_end, dt), t_end, true};
    }
};

/// What run() reports.
struct run_report {
    run_stats stats{};                              ///< steps, reductions, evaluations, solves (also if it failed)
    std::vector<invariant_record> invariants;       ///< every named invariant, monitored at every step
    double t = 0.0;                                 ///< the time of the last state reached
    std::optional<step_size_underflow> failure;     ///< set if a step could not be completed
    /// True if the run reached its end.
    bool completed() const { return !failure.has_value(); }
};

/// Runs `stepper` on `model` from x over `span`, monitoring the model's invariants at every step (so the drift
/// is the true maximum, whatever opt.every). The observer sees (x, t, i, monitor), (x, t, i) or (x, t) at step 0,
/// every opt.every steps and at the last; it may throw to stop the run (the CLI's Ctrl-C). A step that fails even
/// at the smallest size ends the run without an exception: the report then holds `failure`, and the statistics
/// and drifts up to the last completed step; x is the state reached.
template <has_named_invariants Model, class St, class Observer = no_observer>
    requires stepper<St, const Model&, typename Model::state_type>
run_report run(St& stepper, const Model& model, typename Model::state_type& x, const run_span& span,
               Observer&& observe = {}, run_options opt = {}) {
    using S = typename Model::state_type;
    if (opt.every == 0) throw std::invalid_argument("observer interval must be at least 1");
    invariant_monitor<Model> monitor(model);
    run_report report;
    const std::uint64_t every = opt.every, last = span.steps;
    auto watch = [&](const S& s, double t, std::uint64_t i) {
        monitor.record(s);
        report.t = t;
        if (i % every == 0 || i == last) {
            if constexpr (std::invocable<Observer&, const S&, double, std::uint64_t, const invariant_monitor<Model>&>)
                observe(s, t, i, std::as_const(monitor));
            else
                detail::notify(observe, s, t, i);
        }
    };
    run_options each = opt;
    each.every = 1;
    try {
        report.stats = span.to_end_time ? integrate_to(stepper, model, x, span.t0, span.t_end, span.dt, watch, each)
                                        : integrate_n_steps(stepper, model, x, span.t0, span.dt, span.steps, watch, each);
    } catch (const step_size_underflow& e) {
        report.stats = e.stats;
        report.failure = e;
    }
    report.invariants = monitor.records();
    return report;
}

}  // namespace eci
