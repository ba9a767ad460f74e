// What a run watches and how far it goes: the monitor of a system's invariants (initial, final, largest drift,
// NaN kept) and run_span. The run itself is eci::solve_with (solve.hpp), and eci::run is a wrapper of it.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <concepts>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <limits>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <type_traits>
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

    /// Takes the value v at the next state (the first one fixes I(t0)).
    void record(double v, bool first) {
        if (first) initial = v;
        final = v;
        max_abs_drift = widened_drift(max_abs_drift, initial, v);
    }
    /// The largest drift so far, max_abs_drift, taken on to the value v of an invariant that started at `initial`
    /// (record's rule, for a front end that keeps the drift elsewhere: the spectral command's checkpoint).
    static double widened_drift(double max_abs_drift, double initial, double v) {
        const double d = std::abs(v - initial);
        return d > max_abs_drift || std::isnan(d) ? d : max_abs_drift;  // a NaN, once seen, stays
    }
    /// max_abs_drift / |I(t0)| where that means something: 0 if it never moved; NaN (the CLI's "n/a", JSON null,
    /// Python nan) if it moved from I(t0) = 0 or from a subnormal I(t0) (a Runge-Lenz component at theta =
    /// 2.2e-308, where the quotient reached 6.7e307 and inf), if the quotient overflows, or once it went NaN. Every
    /// front end reports this one value.
    double max_rel_drift() const {
        if (max_abs_drift == 0.0) return 0.0;
        const double d = max_abs_drift / std::abs(initial);
        return std::abs(initial) >= std::numeric_limits<double>::min() && std::isfinite(d)
                   ? d
                   : std::numeric_limits<double>::quiet_NaN();
    }
};

/// A model whose invariants are listed by name, `static constexpr auto invariants()` (see models/invariant.hpp).
template <class M>
concept has_named_invariants = requires {
    typename M::state_type;
    M::invariants();
};

/// A model whose invariants() is a constant expression (every model of eci's list): the monitor then calls each
/// invariant directly.
template <class M>
concept constant_invariant_list =
    has_named_invariants<M> && requires { typename std::integral_constant<std::size_t, M::invariants().size()>; };

/// A model that evaluates its whole (constant) invariant list at once, invariant_values(x, out) giving the bits of
/// each invariant's own function (spectral::flow2d: E and Z in one pass over the state): the monitor then calls it
/// once per state.
template <class M, class S>
concept evaluates_invariants_together =
    constant_invariant_list<M> && requires(const M& m, const S& x, std::span<double> out) { m.invariant_values(x, out); };

/// An invariant given as a function of the state (a Python callable), monitored after the model's own.
template <class S>
struct extra_invariant {
    std::string name;
    std::function<double(const S&)> value;
};

/// Watches a system's invariants along a run: the model's named ones (if it declares them), then `extra` ones;
/// record(x) at every state (the first one fixes I(t0)). The one place eci measures drift: eci::solve and every
/// run built on it, the CLI, the figures, the benchmarks and the tests all read it. S is the state type (for a
/// plain system, which has no state_type, give it).
template <class Model, class S = typename Model::state_type>
class invariant_monitor {
   public:
    using state_type = S;

    /// A monitor of `model`'s invariants and the extra ones (the model must outlive it).
    explicit invariant_monitor(const Model& model, std::vector<extra_invariant<S>> extra = {})
        : model_(&model), extra_(std::move(extra)) {
        if constexpr (has_named_invariants<Model>)
            for (const auto& inv : Model::invariants()) records_.push_back({inv.name});
        for (const auto& e : extra_) records_.push_back({e.name});
        values_.resize(records_.size());
    }

    /// Evaluates every invariant at x and updates its record.
    void record(const S& x) {
        finite_now_ = true;
        std::size_t j = 0;
        if constexpr (evaluates_invariants_together<Model, S>) {
            std::array<double, Model::invariants().size()> v;
            model_->invariant_values(x, v);
            for (; j < v.size(); ++j) update(j, v[j]);
        } else if constexpr (constant_invariant_list<Model>) {
            // One direct call per invariant (its member pointer a constant of the list), which the compiler can
            // inline: a run records every step, and on three modes a call through the pointer cost a tenth of
            // `eci run`'s step.
            static constexpr auto invariants = Model::invariants();
            [&]<std::size_t... I>(std::index_sequence<I...>) {
                (update(I, (model_->*invariants[I].value)(x)), ...);
            }(std::make_index_sequence<invariants.size()>{});
            j = invariants.size();
        } else if constexpr (has_named_invariants<Model>) {  // a list known only when called
            for (const auto& inv : Model::invariants()) update(j++, (model_->*inv.value)(x));
        }
        for (const auto& e : extra_) update(j++, e.value(x));
        started_ = true;
    }
    /// The monitor as an observer (x, t, i).
    void operator()(const S& x, double, std::uint64_t) { record(x); }

    /// The records: the model's invariants() in order, then the extra ones.
    const std::vector<invariant_record>& records() const { return records_; }
    /// The invariants' values at the last recorded state, in the same order.
    std::span<const double> values() const { return values_; }
    /// The largest max_rel_drift() over all invariants, a NaN counted as infinite (a run that blew up, or an
    /// invariant that moved from 0).
    double worst_rel_drift() const {
        double w = 0.0;
        for (const invariant_record& r : records_) {
            const double d = r.max_rel_drift();
            w = std::isnan(d) ? std::numeric_limits<double>::infinity() : std::max(w, d);
            if (std::isinf(w)) break;
        }
        return w;
    }
    /// The first invariant that is not finite now but was at the start, or none.
    std::optional<std::size_t> overflowed() const {
        if (finite_now_) return std::nullopt;  // (known from record(): the run asks at every step)
        for (std::size_t j = 0; j < values_.size(); ++j)
            if (!std::isfinite(values_[j]) && std::isfinite(records_[j].initial)) return j;
        return std::nullopt;
    }
    /// Forget everything: the next record() is a new initial state.
    void restart() {
        for (invariant_record& r : records_) r = {r.name};
        started_ = false;
    }

   private:
    void update(std::size_t j, double v) {
        values_[j] = v;
        finite_now_ = finite_now_ && std::isfinite(v);
        records_[j].record(v, !started_);
    }

    const Model* model_;
    std::vector<extra_invariant<S>> extra_;
    std::vector<invariant_record> records_;
    std::vector<double> values_;
    bool started_ = false;
    bool finite_now_ = true;  // every value of the last record() finite
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

}  // namespace eci
