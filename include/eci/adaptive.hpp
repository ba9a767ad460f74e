// Adaptive step-size control for the embedded steppers (steppers/embedded_rk.hpp): the RMS error norm, an I or PI
// controller (the error controller of the one run loop, detail/run_loop.hpp), negative radicands as their own kind
// of rejection, output at requested times by landing or dense.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <limits>
#include <optional>
#include <ranges>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "concepts.hpp"
#include "detail/format.hpp"
#include "detail/run_loop.hpp"
#include "detail/state_ops.hpp"
#include "integrate.hpp"
#include "registry.hpp"
#include "run.hpp"
#include "steppers/embedded_rk.hpp"
#include "steppers/transformed_embedded_rk.hpp"

namespace eci {

/// Tolerances and controller settings of an adaptive run.
struct adaptive_options {
    double rtol = 1e-6;                  ///< relative tolerance (all components)
    double atol = 1e-6;                  ///< absolute tolerance (all components)
    std::vector<double> rtol_each{};     ///< per state element (a complex mode's two parts share one); overrides rtol
    std::vector<double> atol_each{};     ///< per state element; overrides atol
    double safety = 0.9;                 ///< the controller aims at safety * tolerance
    double min_factor = 0.2;             ///< a step shrinks by at most this factor after an error rejection
    double max_factor = 5.0;             ///< and grows by at most this one after an accepted step
    bool pi_control = false;             ///< PI controller (Gustafsson; Hairer-Wanner II, IV.2) instead of I
    double pi_beta = 0.04;               ///< PI: weight of the previous error (alpha = 1/(q+1) - 0.75 beta)
    double radicand_factor = 0.5;        ///< a negative radicand / non-invertible transform shrinks the step so
    double dt_min = 0.0;                 ///< smallest step; 0 means 64 eps |t|, the resolution of time where the run is
    double dt_max = std::numeric_limits<double>::infinity();  ///< largest step
    std::uint64_t max_attempts = 50'000'000;  ///< accepted plus rejected steps before the run stops
};

/// What an adaptive run did.
struct adaptive_stats {
    std::uint64_t accepted = 0;           ///< accepted steps
    std::uint64_t rejected_error = 0;     ///< steps rejected because the error estimate exceeded the tolerance
    std::uint64_t rejected_radicand = 0;  ///< steps rejected for a negative radicand (or non-finite error)
    /// Of rejected_radicand, the attempts the system stopped by reporting a non-finite rate (eci::non_finite_rate)
    std::uint64_t rejected_non_finite_rate = 0;
    std::uint64_t rhs_evals = 0;          ///< right-hand-side evaluations, rejected steps included
    double dt_smallest = std::numeric_limits<double>::infinity();  ///< smallest accepted step
    double dt_largest = 0.0;                                       ///< largest accepted step
    std::uint64_t dense_points = 0;       ///< outputs interpolated by the dense output
    std::uint64_t landed_points = 0;      ///< outputs computed by a step landing on them
    std::uint64_t dense_fallbacks = 0;    ///< dense outputs refused (negative interpolated xi) and landed instead
    std::uint64_t rejected() const { return rejected_error + rejected_radicand; }
};

/// Why an adaptive attempt was rejected.
enum class rejection {
    error_estimate,   ///< the error estimate exceeded the tolerance
    step_failed,      ///< a negative radicand, a non-invertible transform or a non-finite error
    non_finite_rate,  ///< the system reported a non-finite rate (eci::non_finite_rate)
};

/// An adaptive run stopped: the step fell below the minimum (naming the time and the component that forced it),
/// or the run reached its maximum number of steps. Carries the statistics up to that point.
class adaptive_failure : public std::runtime_error {
   public:
    /// time_unresolved: far from t = 0 the doubles are too far apart for the span's steps (a step too small)
    enum class reason { step_too_small, too_many_steps, time_unresolved };
    adaptive_failure(reason why, double t, std::size_t component, double dt, adaptive_stats s)
        : std::runtime_error(message(why, t, component, dt, s)),
          why(why), time(t), component(component), dt(dt), stats(s) {}
    reason why;
    double time;            ///< the time the run could not step from
    std::size_t component;  ///< the real unknown with the largest error or the negative radicand
    double dt;              ///< the step size that was refused
    adaptive_stats stats;   ///< the run's statistics until then
    rejection last_rejection = rejection::error_estimate;  ///< the cause of the last rejected attempt

