// eci::spectral::grid: the doubly periodic 2-D grid every spectral equation shares. FFTW plans (made once,
// threaded, wisdom in a file or a string), the wavenumber tables, the 2/3-rule dealiasing mask and the half-plane
// weights, the Hermitian k_x = 0 column, physical <-> spectral, shell sums (spectra), sums over modes in a fixed
// order, and the seeded generator of initial fields and stochastic forcing. An equation (flow.hpp) is written with
// these primitives. Link eci::spectral.
#pragma once

#include <algorithm>
#include <cmath>
#include <array>
#include <complex>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#ifdef ECI_MPI
#include <mpi.h>
#endif

namespace eci::spectral {

using cplx = std::complex<double>;

/// How the grid plans its transforms.
struct grid_options {
    int n = 256;               ///< grid points per side: even, at least 8
    int fields = 4;            ///< scratch fields (and the largest batch one transform call takes)
    int threads = 1;           ///< FFTW and OpenMP threads
    bool measure = true;       ///< FFTW_MEASURE plans (FFTW_ESTIMATE when false)
    /// Transform only the columns that hold retained modes (2/3 of them), each row's inverse, product and forward
    /// transform fused in cache (the default); false: FFTW's 2-D plans of the whole half plane. The same terms to
    /// round-off, not the same round-off, and a step 10-20 % faster at N = 512-1024 and 30-40 % at N = 2048, on
    /// one thread and on two (docs/benchmarks.md). A field with an exact mirror symmetry about a grid point (two
    /// Gaussian vortices centred on grid points) has components that are exactly zero with right-hand sides of
    /// round-off; the conditioned update (every conservative method's default) takes them without a halving, but
    /// the paper's update (`--update paper`) cannot (its radicand is negative at every step size there), where
    /// FFTW's 2-D plans happen to give exact zeros: such a run wants pruned = false. A grid spread over two
    /// processes or more has transforms of its own (of the retained columns as well) and does not read it.
    bool pruned = true;
    /// FFTW wisdom read before planning and written after; empty: none. A file there that is not wisdom
    /// (is_fftw_wisdom) is refused (std::invalid_argument), not replaced.
    std::string wisdom_file;
    std::string wisdom;        ///< FFTW wisdom text imported before planning (a checkpoint's)
#ifdef ECI_MPI
    /// The processes the grid is spread over (MPI build only; MPI_COMM_NULL: this process alone, as without MPI).
    /// Slab decomposition: each process holds a slab of physical rows (y) and, in spectral space, a slab of the
    /// k_x columns (see grid). Collective: every process of the communicator constructs its grid with the same
    /// options. A communicator of one process is the serial grid (its plans, layout and bits; distributed() false),
    /// the communicator kept in comm().
    MPI_Comm comm = MPI_COMM_NULL;
#endif
};

/// Spread over processes (grid_options::comm), a process holds physical rows first_row() .. + local_rows() - 1
/// (each padded to 2 columns(), as above) and the spectral columns k_x = first_column() .. + local_columns() - 1.
/// Only the columns k_x <= kmax hold retained modes; they are split evenly between the processes (the last one also
/// owns the columns beyond, which are zero and never transformed nor sent), so every process holds the same share
/// of the state. A process's spectral scratch holds its transformed columns alone (the first
/// spectral_stride() of its columns), row-major: n rows of spectral_stride() modes, at(row, c) = row
/// spectral_stride() + c. A 2-D transform is the 1-D transforms of those columns along y, an all-to-all of the
/// retained columns alone (a third less than the half plane), and the 1-D transforms of the rows along x; there is
/// no transpose back between an inverse and a forward transform. On one process first_row() = first_column() = 0,
/// local_rows() = n, local_columns() = spectral_stride() = columns().
///
/// The storage is FFTW's real-to-complex half plane: n rows (k_y = 0, 1, ..., n/2, -n/2 + 1, ..., -1) of n/2 + 1
/// columns (k_x = 0 ... n/2), normalised so that f(x) = sum_k f_k exp(i k.x). The retained modes are the square
/// |k_x|, |k_y| <= kmax = (n - 1) / 3 without k = 0: with 3 kmax < n no product of two retained fields aliases onto a
/// retained mode, so a term computed on the grid and truncated is the exact Galerkin one.
class grid {
   public:
    /// Plans the transforms and tabulates the wavenumbers; throws std::invalid_argument for bad options.
    explicit grid(const grid_options& o);
    ~grid();
    grid(grid&&) noexcept;
    grid& operator=(grid&&) noexcept;
    grid(const grid&) = delete;
    grid& operator=(const grid&) = delete;

