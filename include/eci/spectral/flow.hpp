// eci::spectral::flow2d: a spectral equation of equation.hpp on the grid of grid.hpp, as a model the steppers
// step: the right-hand side (the equation's nonlinear term, linear terms, forcing) with the rates its parts give E
// and Z, the invariants, diagnostics (max |u|, CFL, spectra and fluxes) and initial fields. Link eci::spectral.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "../models/invariant.hpp"
#include "equation.hpp"
#include "grid.hpp"

namespace eci::spectral {

/// Which forcing drives the flow.
enum class forcing_kind { none, deterministic, stochastic };

/// The parameters of a flow: the equation and its constants, grid, dissipation, forcing and the FFT setup.
struct flow_params {
    std::string equation = "navier-stokes-2d";  ///< a name of equations()
    int n = 256;                       ///< grid points per side: even, at least 8
    double nu = 0.0;                   ///< viscosity: -nu |k|^2 q
    double hyper_nu = 0.0;             ///< hyperviscosity: -hyper_nu |k|^(2p) q
    int hyper_p = 2;                   ///< the hyperviscosity's power p, at least 1
    double hypo_nu = 0.0;              ///< hypoviscosity (large-scale friction): -hypo_nu |k|^(-2 hypo_p) q
    int hypo_p = 1;                    ///< the hypoviscosity's power, at least 1
    double drag = 0.0;                 ///< linear (Ekman) drag: -drag q
    double beta = 0.0;                 ///< Charney-Hasegawa-Mima: the planetary vorticity gradient (Rossby waves)
    double deformation = 0.0;          ///< Charney-Hasegawa-Mima: F = 1 / L_d^2 >= 0 in q = lap psi - F psi
    forcing_kind forcing = forcing_kind::none;
    double forcing_k = 4.0;            ///< centre k_f of the forced band k_f - 1/2 <= |k| < k_f + 1/2
    double forcing_amplitude = 1.0;    ///< deterministic forcing: rms of the forcing field (random fixed phases)
    double injection_rate = 1.0;       ///< stochastic forcing: mean energy injection rate epsilon
    std::uint64_t forcing_seed = 1;    ///< seed of the deterministic phases and of the stochastic generator
    int threads = 1;                   ///< FFTW and OpenMP threads
    bool measure = true;               ///< FFTW_MEASURE plans (FFTW_ESTIMATE when false)
    bool pruned_transforms = true;     ///< transform only the columns with retained modes, rows fused with the
                                       ///< products (grid_options::pruned); false: FFTW's 2-D plans
    std::string wisdom_file;           ///< FFTW wisdom read before planning and written after; empty: none; a
                                       ///< file there that is not wisdom is refused, not replaced
    std::string wisdom;                ///< FFTW wisdom text imported before planning (a checkpoint's, so that a
                                       ///< restart plans the same transforms and continues bit for bit)
#ifdef ECI_MPI
    MPI_Comm comm = MPI_COMM_NULL;     ///< the processes the flow is spread over (grid_options::comm); MPI build only
#endif

