// Per-step cost of eci's 2-D Navier-Stokes model, side by side in one run: conservative vs conventional methods,
// a step vs the FFTs and right-hand sides it performs, threads, and sizes.
// Usage: eci_bench_ns2d_step N [threads] [reps] [wisdom file]
// The ns2d-step row also gives the time of one n x n transform (fft_one: the mean of four c2r and four r2c on four
// fields in turn, planned like eci's, FFTW_MEASURE with the same threads and wisdom) and the FFT floor in units of it per right-hand side
// (fft_equiv_per_rhs: 5 for 4 inverse + 1 forward transforms, 4 for Basdevant's form; batched transforms may come
// out a little below their count), so a table can say how many transforms eci performs without reading its code.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <numbers>
#include <span>
#include <string>
#include <type_traits>
#include <vector>

#include <ctime>

#include <fftw3.h>

#include <eci/eci.hpp>
#include <eci/models/navier_stokes_2d.hpp>

namespace {

using state = eci::navier_stokes_2d::state_type;
// With one thread the process's CPU time: on a shared machine a time slice lost to another process is not
// counted (wall time would be, and the ratios would be noise). With more threads, wall time (the point of threads).
bool use_cpu_clock = true;
double now() {
    if (use_cpu_clock) {
        timespec ts{};
        clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
        return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
    }
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}
double seconds_since(double t) { return now() - t; }

// `reps` attempts of the stepper on system f (success or not: a failed attempt costs the same work), each from w0
// again, so every method steps the same field at CFL 0.5; their times, sorted. update: which finishing pass a
// conservative stepper takes: 0 its default, 1 the paper's update, 2 the conditioned update, 3 the conditioned
// update with each complex mode's modulus update (remedy.complex_by_rescale off: eci's default before session 40). The model's invariants
// are declared to it, as ns2d_step (the CLI's driver) does.
// hooked: each step as a run takes it (eci::solve, the CLI): between the model's begin_attempt and end_attempt, so
// that every right-hand side also records the budget's rates (f is then the model itself).
template <class St, class F>
std::vector<double> step_times(F& f, const eci::navier_stokes_2d& m, const state& w0, double dt, int reps,
                               int update, bool hooked = false) {
    const auto one_step = [&](St& st, state& w) {
        if constexpr (std::is_same_v<F, eci::navier_stokes_2d>) {
            if (hooked) {
                f.begin_attempt();
                const bool ok = bool(st.step(f, w, 0.0, dt));
                f.end_attempt(ok, dt, std::span<const double>(St::tableau.b));
                return;
            }
        }
        st.step(f, w, 0.0, dt);
    };
    St st;
    if constexpr (requires { st.remedy; }) {
        st.set_quadratic_invariants(m.quadratic_invariant_weights());
        if (update == 1) st.remedy.update = eci::update_kind::paper;
        if (update >= 2) st.remedy.update = eci::update_kind::conditioned;
        if (update == 3) st.remedy.complex_by_rescale = false;
    }
    state w = w0;
    one_step(st, w);  // warm up: buffers allocated
    std::vector<double> t;
    t.reserve(std::size_t(reps));
    for (int r = 0; r < reps; ++r) {
        w = w0;
        const double t0 = now();
        one_step(st, w);
        t.push_back(seconds_since(t0));
    }
    std::sort(t.begin(), t.end());
    return t;
}

// One step of St on the model, the fastest of `reps`.
template <class St>
double step_time(eci::navier_stokes_2d& m, const state& w0, double dt, int reps, int update = 0,
                 bool hooked = false) {
    return step_times<St>(m, m, w0, dt, reps, update, hooked).front();
}

// A model that replays the stage derivatives of one real RK4 step (recorded with `record`): a step of any stepper
// on it costs its stage combinations, four copies and its finishing pass, with no transform. The difference
// between two steppers' replayed steps is then the difference of their finishing passes, measured without the
// noise of the transforms around it (which is larger than the difference itself).
struct replay_model {
    std::vector<state> k;
    bool record = false;
    eci::navier_stokes_2d* model = nullptr;
    std::size_t next = 0;
    void operator()(const state& x, state& dx, double t) {
        if (record) {
            (*model)(x, dx, t);
            k.push_back(dx);
            return;
        }
        dx = k[next++ % k.size()];
    }
    // the model's threads for the steppers' element-wise passes, as a step of the model itself has them
    int range_threads() const { return model->range_threads(); }
    template <class Body>
    void for_ranges(std::size_t n, Body body) const {
        model->for_ranges(n, body);
    }
};

// The median of `reps` replayed steps of St from w0 (each from w0 again, so each files the same elements).
template <class St>
double replayed_step(replay_model& f, const eci::navier_stokes_2d& m, const state& w0, double dt, int reps,
                     int update) {
    return step_times<St>(f, m, w0, dt, reps, update)[std::size_t(reps) / 2];
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
    use_cpu_clock = p.threads == 1;
    p.nu = 1e-4;
    eci::navier_stokes_2d m(p);
    const state w0 = m.random_field(p.n / 16.0, 0.5, 1);
    const double dt = 0.5 * (2.0 * std::numbers::pi / p.n) / m.max_velocity(w0);
    // Interleaved: each round times every method once, so load changes hit all alike; the fastest round counts.
    double t_rk4 = 1e300, t_crk4 = 1e300, t_pc = 1e300, t_cpc = 1e300, t_fft = 1e300, t_rhs = 1e300;
    double t_crk4_paper = 1e300, t_cpc_paper = 1e300, t_crk4_cond = 1e300, t_cpc_cond = 1e300, t_crk4_mod = 1e300;
    double t_rk4_run = 1e300, t_crk4_run = 1e300;
    state f;
    m(w0, f, 0.0);
    for (int round = 0; round < 3; ++round) {
        t_rk4 = std::min(t_rk4, step_time<eci::rk4<state>>(m, w0, dt, reps));
        t_crk4 = std::min(t_crk4, step_time<eci::c_rk4<state>>(m, w0, dt, reps));
        t_pc = std::min(t_pc, step_time<eci::pc<state>>(m, w0, dt, reps));
        t_cpc = std::min(t_cpc, step_time<eci::c_pc<state>>(m, w0, dt, reps));
        t_crk4_paper = std::min(t_crk4_paper, step_time<eci::c_rk4<state>>(m, w0, dt, reps, 1));
        t_cpc_paper = std::min(t_cpc_paper, step_time<eci::c_pc<state>>(m, w0, dt, reps, 1));
        t_crk4_cond = std::min(t_crk4_cond, step_time<eci::c_rk4<state>>(m, w0, dt, reps, 2));
        t_crk4_mod = std::min(t_crk4_mod, step_time<eci::c_rk4<state>>(m, w0, dt, reps, 3));
        t_cpc_cond = std::min(t_cpc_cond, step_time<eci::c_pc<state>>(m, w0, dt, reps, 2));
        t_rk4_run = std::min(t_rk4_run, step_time<eci::rk4<state>>(m, w0, dt, reps, 0, true));
        t_crk4_run = std::min(t_crk4_run, step_time<eci::c_rk4<state>>(m, w0, dt, reps, 0, true));
        for (int r = 0; r < reps; ++r) {
            const double t = now();
            m.execute_transforms(4);  // the transforms of one RK4 step, as it makes them (one chain of 4)
            t_fft = std::min(t_fft, seconds_since(t));
        }
        for (int r = 0; r < reps; ++r) {
            const double t = now();
            for (int s = 0; s < 4; ++s) m(w0, f, 0.0);  // the right-hand sides of one RK4 step
            t_rhs = std::min(t_rhs, seconds_since(t));
        }
    }
    // One transform of each direction, on arrays of their own, planned as eci plans its own (the model imported
    // the wisdom file and set the threads). Four real and four complex fields, each transformed in turn (new-array
    // execute), so that the data come from memory as in a right-hand side's four inverse transforms: one transform
    // repeated on the same field would stay in the caches and time below what it costs in a step.
    double t_one = 1e300;
    {
        const std::size_t nr = std::size_t(p.n) * std::size_t(p.n), nc = std::size_t(p.n) * std::size_t(p.n / 2 + 1);
        double* rr = fftw_alloc_real(4 * nr);
        fftw_complex* cc = fftw_alloc_complex(4 * nc);
        fftw_plan_with_nthreads(p.threads);
        fftw_plan fwd = fftw_plan_dft_r2c_2d(p.n, p.n, rr, cc, FFTW_MEASURE);
        fftw_plan inv = fftw_plan_dft_c2r_2d(p.n, p.n, cc, rr, FFTW_MEASURE);
        for (std::size_t j = 0; j < 4 * nr; ++j) rr[j] = std::sin(0.001 * double(j));
        for (int f = 0; f < 4; ++f) fftw_execute_dft_r2c(fwd, rr + f * nr, cc + f * nc);
        for (int round = 0; round < 3 * reps; ++round) {
            const double t = now();
            for (int f = 0; f < 4; ++f) fftw_execute_dft_c2r(inv, cc + f * nc, rr + f * nr);
            for (int f = 0; f < 4; ++f) fftw_execute_dft_r2c(fwd, rr + f * nr, cc + f * nc);
            t_one = std::min(t_one, seconds_since(t) / 8.0);
            // c2r then r2c scales by n^2: keep the values bounded
            for (std::size_t j = 0; j < 4 * nc; ++j) {
                cc[j][0] /= double(nr);
                cc[j][1] /= double(nr);
            }
        }
        fftw_destroy_plan(fwd);
        fftw_destroy_plan(inv);
        fftw_free(rr);
        fftw_free(cc);
    }
    std::printf("ns2d-step N=%d threads=%d clock=%s rk4=%.6g c_rk4=%.6g pc=%.6g c_pc=%.6g fft_rk4_step=%.6g "
                "rhs_rk4_step=%.6g c_rk4/rk4=%.4f c_pc/pc=%.4f c_rk4/fft=%.4f rhs/fft=%.4f dt=%.6g fft_one=%.6g "
                "fft_equiv_per_rhs=%.2f transforms_per_rhs=%d\n",
                p.n, p.threads, use_cpu_clock ? "cpu" : "wall", t_rk4, t_crk4, t_pc, t_cpc, t_fft, t_rhs,
                t_crk4 / t_rk4, t_cpc / t_pc, t_crk4 / t_fft, t_rhs / t_fft, dt, t_one, t_fft / 4.0 / t_one,
                m.transforms_per_rhs());
    // The same ratios paired in time: each round times the transforms of a step, a C-RK4 step and an RK4 step one
    // after the other (the steppers made once, each step from w0), and the medians of the rounds' ratios count. The
    // fastest of each, above, are taken at different moments: on a VM whose speed drifts by 20-40 % within seconds
    // their ratio moved by +-0.1 between runs of this program (c_rk4/fft 1.04-1.34 in twelve runs, session 47),
    // while these medians moved by +-0.01.
    {
        eci::c_rk4<state> crk;
        crk.set_quadratic_invariants(m.quadratic_invariant_weights());
        eci::rk4<state> rk;
        state w = w0;
        crk.step(m, w, 0.0, dt);  // warm up: buffers allocated
        w = w0;
        rk.step(m, w, 0.0, dt);
        const auto median = [](std::vector<double> v) {
            std::sort(v.begin(), v.end());
            return v[v.size() / 2];
        };
        // fresh: each step from a copy of w0 (ns2d-paired); else each stepper continues its own trajectory from w0,
        // as a run takes its steps (ns2d-sequential: no copy before a step, which leaves the state in cache, so a
        // step starts from the state the previous one wrote, as in `eci run`). The second row beside the first says
        // whether stepping from a fresh copy flatters the ratios.
        // hooked: each step between begin_attempt and end_attempt, the budget's rates recorded at every stage, as
        // eci run and eci.solve take their steps (ns2d-run-paired, sequential).
        const auto rounds = [&](const char* row, bool fresh, bool hooked = false) {
            state wc = w0, wr = w0;
            const auto step = [&](auto& st, state& w) {
                if (hooked) m.begin_attempt();
                const bool ok = bool(st.step(m, w, 0.0, dt));
                if (hooked) m.end_attempt(ok, dt, std::span<const double>(std::decay_t<decltype(st)>::tableau.b));
            };
            std::vector<double> c_fft, r_fft, c_r;
            for (int round = 0; round < 9 * reps; ++round) {
                double t = now();
                m.execute_transforms(4);
                const double fft = seconds_since(t);
                if (fresh) wc = w0;
                t = now();
                step(crk, wc);
                const double c = seconds_since(t);
                if (fresh) wr = w0;
                t = now();
                step(rk, wr);
                const double r = seconds_since(t);
                c_fft.push_back(c / fft), r_fft.push_back(r / fft), c_r.push_back(c / r);
            }
            std::printf("%s N=%d threads=%d clock=%s rounds=%d c_rk4/fft=%.4f rk4/fft=%.4f c_rk4/rk4=%.4f\n", row, p.n,
                        p.threads, use_cpu_clock ? "cpu" : "wall", 9 * reps, median(c_fft), median(r_fft),
                        median(c_r));
        };
        rounds("ns2d-paired", true);
        rounds("ns2d-sequential", false);
        rounds("ns2d-run-paired", false, true);
    }
    // The steps as a run takes them (the budget's rates recorded at every stage, as eci run and eci.solve do)
    std::printf("ns2d-run N=%d threads=%d rk4_run=%.6g c_rk4_run=%.6g rk4_run/rk4=%.4f c_rk4_run/rk4_run=%.4f "
                "c_rk4_run/fft=%.4f\n",
                p.n, p.threads, t_rk4_run, t_crk4_run, t_rk4_run / t_rk4, t_crk4_run / t_rk4_run, t_crk4_run / t_fft);
    // The conservative steppers' finishing passes side by side (c_rk4 and c_pc above are the default; the
    // modulus update is C-RK4's default before session 40).
    std::printf("ns2d-update N=%d c_rk4_paper/rk4=%.4f c_rk4_conditioned/rk4=%.4f c_pc_paper/pc=%.4f "
                "c_pc_conditioned/pc=%.4f c_rk4_modulus/rk4=%.4f\n",
                p.n, t_crk4_paper / t_rk4, t_crk4_cond / t_rk4, t_cpc_paper / t_pc, t_cpc_cond / t_pc,
                t_crk4_mod / t_rk4);
    {
        // The finishing passes alone (replayed stages, one thread's CPU time, median of 31 per stepper, interleaved
        // in 3 rounds): how much of c_rk4/rk4 each update costs, in ms and as a share of the RK4 step above.
        replay_model f;
        f.model = &m;
        f.record = true;
        {
            eci::rk4<state> r;
            state w = w0;
            r.step(f, w, 0.0, dt);
        }
        f.record = false;
        double r_rk4 = 1e300, r_cond = 1e300, r_paper = 1e300, r_modulus = 1e300;
        for (int round = 0; round < 3; ++round) {
            r_rk4 = std::min(r_rk4, replayed_step<eci::rk4<state>>(f, m, w0, dt, 31, 0));
            r_cond = std::min(r_cond, replayed_step<eci::c_rk4<state>>(f, m, w0, dt, 31, 0));
            r_paper = std::min(r_paper, replayed_step<eci::c_rk4<state>>(f, m, w0, dt, 31, 1));
            r_modulus = std::min(r_modulus, replayed_step<eci::c_rk4<state>>(f, m, w0, dt, 31, 3));
        }
        std::printf("ns2d-finish N=%d replayed_rk4_ms=%.3f conditioned_extra_ms=%.3f paper_extra_ms=%.3f "
                    "modulus_extra_ms=%.3f conditioned_extra/rk4_step=%.4f paper_extra/rk4_step=%.4f "
                    "modulus_extra/rk4_step=%.4f\n",
                    p.n, 1e3 * r_rk4, 1e3 * (r_cond - r_rk4), 1e3 * (r_paper - r_rk4), 1e3 * (r_modulus - r_rk4),
                    (r_cond - r_rk4) / t_rk4, (r_paper - r_rk4) / t_rk4, (r_modulus - r_rk4) / t_rk4);
    }
    {
        // What a run adds to each step: E and Z (eci::solve's invariants at every step), and a CSV row's max |u|
        // (inverse transforms of the velocity) and palinstrophy (`eci run` writes a row at every step by default).
        // Medians of 31 calls, in ms and as a share of the RK4 step above.
        const auto median_ms = [&](auto fn) {
            std::vector<double> v;
            for (int r = 0; r < 31; ++r) {
                const double t = now();
                fn();
                v.push_back(1e3 * seconds_since(t));
            }
            std::sort(v.begin(), v.end());
            return v[v.size() / 2];
        };
        double ez[2], sink = 0.0;
        const double inv_ms = median_ms([&] { m.invariant_values(w0, ez), sink += ez[0]; });
        const double umax_ms = median_ms([&] { sink += m.max_velocity(w0); });
        const double pal_ms = median_ms([&] { sink += m.palinstrophy(w0); });
        std::printf("ns2d-diagnostics N=%d invariants_ms=%.3f max_velocity_ms=%.3f palinstrophy_ms=%.3f "
                    "invariants/rk4_step=%.4f row/rk4_step=%.4f%s\n",
                    p.n, inv_ms, umax_ms, pal_ms, 1e-3 * inv_ms / t_rk4, 1e-3 * (umax_ms + pal_ms) / t_rk4,
                    sink == 0.0 ? " (zero field)" : "");
    }
    if (p.threads == 1) return 0;
    // Threads: a one-thread model beside this one, C-RK4 steps alternating between them in wall time, so load from
    // other processes hits both alike (on a shared machine it takes cores from the threaded one first).
    use_cpu_clock = false;
    eci::ns2d_params p1 = p;
    p1.threads = 1;
    eci::navier_stokes_2d m1(p1);
    double t1 = 1e300, tn = 1e300;
    for (int round = 0; round < 3 * reps; ++round) {
        t1 = std::min(t1, step_time<eci::c_rk4<state>>(m1, w0, dt, 1));
        tn = std::min(tn, step_time<eci::c_rk4<state>>(m, w0, dt, 1));
    }
    std::printf("ns2d-threads N=%d threads=%d clock=wall c_rk4_1=%.6g c_rk4_%d=%.6g speedup=%.4f\n", p.n, p.threads, t1,
                p.threads, tn, t1 / tn);
}
