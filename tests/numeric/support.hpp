// Shared helpers of the numeric tests: method tags and typed lists from the registry, invariant drift over a run, and least-squares slopes.
// Every tolerance built from these is a multiple of machine epsilon, with its reason stated where it is used.
#pragma once

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include <gtest/gtest.h>

#include <eci/eci.hpp>

namespace eci::test {

/// Machine epsilon of double.
inline constexpr double eps = std::numeric_limits<double>::epsilon();

/// A registry entry as a test tag: its stepper on a plain system of state S (`stepper<S>`) and its registry name.
template <class Entry>
struct method_tag {
    using entry = Entry;  ///< the registry entry (its info, its tableau if it has one)
    template <class S>
    using stepper = eci::stepper_for<Entry, S>;
    static constexpr const char* name = Entry::info.name.data();  // a string literal: null-terminated
};

using euler_m = method_tag<eci::method_entries::euler>;
using pc_m = method_tag<eci::method_entries::pc>;
using rk2_m = method_tag<eci::method_entries::rk2>;
using rk4_m = method_tag<eci::method_entries::rk4>;
using c_euler_m = method_tag<eci::method_entries::c_euler>;
using c_pc_m = method_tag<eci::method_entries::c_pc>;
using c_rk2_m = method_tag<eci::method_entries::c_rk2>;
using c_rk4_m = method_tag<eci::method_entries::c_rk4>;

/// Registry entries that run on any state (every method but the model-specific ones).
template <class E>
struct runs_on_any_state : std::bool_constant<eci::runs_on<E, std::vector<double>>> {};
/// Registry entries of the conservative family that run on any state.
template <class E>
struct conservative_on_any_state
    : std::bool_constant<eci::runs_on<E, std::vector<double>> && E::info.family == eci::method_family::conservative> {};

template <class List>
struct as_test_types;
template <class... E>
struct as_test_types<eci::detail::type_list<E...>> {
    using type = ::testing::Types<method_tag<E>...>;
};

/// The typed-test lists, derived from the registry: a method added there is tested here without a line changed.
using registry_methods_on_any_state =
    as_test_types<eci::detail::filter<runs_on_any_state, eci::method_entry_list>::type>::type;
using registry_conservative_methods_on_any_state =
    as_test_types<eci::detail::filter<conservative_on_any_state, eci::method_entry_list>::type>::type;

/// The largest relative change of a model's energy and enstrophy seen over a run, and the run's statistics.
struct drift_result {
    double energy = 0.0;
    double enstrophy = 0.0;
    run_stats stats{};
    double worst() const { return std::max(energy, enstrophy); }
};

/// |I - I0| / I0, with NaN (a blown-up run) mapped to infinity so that comparisons stay meaningful.
inline double relative_change(double value, double initial) {
    const double r = std::abs(value - initial) / std::abs(initial);
    return std::isnan(r) ? std::numeric_limits<double>::infinity() : r;
}

/// The record of the invariant called `name` in a run's report (fails the test if there is none).
inline const invariant_record& record_of(const solve_report& report, std::string_view name) {
    for (const invariant_record& r : report.invariants)
        if (r.name == name) return r;
    ADD_FAILURE() << "no invariant called " << name;
    static const invariant_record none{};
    return none;
}

/// A record's largest relative drift, NaN (a blown-up run) counted as infinite.
inline double worst_relative(const invariant_record& r) {
    const double d = r.max_rel_drift();
    return std::isnan(d) ? std::numeric_limits<double>::infinity() : d;
}

/// Run `steps` steps of Method from x0 and record the worst relative drift of E and Z, monitored every step
/// (eci::run); a run that underflows has conserved nothing and reports infinite drifts.
template <class Method, class Model>
drift_result measure_drift(const Model& model, typename Model::state_type x, double dt, std::uint64_t steps) {
    typename Method::template stepper<typename Model::state_type> st;
    const solve_report rep = eci::run(st, model, x, run_span::n_steps(steps, dt));
    drift_result r;
    if (!rep.completed()) {
        // Only the conservative methods can fail a step; such a run has not conserved anything.
        r.energy = r.enstrophy = std::numeric_limits<double>::infinity();
        return r;
    }
    r.stats = rep.stats;
    r.energy = worst_relative(record_of(rep, "energy"));
    r.enstrophy = worst_relative(record_of(rep, "enstrophy"));
    return r;
}

/// Least-squares slope of log(y) against log(x).
inline double log_log_slope(const std::vector<double>& x, const std::vector<double>& y) {
    const std::size_t n = x.size();
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    for (std::size_t i = 0; i < n; ++i) {
        const double lx = std::log(x[i]), ly = std::log(y[i]);
        sx += lx, sy += ly, sxx += lx * lx, sxy += lx * ly;
    }
    return (double(n) * sxy - sx * sy) / (double(n) * sxx - sx * sx);
}

/// n points spaced evenly in log between lo and hi.
inline std::vector<double> log_space(double lo, double hi, std::size_t n) {
    std::vector<double> v(n);
    for (std::size_t i = 0; i < n; ++i) v[i] = lo * std::pow(hi / lo, double(i) / double(n - 1));
    return v;
}

/// GoogleTest name generator for typed tests over method tags: the method's registry name, '-' made '_'.
struct method_names {
    template <class Method>
    static std::string GetName(int) {
        std::string s = Method::name;
        for (char& c : s) c = c == '-' ? '_' : c;
        return s;
    }
};

/// sum_k w_k |x_k|^2 with Neumaier's compensated summation: the measurement itself adds about one eps, not the
/// sqrt(N) eps of a plain sum over 10^4 terms, so bounds on an invariant's drift test the stepper, not the sum.
template <class S>
double weighted_square_sum(const S& x, const std::vector<double>& w) {
    double s = 0.0, c = 0.0;
    for (std::size_t i = 0; i < x.size(); ++i) {
        const double v = w[i] * std::norm(x[i]), t = s + v;
        c += std::abs(s) >= std::abs(v) ? (s - t) + v : (v - t) + s;
        s = t;
    }
    return s + c;
}

}  // namespace eci::test