    /// Throws std::invalid_argument naming the first bad parameter (the equation's own included), and a grid
    /// that cannot fit in this machine's memory ("grid size N = 65536 needs about X GiB of memory, more than this
    /// machine's Y GiB": check_fits_in_memory of about 10 copies of FFTW's half plane, the measured peak of C-RK4).
    void validate() const;
    void validate(const spectral::equation& e) const;
    /// A whole-number field ("n", "hyper_p", "hypo_p", "threads") given as a wider integer (a CLI option, a Python
    /// int): `v` as an int when validate() would take it, else std::invalid_argument with validate()'s sentence, so
    /// that every front end refuses a value too wide for int as any other out of range.
    static int whole(std::string_view field, long long v);
    /// Whether a setting can change a run with these parameters: empty if it can, else the sentence refusing it. A
    /// forcing setting does nothing without its forcing (forcing_k and forcing_seed without any, forcing_amplitude
    /// without the deterministic one, injection_rate without the stochastic one), a power nothing without its
    /// coefficient (hyper_p with hyper_nu 0, hypo_p with hypo_nu 0). Both front ends refuse such a setting when it
    /// is given rather than ignore it (a forgotten `--forcing stochastic` ran unforced with the `--injection-rate`
    /// typed). `name` spells a setting as the caller's user types it (the CLI's "--forcing-k", Python's "forcing_k").
    std::string unused_setting(std::string_view field, std::string (*name)(std::string_view)) const;
    /// The forcing named "none", "deterministic" or "stochastic"; std::invalid_argument ("... must be none,
    /// deterministic or stochastic, not 'x'", preceded by name("forcing")) for any other.
    static forcing_kind forcing_named(std::string_view s, std::string (*name)(std::string_view));
    static std::string_view forcing_name(forcing_kind f);
};

/// What the linear terms and the forcing did to E and Z at one right-hand-side evaluation (rates, per unit time).
struct flow_rates {
    double energy_injection = 0.0;      ///< sum_k w_k |a_k| Re(conj(q_k) F_k)
    double energy_dissipation = 0.0;    ///< -sum_k w_k |a_k| Re(conj(q_k) L_k q_k)
    double enstrophy_injection = 0.0;   ///< sum_k w_k Re(conj(q_k) F_k)
    double enstrophy_dissipation = 0.0; ///< -sum_k w_k Re(conj(q_k) L_k q_k)
    double energy_transfer = 0.0;       ///< sum_k w_k |a_k| Re(conj(q_k) N_k): zero up to round-off
    double enstrophy_transfer = 0.0;    ///< sum_k w_k Re(conj(q_k) N_k): zero up to round-off
};

/// The budget of E and Z over steps: injection and dissipation integrated with the steps' own stages and weights.
struct flow_budget {
    double energy_injection = 0.0;       ///< dt sum_j b_j (energy_injection rate at stage j)
    double energy_dissipation = 0.0;     ///< dt sum_j b_j (energy_dissipation rate at stage j)
    double enstrophy_injection = 0.0;    ///< the same for Z
    double enstrophy_dissipation = 0.0;  ///< the same for Z
};

/// Energy and enstrophy flux through each shell: Pi(k) = -sum over shells k' <= k of the nonlinear transfer T(k'),
/// what the nonlinear term carries from the shells <= k to the others (positive: to smaller scales).
struct flow_fluxes {
    std::vector<double> energy, enstrophy;
};

/// A run stopped by flow2d::check_blow_up: what() is its sentence ("blow-up at step i, t = T: energy E (CFL c)"),
/// without the remedy, which is the front end's (its option names).
struct flow_blow_up : std::runtime_error {
    std::uint64_t step;  ///< the step that blew up
    double t;            ///< the time it reached
    std::size_t invariant;  ///< which blew up: 0 (E: not finite, or grown beyond the bound), 1 (Z not finite)
    bool finite;            ///< whether E and Z were still finite (E grown beyond the bound) or not
    flow_blow_up(const std::string& what, std::uint64_t step_, double t_, std::size_t invariant_, bool finite_)
        : std::runtime_error(what), step(step_), t(t_), invariant(invariant_), finite(finite_) {}
};

/// dq/dt = -u . grad q + L q + F on [0, 2 pi)^2 for the equation params().equation, with
/// L = i c(k) - (nu |k|^2 + nu_h |k|^2p + nu_hypo |k|^-2p' + drag).
///
/// The state holds the retained modes alone, 0 <= k_x <= kmax, |k_y| <= kmax, kmax + 1 columns (k_x = 0 ... kmax) of
/// 2 kmax + 1 rows (k_y = 0, 1, ..., kmax, -kmax, ..., -1, the half plane's order), normalised so that q(x) = sum_k
/// q_k e^{i k.x} over the full plane. That is 4/9 of FFTW's half plane: every pass of a stepper over the state, every
/// sum and every buffer is that much smaller. On one process with pruned transforms (the default) it is stored by
/// columns (by_columns()), because a right-hand side transforms along y first: each column is filled, transformed
/// and its result formed while it is in cache (grid::transform_product_columns). Otherwise (spread over processes,
/// or FFTW's 2-D plans) it is stored by rows, the grid's own order, which the passes over the grid's fields then
/// read and write in order. index(), kx(), ky() give where each mode is. k = 0 is zero and stays zero; on the
/// k_x = 0 column k and -k are both stored and are exact conjugates. to_half_plane() gives FFTW's layout (the
/// files' and the grid's), the same from either.
///
/// Spread over processes (flow_params::comm, MPI build), a process's state is the retained modes of its own
/// columns k_x = first_column() .. first_column() + columns() - 1 (the grid's slab cut to kx <= kmax; columns() may
/// be 0), stored by rows. Everything else is unchanged and the equation module never knows: sums (E, Z,
/// spectra, the budget's rates) are over every process in a fixed order (grid::sum_over_ranks), max |u| is the
/// global maximum, forcing and random fields are drawn per global mode (the same at any process count), and
/// to_half_plane / to_physical / from_half_plane / from_physical convert between the process's part and the whole
/// field (the whole field on every process; collective). What a process needs for files of the whole field without
/// holding it: its own rows of the field (to_physical_rows, from_physical_rows) and its own columns of the half
/// plane (to_half_plane_columns, from_half_plane_columns), the blocks of the file it writes or reads, and the field
/// gathered on one process alone (to_physical(q, root)). The steppers make their decisions global through
/// reduce_sums / reduce_max (detail/reduce.hpp), which a flow declares only in the MPI build.
class flow2d {
   public:
    using state_type = std::vector<std::complex<double>>;

