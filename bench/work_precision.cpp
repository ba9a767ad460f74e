// Work-precision data: error at a fixed end time (against an exact or reference solution) and invariant error,
// against right-hand-side evaluations and CPU time, for eci's methods, the implicit midpoint rule and odeint's
// adaptive Dormand-Prince. Usage: eci_bench_work_precision <quick: 0|1> <csv file>; prints a summary per model.
#include <time.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include <eci/eci.hpp>
#include <eci/models/three_wave.hpp>
#include <eci/models/three_wave_exact.hpp>

#include <eci/models/kepler.hpp>
#include <eci/models/kepler_exact.hpp>
#include <eci/models/lotka_volterra.hpp>

#include "bench_common.hpp"

namespace {

using namespace eci::bench;

double cpu_seconds() {
    timespec ts{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

/// One model's test: initial state, end time, the solution there, and how to measure invariants.
template <class Model>
struct wp_problem {
    std::string name;
    Model model;
    typename Model::state_type x0;
    double t_end;
    typename Model::state_type reference;
};

struct wp_point {
    std::string method;
    double param;  // dt for fixed-step methods, tolerance for adaptive ones
    std::uint64_t rhs_evals;
    double cpu;  // seconds per run
    double state_error, invariant_error;
};

template <class Model>
double relative_state_error(const wp_problem<Model>& p, const typename Model::state_type& x) {
    double d = 0, r = 0;
    for (std::size_t i = 0; i < x.size(); ++i) {
        d += (x[i] - p.reference[i]) * (x[i] - p.reference[i]);
        r += p.reference[i] * p.reference[i];
    }
    return std::sqrt(d / r);
}

// Each invariant's change relative to its initial value, or to the largest initial invariant where its own
// is zero (Kepler's A_y on an orbit starting on the x axis); the worst of them.
template <class Model>
double relative_invariant_error(const wp_problem<Model>& p, const typename Model::state_type& x) {
    eci::invariant_monitor<Model> monitor(p.model);
    monitor.record(p.x0);
    monitor.record(x);
    double scale = 0, worst = 0;
    for (const auto& r : monitor.records()) scale = std::max(scale, std::abs(r.initial));
    for (const auto& r : monitor.records())
        worst = std::max(worst, std::abs(r.final - r.initial) / (r.initial != 0.0 ? std::abs(r.initial) : scale));
    return worst;
}

/// Time `run(x)` (which integrates x from x0 to t_end and returns its RHS count) over enough repetitions to
/// measure CPU time above the clock's resolution; the state error is that of the first run.
template <class Model, class Run>
wp_point measure(const wp_problem<Model>& p, const std::string& method, double param, Run run, double min_cpu) {
    auto x = p.x0;
    std::uint64_t evals = 0;
    int reps = 0;
    const double start = cpu_seconds();
    double elapsed = 0;
    wp_point pt{method, param, 0, 0, 0, 0};
    do {
        x = p.x0;
        evals = run(x);
        if (reps == 0) {
            pt.rhs_evals = evals;
            pt.state_error = relative_state_error(p, x);
            pt.invariant_error = relative_invariant_error(p, x);
        }
        ++reps;
        elapsed = cpu_seconds() - start;
    } while (elapsed < min_cpu);
    pt.cpu = elapsed / reps;
    return pt;
}

/// Registry method E on problem p, dt = t_end / 2^e for e from min_exp to max_exp.
template <class E, class Model>
void sweep_fixed(const wp_problem<Model>& p, int min_exp, int max_exp, double min_cpu, std::vector<wp_point>& out) {
    using Stepper = eci::stepper_for<E, Model>;
    for (int e = min_exp; e <= max_exp; ++e) {
        const double dt = p.t_end / std::ldexp(1.0, e);
        auto run = [&](typename Model::state_type& x) {
            Stepper stepper;
            try {
                return eci::integrate_to(stepper, p.model, x, 0.0, p.t_end, dt).rhs_evals;
            } catch (const eci::step_size_underflow&) {
                for (auto& v : x) v = std::numeric_limits<double>::quiet_NaN();
                return std::uint64_t{0};
            }
        };
        const wp_point pt = measure(p, eci::identifier(E::info.name), dt, run, min_cpu);
        if (std::isfinite(pt.state_error) && pt.state_error < 1.0) out.push_back(pt);
    }
}

template <class Model>
void sweep_dopri5(const wp_problem<Model>& p, bool dense, double min_cpu, std::vector<wp_point>& out) {
    using S = typename Model::state_type;
    for (int e = 3; e <= 13; ++e) {
        const double tol = std::pow(10.0, -e);
        auto run = [&](S& x) {
            std::uint64_t count = 0;
            counted_rhs<Model> f{&p.model, &count};
            if (dense)
                odeint::integrate_adaptive(odeint::make_dense_output(tol, tol, odeint::runge_kutta_dopri5<S>()), f, x,
                                           0.0, p.t_end, 1e-3);
            else
                odeint::integrate_adaptive(odeint::make_controlled(tol, tol, odeint::runge_kutta_dopri5<S>()), f, x,
                                           0.0, p.t_end, 1e-3);
            return count;
        };
        out.push_back(measure(p, dense ? "dopri5_dense" : "dopri5", tol, run, min_cpu));
    }
}

/// Every method on one problem, as registry entries (each labelled eci::identifier(name)): the registry picks
/// its stepper on the model, so C-PC and C-RK4 run through the transform (50) or (39) on Kepler and
/// Lotka-Volterra (§IV, §V) and on psi^2 on the three-wave model. `extra` shifts the fixed-step ranges to suit
/// the model's time scale.
template <class Model>
std::vector<wp_point> run_all(const wp_problem<Model>& p, bool quick, int extra) {
    namespace me = eci::method_entries;
    const double min_cpu = quick ? 0.002 : 0.02;
    const int q = quick ? 3 : 0;  // quick runs skip the finest steps
    std::vector<wp_point> pts;
    sweep_fixed<me::euler>(p, 6 + extra, 20 + extra - q, min_cpu, pts);
    sweep_fixed<me::pc>(p, 5 + extra, 18 + extra - q, min_cpu, pts);
    sweep_fixed<me::c_pc>(p, 5 + extra, 18 + extra - q, min_cpu, pts);
    sweep_fixed<me::rk4>(p, 4 + extra, 14 + extra - q, min_cpu, pts);
    sweep_fixed<me::c_rk4>(p, 4 + extra, 14 + extra - q, min_cpu, pts);
    sweep_fixed<me::implicit_midpoint>(p, 5 + extra, 18 + extra - q, min_cpu, pts);
    sweep_dopri5(p, false, min_cpu, pts);
    sweep_dopri5(p, true, min_cpu, pts);
    return pts;
}

// The cheapest run of each method reaching a state error of at most `target`.
void summarise(const std::string& model, const std::vector<wp_point>& pts, double target) {
    std::vector<std::string> methods;
    for (const auto& p : pts)
        if (std::find(methods.begin(), methods.end(), p.method) == methods.end()) methods.push_back(p.method);
    for (const auto& m : methods) {
        const wp_point* best = nullptr;
        for (const auto& p : pts)
            if (p.method == m && p.state_error <= target && (!best || p.cpu < best->cpu)) best = &p;
        if (best)
            std::printf("wp model=%s target=%.0e method=%s rhs_evals=%llu cpu_us=%.2f param=%.3g state_error=%.2e "
                        "invariant_error=%.2e\n",
                        model.c_str(), target, m.c_str(), static_cast<unsigned long long>(best->rhs_evals),
                        1e6 * best->cpu, best->param, best->state_error, best->invariant_error);
        else
            std::printf("wp model=%s target=%.0e method=%s unreached\n", model.c_str(), target, m.c_str());
    }
}

template <class Model>
void emit(std::FILE* csv, const wp_problem<Model>& p, bool quick, int extra) {
    const auto pts = run_all(p, quick, extra);
    for (const auto& pt : pts)
        std::fprintf(csv, "%s,%s,%.6e,%llu,%.6e,%.6e,%.6e\n", p.name.c_str(), pt.method.c_str(), pt.param,
                     static_cast<unsigned long long>(pt.rhs_evals), pt.cpu, pt.state_error, pt.invariant_error);
    summarise(p.name, pts, 1e-4);
    summarise(p.name, pts, 1e-8);
}

}  // namespace

int main(int argc, char** argv) {
    if (argc != 3 || (std::string(argv[1]) != "0" && std::string(argv[1]) != "1")) {
        std::fprintf(stderr, "usage: eci_bench_work_precision <quick: 0|1> <csv file>\n");
        return 2;
    }
    const bool quick = argv[1][0] == '1';
    std::FILE* csv = std::fopen(argv[2], "w");
    if (!csv) {
        std::fprintf(stderr, "eci_bench_work_precision: cannot write %s\n", argv[2]);
        return 2;
    }
    std::fprintf(csv, "model,method,param,rhs_evals,cpu_seconds,state_error,invariant_error\n");

    // Three-wave, the paper's Fig. 5 initial condition, to t = 20 (a few periods), against the exact solution.
    const auto fig5 = eci::find_preset<eci::three_wave>("fig5");
    wp_problem<eci::three_wave> tw{"three_wave", fig5.model, fig5.x0, 20.0, {}};
    tw.reference = eci::three_wave_exact(tw.model, tw.x0)(tw.t_end);
    emit(csv, tw, quick, 0);

    // Lotka-Volterra, the paper's Fig. 7 setup (mu = 1.5, x = 1, y = 0.4), to t = 20 (about three cycles); no
    // closed form, so the reference is RK4 with 2^20 steps (truncation error ~1e-17, below its round-off).
    const auto fig7 = eci::find_preset<eci::lotka_volterra>("fig7");
    wp_problem<eci::lotka_volterra> lv{"lotka_volterra", fig7.model, fig7.x0, 20.0, {}};
    {
        auto x = lv.x0;
        eci::rk4<eci::lotka_volterra::state_type> ref;
        eci::integrate_n_steps(ref, lv.model, x, 0.0, lv.t_end / 1048576.0, 1048576);
        lv.reference = x;
    }
    emit(csv, lv, quick, 0);

    // Kepler, the paper's Figs. 8-9 orbit (r = 1, v_r = theta = 0, ell = 1, K = 3/2, m = 1: e = 1/3, period 3.33),
    // to t = 10 (three orbits), against the exact solution (Kepler's equation).
    const auto fig9 = eci::find_preset<eci::kepler>("fig9");
    wp_problem<eci::kepler> kp{"kepler", fig9.model, fig9.x0, 10.0, {}};
    kp.reference = eci::kepler_exact(kp.model, kp.x0)(kp.t_end);
    emit(csv, kp, quick, 0);
    std::fclose(csv);
    return 0;
}