    int n() const { return n_; }
    int columns() const { return n_ / 2 + 1; }
    /// Stored complex modes, n (n/2 + 1): the size of a state.
    std::size_t size() const { return std::size_t(n_) * std::size_t(columns()); }
    /// Grid points, n^2.
    std::size_t points() const { return std::size_t(n_) * std::size_t(n_); }
    int kmax() const { return (n_ - 1) / 3; }
    /// Why a peak wavenumber k asked for would pile a spectrum up at the cut-off, the front ends' one reason for
    /// refusing it: "is beyond the retained modes (|k_x|, |k_y| <= kmax = K at N = n)", or "" where k <= kmax() or
    /// k is not finite (the field's own check names that).
    std::string beyond_retained(double k) const;
    int threads() const { return threads_; }

    /// Whether the grid is spread over processes (an MPI communicator of two or more; false on a communicator of
    /// one process, which takes the serial path).
    bool distributed() const { return distributed_; }
    /// This process's rank and the number of processes (0 and 1 without a communicator).
    int rank() const { return rank_; }
    int ranks() const { return ranks_; }
    /// This process's physical rows y = first_row() .. first_row() + local_rows() - 1.
    int first_row() const { return row0_; }
    int local_rows() const { return local_rows_; }
    /// This process's spectral columns k_x = first_column() .. first_column() + local_columns() - 1.
    int first_column() const { return col0_; }
    int local_columns() const { return local_cols_; }
    /// Modes per row of a spectral scratch field: columns() on one process; spread over processes, this process's
    /// transformed columns (its columns k_x <= kmax).
    std::size_t spectral_stride() const { return stride_; }
    /// The index in a spectral field of the mode in grid row `row` (k_y = ky_of_row(row)) and this process's
    /// column c (k_x = first_column() + c, c < spectral_stride()).
    std::size_t at(int row, int c) const { return std::size_t(row) * stride_ + std::size_t(c); }
    /// Replaces each v[i] by its sum over the processes: every process's partial sums gathered, then added in rank
    /// order, so a given number of processes repeats bit for bit (never an MPI_Allreduce, whose order may vary).
    /// Collective; a no-op on one process.
    void sum_over_ranks(double* v, std::size_t count) const;
    /// Replaces each v[i] by its maximum over the processes (exact in any order). Collective; a no-op on one.
    void max_over_ranks(double* v, std::size_t count) const;
#ifdef ECI_MPI
    /// The grid's communicator (a duplicate of grid_options::comm, also of a one-process one; MPI_COMM_NULL without).
    MPI_Comm comm() const;
#endif
    /// Whether the transforms skip the columns without retained modes (grid_options::pruned).
    bool pruned() const;
    int kx(std::size_t i) const { return int(i % std::size_t(columns())); }
    int ky(std::size_t i) const { return ky_of_row(int(i / std::size_t(columns()))); }
    int ky_of_row(int row) const { return row <= n_ / 2 ? row : row - n_; }
    /// |k|^2 of stored mode i.
    double k2(std::size_t i) const {
        const double x = kx(i), y = ky(i);
        return x * x + y * y;
    }
    /// How often stored mode i appears in the full plane: 2 (itself and its unstored conjugate), 1 on the k_x = 0 and
    /// Nyquist columns, 0 outside the retained modes (the dealiasing mask and the half-plane weights in one table).
    /// (Computed, not tabulated: a table of the half plane would be another state's worth of memory.)
    double weight(std::size_t i) const { return retained(i) ? (kx(i) == 0 || kx(i) == n_ / 2 ? 1.0 : 2.0) : 0.0; }
    bool retained(std::size_t i) const {
        const int x = kx(i), y = ky(i);
        return x <= kmax() && y <= kmax() && -y <= kmax() && (x != 0 || y != 0);
    }
    /// The columns 0 .. kept_columns(row) - 1 of a row hold every retained mode of the row (kmax + 1, or 0 for a row
    /// outside the square): loops over the state read only these.
    std::size_t kept_columns(int row) const {
        const int ky = ky_of_row(row);
        return (ky <= kmax() && -ky <= kmax()) ? std::size_t(kmax()) + 1 : 0;
    }