    /// Plans the FFTs (once) and tabulates the coefficients. Throws std::invalid_argument for bad parameters.
    explicit flow2d(const flow_params& p);
    /// The same with an equation module that need not be in equations() (a user's own; p.equation is its name).
    flow2d(const flow_params& p, const spectral::equation& e);
    ~flow2d();
    flow2d(flow2d&&) noexcept;
    flow2d& operator=(flow2d&&) noexcept;
    flow2d(const flow2d&) = delete;
    flow2d& operator=(const flow2d&) = delete;

    /// FFTW's accumulated wisdom as text (holds this model's plans).
    static std::string fftw_wisdom() { return grid::fftw_wisdom(); }
    /// Adds FFTW wisdom text to the process's wisdom (what wisdom_file would import); false if it is not wisdom.
    static bool import_fftw_wisdom(const std::string& text) { return grid::import_fftw_wisdom(text); }
    /// Whether a file's text is FFTW wisdom (or empty): grid::is_fftw_wisdom.
    static bool is_fftw_wisdom(std::string_view text) { return grid::is_fftw_wisdom(text); }
    const flow_params& params() const;
    const equation& eq() const;
    const spectral::grid& grid() const;
    int n() const { return n_; }
    int kmax() const { return (n_ - 1) / 3; }
    /// Columns of the state, kmax + 1 (on MPI: this process's retained columns).
    int columns() const { return cols_; }
    /// The k_x of the state's first column (0 but on MPI).
    int first_column() const { return col0_; }
    /// Whether the state holds column k_x (always but on MPI).
    bool owns_column(int kx) const { return kx >= col0_ && kx < col0_ + cols_; }
    /// Rows of the state (modes per column), 2 kmax + 1.
    int rows() const { return 2 * kmax() + 1; }
    /// Modes in the state.
    std::size_t size() const { return std::size_t(rows()) * std::size_t(columns()); }
    /// Whether the state is stored by columns (mode (row r, column c) at c rows() + r) or by rows (r columns() + c).
    bool by_columns() const { return by_columns_; }
    /// The row (k_y = row, or row - rows() beyond kmax) and the column (k_x = first_column() + column) of mode i.
    std::size_t row_of(std::size_t i) const {
        return by_columns_ ? i % std::size_t(rows()) : i / std::size_t(columns());
    }
    std::size_t column_of(std::size_t i) const {
        return by_columns_ ? i / std::size_t(rows()) : i % std::size_t(columns());
    }
    int kx(std::size_t i) const { return kx_of_column(column_of(i)); }
    int ky(std::size_t i) const { return ky_of_row(row_of(i)); }
    /// k_x of the state's column c and k_y of its row r (no division: loops over rows and columns use these).
    int kx_of_column(std::size_t c) const { return col0_ + int(c); }
    int ky_of_row(std::size_t r) const { return int(r) <= kmax() ? int(r) : int(r) - rows(); }
    /// The index of the k-th mode in row order (the half plane's, and a state stored by rows): sums over the state
    /// (E, Z, spectra) add in that order, so that they are the same bits from either layout.
    std::size_t in_row_order(std::size_t k) const {
        if (!by_columns_) return k;
        const std::size_t c = std::size_t(columns());
        return (k % c) * std::size_t(rows()) + k / c;
    }
    /// The index of mode (kx, ky), 0 <= kx <= kmax, |ky| <= kmax (on MPI: owns_column(kx)).
    std::size_t index(int kx, int ky) const {
        const std::size_t r = std::size_t(ky >= 0 ? ky : ky + rows()), c = std::size_t(kx - col0_);
        return by_columns_ ? c * std::size_t(rows()) + r : r * std::size_t(columns()) + c;
    }
#ifdef ECI_MPI
    /// The steppers' reductions (detail/reduce.hpp): each v[i] summed over the processes in rank order, or its
    /// maximum. Collective; no-ops on one process.
    void reduce_sums(std::span<double> v) const { grid().sum_over_ranks(v.data(), v.size()); }
    void reduce_max(std::span<double> v) const { grid().max_over_ranks(v.data(), v.size()); }
    /// Whether the flow is spread over processes (a communicator of two or more): otherwise, also on a
    /// communicator of one process, the steppers treat it as a serial model (no reductions), and the grid takes the
    /// serial path, so the run is the serial one bit for bit.
    bool spread() const { return grid().distributed(); }
#endif
    /// The steppers' element-wise passes over the state, split between the flow's threads (detail/ranges.hpp):
    /// range_threads() ranges at most, body(i0, i1, thread) over each (grid::for_ranges). Spread over processes,
    /// over this process's share.
    int range_threads() const { return grid().threads(); }
    template <class Body>
    void for_ranges(std::size_t n, Body body) const {
        grid().for_ranges(n, body);
    }
    bool retained(std::size_t i) const { return weights_[i] != 0.0; }
    /// How often mode i appears in the full plane: 2 (itself and its conjugate -k, not stored), 1 on the k_x = 0
    /// column (where -k is stored too), 0 for k = 0.
    const std::vector<double>& weights() const { return weights_; }
    /// The state in FFTW's half plane, n rows of n/2 + 1 (zero beyond the retained modes), and back (the modes
    /// beyond are dropped). The layout of checkpoints.
    state_type to_half_plane(const state_type& q) const;
    state_type from_half_plane(const state_type& h) const;
    /// This process's columns of the half plane: n rows (the half plane's order) of grid().local_columns() modes,
    /// k_x = grid().first_column() + c, row-major (zero beyond the retained modes): the block of a checkpoint's
    /// state this process writes. On one process the whole half plane (to_half_plane). Not collective.
    state_type to_half_plane_columns(const state_type& q) const;
    /// The state from this process's columns of a half plane (as to_half_plane_columns gives them; the modes beyond
    /// are dropped): the block of a checkpoint this process reads. On one process from_half_plane. Not collective.
    state_type from_half_plane_columns(const state_type& columns) const;
    /// Makes q the state of a real field exactly, as every field the library makes is: the k_x = 0 column's k and -k
    /// exact conjugates and the mean, k = 0, zero (what check_initial_state takes to round-off).
    void make_hermitian(state_type& q) const;
    /// psi_k = inversion()[i] q_k (0 outside the retained modes).
    const std::vector<double>& inversion() const;
    /// E and Z as quadratic invariants sum_k c_k |q_k|^2 over the stored modes: w_k |a_k| / 2 and w_k / 2.
    std::vector<std::vector<double>> quadratic_invariant_weights() const;
    /// The names of E and Z for this equation (e.g. energy, enstrophy).
    std::array<std::string, 2> invariant_names() const;

