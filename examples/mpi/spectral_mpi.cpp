// The spectral library from a user's own MPI program (built with -DECI_MPI=ON): the program owns MPI and
// hands eci a communicator. Here the world is split in two and each half runs its own decaying-turbulence case (a
// different seed), spread over its half's processes, with C-RK4: the communicator is all eci needs to know.
//
//   mpirun -np 4 build-mpi/examples/example_spectral_mpi
//
// Each process holds its own k_x columns of the state; E and Z are sums over every process of the group. The
// program checks that C-RK4 keeps both to round-off (8 eps sqrt(steps)) and exits non-zero otherwise.
#include <mpi.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>

#include <eci/spectral/step.hpp>

int main(int argc, char** argv) {
    MPI_Init(&argc, &argv);
    int world_rank = 0, world_size = 1;
    MPI_Comm_rank(MPI_COMM_WORLD, &world_rank);
    MPI_Comm_size(MPI_COMM_WORLD, &world_size);
    const int group = world_size > 1 ? world_rank % 2 : 0;
    MPI_Comm comm;
    MPI_Comm_split(MPI_COMM_WORLD, group, world_rank, &comm);
    int rank = 0;
    MPI_Comm_rank(comm, &rank);
    bool ok = true;
    {
        eci::ns2d_params p;
        p.n = 64;
        p.measure = false;
        p.comm = comm;  // the only MPI-specific line: the grid and flow are spread over `comm`
        eci::navier_stokes_2d flow(p);
        auto w = flow.random_field(6.0, 0.5, 1 + std::uint64_t(group));  // this process's columns of the state
        const double dt = 0.5 * (2.0 * std::numbers::pi / p.n) / flow.max_velocity(w);
        const double e0 = flow.energy(w), z0 = flow.enstrophy(w);  // collective: sums over the group
        eci::c_rk4<eci::navier_stokes_2d::state_type> stepper;
        eci::ns2d_budget budget;
        eci::run_stats stats;
        const int steps = 200;
        for (int i = 0; i < steps; ++i) eci::ns2d_step(stepper, flow, w, i * dt, dt, budget, stats);
        const double de = std::abs(flow.energy(w) - e0) / e0, dz = std::abs(flow.enstrophy(w) - z0) / z0;
        const double bound = 8.0 * std::numeric_limits<double>::epsilon() * std::sqrt(double(steps));
        ok = de <= bound && dz <= bound;
        const double palinstrophy = flow.palinstrophy(w);  // collective: every process of the group calls it
        if (rank == 0)
            std::printf("group %d (%d of %d processes, this one holding k_x = %d..%d): %d C-RK4 steps of %.4f, "
                        "E drift %.2g, Z drift %.2g (bound %.2g), palinstrophy %.6g\n",
                        group, flow.grid().ranks(), world_size, flow.first_column(),
                        flow.first_column() + flow.columns() - 1, steps, dt, de, dz, bound, palinstrophy);
    }
    MPI_Comm_free(&comm);
    int mine = ok ? 0 : 1, any = 0;
    MPI_Allreduce(&mine, &any, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
    MPI_Finalize();
    return any;
}
