// Long-run drift of the invariants on the three-wave model (dt = 0.01): C-PC, its compensated variant and C-RK4
// against RK4, over an ensemble of initial conditions, so the growth law of the round-off (sqrt(steps)?) shows.
// Usage: eci_bench_drift <steps> <ensemble size> <csv file>; prints one summary line per method.
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <eci/eci.hpp>
#include <eci/models/three_wave.hpp>

#include "bench_common.hpp"

namespace {

using state = eci::three_wave::state_type;
constexpr double dt = 0.01;

// Log-spaced step counts 1, ..., steps (ten per decade), where the invariants are recorded.
std::vector<std::uint64_t> checkpoints(std::uint64_t steps) {
    std::vector<std::uint64_t> c;
    for (int j = 0;; ++j) {
        const auto n = static_cast<std::uint64_t>(std::llround(std::pow(10.0, j / 10.0)));
        if (n >= steps) break;
        if (c.empty() || n != c.back()) c.push_back(n);
    }
    c.push_back(steps);
    return c;
}

struct curve {
    std::vector<double> e, z;  // relative energy and enstrophy error at each checkpoint
};

template <class Stepper>
curve run_one(const eci::three_wave& m, state x, const std::vector<std::uint64_t>& at) {
    Stepper stepper;
    eci::invariant_monitor<eci::three_wave> monitor(m);  // energy, enstrophy: initial, and at each checkpoint
    monitor.record(x);
    curve c;
    std::uint64_t done = 0;
    for (std::uint64_t target : at) {
        // integrate_n_steps: the driver a user runs, with its step reductions (t only matters for the record);
        // each segment resumes the trajectory, so the compensated residual is carried across checkpoints
        eci::integrate_n_steps(stepper, m, x, double(done) * dt, dt, target - done, eci::no_observer{},
                               {.resume = true});
        done = target;
        monitor.record(x);
        const auto& r = monitor.records();
        c.e.push_back(std::abs(r[0].final - r[0].initial) / r[0].initial);
        c.z.push_back(std::abs(r[1].final - r[1].initial) / r[1].initial);
    }
    return c;
}

struct summary {
    std::vector<double> rms, worst;  // over the ensemble, max(E, Z) error per checkpoint
};

template <class Stepper>
summary run_ensemble(const std::string& name, const eci::three_wave& m, int members,
                     const std::vector<std::uint64_t>& at, std::FILE* csv) {
    summary s{std::vector<double>(at.size(), 0.0), std::vector<double>(at.size(), 0.0)};
    std::vector<double> rms_e(at.size()), rms_z(at.size());
    for (int j = 0; j < members; ++j) {
        // the paper's Fig. 5 initial condition, psi_P varied across the ensemble
        state x0 = eci::find_preset<eci::three_wave>("fig5").x0;
        x0[1] += 0.01 * j;
        const curve c = run_one<Stepper>(m, x0, at);
        for (std::size_t i = 0; i < at.size(); ++i) {
            rms_e[i] += c.e[i] * c.e[i] / members;
            rms_z[i] += c.z[i] * c.z[i] / members;
            s.rms[i] += std::max(c.e[i] * c.e[i], c.z[i] * c.z[i]) / members;
            s.worst[i] = std::max({s.worst[i], c.e[i], c.z[i]});
        }
    }
    for (std::size_t i = 0; i < at.size(); ++i) {
        s.rms[i] = std::sqrt(s.rms[i]);
        std::fprintf(csv, "%s,%llu,%.6e,%.6e,%.6e\n", name.c_str(), static_cast<unsigned long long>(at[i]),
                     std::sqrt(rms_e[i]), std::sqrt(rms_z[i]), s.worst[i]);
    }
    return s;
}

// Least-squares slope of log(rms) against log(steps) over steps >= 1000 (round-off growth exponent).
double growth_exponent(const std::vector<std::uint64_t>& at, const std::vector<double>& rms) {
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    int n = 0;
    for (std::size_t i = 0; i < at.size(); ++i) {
        if (at[i] < 1000 || !(rms[i] > 0.0)) continue;
        const double lx = std::log10(double(at[i])), ly = std::log10(rms[i]);
        sx += lx, sy += ly, sxx += lx * lx, sxy += lx * ly, ++n;
    }
    return n > 1 ? (n * sxy - sx * sy) / (n * sxx - sx * sx) : 0.0;
}

/// The methods compared, as registry entries: each is labelled by its registry name (eci::identifier).
using drift_methods = eci::bench::method_set<eci::method_entries::c_pc, eci::method_entries::c_pc_compensated,
                                 eci::method_entries::c_rk4, eci::method_entries::rk4, eci::method_entries::pc>;

template <class Report, class... E>
void run_all(Report& report, const eci::three_wave& m, int members, const std::vector<std::uint64_t>& at,
             std::FILE* csv, eci::bench::method_set<E...>) {
    (report(eci::identifier(E::info.name),
            run_ensemble<eci::stepper_for<E, eci::three_wave>>(eci::identifier(E::info.name), m, members, at, csv)),
     ...);
}

}  // namespace

int main(int argc, char** argv) {
    if (argc != 4) {
        std::fprintf(stderr, "usage: eci_bench_drift <steps> <ensemble size> <csv file>\n");
        return 2;
    }
    const std::uint64_t steps = std::strtoull(argv[1], nullptr, 10);
    const int members = std::atoi(argv[2]);
    if (steps < 10 || members < 1) {
        std::fprintf(stderr, "eci_bench_drift: need at least 10 steps and 1 ensemble member\n");
        return 2;
    }
    std::FILE* csv = std::fopen(argv[3], "w");
    if (!csv) {
        std::fprintf(stderr, "eci_bench_drift: cannot write %s\n", argv[3]);
        return 2;
    }
    const eci::three_wave m = eci::find_preset<eci::three_wave>("fig5").model;
    const auto at = checkpoints(steps);
    std::fprintf(csv, "method,steps,rms_rel_energy_error,rms_rel_enstrophy_error,max_rel_invariant_error\n");
    auto report = [&](const std::string& name, const summary& s) {
        std::printf("drift method=%s steps=%llu rms=%.3e max=%.3e exponent=%.3f\n", name.c_str(),
                    static_cast<unsigned long long>(steps), s.rms.back(), s.worst.back(), growth_exponent(at, s.rms));
    };
    run_all(report, m, members, at, csv, drift_methods{});
    std::fclose(csv);
    return 0;
}