   private:
    static std::string message(reason why, double t, std::size_t component, double dt, const adaptive_stats& s) {
        std::ostringstream os;
        os.precision(17);
        if (why == reason::time_unresolved)
            os << "adaptive step fell below the spacing of doubles at t = " << t << " (dt = " << dt
               << "): time cannot advance there (count time from 0: a start time nearer 0)";
        else if (why == reason::step_too_small)
            os << "adaptive step fell below the minimum at t = " << t << " (dt = " << dt << ", component " << component
               << ", after " << s.accepted << " accepted steps; tolerance too tight, a singularity, or the state "
               << "is not finite)";
        else
            os << "adaptive run reached its maximum of " << s.accepted + s.rejected() << " steps at t = " << t
               << " (dt = " << dt << ")";
        return os.str();
    }
};

/// How a run with output times produces its rows: by landing a step on each time, or by dense output (for a
/// conservative stepper an interpolant of xi that keeps every invariant).
enum class output_mode {
    landing,   ///< a step lands on every output time
    dense,     ///< the stepper's dense output (landed where a conservative interpolant would need sqrt of < 0)
    automatic  ///< dense where it is as accurate as the steps (DP54's continuous extension, BS32), else landing
};

/// A stepper the adaptive drivers can run: attempt / accept / reset with an embedded error estimate.
template <class St, class F, class S>
concept adaptive_stepper = system<F, S> && St::has_error_estimate && St::embedded_order > 0 &&
                           requires(St& st, F& f, const S& cx, S& x, double t, double dt, const error_weights* w) {
                               { st.attempt(f, cx, t, dt, w, true) } -> std::same_as<attempt_result>;
                               st.accept(x);
                               st.reset();
                           };

namespace detail {

/// A tolerance, rtol or atol (`name`), is a finite number >= 0: std::invalid_argument "NAME must be a finite number
/// >= 0, not V" otherwise, the sentence Python's eci.solve says too.
inline void check_tolerance(const char* name, double v) {
    if (!(v >= 0.0 && std::isfinite(v)))
        throw std::invalid_argument(std::string(name) + " must be a finite number >= 0, not " + shortest_text(v));
}

}  // namespace detail

/// Checks adaptive settings for a state of `elements` elements; std::invalid_argument naming the bad one.
inline void check_adaptive_options(const adaptive_options& o, std::size_t elements) {
    auto non_negative_finite = [](double v) { return v >= 0.0 && std::isfinite(v); };
    detail::check_tolerance("rtol", o.rtol);
    detail::check_tolerance("atol", o.atol);
    for (const auto* v : {&o.rtol_each, &o.atol_each}) {
        if (!v->empty() && v->size() != elements)
            throw std::invalid_argument("per-component tolerances need one value per state element (" +
                                        std::to_string(elements) + "), got " + std::to_string(v->size()));
        for (double e : *v)
            if (!non_negative_finite(e)) throw std::invalid_argument("per-component tolerances must be finite and >= 0");
    }
    if (o.rtol_each.empty() && o.atol_each.empty() && !(o.rtol + o.atol > 0.0))
        throw std::invalid_argument("rtol and atol cannot both be zero");
    if (!(o.safety > 0.0 && o.safety <= 1.0)) throw std::invalid_argument("safety factor must be in (0, 1]");
    if (!(o.min_factor > 0.0 && o.min_factor < 1.0)) throw std::invalid_argument("min_factor must be in (0, 1)");
    if (!(o.max_factor > 1.0 && std::isfinite(o.max_factor))) throw std::invalid_argument("max_factor must be > 1");
    if (!(o.radicand_factor > 0.0 && o.radicand_factor < 1.0))
        throw std::invalid_argument("radicand_factor must be in (0, 1)");
    if (!(o.pi_beta >= 0.0 && o.pi_beta < 0.5)) throw std::invalid_argument("pi_beta must be in [0, 0.5)");
    if (!(o.dt_min >= 0.0) || !std::isfinite(o.dt_min)) throw std::invalid_argument("dt_min must be finite, >= 0");
    if (!(o.dt_max > 0.0)) throw std::invalid_argument("dt_max must be positive");
    if (o.dt_min > o.dt_max)
        throw std::invalid_argument("dt_min " + detail::shortest_text(o.dt_min) + " exceeds dt_max " +
                                    detail::shortest_text(o.dt_max));
    if (o.max_attempts == 0) throw std::invalid_argument("max_attempts must be at least 1");
}

namespace detail {

inline void check_options(const adaptive_options& o, std::size_t elements) { check_adaptive_options(o, elements); }

/// The adaptive drivers' view of a system: counts its evaluations and exposes it as wrapped(), so that a stepper
/// that needs the model behind f (a transform) still reaches it.
template <class F>
struct counted_system {
    F* f;
    std::uint64_t* count;
    static constexpr bool reports_non_finite_rate = eci::reports_non_finite_rate<F>;
    template <class S>
    void operator()(const S& x, S& dxdt, double t) const {
        ++*count;
        (*f)(x, dxdt, t);
    }
    const F& wrapped() const { return *f; }
};

/// One attempt; a non-finite rate reported by the system is a failed attempt (`rate_failed` set).
template <class St, class F, class S>
attempt_result attempt_checked(St& st, F& f, const S& x, double t, double dt, const error_weights* w, bool worst,
                               bool& rate_failed) {
    rate_failed = false;
    if constexpr (reports_non_finite_rate<F>) {
        try {
            return st.attempt(f, x, t, dt, w, worst);
        } catch (const non_finite_rate& e) {
            rate_failed = true;
            attempt_result r;
            r.ok = true;  // as a non-finite error estimate: the step shrinks by min_factor
            r.error = std::numeric_limits<double>::quiet_NaN();
            r.component = e.component;
            return r;
        }
    } else {
        return st.attempt(f, x, t, dt, w, worst);
    }
}


/// An attempt of the error controller: a step of size dt (signed by the run's direction when taken), landing on
/// the target or not.
struct adaptive_attempt {
    double dt;
    bool landing;
};

/// The error controller of run_loop, shared by all adaptive drivers: I or PI control of the step from the embedded
/// error estimate, failed attempts (negative radicand, non-finite error or rate) as their own rejections, the
/// attempt budget and the minimum step. `advance(t_target, on_accept)` steps x from t to t_target (landing on it);
/// on_accept(t_prev, t_new) sees every accepted step.
template <class St, class F, class S>
class error_control {
   public:
    error_control(St& st, F& f, S& x, double t0, double dt0, const adaptive_options& o, adaptive_stats& stats)
        : st_(st), f_(f), x_(x), t_(t0), dt_(std::max(dt0, o.dt_min)), first_dt_(dt_), o_(o), stats_(stats) {
        // A step the user set a floor for (dt_min > 0) starts at it at least, and never goes below it but to land.
        const std::size_t n = reals(std::as_const(x)).size();
        const std::size_t per = std::ranges::size(x) ? n / std::ranges::size(x) : 1;
        auto expand = [&](const std::vector<double>& each, std::vector<double>& out) {
            if (each.empty()) return;
            out.resize(n);
            for (std::size_t i = 0; i < n; ++i) out[i] = each[i / per];
        };
        expand(o.rtol_each, rtol_);
        expand(o.atol_each, atol_);
        w_ = {o.rtol, o.atol, rtol_.empty() ? nullptr : rtol_.data(), atol_.empty() ? nullptr : atol_.data()};
        st_.reset();
    }