    /// The right-hand side. Records the rates of the linear terms and forcing when recording is on.
    void operator()(const state_type& q, state_type& dqdt, double t);
    /// The stages of an explicit Runge-Kutta step of `stages` stages, as the steppers run them one at a time
    /// (detail::stage_storage) and with the same bits: k[0] = f(x), k[i] = f(Y_i), Y_i = x + sum_{j<i} (dt a_ij) k_j
    /// (a row-major, stages x stages; the nonzero a_ij in order), the last Y_i left in y; each evaluation recorded
    /// when recording is on. Run as one chain of column passes (grid::transform_product_chain): Y_i is formed column
    /// by column as the previous stage finishes that column, and filled into the transforms' columns while all of it
    /// is in cache, which saves a pass over the state per stage and a read of the transforms' columns; where Y_i's row
    /// of a is the one term a_{i,i-1}, in the loop that makes k_{i-1}, mode by mode. false, with
    /// nothing done, where the grid has no column pass (spread over processes, unpruned transforms): the caller
    /// then evaluates the stages one at a time. (The flow is autonomous: t, the step's start, is not read.)
    bool run_stages(int stages, const double* a, double dt, const state_type& x, state_type* k, state_type& y,
                    double t);
    /// The transforms of `stages` right-hand-side evaluations and nothing else, as a step of that many stages makes
    /// them (run_stages' chain where it takes them): the FFT floor of a step, for benchmarks.
    void execute_transforms(int stages = 1);
    /// How many transforms one right-hand side executes (4 in Basdevant's form, 5 in the advective one).
    int transforms_per_rhs() const;
    /// The fused column pass's loops over modes (filling the columns, the products, the right-hand side) in AVX2
    /// where the processor has it (the default), or in the baseline's: the same bits either way, which a test and
    /// the benchmarks compare. Turning them on where the processor lacks AVX2 leaves them off.
    void set_vector_passes(bool on);
    /// The form the right-hand side computes the nonlinear term in now: the equation's, or the advective form
    /// (which every equation allows) for a step retried in it.
    nonlinear_form form() const { return form_; }
    void set_form(nonlinear_form f);
    /// Attempts retried in the advective form (begin_retry), since construction.
    std::uint64_t form_retries() const { return form_retries_; }
    /// The nonlinear term alone, -u . grad q, dealiased (zero outside the retained modes).
    void nonlinear(const state_type& q, state_type& out);
    /// The same term by the advective form (5 transforms) whatever the equation's form.
    void nonlinear_advective(const state_type& q, state_type& out);
    /// The rates of one state (with the current forcing).
    flow_rates rates(const state_type& q);