    /// Makes the k_x = 0 and Nyquist columns exact conjugates (k and -k are both stored there), so the array is the
    /// transform of a real field bit for bit.
    void make_hermitian(cplx* f) const;

    /// Scratch field j (0 <= j < fields): its spectral view, n rows of spectral_stride() modes (at())...
    cplx* spectral(int j) const;
    /// ... and the same memory as a real field: n rows of n values, each row padded to 2 columns() (FFTW's in-place
    /// layout). Entry (row y, column x) is physical(j)[y * padded() + x].
    double* physical(int j) const;
    std::size_t padded() const { return 2 * std::size_t(columns()); }
    /// Spectral -> physical for scratch fields 0 .. count-1, in place, one call (FFTW's batch).
    void inverse(int count) const;
    /// Physical -> spectral for scratch fields first .. first + count - 1, in place (unnormalised: n^2 f_k). With
    /// pruned transforms only the columns k_x <= kmax are computed; the others hold no meaning. Spread over
    /// processes, the spectral side is this process's transformed columns (at()), read or written alone.
    void forward(int first, int count) const;

    /// The all-to-alls of a transform of `count` fields spread over processes, to the rows and back, and nothing
    /// else (their cost, for benchmarks; the fields' contents are scrambled). A no-op on one process.
    void exchange(int count) const;
    /// The transforms of a product term, fused: fields 0 .. in-1 to physical space, then, row by row while the row
    /// is in cache, row(x) -> row(x) by `fn`, then fields 0 .. out-1 back to spectral space (unnormalised). fn gets
    /// `in` pointers to the row's n values of each field and writes the outputs over the first `out`. Only the
    /// columns k_x <= kmax of the inputs are read (the rest are taken as zero) and of the outputs written.
    template <class Fn>
    void transform_product(int in, int out, Fn fn) const {
        product_pass(in, out, [](void* c, double* const* rows, std::size_t nx) { (*static_cast<Fn*>(c))(rows, nx); },
                     &fn);
    }