    double time() const { return t_; }

    /// Steps x from the current time to t_target, forward or (t_target < time()) backward in time: the
    /// controller works on the step's size, the stepper gets it signed (every eci stepper takes a negative dt).
    template <class OnAccept>
    void advance(double t_target, OnAccept&& on_accept) {
        target_ = t_target;
        forward_ = !(t_target < t_);
        dir_ = forward_ ? 1.0 : -1.0;
        run_loop(*this, [&](position) { on_accept(t_prev_, t_); });
    }

    /// The controller keeps where the run is itself (run_loop's position is for the fixed-step controller).
    struct position {};
    static position start() { return {}; }
    static void leave(position) {}

    bool more(position) const { return forward_ ? t_ < target_ : t_ > target_; }

    adaptive_attempt propose(position) {
        // Land on the target when the proposed step would (nearly) reach it: no sliver of a last step.
        double dt = std::min({dt_, o_.dt_max});  // the step's size
        const bool landing = forward_ ? t_ + 1.01 * dt >= target_ : t_ - 1.01 * dt <= target_;
        if (landing) dt = forward_ ? target_ - t_ : t_ - target_;
        // Far from t = 0 a step below the spacing of doubles would be accepted without moving the time (at
        // t = 1e17, where they are 16 apart, five such steps were "accepted" before the step fell below the floor
        // with "tolerance too tight, a singularity, ..."): where the span left is under 2^20 such spacings, time
        // itself is what stops the run, and the failure says so. (Elsewhere such a step is the controller's, as
        // with a tolerance too tight: rejected, then the floor's failure names the component.)
        if (!landing && t_ + dir_ * dt == t_ &&
            std::abs(std::nextafter(t_, dir_ * HUGE_VAL) - t_) * 0x1p20 > std::abs(target_ - t_))
            throw adaptive_failure(adaptive_failure::reason::time_unresolved, t_, 0, dir_ * dt, stats_);
        if (stats_.accepted + stats_.rejected() >= o_.max_attempts)
            throw adaptive_failure(adaptive_failure::reason::too_many_steps, t_, 0, dir_ * dt, stats_);
        return {dt, landing};
    }

