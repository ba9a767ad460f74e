// The files of the spectral equations' `eci run` (navier-stokes-2d, charney-hasegawa-mima, surface-qg): HDF5
// snapshots and checkpoints (written atomically), and the field and spectrum figures drawn by gnuplot.
#pragma once

#include <complex>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <eci/models/navier_stokes_2d.hpp>

#ifdef ECI_MPI
#include <mpi.h>
#endif

namespace eci::cli {

/// Everything a restart needs: parameters, state, step counter, generator, and the run's statistics so far.
struct ns2d_checkpoint {
    ns2d_params params;
    std::string method;
    /// The conservative methods' update, "conditioned" or "paper" (--update); a checkpoint of an earlier version
    /// recorded none and reads as "conditioned", the default its run took.
    std::string update = "conditioned";
    double dt = 0.0;
    std::uint64_t step = 0;           ///< steps done; t = step * dt
    std::uint64_t total_steps = 0;    ///< steps the run was asked for
    /// The end time the run lands on, its last step shortened to it (--t-end, the default end), as steps_to_reach
    /// and integrate_to take it (total_steps of them); NaN for a run of --steps whole steps. The state is always
    /// on the grid, t = step * dt: the end of a run whose last step was shortened is kept at the step before it.
    double t_end = std::numeric_limits<double>::quiet_NaN();
    std::uint64_t rng_state = 0;
    navier_stokes_2d::state_type state;  ///< FFTW's half plane (flow2d::to_half_plane), the file's layout
    /// Store the process's FFTW wisdom (the plans, for a bit-identical restart); false for a run spread over MPI
    /// processes, whose MPI plans' wisdom a process without FFTW's MPI solvers could not read.
    bool keep_wisdom = true;
    // statistics
    std::uint64_t halvings = 0, rhs_evals = 0;
    ns2d_budget budget;               ///< cumulative since step 0
    double energy0 = 0.0, enstrophy0 = 0.0;
    double max_energy_drift = 0.0, max_enstrophy_drift = 0.0;      ///< max |I - I0| over steps
    double max_energy_residual = 0.0, max_enstrophy_residual = 0.0;  ///< max per-step budget residual, relative
    /// The state's checksum as read from the file (state_checksum; none in files of earlier versions). Written from
    /// the state itself, never from this field.
    std::optional<std::uint64_t> checksum;
};

/// A checksum of n rows of `columns` modes of the half plane from column first_column (row-major, a process's
/// columns or the whole half plane): a sum over the modes, mod 2^64, of a hash of each mode's global index and
/// bits, so that the parts of any split over processes add up to the whole's. A checkpoint stores it; a restart or
/// --ic refuses a state that does not match (a damaged or edited file that is still finite).
std::uint64_t state_checksum(const std::complex<double>* state, int n, int first_column, int columns);
/// What a checkpoint of `equation` at `path` whose state does not match its checksum is told (read_checkpoint's and
/// a process's check of its parts, summed).
std::string checksum_mismatch(const std::string& path, const std::string& equation);

/// Writes the checkpoint through output.hpp's write_replacing (a temporary beside the target, HDF5's flush and close
/// checked, synced, renamed over `path`); throws run_error.
void write_checkpoint(const std::string& path, const ns2d_checkpoint& c);
/// Reads a checkpoint; throws std::runtime_error naming the problem (unreadable, not an eci checkpoint, a grid other
/// than n when n > 0, found before the state is read, ...). with_state false: everything but the state, whose
/// dataset's shape is checked but not read (state stays empty: read_checkpoint_columns reads a process's part).
ns2d_checkpoint read_checkpoint(const std::string& path, int n = 0, bool with_state = true);
/// The columns k_x = first_column .. first_column + columns - 1 of the state of the checkpoint `path` whose header
/// read_checkpoint gave: n rows of `columns` modes, row-major (flow2d::from_half_plane_columns), and nothing else of
/// the file's state. Throws std::runtime_error (unreadable, a non-finite value).
std::vector<std::complex<double>> read_checkpoint_columns(const std::string& path, const ns2d_checkpoint& header,
                                                          int first_column, int columns);

/// A snapshot: the field on the grid with grid, time and parameters as attributes, written to `path` (a new file in
/// the run's staging directory; the flush and close are checked); throws run_error.
void write_snapshot_h5(const std::string& path, const navier_stokes_2d& m, const std::vector<double>& field,
                       double t, std::uint64_t step, const std::string& method, double dt);
/// Whether `path` is an HDF5 file holding an eci checkpoint (false for a snapshot); throws if it is unreadable.
bool is_checkpoint(const std::string& path);
/// The field of an eci snapshot (any equation's) or of a user's file and its grid size; a grid other than n (when
/// n > 0) is refused before the field is read. The dataset is the one the attribute `field` names; in a file without
/// that attribute, `own_field` (the run's equation's field, "buoyancy"), else "vorticity". with_field false: the grid
/// size alone (the field's shape checked, not read). Throws std::runtime_error.
std::pair<int, std::vector<double>> read_vorticity(const std::string& path, int n = 0, bool with_field = true,
                                                   const std::string& own_field = "vorticity");
/// Rows first_row .. first_row + rows - 1 of the field read_vorticity reads, on the n x n grid (row-major; the rest of
/// the file's field is not read). Throws std::runtime_error.
std::vector<double> read_vorticity_rows(const std::string& path, int n, int first_row, int rows,
                                        const std::string& own_field = "vorticity");

#ifdef ECI_MPI
// ---- The files of a run spread over MPI processes: the serial layout, no process holding the whole field. Each
// writer is collective over `comm`: each process gives its block; rank 0 alone creates the file, every dataset at its
// full size (a full disk fails there), then all processes write their blocks in one parallel HDF5 collective write.
// A failure on any process is one run_error on every process, with the reason of the lowest-ranked process that
// failed, and no file is left behind.

/// write_checkpoint from every process's columns: c.state is this process's columns first_column .. + columns - 1
/// of the half plane (flow2d::to_half_plane_columns). The temporary, its sync and rename are rank 0's, as on one
/// process; each process syncs the file after its write.
void write_checkpoint(const std::string& path, const ns2d_checkpoint& c, MPI_Comm comm, int first_column,
                      int columns);
/// write_snapshot_h5 from every process's rows of the field (flow2d::to_physical_rows: m.grid().first_row() ..);
/// `path` is rank 0's (the others' is ignored: rank 0 tells them).
void write_snapshot_h5(const std::string& path, const navier_stokes_2d& m, const std::vector<double>& rows,
                       double t, std::uint64_t step, const std::string& method, double dt, MPI_Comm comm);
/// The reason of the lowest-ranked process of comm whose own reason (`mine`) is not empty, on every process; empty
/// if none failed. Collective.
std::string first_failure(MPI_Comm comm, const std::string& mine);
#endif

/// The field as a PNG (diverging colour map symmetric about 0, colour bar `symbol`, `name` and time in the title), by
/// gnuplot, written to `path` (in the staging directory). Returns false (and draws nothing) when gnuplot is not
/// available.
bool plot_vorticity_png(const std::string& path, int n, const std::vector<double>& field, double t,
                        const std::string& name, const std::string& symbol);
/// The shell spectra and the nonlinear fluxes through each shell.
struct spectrum_rows {
    std::vector<double> energy, enstrophy, energy_flux, enstrophy_flux;
};
/// E(k), Z(k), Pi_E(k), Pi_Z(k) as CSV (k,E,Z,Pi_E,Pi_Z) and, if gnuplot is available, a log-log PNG of E(k) with
/// k^-3 and k^-5/3 guide lines, written to the paths given (in the staging directory; the CSV's writes checked).
void write_spectrum(const std::string& csv_path, const std::string& png_path, const spectrum_rows& r, double t);
/// The time attribute of a snapshot (finite); throws std::runtime_error.
double read_snapshot_time(const std::string& path);
/// The picture write_spectrum draws, drawn again from the spectrum CSV it wrote (at time t) to `png_path`; false if it
/// was not drawn (no plotting program, stopped, or not a CSV of write_spectrum's).
bool redraw_spectrum_png(const std::string& csv_path, const std::string& png_path, double t);

}  // namespace eci::cli