    /// Whether transform_product_columns is available: pruned transforms on one process (the default serial grid).
    bool column_pass() const;
    /// The same transforms for a state stored by columns (flow.hpp), fused with its loads and stores: for each
    /// retained column k_x = 0 .. kmax (split between the threads), load(kx, col, thread) writes column k_x of
    /// input fields 0 .. in-1: col[j][y] for the rows y = 0 .. kmax and n - kmax .. n - 1 (k_y = y or y - n; the
    /// rows between are zero, written by the grid), which is then transformed along y while it is in cache; the
    /// rows as in transform_product (fn); then, column by column, the outputs transformed back along y and
    /// store(kx, col, thread) reads col[j][y] of output fields 0 .. out-1 (unnormalised) at the same rows. Only
    /// when column_pass(); the scratch fields' contents are the grid's own layout for this (not at()'s). With
    /// out = 0 the inverse transforms and fn alone: nothing is transformed back, store is never called.
    template <class Load, class Fn, class Store>
    void transform_product_columns(int in, int out, Load load, Fn fn, Store store) const {
        transform_product_chain(
            1, in, out, [&](int, int kx, cplx* const* col, int tid) { load(kx, col, tid); }, fn,
            [&](int, int kx, cplx* const* col, int tid) { store(kx, col, tid); });
    }
    /// `stages` of transform_product_columns in a row, load(stage, kx, col, thread) and store(stage, kx, col,
    /// thread): each column's store of one stage is followed soon by its load of the next, on the same thread,
    /// while the column's memory is in cache (a stage's inputs at column k_x may depend on the previous stage's
    /// outputs at k_x alone: the stages of a Runge-Kutta step on a state stored by columns, flow2d::run_stages).
    /// A thread takes its columns in small groups (up to 4, ~128 kB of transform columns): the group's stores in
    /// column order, then the group's loads; store and load see each column in that order, never a column's load
    /// before its store.
    /// Here store's col has max(in, out) fields, and a store followed by a load may write that load's inputs itself
    /// (col[j][y], j < in, at the retained rows, where it has just read the outputs), which the grid keeps: it
    /// zeroes only the rows between before the load, which then need not write them again.
    template <class Load, class Fn, class Store>
    void transform_product_chain(int stages, int in, int out, Load load, Fn fn, Store store) const {
        column_product(
            stages, in, out,
            [](void* c, int s, int kx, cplx* const* col, int tid) { (*static_cast<Load*>(c))(s, kx, col, tid); }, &load,
            [](void* c, double* const* rows, std::size_t nx) { (*static_cast<Fn*>(c))(rows, nx); }, &fn,
            [](void* c, int s, int kx, cplx* const* col, int tid) { (*static_cast<Store*>(c))(s, kx, col, tid); },
            &store);
    }

    /// body(row0, row1) over the rows 0 .. rows-1 (default: the grid's n), split between the threads.
    template <class Body>
    void for_rows(Body body, int rows = 0) const;
    /// body(b0, b1, thread) over 0 .. count-1 split between the threads as for_rows splits rows (the columns of a
    /// state, say), thread 0 first.
    template <class Body>
    void for_blocks(int count, Body body) const {
        run_rows(count, [](void* c, int b0, int b1, int tid) { (*static_cast<Body*>(c))(b0, b1, tid); }, &body);
    }
    /// Sums K quantities over the rows: body(row0, row1, acc) adds into acc; per-thread partial sums combined in
    /// thread order, so a thread count repeats bit for bit.
    template <std::size_t K, class Body>
    std::array<double, K> sum_rows(Body body, int rows = 0) const;
    /// body(i0, i1, thread) over contiguous ranges of 0 .. n - 1 in order, one per thread (thread 0 first, each
    /// range but the last a multiple of 8 long), or body(0, n, 0) on the calling thread for one thread or a short
    /// loop: the steppers' element-wise passes over a state (detail/ranges.hpp). The same n and thread count give
    /// the same ranges.
    template <class Body>
    void for_ranges(std::size_t n, Body body) const;

    /// The real field (row-major, n x n, y rows) of a state.
    std::vector<double> to_physical(const cplx* f) const;
    /// The state of a real field on the grid (row-major, n x n): transformed, truncated to the retained modes.
    /// Refuses a value that is not finite (field_scale); a field near the largest double is transformed scaled.
    std::vector<cplx> from_physical(std::span<const double> field) const;
    /// The power of two a real field is divided by before its forward transform, so that the transform's sums (up
    /// to n^2 max |f|) cannot overflow where its modes (at most max |f|) do not: 1 for every field below
    /// DBL_MAX / (4 n^2), whose transform is then the unscaled one bit for bit. `values` are this process's rows
    /// from row `first_row` (the whole field on one process); std::invalid_argument naming the first value that is
    /// not finite ("field value at x = 3, y = 5 is nan: a field must be finite"). Collective.
    double field_scale(std::span<const double> values, int first_row) const;
    /// Puts this process's rows of a real field (`rows`, from row `first_row`; the whole field on one process) into
    /// physical field 0, each divided by field_scale's power of two (the padding zeroed), and returns that power:
    /// the first half of every forward transform of a user's field (from_physical here and flow2d's). Collective.
    double load_physical_rows(std::span<const double> rows, int first_row) const;
    /// Shells k = round(|k|) = 0 .. shell_count() - 1 hold every retained mode (spectra).
    std::size_t shell_count() const;