    /// E = 1/2 sum |a_k| |q_k|^2 (full plane).
    double energy(const state_type& q) const;
    /// Z = 1/2 sum |q_k|^2.
    double enstrophy(const state_type& q) const;
    /// P = 1/2 sum |k|^2 |q_k|^2.
    double palinstrophy(const state_type& q) const;
    /// E and Z at once, into out[0] and out[1] (invariants()'s order; two values): one pass over the state, the bits
    /// of energy(q) and enstrophy(q). A run's invariant monitor takes them so at every step. Collective.
    void invariant_values(const state_type& q, std::span<double> out) const;
    /// The invariants the conservative methods keep in the inviscid, unforced limit (names: invariant_names()).
    static constexpr auto invariants() {
        return std::array<named_invariant<flow2d>, 2>{{{"energy", &flow2d::energy}, {"enstrophy", &flow2d::enstrophy}}};
    }
    /// max over the grid of |u|.
    double max_velocity(const state_type& q);
    /// Refuses an initial state whose arithmetic is beyond double precision with the one line every front end
    /// gives (std::invalid_argument): "initial condition is not finite" (a mode inf or nan), "initial condition:
    /// energy E and enstrophy Z must be finite normal numbers" (by invariant_names(); 0 is allowed), and a state
    /// that is not a real field's beyond the round-off of a transform (16 eps log2(N) ||q||): a k_x = 0 column that
    /// is not Hermitian, a mean (k = 0) that is not zero. Within it, make_hermitian makes it exact. Collective:
    /// every process of a spread flow gives the same verdict.
    void check_initial_state(const state_type& q) const;
    /// Refuses an initial state whose rate dq/dt is not finite (a field whose nonlinear term overflows: every step
    /// of it would fail, "a smaller dt" no help) with one line (std::invalid_argument). One right-hand side, not
    /// recorded in a step's budget; collective as check_initial_state. The front ends call it after that check.
    void check_initial_rates(const state_type& q);
    /// The front ends' blow-up stop, after step `step` (reaching t) of size dt with invariants {E, Z} (the run's
    /// monitor's values at q): throws flow_blow_up where E or Z is not finite, or where E exceeds 1e3 (e0 +
    /// injected), energy grown a thousandfold beyond the initial energy and what the forcing put in since (an
    /// unstable step grows it by orders of magnitude within a few steps; a forced flow's energy stays within its
    /// injection). Collective (the message's CFL), every process deciding alike (E, Z are global sums).
    void check_blow_up(const state_type& q, std::span<const double> invariants, double e0, double injected,
                       std::uint64_t step, double t, double dt);
    /// The CFL number of the front ends' default step (eci run's --cfl, Python's cfl_step and eci.solve).
    static constexpr double default_cfl = 0.5;
    /// The step of CFL number `cfl` at the initial state q, cfl dx / max|u|, at most cfl / max|omega| of the
    /// equation's linear waves (Rossby waves with beta) and at most 2 cfl / linear_rate() of its damping: the front
    /// ends' default step, after check_initial_state(q). std::invalid_argument naming the settings as the front
    /// end does (`dt_name`, `cfl_name`): "CFL must be a positive number", "the initial velocity is zero: give DT", "the time step from
    /// CFL c, CFL dx / max|u| = h, is not a positive finite number".
    double initial_cfl_step(const state_type& q, double cfl, std::string_view dt_name, std::string_view cfl_name);
    /// The fastest decay rate of the linear terms, max over the retained modes of nu |k|^2 + nu_h |k|^2p + mu +
    /// nu_hypo |k|^-2p' (0 inviscid; collective). An explicit step is stable on them only for dt times it within
    /// the method's real stability interval (2 for Euler, Heun and the midpoint rule, 2.79 for RK4).
    double linear_rate() const;
    /// "" where dt linear_rate() <= 2, else the sentence a front end adds to a failed step's message: the damping
    /// is too stiff for an explicit step of dt, and the dt that would be within every method's stability.
    std::string stiffness_hint(double dt) const;
    /// Where E and Z lose their relative precision: the number of retained modes (all processes') times DBL_MIN.
    /// Below it the invariants' terms (each at most |q_k|^2: the weights w_k |a_k| / 2 and w_k / 2 are at most 1 for
    /// every equation here) are subnormal and round to an absolute 2^-1074, so a per-step budget residual is measured
    /// relative to at least this value (it is then eps of it), not to a decayed E of 1e-320.
    double invariant_floor() const;
    /// One step's budget residual of an invariant, |after - before - (injection - dissipation)|, relative to the
    /// invariant after the step (before it, where a decayed flow reached exactly 0), and to at least
    /// invariant_floor(): what both front ends report per step (eci run's max_energy_budget_residual_per_step,
    /// Python's result.budget of the same name).
    double budget_residual(double before, double after, double injection, double dissipation) const {
        return std::abs(after - before - (injection - dissipation)) /
               std::max(after != 0.0 ? after : before, invariant_floor());
    }
    /// "" unless the field has decayed below double precision's normal range (Z(q) below invariant_floor(): its
    /// components' squares subnormal); then the sentence a front end gives for a failed step instead of "a smaller dt
    /// may pass": a conservative update is formed from those squares, which are round-off there, and a smaller step
    /// cannot help; a conventional method takes the field on to zero. Collective (Z).
    std::string decay_hint(const state_type& q) const;
    /// The CFL number max|u| dt / dx with dx = 2 pi / n.
    double cfl(const state_type& q, double dt);
    /// The shell-summed spectra E(k) and Z(k), k = 0, 1, ...: sums over modes with round(|k|) = k.
    std::vector<double> energy_spectrum(const state_type& q) const;
    std::vector<double> enstrophy_spectrum(const state_type& q) const;
    /// The fluxes Pi_E(k), Pi_Z(k) of the nonlinear term (one right-hand side's transforms).
    flow_fluxes fluxes(const state_type& q);

