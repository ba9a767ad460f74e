// The spectral core spread over MPI processes against the same run on one process (no communicator), run under
// `mpirun -np P` (P = 1, 2, 3 by ctest, label mpi). Every check is made on every rank and the verdicts combined;
// rank 0 prints one line per check. Exit 0 when all hold, 1 otherwise.
//
// Why the bounds are what they are: the distributed transforms (1-D transforms of the columns and of the rows, an
// all-to-all between them) and the reductions (per-rank partial sums added in rank order) round differently from
// the serial ones, by a few eps per operation. Over s steps these differences are independent of sign from step to step, so they add up like a
// random walk: k eps sqrt(s) relative to the state's largest mode, k counting the operations whose round-off enters
// one step (the transforms' log2(N) levels and the 4 stages). The run is short enough in time (dt = 0.002) that
// the flow's own amplification of differences stays O(1). E and Z of a conservative method change by round-off
// only (each step rounds them by a few eps, again as a random walk).
#include <mpi.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdio>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <utility>
#include <string>
#include <vector>

#include <eci/adaptive.hpp>
#include <eci/memory.hpp>
#include <eci/spectral/step.hpp>

namespace {

using eci::navier_stokes_2d;
using state = navier_stokes_2d::state_type;
constexpr double eps = std::numeric_limits<double>::epsilon();

int rank_ = 0, ranks_ = 1;
bool all_ok = true;

void check(bool ok, const std::string& what) {
    int mine = ok ? 1 : 0, all = 0;
    MPI_Allreduce(&mine, &all, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
    if (rank_ == 0) std::printf("%s %s\n", all ? "ok  " : "FAIL", what.c_str());
    if (!all) all_ok = false;
}

// The update the conservative steppers take (the conditioned one by default; some checks take the
// paper's), spread over processes and on one alike.
eci::update_kind update_ = eci::update_kind::conditioned;
template <class Stepper>
void set_update(Stepper& st) {
    if constexpr (requires { st.remedy.update; }) st.remedy.update = update_;
}

struct run_result {
    state half;  // the final state, FFTW's half plane (the whole field, on every rank)
    double e0, z0, e1, z1;
    eci::ns2d_budget budget;
    double max_budget_residual = 0.0;  // per step, relative
};

// `steps` steps from the random field of seed 1 (or from `start`, a half plane, with the generator at `rng`).
template <class Stepper>
run_result run(eci::ns2d_params p, MPI_Comm comm, int steps, double dt, const state* start = nullptr,
               std::uint64_t rng = 0, std::uint64_t* rng_out = nullptr) {
    p.comm = comm;
    navier_stokes_2d m(p);
    state w = start ? m.from_half_plane(*start) : m.random_field(4.0, 0.5, 1);
    if (start) m.set_rng_state(rng);
    Stepper st;
    set_update(st);
    run_result r{};
    r.e0 = m.energy(w);
    r.z0 = m.enstrophy(w);
    eci::run_stats stats;
    for (int i = 0; i < steps; ++i) {
        const double e0 = m.energy(w);
        eci::ns2d_budget b;
        eci::ns2d_step(st, m, w, i * dt, dt, b, stats);
        const double e1 = m.energy(w);
        r.max_budget_residual = std::max(
            r.max_budget_residual, std::abs(e1 - e0 - (b.energy_injection - b.energy_dissipation)) / e1);
        r.budget.energy_injection += b.energy_injection;
        r.budget.energy_dissipation += b.energy_dissipation;
    }
    r.e1 = m.energy(w);
    r.z1 = m.enstrophy(w);
    r.half = m.to_half_plane(w);
    if (rng_out) *rng_out = m.rng_state();
    return r;
}

// max |a - b| / max |b|
double rel_diff(const state& a, const state& b) {
    double d = 0.0, s = 0.0;
    for (std::size_t i = 0; i < b.size(); ++i) {
        d = std::max(d, std::abs(a[i] - b[i]));
        s = std::max(s, std::abs(b[i]));
    }
    return d / s;
}

bool same_bits(const state& a, const state& b) {
    if (a.size() != b.size()) return false;
    for (std::size_t i = 0; i < a.size(); ++i)
        if (a[i].real() != b[i].real() || a[i].imag() != b[i].imag()) return false;
    return true;
}

std::string num(double v) {
    char b[32];
    std::snprintf(b, sizeof b, "%.3g", v);
    return b;
}

template <class Stepper>
void against_serial(const std::string& name, eci::ns2d_params p, int steps, double dt, double k, bool conservative) {
    const run_result one = run<Stepper>(p, MPI_COMM_NULL, steps, dt);
    const run_result all = run<Stepper>(p, MPI_COMM_WORLD, steps, dt);
    const double bound = k * eps * std::sqrt(double(steps)), d = rel_diff(all.half, one.half);
    check(d <= bound, name + ": state after " + std::to_string(steps) + " steps = the serial run's to " + num(d) +
                          " <= " + num(k) + " eps sqrt(steps) = " + num(bound));
    if (ranks_ == 1)  // a communicator of one process takes the serial grid: the same bits, not only round-off
        check(same_bits(all.half, one.half), name + ": on a communicator of one process, the serial run bit for bit");
    const run_result again = run<Stepper>(p, MPI_COMM_WORLD, steps, dt);
    check(same_bits(again.half, all.half), name + ": a second run on the same ranks repeats bit for bit");
    if (conservative && p.nu == 0.0 && p.forcing == eci::ns2d_forcing::none) {
        // C-RK4 conserves E and Z to round-off: a few eps per step, accumulated as a random walk
        const double de = std::abs(all.e1 - all.e0) / all.e0, dz = std::abs(all.z1 - all.z0) / all.z0;
        const double b = 8.0 * eps * std::sqrt(double(steps));
        check(de <= b && dz <= b, name + ": E and Z exact: drift " + num(de) + ", " + num(dz) + " <= 8 eps sqrt(steps) = " + num(b));
    }
    if (p.nu != 0.0 || p.forcing != eci::ns2d_forcing::none) {
        // a conservative method's budget closes per step: E1 - E0 = injection - dissipation to round-off of E
        if (conservative)
            check(all.max_budget_residual <= 64.0 * eps,
              name + ": budget closed per step to " + num(all.max_budget_residual) + " <= 64 eps of E");
        const double di = std::abs(all.budget.energy_injection - one.budget.energy_injection) /
                          std::max(std::abs(one.budget.energy_injection), 1e-300);
        if (p.forcing != eci::ns2d_forcing::none)
            check(di <= bound, name + ": the injected energy = the serial run's to " + num(di) +
                                   " (forcing drawn per global mode)");
    }
}

}  // namespace

int main(int argc, char** argv) {
    MPI_Init(&argc, &argv);
    MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
    int ranks = 1;
    MPI_Comm_size(MPI_COMM_WORLD, &ranks);
    ranks_ = ranks;
    if (rank_ == 0) std::printf("spectral core on %d MPI process(es)\n", ranks);
    {
        eci::ns2d_params p;
        p.n = 32;
        p.measure = false;  // FFTW_ESTIMATE: the same plans on every run
        const double dt = 0.002;
        const double k = 16.0;  // measured: at most 0.6 eps sqrt(steps) on 1-3 ranks
        using S = state;
        against_serial<eci::c_rk4<S>>("navier-stokes-2d N=32 C-RK4 inviscid", p, 100, dt, k, true);
        update_ = eci::update_kind::paper;
        against_serial<eci::c_rk4<S>>("navier-stokes-2d N=32 C-RK4 inviscid, the paper's update", p, 100, dt, k, true);
        update_ = eci::update_kind::conditioned;
        against_serial<eci::rk4<S>>("navier-stokes-2d N=32 RK4 inviscid", p, 100, dt, k, false);
        p.n = 64;
        against_serial<eci::c_rk4<S>>("navier-stokes-2d N=64 C-RK4 inviscid", p, 100, dt, k, true);
        eci::ns2d_params f = p;
        f.n = 32;
        f.nu = 1e-3;
        f.forcing = eci::ns2d_forcing::stochastic;
        f.forcing_k = 3.0;
        against_serial<eci::c_rk4<S>>("navier-stokes-2d N=32 C-RK4 viscous, stochastic forcing", f, 100, dt, k, true);
        f.forcing = eci::ns2d_forcing::deterministic;
        against_serial<eci::rk4<S>>("navier-stokes-2d N=32 RK4 viscous, deterministic forcing", f, 100, dt, k, false);
        eci::ns2d_params c = p;
        c.n = 32;
        c.equation = "charney-hasegawa-mima";
        c.beta = 2.0;
        c.deformation = 1.0;
        against_serial<eci::c_rk4<S>>("charney-hasegawa-mima N=32 C-RK4", c, 100, dt, k, true);
        // A grid whose retained columns do not split evenly between the processes (N = 48: kmax + 1 = 16 retained
        // columns, 5 + 5 + 6 on 3 ranks; 25 rows and columns of the half plane): the serial run to round-off, and
        // every process's share of the state within one column of the others'.
        {
            eci::ns2d_params b = p;
            b.n = 48;
            b.nu = 1e-3;
            const run_result ser = run<eci::c_rk4<S>>(b, MPI_COMM_NULL, 100, dt);
            const run_result spread = run<eci::c_rk4<S>>(b, MPI_COMM_WORLD, 100, dt);
            const double bound = k * eps * std::sqrt(100.0);
            const double d = rel_diff(spread.half, ser.half);
            check(d <= bound, "N=48 C-RK4 viscous: " + num(d) + " from the serial state after 100 steps, <= " +
                                  num(bound));
            navier_stokes_2d m([&] { auto c = b; c.comm = MPI_COMM_WORLD; return c; }());
            int mine[2] = {m.columns(), -m.columns()}, most[2] = {0, 0};
            MPI_Allreduce(mine, most, 2, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
            check(most[0] + most[1] <= 1, "N=48 on " + std::to_string(ranks) + " process(es): the state's columns " +
                                              std::to_string(-most[1]) + " .. " + std::to_string(most[0]) +
                                              " per process");
        }

        eci::ns2d_params q = p;
        q.n = 32;
        q.equation = "surface-qg";
        against_serial<eci::c_rk4<S>>("surface-qg N=32 C-RK4", q, 100, dt, k, true);

        // A restart on another number of processes: 50 steps on a communicator of ceil(P/2) ranks, its state
        // (the half plane, as in a checkpoint) continued for 50 on all P and on rank 0 alone, against 100 steps
        // on all P in one go. The generator's state travels with it (stochastic forcing).
        MPI_Comm half = MPI_COMM_NULL, solo = MPI_COMM_NULL;
        MPI_Comm_split(MPI_COMM_WORLD, rank_ < (ranks + 1) / 2 ? 0 : MPI_UNDEFINED, rank_, &half);
        MPI_Comm_split(MPI_COMM_WORLD, rank_ == 0 ? 0 : MPI_UNDEFINED, rank_, &solo);
        eci::ns2d_params r = f;
        r.forcing = eci::ns2d_forcing::stochastic;
        state mid;
        std::uint64_t rng = 0;
        if (half != MPI_COMM_NULL) mid = run<eci::c_rk4<S>>(r, half, 50, dt, nullptr, 0, &rng).half;
        // the half plane and generator to every rank (as every rank reads a checkpoint)
        mid.resize(std::size_t(r.n) * std::size_t(r.n / 2 + 1));
        MPI_Bcast(mid.data(), int(2 * mid.size()), MPI_DOUBLE, 0, MPI_COMM_WORLD);
        MPI_Bcast(&rng, 1, MPI_UINT64_T, 0, MPI_COMM_WORLD);
        struct restartable {
            static run_result go(eci::ns2d_params p, MPI_Comm c, int steps, double dt, const state* s, std::uint64_t g) {
                return run<eci::c_rk4<S>>(p, c, steps, dt, s, g);
            }
        };
        const run_result whole = run<eci::c_rk4<S>>(r, MPI_COMM_WORLD, 100, dt);
        // the second half's step times start at 0 in run(): the flow is autonomous, so the times do not matter
        const run_result on_all = restartable::go(r, MPI_COMM_WORLD, 50, dt, &mid, rng);
        const double bound = k * eps * std::sqrt(100.0);
        const double d_all = rel_diff(on_all.half, whole.half);
        check(d_all <= bound, "restart from " + std::to_string((ranks + 1) / 2) + " rank(s) on " +
                                  std::to_string(ranks) + ": continues the run to " + num(d_all) + " <= " + num(bound));
        double d_solo = 0.0;
        if (solo != MPI_COMM_NULL) d_solo = rel_diff(restartable::go(r, solo, 50, dt, &mid, rng).half, whole.half);
        MPI_Bcast(&d_solo, 1, MPI_DOUBLE, 0, MPI_COMM_WORLD);
        check(d_solo <= bound, "restart from " + std::to_string((ranks + 1) / 2) + " rank(s) on 1: continues the run to " +
                                   num(d_solo) + " <= " + num(bound));

        // The library on a communicator of one process (rank 0 alone, at any number of ranks) takes the serial
        // grid: not spread (the steppers' reductions empty, the conditioned update taken as on one
        // process), the serial layout, and the serial run's state bit for bit, with the default update and with the
        // pruned transforms (which the MPI transforms do not have).
        {
            int verdict[3] = {1, 1, 1};
            if (solo != MPI_COMM_NULL) {
                auto steps_on = [&](MPI_Comm comm, bool pruned, bool& spread, int& same_comm) {
                    eci::ns2d_params s = f;
                    s.comm = comm;
                    s.pruned_transforms = pruned;
                    navier_stokes_2d m(s);
                    spread = m.spread() || m.grid().distributed() || m.grid().ranks() != 1;
                    if (comm != MPI_COMM_NULL) MPI_Comm_compare(m.grid().comm(), comm, &same_comm);
                    state w = m.random_field(4.0, 0.5, 1);
                    eci::c_rk4<S> st;  // (the default update: the conditioned one)
                    eci::ns2d_budget b;
                    eci::run_stats stats;
                    for (int i = 0; i < 100; ++i) eci::ns2d_step(st, m, w, i * dt, dt, b, stats);
                    return m.to_half_plane(w);
                };
                bool spread = false, spread_null = false;
                int same_comm = MPI_UNEQUAL, ignored = 0;
                for (bool pruned : {false, true}) {
                    const state alone = steps_on(solo, pruned, spread, same_comm);
                    const state serial = steps_on(MPI_COMM_NULL, pruned, spread_null, ignored);
                    verdict[pruned ? 1 : 0] = same_bits(alone, serial) ? 1 : 0;
                }
                verdict[2] = !spread && !spread_null && same_comm == MPI_CONGRUENT ? 1 : 0;
            }
            MPI_Bcast(verdict, 3, MPI_INT, 0, MPI_COMM_WORLD);
            check(verdict[2] == 1, "a communicator of one process: not spread, one rank, a duplicate of it in comm()");
            check(verdict[0] == 1, "a communicator of one process: 100 C-RK4 steps (conditioned update, forced, "
                                   "viscous) = the serial run bit for bit");
            check(verdict[1] == 1, "a communicator of one process, pruned transforms: = the serial run bit for bit");
        }
        if (half != MPI_COMM_NULL) MPI_Comm_free(&half);
        if (solo != MPI_COMM_NULL) MPI_Comm_free(&solo);

        // The remedy of negative radicands spread over ranks (its counts, defects, Gram sums and largest weights
        // reduced; its decisions the same on every rank): a spectrum |omega_k| = exp(-|k|/3) falls below round-off
        // inside the retained modes, where the radicands come out negative, at CFL 0.5. With the conditioned update
        // the ill-conditioned modes are chosen from the histogram summed over the ranks (one cut for all), and
        // their conventional updates with the negative radicands' restored by one rescale solved from global sums.
        for (const auto u : {eci::update_kind::paper, eci::update_kind::conditioned}) {
            const std::string name = u == eci::update_kind::paper ? "remedy (paper's update)" : "conditioned update";
            auto remedied = [&](MPI_Comm comm, std::uint64_t& steps_remedied, std::uint64_t& halvings,
                                std::uint64_t& conditioned) {
                eci::ns2d_params e = p;
                e.n = 32;
                e.comm = comm;
                navier_stokes_2d m(e);
                state w = m.random_field(4.0, 0.5, 17);
                for (std::size_t i = 0; i < m.size(); ++i) {
                    if (!m.retained(i) || std::abs(w[i]) == 0.0) continue;
                    w[i] *= std::exp(-std::hypot(double(m.kx(i)), double(m.ky(i))) / 3.0) / std::abs(w[i]);
                }
                const double dt0 = 0.5 * (2.0 * std::numbers::pi / e.n) / m.max_velocity(w);
                const double e0 = m.energy(w), z0 = m.enstrophy(w);
                eci::c_rk4<S> st;
                st.remedy.update = u;
                eci::ns2d_budget b;
                eci::run_stats stats;
                double drift = 0.0;
                for (int i = 0; i < 50; ++i) {
                    eci::ns2d_step(st, m, w, i * dt0, dt0, b, stats);
                    drift = std::max({drift, std::abs(m.energy(w) - e0) / e0, std::abs(m.enstrophy(w) - z0) / z0});
                }
                steps_remedied = st.remedy_statistics().remedied_steps;
                conditioned = st.remedy_statistics().conditioned;
                halvings = stats.step_reductions;
                return std::make_pair(m.to_half_plane(w), drift);
            };
            std::uint64_t rs = 0, hs = 0, cs = 0, rd = 0, hd = 0, cd = 0;
            const auto [ws, drift_s] = remedied(MPI_COMM_NULL, rs, hs, cs);
            const auto [wd, drift_d] = remedied(MPI_COMM_WORLD, rd, hd, cd);
            std::uint64_t mine[3] = {rd, hd, cd}, lo[3] = {}, hi[3] = {};
            MPI_Allreduce(mine, lo, 3, MPI_UINT64_T, MPI_MIN, MPI_COMM_WORLD);
            MPI_Allreduce(mine, hi, 3, MPI_UINT64_T, MPI_MAX, MPI_COMM_WORLD);
            // the conditioned update takes ill-conditioned modes conventional in this run (else it tests nothing)
            const bool engaged = u == eci::update_kind::paper || cd > 0;
            check(rd > 0 && engaged && lo[0] == hi[0] && lo[1] == hi[1] && lo[2] == hi[2],
                  name + ": " + std::to_string(rd) + " remedied steps, " + std::to_string(hd) + " halvings, " +
                      std::to_string(cd) + " unknowns taken conventional, the same on every rank (serial: " +
                      std::to_string(rs) + ", " + std::to_string(hs) + ", " + std::to_string(cs) + ")");
            const double b = 8.0 * eps * std::sqrt(50.0);
            check(drift_d <= b, name + ": E and Z exact through remedied steps: drift " + num(drift_d) +
                                    " <= 8 eps sqrt(steps)");
            const double d = rel_diff(wd, ws);
            check(d <= k * eps * std::sqrt(50.0), name + ": state = the serial run's to " + num(d));
        }

        // the field on the grid (snapshots) and back
        eci::ns2d_params g = p;
        g.n = 32;
        navier_stokes_2d ms(g);
        g.comm = MPI_COMM_WORLD;
        navier_stokes_2d md(g);
        const state ws = ms.random_field(4.0, 0.5, 1), wd = md.random_field(4.0, 0.5, 1);
        const std::vector<double> fs = ms.to_physical(ws), fd = md.to_physical(wd);
        double dphys = 0.0, smax = 0.0;
        for (std::size_t i = 0; i < fs.size(); ++i)
            dphys = std::max(dphys, std::abs(fd[i] - fs[i])), smax = std::max(smax, std::abs(fs[i]));
        check(fd.size() == fs.size() && dphys <= 16.0 * eps * smax,
              "to_physical = the serial field to " + num(dphys / smax) + " <= 16 eps of max |q|");
        const double back = rel_diff(md.to_half_plane(md.from_physical(fd)), ms.to_half_plane(ws));
        check(back <= 16.0 * eps, "from_physical(to_physical(q)) = q to " + num(back) + " <= 16 eps");
        const double vs = ms.max_velocity(ws), vd = md.max_velocity(wd);
        check(std::abs(vs - vd) <= 16.0 * eps * vs, "max |u| = the serial value to 16 eps");
        const auto es = ms.energy_spectrum(ws), ed = md.energy_spectrum(wd);
        double dspec = 0.0, stot = 0.0;
        for (std::size_t i = 0; i < es.size(); ++i) dspec = std::max(dspec, std::abs(es[i] - ed[i])), stot += es[i];
        check(es.size() == ed.size() && dspec <= 16.0 * eps * stot, "energy spectrum = the serial one to 16 eps of E");

        // What a process writes into and reads from a file of the whole field (snapshots, checkpoints, --ic,
        // --restart): its own rows of the field and its own columns of the half plane, no more; the whole field
        // only on the one process that asks for it (a picture)
        const eci::spectral::grid& gd = md.grid();
        const std::size_t n = std::size_t(g.n), nc = n / 2 + 1;
        const std::size_t rows = std::size_t(gd.local_rows()), cols = std::size_t(gd.local_columns());
        const std::vector<double> mine = md.to_physical_rows(wd);
        double drows = 0.0;
        if (mine.size() == rows * n)
            for (std::size_t i = 0; i < mine.size(); ++i)
                drows = std::max(drows, std::abs(mine[i] - fs[std::size_t(gd.first_row()) * n + i]));
        check(mine.size() == rows * n && drows <= 16.0 * eps * smax,
              "to_physical_rows: this process's " + std::to_string(rows) + " rows of the serial field to " +
                  num(drows / smax));
        // (the rows of every process are the field's rows once each: no process holds more than its share)
        double total_rows = double(rows), most_rows = double(rows);
        MPI_Allreduce(MPI_IN_PLACE, &total_rows, 1, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
        MPI_Allreduce(MPI_IN_PLACE, &most_rows, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
        check(total_rows == double(n) && (ranks == 1 || most_rows < double(n)),
              "the processes' rows are the field's " + std::to_string(n) + ", at most " + num(most_rows) + " each");
        const double from_rows = rel_diff(md.to_half_plane(md.from_physical_rows(mine)), ms.to_half_plane(ws));
        check(from_rows <= 16.0 * eps, "from_physical_rows(to_physical_rows(q)) = q to " + num(from_rows));
        const state part = md.to_half_plane_columns(wd), gathered = md.to_half_plane(wd);
        bool cut = part.size() == n * cols;
        for (std::size_t r = 0; cut && r < n; ++r)
            for (std::size_t c = 0; c < cols; ++c)
                cut = cut && part[r * cols + c] == gathered[r * nc + std::size_t(gd.first_column()) + c];
        check(cut, "to_half_plane_columns: this process's " + std::to_string(cols) +
                       " columns of the gathered half plane, bit for bit");
        double total_cols = double(cols), most_cols = double(cols);
        MPI_Allreduce(MPI_IN_PLACE, &total_cols, 1, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
        MPI_Allreduce(MPI_IN_PLACE, &most_cols, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
        check(total_cols == double(nc) && (ranks == 1 || most_cols < double(nc)),
              "the processes' columns are the half plane's " + std::to_string(nc) + ", at most " + num(most_cols) +
                  " each");
        check(same_bits(md.from_half_plane_columns(part), wd), "from_half_plane_columns(to_half_plane_columns(q)) = q");
        // a checkpoint of the serial run read by columns on these processes: the serial state's modes exactly
        state serial_cut(n * cols);
        const state hs = ms.to_half_plane(ws);
        for (std::size_t r = 0; r < n; ++r)
            for (std::size_t c = 0; c < cols; ++c)
                serial_cut[r * cols + c] = hs[r * nc + std::size_t(gd.first_column()) + c];
        check(same_bits(md.to_half_plane(md.from_half_plane_columns(serial_cut)), hs),
              "from_half_plane_columns of the serial half plane's columns: the serial state bit for bit");
        for (int root : {0, ranks - 1}) {
            const std::vector<double> at = md.to_physical(wd, root);
            check(rank_ == root ? at == fd : at.empty(),
                  "to_physical(q, " + std::to_string(root) + "): the whole field on rank " + std::to_string(root) +
                      " alone, nothing on the others");
        }
        // an initial field made from this process's rows alone
        const double pair = rel_diff(md.to_half_plane(md.vortex_pair(0.25, 0.7, 10.0)),
                                     ms.to_half_plane(ms.vortex_pair(0.25, 0.7, 10.0)));
        check(pair <= 16.0 * eps, "vortex_pair from each process's rows = the serial one to " + num(pair));
    }
    // The embedded pairs decide over this process's unknowns alone (their error norm, their negative radicands,
    // the first-step rule): on a spread state they are refused on every process before any collective, so none is
    // left waiting; on one process they step as they do serially.
    {
        eci::ns2d_params p;
        p.n = 32;
        p.measure = false;
        p.comm = MPI_COMM_WORLD;
        navier_stokes_2d m(p);
        state w = m.random_field(4.0, 0.5, 1);
        const auto refused = [](auto&& call) {
            try {
                call();
                return false;
            } catch (const std::invalid_argument&) {
                return true;
            }
        };
        eci::c_dp54<state> st;
        const bool step_refused = refused([&] { st.step(m, w, 0.0, 0.002); });
        const bool first_refused = refused([&] { eci::choose_first_step(m, w, 0.0, 1.0, 5, eci::adaptive_options{}); });
        check(step_refused == m.spread() && first_refused == m.spread(),
              std::string("C-DP54 and the first-step rule on ") + (m.spread() ? "a spread state: refused on every "
                                                                                 "process, none left waiting"
                                                                               : "one process: they run"));
    }
    // The memory guard counts a process's share: a grid whose whole does not fit in one machine's memory but whose
    // 1/P share does is refused on one process and taken spread over P (the smallest such N, from this machine's
    // memory; none where N = 65536 still fits whole).
    if (ranks_ > 1) {
        const double have = eci::physical_memory();
        const auto need = [](int n) { return 10.0 * 16.0 * double(n) * double(n / 2 + 1); };
        int n = 8;
        while (n < 65536 && need(n) <= have) n *= 2;
        while (n > 8 && need(n - 2) > have) n -= 2;
        if (have > 0.0 && need(n) > have && need(n) / ranks_ <= have) {
            eci::ns2d_params big;
            big.n = n;
            bool alone = false, spread = true;
            try {
                big.validate();
            } catch (const std::invalid_argument&) {
                alone = true;
            }
            big.comm = MPI_COMM_WORLD;
            try {
                big.validate();
            } catch (const std::invalid_argument&) {
                spread = false;
            }
            check(alone && spread, "N = " + std::to_string(n) + ", beyond this machine's memory whole: refused on one "
                                   "process, taken spread over " + std::to_string(ranks_));
        }
    }
    MPI_Finalize();
    return all_ok ? 0 : 1;
}