    /// The plans as FFTW wisdom text (so a restart plans the same transforms and repeats bit for bit).
    static std::string fftw_wisdom();
    /// Adds FFTW wisdom text (a wisdom file's contents) to the process's wisdom; false if it is not FFTW wisdom.
    static bool import_fftw_wisdom(const std::string& text);
    /// Whether `text` is FFTW wisdom, of this FFTW version or another ("(fftw-VERSION fftw_wisdom ..."), or nothing
    /// but white space: a file that may be replaced by the process's wisdom. Any other file named as the wisdom file
    /// (a mistyped output's name) is refused, not replaced.
    static bool is_fftw_wisdom(std::string_view text);

   private:
    void run_rows(int rows, void (*fn)(void*, int, int, int), void* ctx) const;
    void run_ranges(std::size_t n, void (*fn)(void*, std::size_t, std::size_t, int), void* ctx) const;
    void product_pass(int in, int out, void (*fn)(void*, double* const*, std::size_t), void* ctx) const;
    void column_product(int stages, int in, int out, void (*load)(void*, int, int, cplx* const*, int), void* load_ctx,
                        void (*fn)(void*, double* const*, std::size_t), void* fn_ctx,
                        void (*store)(void*, int, int, cplx* const*, int), void* store_ctx) const;
    struct plans;
    void plan_distributed(const grid_options& o);
    // spread over processes: the column transforms, the all-to-alls and the row passes (grid.cpp)
    void exchange_to_rows(int first, int count, bool self_copy) const;
    void exchange_to_columns(int first, int count, bool self_copy) const;
    void columns_1d(int first, int count, bool inverse) const;
    void gather_row(int j, int y, double* b, bool in_place) const;
    void scatter_row(int j, int y, const double* b, bool in_place, int field) const;
    int n_, fields_, threads_;
    bool distributed_ = false;
    int rank_ = 0, ranks_ = 1, row0_ = 0, local_rows_ = 0, col0_ = 0, local_cols_ = 0;
    std::size_t field_stride_ = 0;  // complex values from one scratch field to the next
    std::size_t stride_ = 0;        // spectral_stride()
    std::unique_ptr<plans> p_;
};

/// SplitMix64: a seed gives the same field and forcing on every platform.
inline std::uint64_t splitmix_next(std::uint64_t& s) {
    std::uint64_t z = (s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}
/// Uniform in [0, 1) from the generator.
inline double uniform(std::uint64_t& s) { return double(splitmix_next(s) >> 11) * 0x1.0p-53; }
/// A complex Gaussian of unit variance E|g|^2 = 1 (Box-Muller; both outputs used, no hidden cached value).
cplx complex_gaussian(std::uint64_t& s);

template <class Body>
void grid::for_rows(Body body, int rows) const {
    run_rows(rows ? rows : n_, [](void* c, int r0, int r1, int) { (*static_cast<Body*>(c))(r0, r1); }, &body);
}

template <class Body>
void grid::for_ranges(std::size_t n, Body body) const {
    run_ranges(n, [](void* c, std::size_t i0, std::size_t i1, int tid) { (*static_cast<Body*>(c))(i0, i1, tid); },
               &body);
}

template <std::size_t K, class Body>
std::array<double, K> grid::sum_rows(Body body, int rows) const {
    std::array<std::array<double, K>, 64> part{};
    struct ctx_t {
        Body* body;
        std::array<std::array<double, K>, 64>* part;
    } ctx{&body, &part};
    run_rows(
        rows ? rows : n_,
        [](void* c, int r0, int r1, int tid) {
            auto& x = *static_cast<ctx_t*>(c);
            std::array<double, K> acc{};
            (*x.body)(r0, r1, acc);
            (*x.part)[std::size_t(tid)] = acc;
        },
        &ctx);
    std::array<double, K> total{};
    for (int t = 0; t < std::min(threads_, 64); ++t)
        for (std::size_t k = 0; k < K; ++k) total[k] += part[std::size_t(t)][k];
    return total;
}

}  // namespace eci::spectral
