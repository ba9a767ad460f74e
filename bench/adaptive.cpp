// Adaptive methods against Boost.Odeint: work-precision (end-time error and invariant error against
// RHS evaluations and CPU time) on four models, per-step cost C-DP54 / DP54 on a large n-wave system, and the
// long-run round-off of compensated xi. Usage:
//   eci_bench_adaptive <quick 0|1> <csv file> [cost modes N, 0 = skip] [long-run steps, 0 = skip]
#include <time.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include <eci/adaptive.hpp>
#include <eci/models/kepler.hpp>
#include <eci/models/kepler_exact.hpp>
#include <eci/models/lotka_volterra.hpp>
#include <eci/models/n_wave.hpp>
#include <eci/models/three_wave.hpp>
#include <eci/models/three_wave_exact.hpp>
#include <eci/steppers/transformed_embedded_rk.hpp>

#include "bench_common.hpp"

namespace {

using namespace eci::bench;

double cpu_seconds() {
    timespec ts{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

/// Euler's equations of a free rigid body (two quadratic invariants, |L|^2 and the kinetic energy).
struct rigid_body {
    using state_type = std::array<double, 3>;
    double i1 = 1.0, i2 = 2.0, i3 = 3.0;
    void operator()(const state_type& l, state_type& d, double) const {
        d[0] = (1.0 / i3 - 1.0 / i2) * l[1] * l[2];
        d[1] = (1.0 / i1 - 1.0 / i3) * l[2] * l[0];
        d[2] = (1.0 / i2 - 1.0 / i1) * l[0] * l[1];
    }
    std::vector<double> invariants(const state_type& l) const {
        return {l[0] * l[0] + l[1] * l[1] + l[2] * l[2], 0.5 * (l[0] * l[0] / i1 + l[1] * l[1] / i2 + l[2] * l[2] / i3)};
    }
};

std::vector<double> invariants_of(const eci::three_wave& m, const eci::three_wave::state_type& x) {
    return {m.energy(x), m.enstrophy(x)};
}
std::vector<double> invariants_of(const eci::kepler& m, const eci::kepler::state_type& x) {
    const auto a = m.runge_lenz(x);
    return {m.hamiltonian(x), a[0], a[1]};
}
std::vector<double> invariants_of(const eci::lotka_volterra& m, const eci::lotka_volterra::state_type& x) {
    return {m.hamiltonian(x)};
}
std::vector<double> invariants_of(const rigid_body& m, const rigid_body::state_type& x) { return m.invariants(x); }
std::vector<double> invariants_of(const eci::n_wave<double>& m, const std::vector<double>& x) {
    return {m.energy(x), m.enstrophy(x)};
}

template <class Model>
struct problem {
    std::string name;
    Model model;
    typename Model::state_type x0, reference;
    double t_end;
};

struct point {
    std::string model, method;
    double tol;
    std::uint64_t evals;
    double cpu, state_error, invariant_error;
};

template <class Model>
double state_error(const problem<Model>& p, const typename Model::state_type& x) {
    double d = 0, r = 0;
    for (std::size_t i = 0; i < x.size(); ++i) d += (x[i] - p.reference[i]) * (x[i] - p.reference[i]), r += p.reference[i] * p.reference[i];
    return std::sqrt(d / r);
}

// The worst change of any invariant, relative to the largest initial invariant (A_y starts at 0 on Kepler).
template <class Model>
double invariant_error(const problem<Model>& p, const typename Model::state_type& x) {
    const auto a = invariants_of(p.model, p.x0), b = invariants_of(p.model, x);
    double scale = 0, worst = 0;
    for (double v : a) scale = std::max(scale, std::abs(v));
    for (std::size_t i = 0; i < a.size(); ++i) worst = std::max(worst, std::abs(b[i] - a[i]) / scale);
    return worst;
}

template <class Model, class Run>
point measure(const problem<Model>& p, const std::string& method, double tol, Run run, double min_cpu) {
    point pt{p.name, method, tol, 0, 0, 0, 0};
    int reps = 0;
    const double start = cpu_seconds();
    do {
        auto x = p.x0;
        const std::uint64_t evals = run(x);
        if (reps++ == 0) {
            pt.evals = evals;
            pt.state_error = state_error(p, x);
            pt.invariant_error = invariant_error(p, x);
        }
    } while (cpu_seconds() - start < min_cpu);
    pt.cpu = (cpu_seconds() - start) / reps;
    return pt;
}

template <class Model, class Make>
void sweep_eci(const problem<Model>& p, const std::string& method, Make make, double min_cpu, std::vector<point>& out) {
    for (int e = 3; e <= 12; ++e) {
        const double tol = std::pow(10.0, -e);
        out.push_back(measure(p, method, tol, [&](typename Model::state_type& x) {
            auto st = make();
            eci::adaptive_options o;
            o.rtol = o.atol = tol;
            return eci::integrate_adaptive(st, p.model, x, 0.0, p.t_end, 1e-3, o).rhs_evals;
        }, min_cpu));
    }
}

template <int Kind, class Model, class OdeintStepper>
void sweep_odeint(const problem<Model>& p, const std::string& method, OdeintStepper proto, double min_cpu,
                  std::vector<point>& out) {
    using S = typename Model::state_type;
    for (int e = 3; e <= 12; ++e) {
        const double tol = std::pow(10.0, -e);
        out.push_back(measure(p, method, tol, [&](S& x) {
            std::uint64_t count = 0;
            counted_rhs<Model> f{&p.model, &count};
            if constexpr (Kind == 1)
                odeint::integrate_adaptive(odeint::make_dense_output(tol, tol, proto), f, x, 0.0, p.t_end, 1e-3);
            else
                odeint::integrate_adaptive(odeint::make_controlled(tol, tol, proto), f, x, 0.0, p.t_end, 1e-3);
            return count;
        }, min_cpu));
    }
}

/// Evaluations the reference method needs for a given error, interpolated in log-log between its points.
double evals_at_error(const std::vector<point>& pts, const std::string& model, const std::string& method, double err) {
    std::vector<std::pair<double, double>> v;  // (log err, log evals), sorted by error
    for (const point& p : pts)
        if (p.model == model && p.method == method && p.state_error > 0) v.push_back({std::log(p.state_error), std::log(double(p.evals))});
    std::sort(v.begin(), v.end());
    const double le = std::log(err);
    for (std::size_t i = 1; i < v.size(); ++i)
        if (le >= v[i - 1].first && le <= v[i].first) {
            const double w = (le - v[i - 1].first) / (v[i].first - v[i - 1].first);
            return std::exp(v[i - 1].second + w * (v[i].second - v[i - 1].second));
        }
    return NAN;  // outside the reference's range
}

void compare(const std::vector<point>& pts, const std::string& model, const std::string& a, const std::string& b) {
    std::vector<double> ratios;
    double worst_inv = 0;
    for (const point& p : pts) {
        if (p.model != model || p.method != a) continue;
        worst_inv = std::max(worst_inv, p.invariant_error);
        const double ref = evals_at_error(pts, model, b, p.state_error);
        if (std::isfinite(ref)) ratios.push_back(double(p.evals) / ref);
    }
    if (ratios.empty()) {
        std::printf("wp %-14s %-12s vs %-16s no overlap in error\n", model.c_str(), a.c_str(), b.c_str());
        return;
    }
    std::sort(ratios.begin(), ratios.end());
    std::printf("wp %-14s %-12s vs %-16s evals ratio at equal end-time error: median %.2f, range %.2f..%.2f (%zu "
                "points); worst invariant error %.1e\n",
                model.c_str(), a.c_str(), b.c_str(), ratios[ratios.size() / 2], ratios.front(), ratios.back(),
                ratios.size(), worst_inv);
}

// Per-step cost of C-DP54 against DP54 on the n-wave system with 20 triads per mode: attempt + accept with the
// error norm (what an adaptive run does per step), paired and interleaved, the median of the ratios.
void per_step_cost(std::size_t modes, int pairs) {
    const auto model = eci::n_wave<double>::random(modes, 20, 12345);
    rhs<eci::n_wave<double>> f{&model};
    const auto x0 = model.random_state(1);
    const eci::error_weights w{1e-6, 1e-6};
    eci::dp54<std::vector<double>> conv;
    eci::c_dp54<std::vector<double>> cons;
    auto xa = x0, xb = x0;
    auto time_one = [&](auto& st, std::vector<double>& x) {
        const double t0 = cpu_seconds();
        const auto r = st.attempt(f, std::as_const(x), 0.0, 1e-3, &w);
        if (r.ok) st.accept(x);
        return cpu_seconds() - t0;
    };
    time_one(conv, xa), time_one(cons, xb);  // first steps evaluate k_1 (7 evaluations); FSAL after that
    std::vector<double> ratios;
    for (int i = 0; i < pairs; ++i) {
        const bool flip = i % 2;
        const double a = flip ? 0 : time_one(conv, xa);
        const double b = time_one(cons, xb);
        const double a2 = flip ? time_one(conv, xa) : a;
        ratios.push_back(b / a2);
    }
    std::sort(ratios.begin(), ratios.end());
    const std::size_t m = ratios.size();
    std::printf("cost n-wave N=%zu (20 triads/mode): C-DP54 / DP54 per step (attempt + accept + norm) median %.3f, "
                "quartiles %.3f..%.3f, range %.3f..%.3f over %d pairs (target <= 1.05)\n",
                modes, ratios[m / 2], ratios[m / 4], ratios[(3 * m) / 4], ratios.front(), ratios.back(), pairs);
}

// Long-run round-off: fixed steps of 0.01 on the three-wave model; the worst relative drift of the model's E and Z
// (as a user measures them, in double: a few eps of that is the measurement) up to each decade of steps, and the
// fitted growth exponent (0.5 = a random walk, 0 = bounded).
/// The same sweeps on every problem: eci's C-DP54 (through the transform where the model has one), DP54 and
/// C-F78 against odeint's controlled and dense dopri5 and its Fehlberg 7(8).
template <class S, class Model, class MakeCdp54, class MakeCf78>
void sweep_all(const problem<Model>& p, MakeCdp54 c_dp54, MakeCf78 c_f78, double min_cpu, std::vector<point>& pts) {
    sweep_eci(p, "c-dp54", c_dp54, min_cpu, pts);
    sweep_eci(p, "dp54", [] { return eci::dp54<S>{}; }, min_cpu, pts);
    sweep_eci(p, "c-f78", c_f78, min_cpu, pts);
    sweep_odeint<0>(p, "dopri5", odeint::runge_kutta_dopri5<S>(), min_cpu, pts);
    sweep_odeint<1>(p, "dopri5_dense", odeint::runge_kutta_dopri5<S>(), min_cpu, pts);
    sweep_odeint<0>(p, "fehlberg78", odeint::runge_kutta_fehlberg78<S>(), min_cpu, pts);
}

template <class St>
void long_run(const char* name, std::uint64_t steps) {
    const eci::three_wave m{};
    eci::three_wave::state_type x{std::sqrt(1.5), 1.0, std::sqrt(1.5)};
    const double e0 = m.energy(x), z0 = m.enstrophy(x);
    St st;
    double worst = 0;
    std::vector<std::pair<std::uint64_t, double>> decades;
    std::uint64_t next = 1000;
    eci::integrate_n_steps(st, m, x, 0.0, 0.01, steps, [&](const auto& y, double, std::uint64_t i) {
        worst = std::max({worst, std::abs(m.energy(y) - e0) / e0, std::abs(m.enstrophy(y) - z0) / z0});
        if (i == next || i == steps) {
            decades.push_back({i, worst});
            next *= 10;
        }
    }, eci::run_options{std::max<std::uint64_t>(1, steps / 10000)});
    std::string growth;
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    for (const auto& [n, w] : decades) {
        char buf[64];
        std::snprintf(buf, sizeof buf, " %.0e:%.1e", double(n), w);
        growth += buf;
        const double lx = std::log(double(n)), ly = std::log(std::max(w, 1e-300));
        sx += lx, sy += ly, sxx += lx * lx, sxy += lx * ly;
    }
    const double k = double(decades.size());
    const double slope = decades.size() > 1 ? (k * sxy - sx * sy) / (k * sxx - sx * sx) : NAN;
    std::printf("long run %-20s %llu steps of 0.01: worst relative drift of E, Z %.2e (target <= 1e-14); by "
                "steps%s; growth exponent %.2f\n",
                name, (unsigned long long)steps, worst, growth.c_str(), slope);
}

}  // namespace

int main(int argc, char** argv) {
    if (argc < 3) {
        std::fprintf(stderr, "usage: eci_bench_adaptive <quick 0|1> <csv file> [cost modes] [long-run steps]\n");
        return 2;
    }
    const bool quick = std::atoi(argv[1]) != 0;
    const std::size_t cost_modes = argc > 3 ? std::strtoull(argv[3], nullptr, 10) : 0;
    const std::uint64_t long_steps = argc > 4 ? std::strtoull(argv[4], nullptr, 10) : 0;
    std::FILE* csv = std::fopen(argv[2], "w");
    if (!csv) {
        std::fprintf(stderr, "eci_bench_adaptive: cannot write %s\n", argv[2]);
        return 2;
    }
    const double min_cpu = quick ? 0.0 : 0.05;
    std::vector<point> pts;

    // Three-wave, Figure 5's initial condition, to t = 100 (exact solution).
    {
        problem<eci::three_wave> p{"three_wave", {}, {std::sqrt(1.5), 1.0, std::sqrt(1.5)}, {}, 100.0};
        p.reference = eci::three_wave_exact(p.model, p.x0)(p.t_end);
        using S = eci::three_wave::state_type;
        sweep_all<S>(p, [] { return eci::c_dp54<S>{}; }, [] { return eci::c_f78<S>{}; }, min_cpu, pts);
    }
    // Rigid body near its unstable axis to t = 100 (reference: odeint Fehlberg 7(8) at 1e-15).
    {
        problem<rigid_body> p{"rigid_body", {}, {0.01, 1.0, 0.02}, {}, 100.0};
        using S = rigid_body::state_type;
        p.reference = p.x0;
        odeint::integrate_adaptive(odeint::make_controlled(1e-15, 1e-15, odeint::runge_kutta_fehlberg78<S>()), p.model,
                                   p.reference, 0.0, p.t_end, 1e-4);
        sweep_all<S>(p, [] { return eci::c_dp54<S>{}; }, [] { return eci::c_f78<S>{}; }, min_cpu, pts);
    }
    // Kepler, e = 0.9 from perihelion, 100 orbits (exact solution), through the transform (50).
    {
        eci::kepler m{};
        const double e = 0.9, pr = m.ell * m.ell / (m.m * m.K), a = pr / (1.0 - e * e);
        const double period = 2.0 * std::numbers::pi * std::sqrt(m.m * a * a * a / m.K);
        problem<eci::kepler> p{"kepler_e0.9", m, {pr / (1.0 + e), 0.0, 0.0}, {}, 100.0 * period};
        p.reference = eci::kepler_exact(p.model, p.x0)(p.t_end);
        using S = eci::kepler::state_type;
        using Tr = eci::kepler::transform;
        sweep_all<S>(
            p, [] { return eci::transformed_dp54<Tr>{}; },
            [] { return eci::transformed_embedded_rk<eci::tableaus::fehlberg_78, Tr>{}; }, min_cpu, pts);
    }
    // Lotka-Volterra, the paper's mu = 1.5 from (1, 0.4), to t = 100 (reference: odeint Fehlberg 7(8) at 1e-15).
    {
        problem<eci::lotka_volterra> p{"lotka_volterra", {}, {1.0, 0.4}, {}, 100.0};
        using S = eci::lotka_volterra::state_type;
        using Tr = eci::lotka_volterra::transform;
        p.reference = p.x0;
        odeint::integrate_adaptive(odeint::make_controlled(1e-15, 1e-15, odeint::runge_kutta_fehlberg78<S>()), p.model,
                                   p.reference, 0.0, p.t_end, 1e-4);
        sweep_all<S>(
            p, [] { return eci::transformed_dp54<Tr>{}; },
            [] { return eci::transformed_embedded_rk<eci::tableaus::fehlberg_78, Tr>{}; }, min_cpu, pts);
    }

    // A random real n-wave system (30 modes, 4 triads per mode) to t = 20 (reference: odeint Fehlberg 7(8) at
    // 1e-14): many modes pass through zero, where the conservative method's psi = sqrt(xi) is least accurate.
    {
        problem<eci::n_wave<double>> p{"n_wave30", eci::n_wave<double>::random(30, 4, 7), {}, {}, 20.0};
        p.x0 = p.model.random_state(3);
        using S = std::vector<double>;
        p.reference = p.x0;
        odeint::integrate_adaptive(odeint::make_controlled(1e-14, 1e-14, odeint::runge_kutta_fehlberg78<S>()), p.model,
                                   p.reference, 0.0, p.t_end, 1e-4);
        sweep_all<S>(p, [] { return eci::c_dp54<S>{}; }, [] { return eci::c_f78<S>{}; }, min_cpu, pts);
    }

    std::fprintf(csv, "model,method,tol,rhs_evals,cpu_seconds,state_error,invariant_error\n");
    for (const point& p : pts)
        std::fprintf(csv, "%s,%s,%.0e,%llu,%.6e,%.6e,%.6e\n", p.model.c_str(), p.method.c_str(), p.tol,
                     (unsigned long long)p.evals, p.cpu, p.state_error, p.invariant_error);
    std::fclose(csv);
    for (const char* model : {"three_wave", "rigid_body", "kepler_e0.9", "lotka_volterra", "n_wave30"}) {
        compare(pts, model, "c-dp54", "dopri5");
        compare(pts, model, "c-dp54", "dopri5_dense");
        compare(pts, model, "c-dp54", "dp54");
        compare(pts, model, "c-f78", "fehlberg78");
    }
    if (cost_modes > 0) per_step_cost(cost_modes - cost_modes % 3, quick ? 5 : 15);
    if (long_steps > 0) {
        long_run<eci::c_rk4_compensated<eci::three_wave::state_type>>("c-rk4 compensated", long_steps);
        long_run<eci::c_dp54_compensated<eci::three_wave::state_type>>("c-dp54 compensated", long_steps);
        long_run<eci::c_dp54<eci::three_wave::state_type>>("c-dp54 (plain)", long_steps);
        long_run<eci::c_rk4<eci::three_wave::state_type>>("c-rk4 (plain)", long_steps);
    }
    return 0;
}
