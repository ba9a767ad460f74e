// The grid of grid.hpp: FFTW plans (in place, batched, threaded, wisdom), wavenumber tables, the rows split between
// OpenMP threads; spread over processes, the 1-D column and row transforms with the all-to-all of the retained
// columns between them.
#include "eci/spectral/grid.hpp"

#include <fftw3.h>
#include <omp.h>
#include <sys/mman.h>

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <mutex>
#include <new>
#include <numbers>
#include <stdexcept>

namespace eci::spectral {

namespace {

std::once_flag fftw_threads_once;

// f(row0, row1, thread) on each thread's share of the rows.
template <class F>
void omp_rows(int threads, int rows, F f) {
#pragma omp parallel num_threads(std::min(threads, 64))
    {
        const int tid = omp_get_thread_num(), nth = omp_get_num_threads();
        f(rows * tid / nth, rows * (tid + 1) / nth, tid);
    }
}

void require(bool ok, const std::string& what) {
    if (!ok) throw std::invalid_argument(what);
}

void advise_huge_pages([[maybe_unused]] void* p, [[maybe_unused]] std::size_t bytes) {
#ifdef MADV_HUGEPAGE
    const std::uintptr_t page = 4096, a = (reinterpret_cast<std::uintptr_t>(p) + page - 1) / page * page,
                         e = (reinterpret_cast<std::uintptr_t>(p) + bytes) / page * page;
    if (e > a) madvise(reinterpret_cast<void*>(a), e - a, MADV_HUGEPAGE);  // advice: a refusal changes nothing
#endif
}

}  // namespace

cplx complex_gaussian(std::uint64_t& s) {
    const double u1 = 1.0 - uniform(s), u2 = uniform(s);
    const double r = std::sqrt(-std::log(u1));
    return {r * std::cos(2.0 * std::numbers::pi * u2), r * std::sin(2.0 * std::numbers::pi * u2)};
}

struct grid::plans {
    cplx* buf = nullptr;  // `fields` in-place fields of size() complex values (2 size() doubles) each
    // inverse[c]: fields 0..c; forward[c]: c + 1 fields from field 0. Pruned: the column (k_y) transforms of the
    // kmax + 1 retained columns and the row (k_x) transforms of every row, two plans each way.
    std::vector<fftw_plan> inverse, forward, inverse_rows, forward_columns;
    bool pruned = false;
    // The fused passes: per thread, a buffer of rows (aligned as the plans were made on them: plan_rows), and one
    // row's 1-D c2r and r2c, in place (the distributed pass, and transform_product without the column pass).
    std::vector<double*> rows;
    fftw_plan row_c2r = nullptr, row_r2c = nullptr;
    // column_product's row transforms, out of place (complex row -> real row -> complex row): FFTW transforms a row
    // in place through a buffer copy (rdft2-buffered), out of place directly, 1.2 x faster at n = 1024
    fftw_plan block_c2r = nullptr, block_r2c = nullptr;
    // Allocates `threads` such buffers of `count` rows of `pad` doubles (every one alike, so aligned alike) and
    // plans a row's transforms single-threaded on the first: each thread transforms rows of its own.
    void plan_rows(int n, int count, int threads, std::size_t pad, unsigned flags) {
        fftw_plan_with_nthreads(1);
        for (int t = 0; t < threads; ++t) {
            rows.push_back(fftw_alloc_real(std::size_t(count) * pad));
            if (!rows.back()) throw std::bad_alloc();
        }
        double* r0 = rows[0];
        row_c2r = fftw_plan_dft_c2r_1d(n, reinterpret_cast<fftw_complex*>(r0), r0, flags);
        row_r2c = fftw_plan_dft_r2c_1d(n, r0, reinterpret_cast<fftw_complex*>(r0), flags);
        if (!row_c2r || !row_r2c) throw std::runtime_error("FFTW could not plan the row transforms");
    }
    // A state stored by columns (column_product): each retained column of field j at buf + j col_field + c col_ld,
    // n values (the rows' order), col_ld = n + 4 so that a row's values of successive columns fall in different
    // cache sets (col_ld = n, a power of two, put them in one set: the row pass 1.4 x slower in a probe);
    // columns_y_*[c]: the transforms along y of one column of fields 0 .. c, in place.
    std::vector<fftw_plan> columns_y_inverse, columns_y_forward;
    std::size_t col_ld = 0, col_field = 0;
    // column_product's row pass takes row_block rows at a time: a row's value of a column and the next rows' share
    // its cache line, so a block reads (and writes) each line of the columns once, not once per row. In a thread's
    // rows[thread]: row q of field j of a block, spectral at (j row_block + q) row_pad and physical at
    // ((fields + j) row_block + q) row_pad (row_pad below: every row has the 64-byte alignment of the rows the
    // plans are made on).
    static constexpr int row_block = 4;
    // Spread over processes. Rank q holds rows row0[q] .. + nrows[q] - 1 and transforms the retained columns
    // col0[q] .. + ncols[q] - 1 (contiguous in rank order, so col0[q] is also the number before q's). The column
    // transforms along y run in place on the spectral fields (n rows of ncols[me] modes); the all-to-all sends
    // each process the rows it holds of every column; recv holds, per field (field_stride apart), what the others
    // sent: from rank s, nrows[me] rows of ncols[s] modes at nrows[me] col0[s] (its own block is read from, and
    // written to, the spectral field where it lies, but by inverse() and forward(), which copy it through recv);
    // the rows are transformed along x one at a time in a thread's buffer (`rows`, row_pad doubles per field;
    // row_pad, padded() rounded up to 8 doubles, is the row stride of every thread buffer, serial or not).
    std::vector<int> row0, nrows, col0, ncols;
    std::vector<fftw_plan> columns_inverse, columns_forward;  // [c]: fields 0 .. c, in place
    cplx* recv = nullptr;
    std::size_t recv_stride = 0, row_pad = 0;
#ifdef ECI_MPI
    MPI_Comm comm = MPI_COMM_NULL;
    std::vector<MPI_Request> requests;
#endif
    ~plans() {
#ifdef ECI_MPI
        if (comm != MPI_COMM_NULL) {
            int finalized = 0;
            MPI_Finalized(&finalized);
            if (!finalized) MPI_Comm_free(&comm);
        }
#endif
        for (auto* v : {&inverse, &forward, &inverse_rows, &forward_columns, &columns_inverse, &columns_forward,
                        &columns_y_inverse, &columns_y_forward})
            for (fftw_plan p : *v)
                if (p) fftw_destroy_plan(p);
        for (fftw_plan p : {row_c2r, row_r2c, block_c2r, block_r2c})
            if (p) fftw_destroy_plan(p);
        for (double* r : rows) fftw_free(r);
        fftw_free(recv);
        fftw_free(buf);
    }
};

grid::grid(const grid_options& o) : n_(o.n), fields_(o.fields), threads_(o.threads), p_(std::make_unique<plans>()) {
    require(o.n >= 8 && o.n % 2 == 0, "grid size N must be even and at least 8, not " + std::to_string(o.n));
    require(o.n <= 65536, "grid size N = " + std::to_string(o.n) + " is too large");
    require(o.threads >= 1 && o.threads <= 64, "threads must be in 1..64");
    require(o.fields >= 1 && o.fields <= 8, "scratch fields must be in 1..8");
    const std::size_t m = size();
    local_rows_ = n_;
    local_cols_ = columns();
    field_stride_ = m;
    stride_ = std::size_t(columns());
    p_->row_pad = (padded() + 7) / 8 * 8;
    std::call_once(fftw_threads_once, [] { fftw_init_threads(); });
    if (!o.wisdom_file.empty()) {
        // read whole and checked first: written back below, it must not replace another file named by mistake
        std::string text;
        if (std::FILE* f = std::fopen(o.wisdom_file.c_str(), "rb")) {
            char chunk[4096];
            for (std::size_t got; (got = std::fread(chunk, 1, sizeof chunk, f)) > 0;) text.append(chunk, got);
            std::fclose(f);
        }
        if (!is_fftw_wisdom(text))
            throw std::invalid_argument("wisdom file '" + o.wisdom_file +
                                        "' is not FFTW wisdom (it would be replaced): name a wisdom file or a new one");
        if (!text.empty()) fftw_import_wisdom_from_string(text.c_str());  // (another FFTW version's: ignored)
    }
    if (!o.wisdom.empty() && !fftw_import_wisdom_from_string(o.wisdom.c_str()))
        throw std::invalid_argument("FFTW wisdom could not be read");
    fftw_plan_with_nthreads(o.threads);
#ifdef ECI_MPI
    if (o.comm != MPI_COMM_NULL) {
        // Spread over two processes or more: FFTW's MPI transforms. A communicator of one process holds the whole
        // field: the serial plans below (batched, no transposes, the pruned transforms available) give the same
        // bits as a grid without one; the communicator is kept (comm()) for a caller's own collectives.
        int size = 1;
        MPI_Comm_size(o.comm, &size);
        if (size > 1) {
            plan_distributed(o);
            return;
        }
        MPI_Comm_dup(o.comm, &p_->comm);
    }
#endif
    p_->buf = reinterpret_cast<cplx*>(fftw_alloc_complex(std::size_t(fields_) * m));
    if (!p_->buf) throw std::bad_alloc();
    // The row pass of transform_product_columns reads one value of every retained column per row, each column a
    // page or more apart: at N = 2048, 1366 pages a row, beyond the TLB. Huge pages where the kernel gives them on
    // request (transparent huge pages in "madvise" mode); nothing changes where it does not.
    advise_huge_pages(p_->buf, std::size_t(fields_) * m * sizeof(cplx));
    std::fill(p_->buf, p_->buf + std::size_t(fields_) * m, cplx{});
    const unsigned flags = o.measure ? FFTW_MEASURE : FFTW_ESTIMATE;
    const int dims[2] = {n_, n_};
    // In place: a real row of n values padded to 2 columns() doubles (FFTW's layout), so one field's spectral and
    // physical views share memory and a state's scratch is `fields` state sizes.
    const int embed_r[2] = {n_, int(padded())}, embed_c[2] = {n_, columns()};
    auto* c = reinterpret_cast<fftw_complex*>(p_->buf);
    auto* r = reinterpret_cast<double*>(p_->buf);
    // MEASURE overwrites the arrays it plans on: plan before anything is stored in them.
    p_->pruned = o.pruned;
    const int nc = columns(), kept = kmax() + 1;
    for (int k = 1; k <= fields_; ++k) {
        if (!o.pruned) {
            p_->inverse.push_back(
                fftw_plan_many_dft_c2r(2, dims, k, c, embed_c, 1, int(m), r, embed_r, 1, int(2 * m), flags));
            p_->forward.push_back(
                fftw_plan_many_dft_r2c(2, dims, k, r, embed_r, 1, int(2 * m), c, embed_c, 1, int(m), flags));
            if (!p_->inverse.back() || !p_->forward.back())
                throw std::runtime_error("FFTW could not plan the transforms");
            continue;
        }
        // A 2-D transform is n transforms along y of each column and n along x of each row. Only the columns
        // k_x <= kmax hold retained modes (2/3 of the n/2 + 1): transform those along y alone, into and out of the
        // spectral side; every row along x. The columns beyond stay zero going in and are not read coming out.
        const fftw_iodim column{n_, nc, nc};  // along y, within a column
        const fftw_iodim by_column[2] = {{k, int(m), int(m)}, {kept, 1, 1}};
        const fftw_iodim row{n_, 1, 1};
        const fftw_iodim by_row_c2r[2] = {{k, int(m), int(2 * m)}, {n_, nc, 2 * nc}};  // complex in, real out
        const fftw_iodim by_row_r2c[2] = {{k, int(2 * m), int(m)}, {n_, 2 * nc, nc}};  // real in, complex out
        p_->inverse.push_back(fftw_plan_guru_dft(1, &column, 2, by_column, c, c, FFTW_BACKWARD, flags));
        p_->inverse_rows.push_back(fftw_plan_guru_dft_c2r(1, &row, 2, by_row_c2r, c, r, flags));
        p_->forward.push_back(fftw_plan_guru_dft_r2c(1, &row, 2, by_row_r2c, r, c, flags));
        p_->forward_columns.push_back(fftw_plan_guru_dft(1, &column, 2, by_column, c, c, FFTW_FORWARD, flags));
        if (!p_->inverse.back() || !p_->inverse_rows.back() || !p_->forward.back() || !p_->forward_columns.back())
            throw std::runtime_error("FFTW could not plan the transforms");
    }
    // the fused pass's row transforms (the rows are split between the threads); room for column_product's blocks
    p_->plan_rows(n_, o.pruned ? 2 * fields_ * plans::row_block : fields_, threads_, p_->row_pad, flags);
    if (o.pruned) {
        double* cr = p_->rows[0];
        double* re = cr + std::size_t(fields_) * plans::row_block * p_->row_pad;
        fftw_plan_with_nthreads(1);
        p_->block_c2r = fftw_plan_dft_c2r_1d(n_, reinterpret_cast<fftw_complex*>(cr), re, flags);
        p_->block_r2c = fftw_plan_dft_r2c_1d(n_, re, reinterpret_cast<fftw_complex*>(cr), flags);
        if (!p_->block_c2r || !p_->block_r2c) throw std::runtime_error("FFTW could not plan the row transforms");
        // column_product's transforms along y, one column of up to `fields` fields at a time (each thread its own
        // columns), in the memory of the scratch fields: kept columns of n + 4 per field fit in a field's n
        // columns() (kept < columns() - 1), and n + 4 (even) keeps every column's start 32-byte aligned, as the
        // buffer's first column the plans are made on
        p_->col_ld = std::size_t(n_) + 4;
        p_->col_field = std::size_t(kept) * p_->col_ld;
        const fftw_iodim along_y{n_, 1, 1};
        for (int k = 1; k <= fields_; ++k) {
            const fftw_iodim fields{k, int(p_->col_field), int(p_->col_field)};
            p_->columns_y_inverse.push_back(fftw_plan_guru_dft(1, &along_y, 1, &fields, c, c, FFTW_BACKWARD, flags));
            p_->columns_y_forward.push_back(fftw_plan_guru_dft(1, &along_y, 1, &fields, c, c, FFTW_FORWARD, flags));
            if (!p_->columns_y_inverse.back() || !p_->columns_y_forward.back())
                throw std::runtime_error("FFTW could not plan the column transforms");
        }
    }
    fftw_plan_with_nthreads(o.threads);
    std::fill(p_->buf, p_->buf + std::size_t(fields_) * m, cplx{});
    if (!o.wisdom_file.empty()) {
        // temporary + rename, so a concurrent reader never sees half a file
        const std::string tmp = o.wisdom_file + ".tmp" + std::to_string(reinterpret_cast<std::uintptr_t>(this));
        if (fftw_export_wisdom_to_filename(tmp.c_str())) std::rename(tmp.c_str(), o.wisdom_file.c_str());
    }
}

void grid::plan_distributed([[maybe_unused]] const grid_options& o) {
#ifdef ECI_MPI
    distributed_ = true;
    MPI_Comm_dup(o.comm, &p_->comm);
    MPI_Comm_rank(p_->comm, &rank_);
    MPI_Comm_size(p_->comm, &ranks_);
    // Rows split evenly, and the retained columns 0 .. kmax split evenly (the last process also owns the columns
    // beyond, which are zero): each process's share of the state, of the column transforms and of the all-to-all
    // is 1/P of the whole.
    const int P = ranks_, K = kmax() + 1;
    auto& q = *p_;
    q.row0.resize(std::size_t(P));
    q.nrows.resize(std::size_t(P));
    q.col0.resize(std::size_t(P));
    q.ncols.resize(std::size_t(P));
    for (int k = 0; k < P; ++k) {
        const auto split = [&](int total, int at) { return int(std::int64_t(total) * at / P); };
        q.row0[std::size_t(k)] = split(n_, k);
        q.nrows[std::size_t(k)] = split(n_, k + 1) - split(n_, k);
        q.col0[std::size_t(k)] = split(K, k);
        q.ncols[std::size_t(k)] = split(K, k + 1) - split(K, k);
    }
    const std::size_t me = std::size_t(rank_);
    row0_ = q.row0[me];
    local_rows_ = q.nrows[me];
    col0_ = q.col0[me];
    local_cols_ = rank_ == P - 1 ? columns() - col0_ : q.ncols[me];
    stride_ = std::size_t(q.ncols[me]);
    // (a message, one field's block, counts its complex values in an int)
    require(std::int64_t(n_ / P + 1) * std::int64_t(K / P + 1) < std::int64_t(INT_MAX),
            "grid size N = " + std::to_string(n_) + " is too large for " + std::to_string(P) + " processes");
    // a field: the spectral side (n rows of this process's columns) or the physical one (its rows, padded);
    // every field on a 64-byte boundary, as the first (plans are made on field 0 and executed on the others)
    const std::size_t spec = std::size_t(n_) * stride_, phys = std::size_t(local_rows_) * std::size_t(columns());
    field_stride_ = (std::max({spec, phys, std::size_t(1)}) + 3) / 4 * 4;
    const std::size_t recv_stride = (std::max(std::size_t(local_rows_) * std::size_t(K), std::size_t(1)) + 3) / 4 * 4;
    const std::size_t total = std::size_t(fields_) * field_stride_;
    p_->buf = reinterpret_cast<cplx*>(fftw_alloc_complex(total));
    p_->recv = reinterpret_cast<cplx*>(fftw_alloc_complex(std::size_t(fields_) * recv_stride));
    if (!p_->buf || !p_->recv) throw std::bad_alloc();
    std::fill(p_->buf, p_->buf + total, cplx{});
    std::fill(p_->recv, p_->recv + std::size_t(fields_) * recv_stride, cplx{});
    const unsigned flags = o.measure ? FFTW_MEASURE : FFTW_ESTIMATE;
    auto* c = reinterpret_cast<fftw_complex*>(p_->buf);
    const int kl = int(stride_);
    if (kl > 0) {
        // along y, in place: element y of column c at y kl + c (FFTW's layout of a 2-D transform's columns)
        const fftw_iodim column{n_, kl, kl};
        for (int k = 1; k <= fields_; ++k) {
            const fftw_iodim many[2] = {{k, int(field_stride_), int(field_stride_)}, {kl, 1, 1}};
            p_->columns_inverse.push_back(fftw_plan_guru_dft(1, &column, 2, many, c, c, FFTW_BACKWARD, flags));
            p_->columns_forward.push_back(fftw_plan_guru_dft(1, &column, 2, many, c, c, FFTW_FORWARD, flags));
            if (!p_->columns_inverse.back() || !p_->columns_forward.back())
                throw std::runtime_error("FFTW could not plan the column transforms");
        }
    }
    // the rows along x: one thread each, in a thread's buffer
    p_->plan_rows(n_, fields_, threads_, p_->row_pad, flags);
    fftw_plan_with_nthreads(o.threads);
    std::fill(p_->buf, p_->buf + total, cplx{});
    p_->requests.reserve(std::size_t(2 * P * fields_));
    p_->recv_stride = recv_stride;
#endif
}

#ifdef ECI_MPI
MPI_Comm grid::comm() const { return p_->comm; }
#endif

void grid::sum_over_ranks([[maybe_unused]] double* v, [[maybe_unused]] std::size_t count) const {
#ifdef ECI_MPI
    if (!distributed_ || count == 0) return;
    std::vector<double> all(count * std::size_t(ranks_));
    MPI_Allgather(v, int(count), MPI_DOUBLE, all.data(), int(count), MPI_DOUBLE, p_->comm);
    for (std::size_t i = 0; i < count; ++i) {
        double acc = all[i];
        for (std::size_t r = 1; r < std::size_t(ranks_); ++r) acc += all[r * count + i];
        v[i] = acc;
    }
#endif
}

void grid::max_over_ranks([[maybe_unused]] double* v, [[maybe_unused]] std::size_t count) const {
#ifdef ECI_MPI
    if (!distributed_ || count == 0) return;
    MPI_Allreduce(MPI_IN_PLACE, v, int(count), MPI_DOUBLE, MPI_MAX, p_->comm);
#endif
}

grid::~grid() = default;
grid::grid(grid&&) noexcept = default;
grid& grid::operator=(grid&&) noexcept = default;

bool grid::import_fftw_wisdom(const std::string& text) {
    std::call_once(fftw_threads_once, [] { fftw_init_threads(); });  // FFTW's threads first, as the constructor
    return !text.empty() && fftw_import_wisdom_from_string(text.c_str()) != 0;
}

bool grid::is_fftw_wisdom(std::string_view text) {
    const std::size_t start = text.find_first_not_of(" \t\r\n");
    if (start == std::string_view::npos) return true;  // empty: nothing to lose
    text.remove_prefix(start);
    const std::string_view head = text.substr(0, text.find('\n'));
    return head.starts_with("(fftw-") && head.find(" fftw_wisdom") != std::string_view::npos;
}

std::string grid::fftw_wisdom() {
    char* w = fftw_export_wisdom_to_string();
    if (!w) return {};
    std::string s(w);
    fftw_free(w);
    return s;
}

cplx* grid::spectral(int j) const { return p_->buf + std::size_t(j) * field_stride_; }
double* grid::physical(int j) const { return reinterpret_cast<double*>(spectral(j)); }

bool grid::pruned() const { return p_->pruned; }

void grid::inverse(int count) const {
#ifdef ECI_MPI
    if (distributed_) {
        columns_1d(0, count, true);
        exchange_to_rows(0, count, true);
        const std::size_t pad = padded(), nx = std::size_t(n_);
        omp_rows(threads_, local_rows_, [&](int r0, int r1, int tid) {
            double* b = p_->rows[std::size_t(tid)];
            for (int y = r0; y < r1; ++y)
                for (int j = 0; j < count; ++j) {
                    gather_row(j, y, b, false);
                    fftw_execute_dft_c2r(p_->row_c2r, reinterpret_cast<fftw_complex*>(b), b);
                    std::copy(b, b + nx, physical(j) + std::size_t(y) * pad);
                }
        });
        return;
    }
#endif
    fftw_execute(p_->inverse.at(std::size_t(count - 1)));
    if (p_->pruned) fftw_execute(p_->inverse_rows[std::size_t(count - 1)]);
}

void grid::forward(int first, int count) const {
#ifdef ECI_MPI
    if (distributed_) {
        const std::size_t pad = padded(), nx = std::size_t(n_);
        omp_rows(threads_, local_rows_, [&](int r0, int r1, int tid) {
            double* b = p_->rows[std::size_t(tid)];
            for (int y = r0; y < r1; ++y)
                for (int j = 0; j < count; ++j) {
                    const double* row = physical(first + j) + std::size_t(y) * pad;
                    std::copy(row, row + nx, b);
                    fftw_execute_dft_r2c(p_->row_r2c, b, reinterpret_cast<fftw_complex*>(b));
                    scatter_row(j, y, b, false, first + j);
                }
        });
        exchange_to_columns(first, count, true);
        columns_1d(first, count, false);
        return;
    }
#endif
    const std::size_t k = std::size_t(count - 1);
    auto* c = reinterpret_cast<fftw_complex*>(spectral(first));
    // a batch that does not start at field 0: the new-array interface on the same layout (alignment is the same,
    // every field starts on a multiple of size() complex values)
    if (first == 0)
        fftw_execute(p_->forward.at(k));
    else
        fftw_execute_dft_r2c(p_->forward.at(k), physical(first), c);
    if (!p_->pruned) return;
    if (first == 0)
        fftw_execute(p_->forward_columns[k]);
    else
        fftw_execute_dft(p_->forward_columns[k], c, c);
}

void grid::columns_1d(int first, int count, bool inverse) const {
    if (stride_ == 0 || count == 0) return;
    const fftw_plan plan = (inverse ? p_->columns_inverse : p_->columns_forward).at(std::size_t(count - 1));
    auto* c = reinterpret_cast<fftw_complex*>(spectral(first));
    fftw_execute_dft(plan, c, c);
}

// Row y (this process's) of field j, from every process's block of the retained columns, into a thread's buffer b
// as FFTW's half-complex row (zero beyond kmax). in_place: this process's own block read from the spectral field
// (the product pass) rather than from recv (inverse(), whose output overwrites the spectral field).
void grid::gather_row(int j, int y, double* b, bool in_place) const {
    auto* row = reinterpret_cast<cplx*>(b);
    const auto& q = *p_;
    const cplx* recv = q.recv + std::size_t(j) * q.recv_stride;
    const std::size_t R = std::size_t(local_rows_);
    for (int s = 0; s < ranks_; ++s) {
        const std::size_t cs = std::size_t(q.ncols[std::size_t(s)]), c0 = std::size_t(q.col0[std::size_t(s)]);
        const cplx* src = in_place && s == rank_ ? spectral(j) + (std::size_t(row0_) + std::size_t(y)) * stride_
                                                 : recv + R * c0 + std::size_t(y) * cs;
        std::copy(src, src + cs, row + c0);
    }
    const std::size_t K = std::size_t(kmax()) + 1;
    std::fill(row + K, row + columns(), cplx{});
}

// The inverse of gather_row: the retained columns of the transformed row b to every process's block (recv, or
// this process's own in spectral field `field` when in_place).
void grid::scatter_row(int j, int y, const double* b, bool in_place, int field) const {
    const auto* row = reinterpret_cast<const cplx*>(b);
    const auto& q = *p_;
    cplx* recv = q.recv + std::size_t(j) * q.recv_stride;
    const std::size_t R = std::size_t(local_rows_);
    for (int s = 0; s < ranks_; ++s) {
        const std::size_t cs = std::size_t(q.ncols[std::size_t(s)]), c0 = std::size_t(q.col0[std::size_t(s)]);
        cplx* dst = in_place && s == rank_ ? spectral(field) + (std::size_t(row0_) + std::size_t(y)) * stride_
                                           : recv + R * c0 + std::size_t(y) * cs;
        std::copy(row + c0, row + c0 + cs, dst);
    }
}

// Spectral fields first .. first + count - 1 (after their column transforms) to recv: to each process the rows it
// holds of this process's columns, from each process this process's rows of its columns. self_copy: this
// process's own block copied to recv too.
void grid::exchange_to_rows(int first, int count, bool self_copy) const {
#ifdef ECI_MPI
    auto& q = *p_;
    const std::size_t R = std::size_t(local_rows_);
    q.requests.clear();
    for (int j = 0; j < count; ++j) {
        cplx* recv = q.recv + std::size_t(j) * q.recv_stride;
        const cplx* field = spectral(first + j);
        for (int s = 0; s < ranks_; ++s) {
            const std::size_t cs = std::size_t(q.ncols[std::size_t(s)]);
            if (s == rank_ || cs * R == 0) continue;
            q.requests.emplace_back();
            MPI_Irecv(recv + R * std::size_t(q.col0[std::size_t(s)]), int(R * cs), MPI_C_DOUBLE_COMPLEX, s, j, q.comm,
                      &q.requests.back());
        }
        for (int d = 0; d < ranks_; ++d) {
            const std::size_t rd = std::size_t(q.nrows[std::size_t(d)]);
            if (d == rank_ || rd * stride_ == 0) continue;
            q.requests.emplace_back();
            MPI_Isend(field + std::size_t(q.row0[std::size_t(d)]) * stride_, int(rd * stride_), MPI_C_DOUBLE_COMPLEX,
                      d, j, q.comm, &q.requests.back());
        }
        if (self_copy)
            std::copy(field + std::size_t(row0_) * stride_, field + (std::size_t(row0_) + R) * stride_,
                      recv + R * std::size_t(col0_));
    }
    MPI_Waitall(int(q.requests.size()), q.requests.data(), MPI_STATUSES_IGNORE);
#else
    (void)first, (void)count, (void)self_copy;
#endif
}

// The reverse: recv (each process's columns of this process's rows) to the spectral fields first ..
// (n rows of this process's columns), before their column transforms.
void grid::exchange_to_columns(int first, int count, bool self_copy) const {
#ifdef ECI_MPI
    auto& q = *p_;
    const std::size_t R = std::size_t(local_rows_);
    q.requests.clear();
    for (int j = 0; j < count; ++j) {
        const cplx* recv = q.recv + std::size_t(j) * q.recv_stride;
        cplx* field = spectral(first + j);
        for (int s = 0; s < ranks_; ++s) {
            const std::size_t rs = std::size_t(q.nrows[std::size_t(s)]);
            if (s == rank_ || rs * stride_ == 0) continue;
            q.requests.emplace_back();
            MPI_Irecv(field + std::size_t(q.row0[std::size_t(s)]) * stride_, int(rs * stride_), MPI_C_DOUBLE_COMPLEX,
                      s, j, q.comm, &q.requests.back());
        }
        for (int d = 0; d < ranks_; ++d) {
            const std::size_t cd = std::size_t(q.ncols[std::size_t(d)]);
            if (d == rank_ || cd * R == 0) continue;
            q.requests.emplace_back();
            MPI_Isend(recv + R * std::size_t(q.col0[std::size_t(d)]), int(R * cd), MPI_C_DOUBLE_COMPLEX, d, j, q.comm,
                      &q.requests.back());
        }
        if (self_copy)
            std::copy(recv + R * std::size_t(col0_), recv + R * (std::size_t(col0_) + stride_),
                      field + std::size_t(row0_) * stride_);
    }
    MPI_Waitall(int(q.requests.size()), q.requests.data(), MPI_STATUSES_IGNORE);
#else
    (void)first, (void)count, (void)self_copy;
#endif
}

void grid::exchange(int count) const {
    if (!distributed_) return;
    exchange_to_rows(0, count, false);
    exchange_to_columns(0, count, false);
}

void grid::run_rows(int rows, void (*fn)(void*, int, int, int), void* ctx) const {
    omp_rows(threads_, rows, [&](int r0, int r1, int tid) { fn(ctx, r0, r1, tid); });
}

void grid::run_ranges(std::size_t n, void (*fn)(void*, std::size_t, std::size_t, int), void* ctx) const {
    // below this a pass over a few arrays of n doubles takes about as long as waking the threads
    constexpr std::size_t min_split = 8192;
    if (threads_ <= 1 || n < min_split) {
        fn(ctx, 0, n, 0);
        return;
    }
#pragma omp parallel num_threads(std::min(threads_, 64))
    {
        const std::size_t tid = std::size_t(omp_get_thread_num()), nth = std::size_t(omp_get_num_threads());
        // multiples of 8 (a cache line of doubles) between the threads' ranges
        const auto cut = [&](std::size_t t) { return t == nth ? n : n * t / nth / 8 * 8; };
        fn(ctx, cut(tid), cut(tid + 1), int(tid));
    }
}

void grid::product_pass(int in, int out, void (*fn)(void*, double* const*, std::size_t), void* ctx) const {
    const std::size_t nc = std::size_t(columns()), pad = padded();
    if (distributed_) {
        // along y (this process's columns), the all-to-all, then each row of every field in a thread's buffer:
        // c2r, fn, r2c while it is in cache; the all-to-all back, along y again. This process's own block stays in
        // the spectral fields (each row's outputs go where its inputs were read).
        columns_1d(0, in, true);
        exchange_to_rows(0, in, false);
        omp_rows(threads_, local_rows_, [&](int r0, int r1, int tid) {
            double* b[8];
            for (int j = 0; j < in; ++j) b[j] = p_->rows[std::size_t(tid)] + std::size_t(j) * p_->row_pad;
            for (int y = r0; y < r1; ++y) {
                for (int j = 0; j < in; ++j) {
                    gather_row(j, y, b[j], true);
                    fftw_execute_dft_c2r(p_->row_c2r, reinterpret_cast<fftw_complex*>(b[j]), b[j]);
                }
                fn(ctx, b, std::size_t(n_));
                for (int j = 0; j < out; ++j) {
                    fftw_execute_dft_r2c(p_->row_r2c, b[j], reinterpret_cast<fftw_complex*>(b[j]));
                    scatter_row(j, y, b[j], true, j);
                }
            }
        });
        exchange_to_columns(0, out, false);
        columns_1d(0, out, false);
        return;
    }
    if (!p_->pruned) {  // FFTW's 2-D transforms and a pass over the fields (this process's rows) between them
        inverse(in);
        omp_rows(threads_, local_rows_, [&](int r0, int r1, int) {
            double* g[8];
            for (int y = r0; y < r1; ++y) {
                for (int j = 0; j < in; ++j) g[j] = physical(j) + std::size_t(y) * pad;
                fn(ctx, g, std::size_t(n_));
            }
        });
        return forward(0, out);
    }
    // Along y, the retained columns; then each row, in a thread's own buffer: c2r, fn, r2c (the row stays in cache
    // from one to the next, and the fields are read and written once); along y again, the retained columns.
    const std::size_t kept = std::size_t(kmax()) + 1;
    fftw_execute(p_->inverse.at(std::size_t(in - 1)));
    omp_rows(threads_, n_, [&](int r0, int r1, int tid) {
        double* b[8];
        for (int j = 0; j < in; ++j) b[j] = p_->rows[std::size_t(tid)] + std::size_t(j) * pad;
        for (int y = r0; y < r1; ++y) {
            for (int j = 0; j < in; ++j) {
                // the columns beyond kmax are zero: written here, in cache, not read from the field
                const cplx* src = spectral(j) + std::size_t(y) * nc;
                std::copy(src, src + kept, reinterpret_cast<cplx*>(b[j]));
                std::fill(reinterpret_cast<cplx*>(b[j]) + kept, reinterpret_cast<cplx*>(b[j]) + nc, cplx{});
                fftw_execute_dft_c2r(p_->row_c2r, reinterpret_cast<fftw_complex*>(b[j]), b[j]);
            }
            fn(ctx, b, std::size_t(n_));
            for (int j = 0; j < out; ++j) {
                fftw_execute_dft_r2c(p_->row_r2c, b[j], reinterpret_cast<fftw_complex*>(b[j]));
                const cplx* row = reinterpret_cast<const cplx*>(b[j]);
                std::copy(row, row + kept, spectral(j) + std::size_t(y) * nc);  // the columns the next pass reads
            }
        }
    });
    fftw_execute(p_->forward_columns.at(std::size_t(out - 1)));
}

bool grid::column_pass() const { return p_->pruned && !distributed_; }

void grid::column_product(int stages, int in, int out, void (*load)(void*, int, int, cplx* const*, int),
                          void* load_ctx, void (*fn)(void*, double* const*, std::size_t), void* fn_ctx,
                          void (*store)(void*, int, int, cplx* const*, int), void* store_ctx) const {
    if (!column_pass()) throw std::logic_error("grid::transform_product_columns needs pruned transforms on one process");
    if (out == 0 && stages != 1) throw std::logic_error("grid::transform_product_chain: a stage with no outputs ends it");
    const std::size_t nc = std::size_t(columns()), ld = p_->col_ld, fs = p_->col_field;
    const int kept = kmax() + 1, K = kmax();
    // (out = 0: the inverse transforms and fn alone, nothing transformed back or stored: flow2d::max_velocity)
    const fftw_plan inv = p_->columns_y_inverse.at(std::size_t(in - 1));
    const fftw_plan fwd = out > 0 ? p_->columns_y_forward.at(std::size_t(out - 1)) : nullptr;
    // column c of stage s's inputs: loaded, the rows between the retained ones zeroed, transformed along y (in cache)
    const auto load_column = [&](int s, int c, int tid) {
        cplx* col[8];
        for (int j = 0; j < in; ++j) {
            col[j] = p_->buf + std::size_t(j) * fs + std::size_t(c) * ld;
            std::fill(col[j] + K + 1, col[j] + (n_ - K), cplx{});
        }
        load(load_ctx, s, c, col, tid);
        fftw_execute_dft(inv, reinterpret_cast<fftw_complex*>(col[0]), reinterpret_cast<fftw_complex*>(col[0]));
    };
    // column c of stage s's outputs: transformed back along y, then read by store while in cache (which may write
    // the next stage's inputs at the retained rows: col[j], j < in, as load would)
    const auto forward_column = [&](int c) {
        cplx* first = p_->buf + std::size_t(c) * ld;
        fftw_execute_dft(fwd, reinterpret_cast<fftw_complex*>(first), reinterpret_cast<fftw_complex*>(first));
    };
    const auto store_column = [&](int s, int c, int tid) {
        cplx* col[8];
        cplx* first = p_->buf + std::size_t(c) * ld;
        for (int j = 0; j < std::max(in, out); ++j) col[j] = first + std::size_t(j) * fs;
        store(store_ctx, s, c, col, tid);
    };
    // A stage's columns are taken in groups: the group's forward transforms, then its stores, then the next stage's
    // loads, so that the stores' loops over a state stored by columns read the group's modes as one contiguous run
    // rather than a column's between two transforms (0.3 ms less per C-RK4 step at N = 1024, ~1 %, paired in time;
    // the transforms alone take as long). Each column's own sequence is unchanged, so the same bits. A group's
    // transform columns stay within ~128 kB (of the L2 cache): 4 columns at N = 1024 in Basdevant's form, fewer above.
    const std::size_t column_bytes = std::size_t(std::max(in, out)) * std::size_t(n_) * sizeof(cplx);
    const int group = std::clamp(int(std::size_t(131072) / column_bytes), 1, 4);
    omp_rows(threads_, kept, [&](int c0, int c1, int tid) {
        for (int c = c0; c < c1; ++c) load_column(0, c, tid);
    });
    // the rows in blocks of row_block, in a thread's buffer: gathered from the columns, c2r, fn, r2c, scattered back
    // (a block's values of one column share a cache line; successive columns are ld apart, in different cache sets)
    constexpr int R = plans::row_block;
    static_assert(R == 4, "the full blocks below copy four rows by hand");
    const std::size_t bl = p_->row_pad;
    // Where the columns are larger than a share of the L3 cache (from N = 1024 in Basdevant's form), the lines of the
    // next block are asked for (prefetch for writing: the block is scattered back into them) before this block is
    // gathered: between a block's gather and the next one's come its transforms, in which the lines arrive. Paired
    // in time at N = 1024, one thread: 0.8-1.2 ms less for the transforms of a step (~3 %) and as much less for a
    // C-RK4 step; at N = 2048 ~3 %; at N = 256 and 512, where the columns stay in cache, +-1 %, so not there.
    const bool ahead = std::size_t(std::max(in, out)) * fs * sizeof(cplx) >= (std::size_t(8) << 20);
    const auto row_pass = [&](int blk0, int blk1, int tid) {
        double* const base = p_->rows[std::size_t(tid)];
        const auto row = [&](int j, int q) { return base + (std::size_t(j) * R + std::size_t(q)) * bl; };
        const auto real = [&](int j, int q) { return row(fields_ + j, q); };
        for (int blk = blk0; blk < blk1; ++blk) {
            const int y0 = blk * R, rb = std::min(R, n_ - y0);
            if (ahead && blk + 1 < blk1)
                for (int j = 0; j < std::max(in, out); ++j) {
                    const cplx* next = p_->buf + std::size_t(j) * fs + std::size_t(y0 + R);
                    for (int c = 0; c < kept; ++c) __builtin_prefetch(next + std::size_t(c) * ld, 1, 3);
                }
            for (int j = 0; j < in; ++j) {
                const cplx* src = p_->buf + std::size_t(j) * fs + std::size_t(y0);
                cplx* r[R];
                for (int q = 0; q < R; ++q) r[q] = reinterpret_cast<cplx*>(row(j, q));
                if (rb == R) {
                    for (int c = 0; c < kept; ++c) {
                        const cplx* s = src + std::size_t(c) * ld;
                        r[0][c] = s[0], r[1][c] = s[1], r[2][c] = s[2], r[3][c] = s[3];
                    }
                } else {
                    for (int c = 0; c < kept; ++c)
                        for (int q = 0; q < rb; ++q) r[q][c] = src[std::size_t(c) * ld + std::size_t(q)];
                }
                for (int q = 0; q < rb; ++q) {
                    std::fill(r[q] + kept, r[q] + nc, cplx{});
                    fftw_execute_dft_c2r(p_->block_c2r, reinterpret_cast<fftw_complex*>(r[q]), real(j, q));
                }
            }
            for (int q = 0; q < rb; ++q) {
                double* b[8];
                for (int j = 0; j < in; ++j) b[j] = real(j, q);
                fn(fn_ctx, b, std::size_t(n_));
            }
            for (int j = 0; j < out; ++j) {
                const cplx* r[R];
                for (int q = 0; q < rb; ++q) {
                    fftw_execute_dft_r2c(p_->block_r2c, real(j, q), reinterpret_cast<fftw_complex*>(row(j, q)));
                    r[q] = reinterpret_cast<const cplx*>(row(j, q));
                }
                cplx* dst = p_->buf + std::size_t(j) * fs + std::size_t(y0);
                if (rb == R) {
                    for (int c = 0; c < kept; ++c) {
                        cplx* d = dst + std::size_t(c) * ld;
                        d[0] = r[0][c], d[1] = r[1][c], d[2] = r[2][c], d[3] = r[3][c];
                    }
                } else {
                    for (int c = 0; c < kept; ++c)
                        for (int q = 0; q < rb; ++q) dst[std::size_t(c) * ld + std::size_t(q)] = r[q][c];
                }
            }
        }
    };
    for (int s = 0; s < stages; ++s) {
        omp_rows(threads_, (n_ + R - 1) / R, row_pass);
        if (out == 0) continue;
        // stage s's outputs, and, a group of columns at a time while their memory is in cache, the next stage's
        // inputs (a column of the next stage's state needs only that column of this stage's result)
        const bool last = s + 1 == stages;
        omp_rows(threads_, kept, [&](int c0, int c1, int tid) {
            for (int g0 = c0; g0 < c1; g0 += group) {
                const int g1 = std::min(c1, g0 + group);
                for (int c = g0; c < g1; ++c) forward_column(c);
                for (int c = g0; c < g1; ++c) store_column(s, c, tid);
                if (!last)
                    for (int c = g0; c < g1; ++c) load_column(s + 1, c, tid);
            }
        });
    }
}

void grid::make_hermitian(cplx* w) const {
    const std::size_t cols = std::size_t(columns());
    for (std::size_t col : {std::size_t(0), cols - 1}) {
        for (int row = 1; row < n_ / 2; ++row)
            w[std::size_t(n_ - row) * cols + col] = std::conj(w[std::size_t(row) * cols + col]);
        w[col] = w[col].real();
        w[std::size_t(n_ / 2) * cols + col] = w[std::size_t(n_ / 2) * cols + col].real();
    }
}

std::vector<double> grid::to_physical(const cplx* f) const {
    require(!distributed_, "grid::to_physical holds the whole field: on MPI use flow2d::to_physical");
    std::copy(f, f + size(), spectral(0));  // the inverse transform overwrites its input
    inverse(1);
    std::vector<double> out(points());
    const double* r = physical(0);
    for (int y = 0; y < n_; ++y)
        std::copy(r + std::size_t(y) * padded(), r + std::size_t(y) * padded() + std::size_t(n_),
                  out.begin() + std::ptrdiff_t(y) * n_);
    return out;
}

std::vector<cplx> grid::from_physical(std::span<const double> field) const {
    require(!distributed_, "grid::from_physical holds the whole field: on MPI use flow2d::from_physical");
    if (field.size() != points())
        throw std::invalid_argument("field has " + std::to_string(field.size()) + " values, the grid " +
                                    std::to_string(points()));
    const double s = load_physical_rows(field, 0);
    forward(0, 1);
    std::vector<cplx> w(size());
    const double scale = s * (1.0 / double(points()));  // (s a power of two: the unscaled product where s = 1)
    const cplx* c = spectral(0);
    for (std::size_t i = 0; i < size(); ++i) w[i] = retained(i) ? scale * c[i] : cplx{};
    make_hermitian(w.data());
    return w;
}

double grid::load_physical_rows(std::span<const double> rows, int first_row) const {
    const double s = field_scale(rows, first_row);  // (collective: a value not finite refused everywhere)
    double* r = physical(0);
    const std::size_t count = rows.size() / std::size_t(n_);
    for (std::size_t y = 0; y < count; ++y) {
        const auto src = rows.begin() + std::ptrdiff_t(y * std::size_t(n_));
        std::transform(src, src + n_, r + y * padded(), [s](double f) { return f / s; });
        std::fill(r + y * padded() + std::size_t(n_), r + (y + 1) * padded(), 0.0);
    }
    return s;
}

double grid::field_scale(std::span<const double> values, int first_row) const {
    // the largest magnitude and the first value that is not finite (minus its index over the whole field; -inf:
    // none), reduced over the processes, and then what that value is: every process refuses the same value alike
    constexpr double none = -std::numeric_limits<double>::infinity();
    const std::size_t first = std::size_t(first_row) * std::size_t(n_);
    double v[2] = {0.0, none};
    for (std::size_t j = 0; j < values.size(); ++j) {
        if (!std::isfinite(values[j])) {
            v[1] = -double(first + j);
            break;
        }
        v[0] = std::max(v[0], std::abs(values[j]));
    }
    const double own = v[1];
    max_over_ranks(v, 2);
    if (v[1] != none) {
        const auto at = std::size_t(-v[1]);
        double kind = own == v[1] ? (std::isnan(values[at - first]) ? 0.0 : values[at - first] > 0 ? 1.0 : 2.0) : -1.0;
        max_over_ranks(&kind, 1);
        throw std::invalid_argument("field value at x = " + std::to_string(at % std::size_t(n_)) + ", y = " +
                                    std::to_string(at / std::size_t(n_)) + " is " +
                                    (kind == 0.0 ? "nan" : kind == 1.0 ? "inf" : "-inf") + ": a field must be finite");
    }
    const double limit = std::numeric_limits<double>::max() / (4.0 * double(n_) * double(n_));
    return v[0] < limit ? 1.0 : std::ldexp(1.0, std::ilogb(v[0]));  // (then max |f / s| < 2; s <= 2^1023)
}

std::string grid::beyond_retained(double k) const {
    if (!std::isfinite(k) || k <= double(kmax())) return "";
    return "is beyond the retained modes (|k_x|, |k_y| <= kmax = " + std::to_string(kmax()) + " at N = " +
           std::to_string(n_) + ")";
}

std::size_t grid::shell_count() const { return std::size_t(std::ceil(std::sqrt(2.0) * kmax())) + 2; }

}  // namespace eci::spectral
