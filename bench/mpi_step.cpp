// Per-step cost of the spectral core spread over MPI processes (ECI_MPI=ON), side by side in one run: a C-RK4
// step (its default, conditioned update, and the paper's update: crk4_paper) and an RK4 step of 2-D Navier-Stokes on MPI_COMM_WORLD, the transforms that step performs, and the all-to-alls
// inside those transforms (every 2-D transform is the 1-D transforms of a process's retained columns along y, an
// all-to-all of the retained columns, and the 1-D transforms of its rows along x).
// Run on one process it also times the serial grid (no communicator) in the same process with the same threads,
// so "1-rank MPI against the serial step" is a ratio of one run. (A communicator of one process takes the serial
// grid inside the library: the two rows then time the same code, and the 1-rank row's transposes are 0.)
//
//   mpirun -np P eci_bench_mpi_step N [threads] [reps]
//
// Prints one line per layout, key=value, wall seconds per step (the fastest of reps; each rep the slowest rank's
// time between barriers). bench/mpi.sh runs it for 1 and 2 processes and prints the ratios.
#include <mpi.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <numbers>
#include <vector>

#include <eci/eci.hpp>
#include <eci/models/navier_stokes_2d.hpp>

namespace {

using state = eci::navier_stokes_2d::state_type;

// The slowest rank's time of fn() between two barriers, the fastest of reps.
template <class Fn>
double timed(MPI_Comm comm, int reps, Fn fn) {
    double best = 1e300;
    for (int r = 0; r < reps; ++r) {
        MPI_Barrier(comm);
        const double t0 = MPI_Wtime();
        fn();
        double t = MPI_Wtime() - t0, slowest = 0.0;
        MPI_Allreduce(&t, &slowest, 1, MPI_DOUBLE, MPI_MAX, comm);
        best = std::min(best, slowest);
    }
    return best;
}

struct result {
    double crk4 = 0, crk4_paper = 0, rk4 = 0, transforms = 0, transposes = 0;
};

// One layout: the flow spread over `comm` (MPI_COMM_NULL: this process alone, the serial grid). Every process of
// `timing` calls it. A step is timed from the same field at CFL 0.5 each rep, as eci_bench_ns2d_step does.
result measure(int n, int threads, int reps, MPI_Comm comm, MPI_Comm timing) {
    eci::ns2d_params p;
    p.n = n;
    p.threads = threads;
    p.nu = 1e-4;
    p.comm = comm;
    eci::navier_stokes_2d m(p);
    const state w0 = m.random_field(n / 16.0, 0.5, 1);
    const double dt = 0.5 * (2.0 * std::numbers::pi / n) / m.max_velocity(w0);
    result r;
    state w = w0;
    // C-RK4 with its default update (the conditioned one, on any number of processes) and with the paper's
    for (const auto u : {eci::update_kind::conditioned, eci::update_kind::paper}) {
        eci::c_rk4<state> st;
        st.set_quadratic_invariants(m.quadratic_invariant_weights());
        st.remedy.update = u;
        st.step(m, w, 0.0, dt);  // buffers allocated
        (u == eci::update_kind::paper ? r.crk4_paper : r.crk4) = timed(timing, reps, [&] {
            w = w0;
            st.step(m, w, 0.0, dt);
        });
    }
    {
        eci::rk4<state> st;
        st.step(m, w, 0.0, dt);
        r.rk4 = timed(timing, reps, [&] {
            w = w0;
            st.step(m, w, 0.0, dt);
        });
    }
    // The transforms of an RK4 step: 4 right-hand sides of Basdevant's form, 2 inverse and 2 forward each (as the
    // step makes them, with the pass over the rows between them: one chain on one process, flow2d::run_stages).
    r.transforms = timed(timing, reps, [&] { m.execute_transforms(4); });
    // The all-to-alls inside them: one of the pair's retained columns each way per right-hand side.
    if (m.grid().distributed())
        r.transposes = timed(timing, reps, [&] {
            for (int s = 0; s < 4; ++s) m.grid().exchange(2);
        });
    return r;
}

}  // namespace

int main(int argc, char** argv) {
    MPI_Init(&argc, &argv);
    int rank = 0, ranks = 1;
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    MPI_Comm_size(MPI_COMM_WORLD, &ranks);
    if (argc < 2) {
        if (rank == 0) std::fprintf(stderr, "usage: mpirun -np P %s N [threads] [reps]\n", argv[0]);
        MPI_Finalize();
        return 2;
    }
    const int n = std::atoi(argv[1]);
    const int threads = argc > 2 ? std::atoi(argv[2]) : 1;
    const int reps = argc > 3 ? std::atoi(argv[3]) : 5;
    const auto print = [&](const char* layout, const result& r) {
        if (rank == 0)
            std::printf("N=%d ranks=%d threads=%d layout=%s crk4=%.6g crk4_paper=%.6g rk4=%.6g transforms=%.6g "
                        "transposes=%.6g\n", n, ranks, threads, layout, r.crk4, r.crk4_paper, r.rk4, r.transforms,
                        r.transposes);
    };
    // Alternated, twice, so a change of load hits both layouts alike; the faster of the two rounds is kept.
    result mpi, serial;
    const auto keep = [](result& best, const result& x) {
        if (best.crk4 == 0 || x.crk4 < best.crk4) best.crk4 = x.crk4;
        if (best.crk4_paper == 0 || x.crk4_paper < best.crk4_paper) best.crk4_paper = x.crk4_paper;
        if (best.rk4 == 0 || x.rk4 < best.rk4) best.rk4 = x.rk4;
        if (best.transforms == 0 || x.transforms < best.transforms) best.transforms = x.transforms;
        if (best.transposes == 0 || x.transposes < best.transposes) best.transposes = x.transposes;
    };
    for (int round = 0; round < 2; ++round) {
        keep(mpi, measure(n, threads, reps, MPI_COMM_WORLD, MPI_COMM_WORLD));
        if (ranks == 1) keep(serial, measure(n, threads, reps, MPI_COMM_NULL, MPI_COMM_WORLD));
    }
    print("mpi", mpi);
    if (ranks == 1) print("serial", serial);
    MPI_Finalize();
    return 0;
}
