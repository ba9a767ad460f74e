// Adaptive conservative against conventional on the random n-wave system: right-hand-side evaluations against
// end-time error for dp54 and c-dp54 (the registry's adaptive steppers on the model, as `eci run --rtol` and
// eci.solve build them) over a tolerance sweep, real and complex amplitudes, several seeds, and the ratio of
// c-dp54's evaluations to dp54's at equal end-time error (dp54's interpolated log-log at c-dp54's error).
// Usage: eci_bench_adaptive_nwave [csv file] [modes] [triads per mode] [t_end]
#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <eci/adaptive.hpp>
#include <eci/models/n_wave.hpp>

namespace {

struct point {
    double tol;
    std::uint64_t evals, rejected_radicand;
    double error, invariant_drift;
};

// ||x - ref|| / ||ref|| over the real unknowns.
template <class S>
double relative_error(const S& x, const S& ref) {
    const auto a = eci::reals(x), b = eci::reals(ref);
    double d = 0.0, r = 0.0;
    for (std::size_t i = 0; i < a.size(); ++i) d += (a[i] - b[i]) * (a[i] - b[i]), r += b[i] * b[i];
    return std::sqrt(d / r);
}

template <class Model>
double invariant_drift(const Model& m, const typename Model::state_type& a, const typename Model::state_type& b) {
    return std::max(std::abs(m.energy(b) - m.energy(a)) / m.energy(a),
                    std::abs(m.enstrophy(b) - m.enstrophy(a)) / m.enstrophy(a));
}

template <class Entry, class Model>
point run(const Model& m, const typename Model::state_type& x0, const typename Model::state_type& ref, double t_end,
          double tol) {
    eci::adaptive_stepper_for<Entry, Model> st;
    eci::adaptive_options o;
    o.rtol = o.atol = tol;
    auto x = x0;
    const eci::adaptive_stats s = eci::integrate_adaptive(st, m, x, 0.0, t_end, 1e-3, o);
    return {tol, s.rhs_evals, s.rejected_radicand, relative_error(x, ref), invariant_drift(m, x0, x)};
}

// Evaluations of `ref` at end-time error err, interpolated log-log between its two points that bracket err.
double evals_at(const std::vector<point>& ref, double err) {
    std::vector<std::pair<double, double>> v;
    for (const point& p : ref)
        if (p.error > 0.0) v.push_back({std::log(p.error), std::log(double(p.evals))});
    std::sort(v.begin(), v.end());
    const double le = std::log(err);
    for (std::size_t i = 1; i < v.size(); ++i)
        if (le >= v[i - 1].first && le <= v[i].first) {
            const double w = (le - v[i - 1].first) / (v[i].first - v[i - 1].first);
            return std::exp(v[i - 1].second + w * (v[i].second - v[i - 1].second));
        }
    return NAN;
}

template <class T>
void sweep(std::FILE* csv, std::size_t modes, std::size_t triads, std::uint64_t seed, double t_end) {
    using Model = eci::n_wave<T>;
    const Model m = Model::random(modes, triads, seed);
    const auto x0 = m.random_state(seed + 1);
    // The reference: conventional DP853 at 1e-14 (its error is far below the sweep's smallest).
    auto ref = x0;
    {
        eci::dp853<typename Model::state_type> st;
        eci::adaptive_options o;
        o.rtol = o.atol = 1e-14;
        eci::integrate_adaptive(st, m, ref, 0.0, t_end, 1e-4, o);
    }
    std::vector<point> conv, cons;
    for (int i = 0; i <= 16; ++i) {
        const double tol = std::pow(10.0, -3.0 - 0.5 * i);
        conv.push_back(run<eci::method_entries::dp54>(m, x0, ref, t_end, tol));
        cons.push_back(run<eci::method_entries::c_dp54>(m, x0, ref, t_end, tol));
    }
    const char* kind = Model::is_complex ? "complex" : "real";
    std::vector<double> ratios, resolved;  // resolved: c-dp54's end-time error below 1e-2
    double worst_drift = 0.0;
    std::uint64_t radicand = 0;
    for (std::size_t i = 0; i < cons.size(); ++i) {
        const double at = evals_at(conv, cons[i].error);
        if (std::isfinite(at)) ratios.push_back(double(cons[i].evals) / at);
        if (std::isfinite(at) && cons[i].error <= 1e-2) resolved.push_back(double(cons[i].evals) / at);
        worst_drift = std::max(worst_drift, cons[i].invariant_drift);
        radicand += cons[i].rejected_radicand;
        for (const auto* p : {&conv[i], &cons[i]})
            std::fprintf(csv, "%s,%llu,%s,%.1e,%llu,%llu,%.6e,%.3e\n", kind, (unsigned long long)seed,
                         p == &conv[i] ? "dp54" : "c-dp54", p->tol, (unsigned long long)p->evals,
                         (unsigned long long)p->rejected_radicand, p->error, p->invariant_drift);
    }
    if (ratios.empty() || resolved.empty()) {
        std::printf("n-wave %-7s seed %2llu: no overlap in error\n", kind, (unsigned long long)seed);
        return;
    }
    auto geometric_mean = [](const std::vector<double>& v) {
        double s = 0.0;
        for (double r : v) s += std::log(r);
        return std::exp(s / double(v.size()));
    };
    std::sort(ratios.begin(), ratios.end());
    std::sort(resolved.begin(), resolved.end());
    // (Errors above 1e-2 at t_end are not a resolved solution of this chaotic system: which method lands closer
    // there is chance, so the resolved points are reported apart.)
    std::printf("n-wave %-7s %zu modes seed %2llu: c-dp54 / dp54 evaluations at equal end-time error: all points "
                "geometric mean %.2f, median %.2f, range %.2f..%.2f (%zu); error <= 1e-2 geometric mean %.2f, range "
                "%.2f..%.2f (%zu); c-dp54 radicand rejections %llu; worst E, Z drift %.1e\n",
                kind, modes, (unsigned long long)seed, geometric_mean(ratios), ratios[ratios.size() / 2],
                ratios.front(), ratios.back(), ratios.size(), geometric_mean(resolved), resolved.front(),
                resolved.back(), resolved.size(), (unsigned long long)radicand, worst_drift);
}

}  // namespace

int main(int argc, char** argv) {
    const char* path = argc > 1 ? argv[1] : "adaptive_nwave.csv";
    const std::size_t modes = argc > 2 ? std::strtoull(argv[2], nullptr, 10) : 30;
    const std::size_t triads = argc > 3 ? std::strtoull(argv[3], nullptr, 10) : 4;
    const double t_end = argc > 4 ? std::atof(argv[4]) : 20.0;
    std::FILE* csv = std::fopen(path, "w");
    if (!csv) {
        std::fprintf(stderr, "eci_bench_adaptive_nwave: cannot write %s\n", path);
        return 2;
    }
    std::fprintf(csv, "kind,seed,method,tol,rhs_evals,rejected_radicand,end_error,invariant_drift\n");
    for (std::uint64_t seed : {7, 11, 23}) {
        sweep<double>(csv, modes, triads, seed, t_end);
        sweep<std::complex<double>>(csv, modes, triads, seed, t_end);
    }
    std::fclose(csv);
    return 0;
}