    /// The state of a real field sampled on the n x n grid (row-major, y rows): transformed, truncated, mean removed.
    state_type from_physical(std::span<const double> field);
    /// The field on the grid (row-major, y rows).
    std::vector<double> to_physical(const state_type& q);
    /// The field on process `root` of the flow's communicator alone (empty on the others; collective), for what
    /// one process must see whole (a picture). On one process to_physical(q) (root is 0).
    std::vector<double> to_physical(const state_type& q, int root);
    /// This process's rows of the field: grid().local_rows() rows of n values from y = grid().first_row(),
    /// row-major (collective); the whole field on one process.
    std::vector<double> to_physical_rows(const state_type& q);
    /// The state of a field of which this process gives its rows (as to_physical_rows gives them; collective):
    /// from_physical of a field no process holds whole. On one process from_physical.
    state_type from_physical_rows(std::span<const double> rows);
    /// The initial fields' settings a front end takes when none is given (eci run's --k-peak ..., Python's
    /// keywords): typed once, here.
    struct field_defaults {
        static constexpr double k_peak = 8.0, energy = 0.5;
        static constexpr std::uint64_t seed = 1;
        static constexpr double vortex_radius = 0.25, vortex_separation = 0.7, vortex_peak = 10.0;
        static constexpr double taylor_green_velocity = 1.0;
    };
    /// A random field with energy spectrum E(k) ~ s^4 / (1 + s^2)^4, s = k / k_peak (peak at k_peak, tail k^-4),
    /// random phases, scaled to energy `energy`.
    state_type random_field(double k_peak, double energy, std::uint64_t seed);
    /// Two co-rotating Gaussian vortices of radius `radius`, peak value `peak`, `separation` apart near the centre.
    state_type vortex_pair(double radius, double separation, double peak);
    /// q = 2 U sin x sin y: one |k|, so the nonlinear term vanishes (a steady Euler flow; a Rossby wave with beta).
    state_type taylor_green(double velocity);