    attempt_result attempt(const adaptive_attempt& a, position) {
        return attempt_checked(st_, f_, std::as_const(x_), t_, dir_ * a.dt, &w_, false, rate_failed_);
    }

    static bool acceptable(const attempt_result& r) { return r.ok && std::isfinite(r.error) && r.error <= 1.0; }

    bool accept(const adaptive_attempt& a, const attempt_result& r, position) {
        const double dt = a.dt;
        st_.accept(x_);
        t_prev_ = t_;
        t_ = a.landing ? target_ : t_ + dir_ * dt;
        ++stats_.accepted;
        stats_.dt_smallest = std::min(stats_.dt_smallest, dt);
        stats_.dt_largest = std::max(stats_.dt_largest, dt);
        double factor = o_.safety * std::pow(std::max(r.error, 1e-10), -1.0 / q1);
        if (o_.pi_control) {
            const double alpha = 1.0 / q1 - 0.75 * o_.pi_beta;
            factor = o_.safety * std::pow(std::max(r.error, 1e-10), -alpha) *
                     std::pow(std::max(previous_error_, 1e-4), o_.pi_beta);
        }
        factor = std::clamp(factor, o_.min_factor, just_rejected_ ? 1.0 : o_.max_factor);
        previous_error_ = r.error;
        just_rejected_ = false;
        // A step cut short to land keeps the controller's proposal for the next one.
        dt_ = a.landing && dt < dt_ ? std::max(dt_, dt * factor) : dt * factor;
        dt_ = std::max(dt_, o_.dt_min);  // below it only a rejection goes, and that stops the run
        return true;
    }

    void reject(const adaptive_attempt& a, const attempt_result& r, position) {
        const double dt = a.dt;
        const bool finite = r.ok && std::isfinite(r.error);
        if (!r.ok) {
            ++stats_.rejected_radicand;
            last_ = rejection::step_failed;
            dt_ = dt * o_.radicand_factor;
        } else if (!finite) {
            ++stats_.rejected_radicand;  // a non-finite error: the state or f blew up, as for a radicand
            if (rate_failed_) ++stats_.rejected_non_finite_rate;
            last_ = rate_failed_ ? rejection::non_finite_rate : rejection::step_failed;
            dt_ = dt * o_.min_factor;
        } else {
            ++stats_.rejected_error;
            last_ = rejection::error_estimate;
            dt_ = dt * std::max(o_.min_factor, o_.safety * std::pow(r.error, -1.0 / q1));
        }
        just_rejected_ = true;
        // The default floor is the resolution of time where the run is, 64 eps |t| (not of the end time: a
        // long horizon must not stop a run early), and never below 2^-30 of the span left (a run at t = 0), that
        // span counted as at most 2^60 first steps: a run to t = 1e30 waiting for a terminal event (SciPy's idiom
        // with t_bound = inf) had a floor of 1e7 and stopped at its first rejected step. (A span of more than 2^60
        // first steps cannot be stepped through at that size anyway.)
        const double dt_min =
            o_.dt_min > 0.0 ? o_.dt_min
                            : 64.0 * std::numeric_limits<double>::epsilon() *
                                  std::max({std::abs(t_), 0x1p-30 * std::min(dir_ * (target_ - t_), 0x1p60 * first_dt_),
                                            std::numeric_limits<double>::min()});
        if (dt_ < dt_min) {
            std::size_t component = r.component;
            if (r.ok && !rate_failed_) {
                bool again = false;
                component = attempt_checked(st_, f_, std::as_const(x_), t_, dir_ * dt, &w_, true, again).component;
            }
            st_.reset();
            adaptive_failure e(adaptive_failure::reason::step_too_small, t_, component, dir_ * dt_, stats_);
            e.last_rejection = last_;
            throw e;
        }
    }

   private:
    static constexpr double q1 = double(St::embedded_order + 1);

