// Per-step cost of eci's 2-D Navier-Stokes model, side by side in one run: conservative vs conventional methods,
// a step vs the FFTs it performs, threads, and sizes. Usage: eci_bench_ns2d_step N [threads] [reps] [wisdom file]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <numbers>
#include <string>

#include <eci/eci.hpp>
#include <eci/models/navier_stokes_2d.hpp>

namespace {

using state = eci::navier_stokes_2d::state_type;
using clock_type = std::chrono::steady_clock;

double seconds_since(clock_type::time_point t) { return std::chrono::duration<double>(clock_type::now() - t).count(); }

// One attempt of the stepper (success or not: a failed attempt costs the same work), the fastest of `reps`.
// The state is restored before each attempt, so every method steps the same field at CFL 0.5.
template <class St>
double step_time(eci::navier_stokes_2d& m, const state& w0, double dt, int reps) {
    St st;
    state w = w0;
    st.step(m, w, 0.0, dt);  // warm up: buffers allocated
    double best = 1e300;
    for (int r = 0; r < reps; ++r) {
        w = w0;
        const auto t = clock_type::now();
        st.step(m, w, 0.0, dt);
        best = std::min(best, seconds_since(t));
    }
    return best;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc < 2) {
        std::fprintf(stderr, "usage: %s N [threads] [reps] [wisdom file]\n", argv[0]);
        return 2;
    }
    eci::ns2d_params p;
    p.n = std::atoi(argv[1]);
    p.threads = argc > 2 ? std::atoi(argv[2]) : 1;
    const int reps = argc > 3 ? std::atoi(argv[3]) : 5;
    p.wisdom_file = argc > 4 ? argv[4] : "";
    p.nu = 1e-4;
    eci::navier_stokes_2d m(p);
    const state w0 = m.random_field(p.n / 16.0, 0.5, 1);
    const double dt = 0.5 * (2.0 * std::numbers::pi / p.n) / m.max_velocity(w0);
    // Interleaved: each round times every method once, so load changes hit all alike; the fastest round counts.
    double t_rk4 = 1e300, t_crk4 = 1e300, t_pc = 1e300, t_cpc = 1e300, t_fft = 1e300;
    for (int round = 0; round < 3; ++round) {
        t_rk4 = std::min(t_rk4, step_time<eci::rk4<state>>(m, w0, dt, reps));
        t_crk4 = std::min(t_crk4, step_time<eci::c_rk4<state>>(m, w0, dt, reps));
        t_pc = std::min(t_pc, step_time<eci::pc<state>>(m, w0, dt, reps));
        t_cpc = std::min(t_cpc, step_time<eci::c_pc<state>>(m, w0, dt, reps));
        for (int r = 0; r < reps; ++r) {
            const auto t = clock_type::now();
            for (int s = 0; s < 4; ++s) m.execute_transforms();  // the transforms of one RK4 step
            t_fft = std::min(t_fft, seconds_since(t));
        }
    }
    std::printf("ns2d-step N=%d threads=%d rk4=%.6g c_rk4=%.6g pc=%.6g c_pc=%.6g fft_rk4_step=%.6g "
                "c_rk4/rk4=%.4f c_pc/pc=%.4f c_rk4/fft=%.4f\n",
                p.n, p.threads, t_rk4, t_crk4, t_pc, t_cpc, t_fft, t_crk4 / t_rk4, t_cpc / t_pc, t_crk4 / t_fft);
}