    /// Draws the stochastic forcing for the next step of size dt (held constant over the step); a no-op otherwise.
    void draw_forcing(double dt);
    std::uint64_t rng_state() const { return rng_; }
    void set_rng_state(std::uint64_t s) { rng_ = s; }
    /// The forcing F_k held now (empty for an unforced run).
    const state_type& forcing() const;

    /// Starts recording the rates of each right-hand-side evaluation (cleared on each call).
    void start_recording();
    void stop_recording() { recording_ = false; }
    /// The rates recorded since start_recording, one per evaluation.
    std::span<const flow_rates> recorded() const { return {recorded_.data(), recorded_count_}; }

    // The step hooks the drivers call (concepts.hpp), which make any Runge-Kutta run of the flow a budgeted one.
    /// Before a step of the grid: draws its stochastic forcing (held through retries and halvings) and clears
    /// step_budget().
    void begin_step(double dt);
    /// Before an attempt: records the rates of its stages.
    void begin_attempt() { start_recording(); }
    /// After an attempt: if accepted, adds dt sum_j b_j (the rates of stage j) to step_budget(). Sum w xi changes by
    /// exactly dt sum_j b_j sum_k w_k 2 psi_k^(j) S_k^(j) (errata item 9): with S split into its nonlinear (zero),
    /// linear and forcing parts, these are the discrete dissipation and injection.
    void end_attempt(bool accepted, double dt, std::span<const double> b);
    /// After a failed first attempt: Basdevant's form leaves round-off of random sign in components that are
    /// exactly zero (a Taylor-Green flow's), where the paper's radicand is then negative at every step size; the
    /// advective form's round-off differs (for such symmetric flows its products cancel exactly). So the step is
    /// taken again in the advective form (true) before it is halved; false in the advective form already.
    bool begin_retry();
    /// After that step (completed: it is counted in form_retries()): back to the equation's form.
    void end_retry(bool completed);
    /// The budget of the current step (of its accepted attempts), since begin_step.
    const flow_budget& step_budget() const { return step_budget_; }

   private:
    template <class Value>
    std::vector<double> shells(Value value) const;
    struct impl;
    int n_;
    int col0_ = 0, cols_ = 0;  // the state's columns k_x = col0_ .. col0_ + cols_ - 1
    bool by_columns_ = false;
    std::vector<double> weights_;
    std::unique_ptr<impl> d_;
    std::uint64_t rng_ = 0;
    bool recording_ = false;
    nonlinear_form form_ = nonlinear_form::advective;
    std::uint64_t form_retries_ = 0;
    std::array<flow_rates, 16> recorded_{};
    std::size_t recorded_count_ = 0;
    flow_budget step_budget_{};
};

}  // namespace eci::spectral