    St& st_;
    F& f_;
    S& x_;
    double t_, dt_;
    double first_dt_;  // the first step's size (bounds the span the floor near t = 0 is taken from)
    const adaptive_options& o_;
    adaptive_stats& stats_;
    std::vector<double> rtol_, atol_;
    error_weights w_{};
    double previous_error_ = 1.0;
    bool just_rejected_ = false;
    rejection last_ = rejection::error_estimate;
    bool rate_failed_ = false;  // the last attempt failed on a non-finite rate
    double target_ = 0.0, dir_ = 1.0, t_prev_ = 0.0;
    bool forward_ = true;
};

/// Whether b is at or beyond a in the direction of the run (forward: b >= a).
inline bool reached(double a, double b, bool forward) { return forward ? b >= a : b <= a; }

template <class F, class S>
void check_run(const S& x, double t0, double t_end, double dt0, const adaptive_options& o) {
    if (!std::isfinite(t0) || !std::isfinite(t_end)) throw std::invalid_argument("end time must be finite");
    if (!(dt0 > 0.0) || !std::isfinite(dt0)) throw std::invalid_argument("initial step must be a positive finite number");
    check_options(o, std::ranges::size(x));
}

/// The dense-output half of integrate_adaptive_at: interpolate every output time inside each accepted step.
template <class St, class F, class S, class Loop, class Observer, class Emit>
void dense_run(St& stepper, F& counted, S& x, const std::vector<double>& times, Loop& loop, std::size_t& next,
               Observer& observe, Emit& emit_until, adaptive_stats& stats, bool forward) {
    S scratch{}, start{};
    St fallback{};
    loop.advance(times.back(), [&](double t_prev, double t_new) {
        if (next >= times.size() || reached(t_new, times[next], forward)) return emit_until(t_new);
        stepper.prepare_dense(counted, std::as_const(x), t_new);
        const double h = t_new - t_prev;
        while (next < times.size() && !reached(t_new, times[next], forward)) {
            const double theta = (times[next] - t_prev) / h;
            if (stepper.interpolate(std::as_const(x), theta, scratch)) {
                ++stats.dense_points;
            } else {
                // The interpolated xi went negative: land a step from the step's start instead.
                ++stats.dense_fallbacks;
                start = stepper.step_start();
                fallback.reset();
                if (forward) {
                    integrate_to(fallback, counted, start, t_prev, times[next], times[next] - t_prev);
                } else {  // integrate_to runs forward only; the same one step with halving, backward
                    run_stats ignored;  // its evaluations are counted by `counted`
                    advance_with_reduction(fallback, counted, start, t_prev, times[next] - t_prev, run_options{},
                                           ignored);
                }
                scratch = start;
            }
            detail::notify(observe, std::as_const(scratch), times[next], next);
            ++next;
        }
        emit_until(t_new);
    });
}

}  // namespace detail

/// Integrate x from t0 to t_end (forward, or backward if t_end < t0) with adaptive steps starting from dt0 (a
/// size). The observer sees (x, t) (or (x, t, i)) at t0 and after every accepted step; the last step lands on t_end. Throws adaptive_failure if the step falls
/// below options.dt_min or the run exceeds options.max_attempts.
template <state S, system<S> F, class St, class Observer = no_observer>
    requires adaptive_stepper<St, F, S>
adaptive_stats integrate_adaptive(St& stepper, F&& f, S& x, double t0, double t_end, double dt0,
                                  const adaptive_options& options = {}, Observer&& observe = {}) {
    detail::check_run<F>(x, t0, t_end, dt0, options);
    detail::attach_quadratic_invariants(stepper, f, x);
    adaptive_stats stats;
    const detail::counted_system<std::remove_reference_t<F>> counted{&f, &stats.rhs_evals};
    detail::error_control loop(stepper, counted, x, t0, dt0, options, stats);
    detail::notify(observe, std::as_const(x), t0, 0);
    loop.advance(t_end, [&](double, double t) { detail::notify(observe, std::as_const(x), t, stats.accepted); });
    return stats;
}

/// Integrate x from t0 through the output times `times` (increasing and >= t0, or for a backward run decreasing
/// and <= t0), calling the observer at each with the state there, by landing steps on them or by dense output. x
/// ends at the last time. The direction is that of times.back() from t0.
template <state S, system<S> F, class St, class Observer>
    requires adaptive_stepper<St, F, S>
adaptive_stats integrate_adaptive_at(St& stepper, F&& f, S& x, double t0, const std::vector<double>& times,
                                     double dt0, const adaptive_options& options, Observer&& observe,
                                     output_mode mode = output_mode::automatic) {
    const double t_end = times.empty() ? t0 : times.back();
    detail::check_run<F>(x, t0, t_end, dt0, options);
    const bool forward = !(t_end < t0);
    for (std::size_t i = 0; i < times.size(); ++i)
        if (!std::isfinite(times[i]) || !detail::reached(t0, times[i], forward) ||
            (i > 0 && !detail::reached(times[i - 1], times[i], forward)))
            throw std::invalid_argument(forward ? "output times must be finite, >= the start time and non-decreasing"
                                                : "output times of a backward run must be finite, <= the start time "
                                                  "and non-increasing");
    detail::attach_quadratic_invariants(stepper, f, x);
    adaptive_stats stats;
    const detail::counted_system<std::remove_reference_t<F>> counted{&f, &stats.rhs_evals};
    detail::error_control loop(stepper, counted, x, t0, dt0, options, stats);
    std::size_t next = 0;
    auto emit_until = [&](double t) {  // outputs at or before the current time t that equal it
        while (next < times.size() && detail::reached(times[next], t, forward)) {
            detail::notify(observe, std::as_const(x), times[next], next);
            ++next;
        }
    };
    emit_until(t0);
    if (times.empty()) return stats;
    constexpr bool has_dense = requires(const St& c, St& m, const S& y, S& out, double th) {
        { c.interpolate(y, th, out) } -> std::same_as<step_result>;
        m.prepare_dense(counted, y, th);
        c.step_start();
    };
    if (mode == output_mode::automatic) {
        if constexpr (has_dense && requires { St::dense_matches_steps; }) {
            mode = St::dense_matches_steps ? output_mode::dense : output_mode::landing;
        } else {
            mode = output_mode::landing;
        }
    }
    if (mode == output_mode::dense && !has_dense) throw std::invalid_argument("this stepper has no dense output");
    if (mode == output_mode::landing || !has_dense) {
        while (next < times.size()) {
            loop.advance(times[next], [](double, double) {});
            ++stats.landed_points;
            emit_until(times[next]);
        }
        return stats;
    }
    if constexpr (has_dense)
        detail::dense_run(stepper, counted, x, times, loop, next, observe, emit_until, stats, forward);
    return stats;
}


/// Whether adaptive stepper St has a dense output on states S (prepare_dense / interpolate / step_start).
template <class St, class F, class S>
concept dense_stepper = requires(const St& c, St& m, F& f, const S& y, S& out, double th) {
    { c.interpolate(y, th, out) } -> std::same_as<step_result>;
    m.prepare_dense(f, y, th);
    c.step_start();
};

/// The step an adaptive run has just accepted, as integrate_adaptive_steps shows it: its two ends and its dense
/// output anywhere between them (valid only during the call that shows it).
template <class St, class F, class S>
class accepted_step {
   public:
    using stepper_type = St;
    accepted_step(St& st, F& f, const S& x, double t_start, double t_end, adaptive_stats& stats)
        : st_(st), f_(f), x_(x), t_start_(t_start), t_end_(t_end), stats_(stats) {}
    double t_start() const { return t_start_; }
    double t_end() const { return t_end_; }
    const S& start_state() const { return st_.step_start(); }
    const S& end_state() const { return x_; }
    /// The state at time t of the step (between its ends, either direction): the ends themselves, else the
    /// stepper's dense output (for a conservative pair the interpolant of xi that keeps every invariant); where
    /// that interpolant fails (a negative interpolated xi) a step from the step's start lands on t instead. With
    /// `conventional`, also the conventional interpolant whose sign a conservative one takes (else: out itself).
    void at(double t, S& out, S* conventional = nullptr) {
        if (t == t_end_ || t == t_start_) {
            out = t == t_end_ ? x_ : st_.step_start();
            if (conventional) *conventional = out;
            return;
        }
        if (!prepared_) st_.prepare_dense(f_, x_, t_end_);
        prepared_ = true;
        const double theta = (t - t_start_) / (t_end_ - t_start_);
        bool ok = false;
        if constexpr (requires { st_.interpolate(x_, theta, out, conventional); }) {
            ok = bool(st_.interpolate(x_, theta, out, conventional));
        } else {  // the transformed engine: its interpolant of xi, inverted
            ok = bool(st_.interpolate(x_, theta, out));
            if (conventional) *conventional = out;
        }
        if (ok) {
            ++stats_.dense_points;
            return;
        }
        ++stats_.dense_fallbacks;
        out = st_.step_start();
        St fallback{};
        run_stats ignored;  // its evaluations are counted by f_
        detail::advance_with_reduction(fallback, f_, out, t_start_, t - t_start_, run_options{}, ignored);
        if (conventional) *conventional = out;
    }

   private:
    St& st_;
    F& f_;
    const S& x_;
    double t_start_, t_end_;
    adaptive_stats& stats_;
    bool prepared_ = false;
};

namespace detail {
struct stop_requested {};
}  // namespace detail

/// Integrate x from t0 to t_end (either direction) with adaptive steps, showing every accepted step with its
/// dense output to on_step(accepted_step&), which returns the time within that step at which the run is to stop
/// (an event), or std::nullopt to go on. x ends at t_end, or at that time (the dense output there). The run's
/// first state is not shown: the caller has it.
template <state S, system<S> F, class St, class OnStep>
    requires adaptive_stepper<St, F, S>
adaptive_stats integrate_adaptive_steps(St& stepper, F&& f, S& x, double t0, double t_end, double dt0,
                                        const adaptive_options& options, OnStep&& on_step) {
    detail::check_run<F>(x, t0, t_end, dt0, options);
    detail::attach_quadratic_invariants(stepper, f, x);
    adaptive_stats stats;
    using counted_t = const detail::counted_system<std::remove_reference_t<F>>;
    counted_t counted{&f, &stats.rhs_evals};
    static_assert(dense_stepper<St, counted_t, S>, "integrate_adaptive_steps needs a stepper with dense output");
    detail::error_control loop(stepper, counted, x, t0, dt0, options, stats);
    S stop_state{};
    try {
        loop.advance(t_end, [&](double t_prev, double t_new) {
            accepted_step<St, counted_t, S> step(stepper, counted, std::as_const(x), t_prev, t_new, stats);
            const std::optional<double> t_stop = on_step(step);
            if (!t_stop) return;
            step.at(*t_stop, stop_state);
            throw detail::stop_requested{};
        });
    } catch (const detail::stop_requested&) {
        x = stop_state;
    }
    return stats;
}


namespace detail {

template <class E>
concept embedded_method = tableau_method<E> && embedded_pair<std::remove_cvref_t<decltype(E::tableau)>>;

// The adaptive stepper of registry entry E on model M: the embedded engine, conventional or conservative, or the
// transformed one on a model with a linearizing transform; `unsupported` for a method without an error estimate.
template <class E, class M>
constexpr auto resolve_adaptive() {
    using S = typename M::state_type;
    if constexpr (!embedded_method<E> || records_stages<M>)  // (stage hooks: fixed steps only)
        return type_is<unsupported>{};
    else if constexpr (E::info.family == method_family::conventional)
        return type_is<embedded_rk<E::tableau, S, update_rule::conventional>>{};
    else if constexpr (linearizable<M>)
        return type_is<transformed_embedded_rk<E::tableau, transform_t<M>>>{};
    else if constexpr (quadratic_invariants<M>)
        return type_is<embedded_rk<E::tableau, S, update_rule::conservative>>{};
    else
        return type_is<unsupported>{};
}

}  // namespace detail

/// The adaptive stepper of registry entry E on model M (or a state type), or detail::unsupported.
template <class E, class M>
using adaptive_stepper_for = typename decltype(detail::resolve_adaptive<E, typename detail::as_model<M>::type>())::type;

/// Whether method entry E runs adaptively (an embedded pair) on model M (or on a plain system on state type M).
template <class E, class M>
inline constexpr bool adaptive_runs_on = !std::same_as<adaptive_stepper_for<E, M>, detail::unsupported>;

namespace detail {
template <class M, class Fn, class... E>
bool dispatch_adaptive(std::string_view name, Fn& fn, type_list<E...>) {
    auto try_one = [&]<class Entry>(Entry*) {
        if constexpr (!std::same_as<adaptive_stepper_for<Entry, M>, unsupported>) {
            if (Entry::info.name != name) return false;
            fn(adaptive_stepper_for<Entry, M>{});
            return true;
        } else {
            return false;
        }
    };
    return (try_one(static_cast<E*>(nullptr)) || ...);
}
template <class M, class... E>
std::vector<method_info> adaptive_methods(type_list<E...>) {
    std::vector<method_info> out;
    ((!std::same_as<adaptive_stepper_for<E, M>, unsupported> ? out.push_back(E::info) : void()), ...);
    return out;
}
}  // namespace detail

/// Calls fn(stepper) with the adaptive stepper of the registered method `name` on Model and returns true; false
/// if that method has no error estimate (is not an embedded pair) or does not run on Model.
template <class Model, class Fn>
bool with_adaptive_stepper(std::string_view name, Fn&& fn) {
    return detail::dispatch_adaptive<typename detail::as_model<Model>::type>(name, fn, method_entry_list{});
}

/// The registered methods that run adaptively on Model, in list order.
template <class Model>
std::vector<method_info> adaptive_methods_for() {
    return detail::adaptive_methods<typename detail::as_model<Model>::type>(method_entry_list{});
}

/// A first step and what choosing it cost.
struct first_step_choice {
    double dt = 0.0;             ///< the step's size (> 0; the run goes in the direction of its span)
    std::uint64_t rhs_evals = 0; ///< evaluations of f the rule made (0, 1 or 2)
};

/// The first step of an adaptive run from (t0, x) toward t_end for a method of order `order`, by Hairer, Norsett
/// & Wanner's rule (I, II.4; SciPy's select_initial_step): the step whose error, estimated from f at x and after a
/// small Euler step (backward for t_end < t0), is about the tolerance, with scale_i = atol_i + rtol_i |x_i| (the
/// per-element tolerances where given). Two evaluations of f at most. Edge cases, each a step the run can take
/// and then report on: an empty span gives 1, an empty state the span, a zero scale or a non-finite rate at x
/// (a value, or eci::non_finite_rate) 1e-6 of the span, a non-finite rate after the Euler step that step's size,
/// and a step that underflows (a tolerance like 1e-300) the smallest positive double. The root mean squares are
/// overflow-safe (scaled by the largest entry when the squares overflow). Never larger than the span.
template <state S, system<S> F>
first_step_choice choose_first_step(F&& f, const S& x, double t0, double t_end, int order, const adaptive_options& o) {
    detail::require_one_process(f, "adaptive step control and its first-step rule");
    check_adaptive_options(o, std::ranges::size(x));
    first_step_choice out;
    const double span = std::abs(t_end - t0);
    const double direction = t_end >= t0 ? 1.0 : -1.0;
    if (span == 0.0) return out.dt = 1.0, out;
    const std::size_t n = std::ranges::size(x);
    if (n == 0) return out.dt = span, out;
    const double fallback = 1e-6 * span;
    const double smallest = std::numeric_limits<double>::denorm_min();
    std::vector<double> scale(n), v(n);
    for (std::size_t i = 0; i < n; ++i) {
        const double rtol = o.rtol_each.empty() ? o.rtol : o.rtol_each[i];
        const double atol = o.atol_each.empty() ? o.atol : o.atol_each[i];
        scale[i] = atol + rtol * std::abs(x[i]);
        if (scale[i] == 0.0) return out.dt = fallback, out;
    }
    // The root mean square of |y_i| / scale_i; scaled by the largest entry if the squares overflow.
    auto rms = [&](auto&& element) {
        double sum = 0.0, top = 0.0;
        for (std::size_t i = 0; i < n; ++i) {
            v[i] = std::abs(element(i)) / scale[i];
            sum += v[i] * v[i];
        }
        const double plain = std::sqrt(sum / double(n));
        if (std::isfinite(plain)) return plain;
        for (std::size_t i = 0; i < n; ++i) top = std::max(top, v[i]);
        if (!std::isfinite(top)) return top;
        sum = 0.0;
        for (std::size_t i = 0; i < n; ++i) sum += (v[i] / top) * (v[i] / top);
        return top * std::sqrt(sum / double(n));
    };
    // f at (t, y), or false if its rate is not finite.
    auto evaluate = [&](double t, const S& y, S& dydt) {
        ++out.rhs_evals;
        try {
            f(y, dydt, t);
        } catch (const non_finite_rate&) {
            return false;
        }
        return detail::all_finite(dydt);
    };
    S f0 = x, f1 = x, y1 = x;
    if (!evaluate(t0, x, f0)) return out.dt = fallback, out;
    const double d0 = rms([&](std::size_t i) { return x[i]; });
    const double d1 = rms([&](std::size_t i) { return f0[i]; });
    double h0 = d0 < 1e-5 || d1 < 1e-5 ? 1e-6 : 0.01 * d0 / d1;
    h0 = std::min(h0, span);
    if (!(h0 > 0.0)) return out.dt = smallest, out;  // f / scale beyond the largest double
    for (std::size_t i = 0; i < n; ++i) y1[i] = x[i] + direction * h0 * f0[i];
    if (!evaluate(t0 + direction * h0, y1, f1)) return out.dt = std::min(h0, span), out;
    const double d2 = rms([&](std::size_t i) { return f1[i] - f0[i]; }) / h0;
    const double h1 = std::max(d1, d2) <= 1e-15 ? std::max(1e-6, 1e-3 * h0)
                                                : std::pow(0.01 / std::max(d1, d2), 1.0 / double(order + 1));
    const double h = std::min({100.0 * h0, h1, span});
    // a tolerance so tight that the rule's step underflows: the smallest step, and the run says what is wrong
    out.dt = h > 0.0 && std::isfinite(h) ? h : smallest;
    return out;
}

}  // namespace eci
