// The grid of grid.hpp: FFTW plans (in place, batched, threaded, wisdom), wavenumber tables, the rows split between
// OpenMP threads.
#include "eci/spectral/grid.hpp"

#include <fftw3.h>
#include <omp.h>

#include <cstdio>
#include <mutex>
#include <new>
#include <numbers>
#include <stdexcept>

namespace eci::spectral {

namespace {

std::once_flag fftw_threads_once;

void require(bool ok, const std::string& what) {
    if (!ok) throw std::invalid_argument(what);
}

}  // namespace

cplx complex_gaussian(std::uint64_t& s) {
    const double u1 = 1.0 - uniform(s), u2 = uniform(s);
    const double r = std::sqrt(-std::log(u1));
    return {r * std::cos(2.0 * std::numbers::pi * u2), r * std::sin(2.0 * std::numbers::pi * u2)};
}

struct grid::plans {
    cplx* buf = nullptr;  // `fields` in-place fields of size() complex values (2 size() doubles) each
    std::vector<fftw_plan> inverse, forward;  // inverse[c]: fields 0..c; forward[c]: c + 1 fields from field 0
    ~plans() {
        for (auto* v : {&inverse, &forward})
            for (fftw_plan p : *v)
                if (p) fftw_destroy_plan(p);
        fftw_free(buf);
    }
};

grid::grid(const grid_options& o) : n_(o.n), fields_(o.fields), threads_(o.threads), p_(std::make_unique<plans>()) {
    require(o.n >= 8 && o.n % 2 == 0, "grid size N must be even and at least 8, not " + std::to_string(o.n));
    require(o.n <= 65536, "grid size N = " + std::to_string(o.n) + " is too large");
    require(o.threads >= 1 && o.threads <= 64, "threads must be in 1..64");
    require(o.fields >= 1 && o.fields <= 8, "scratch fields must be in 1..8");
    const std::size_t m = size();
    k2_.assign(m, 0.0);
    weights_.assign(m, 0.0);
    for (std::size_t i = 0; i < m; ++i) {
        const int x = kx(i), y = ky(i);
        k2_[i] = double(x) * x + double(y) * y;
        if (k2_[i] == 0.0 || x > kmax() || std::abs(y) > kmax()) continue;
        weights_[i] = (x == 0 || x == n_ / 2) ? 1.0 : 2.0;
    }
    std::call_once(fftw_threads_once, [] { fftw_init_threads(); });
    if (!o.wisdom_file.empty()) fftw_import_wisdom_from_filename(o.wisdom_file.c_str());
    if (!o.wisdom.empty() && !fftw_import_wisdom_from_string(o.wisdom.c_str()))
        throw std::invalid_argument("FFTW wisdom could not be read");
    fftw_plan_with_nthreads(o.threads);
    p_->buf = reinterpret_cast<cplx*>(fftw_alloc_complex(std::size_t(fields_) * m));
    if (!p_->buf) throw std::bad_alloc();
    std::fill(p_->buf, p_->buf + std::size_t(fields_) * m, cplx{});
    const unsigned flags = o.measure ? FFTW_MEASURE : FFTW_ESTIMATE;
    const int dims[2] = {n_, n_};
    // In place: a real row of n values padded to 2 columns() doubles (FFTW's layout), so one field's spectral and
    // physical views share memory and a state's scratch is `fields` state sizes.
    const int embed_r[2] = {n_, int(padded())}, embed_c[2] = {n_, columns()};
    auto* c = reinterpret_cast<fftw_complex*>(p_->buf);
    auto* r = reinterpret_cast<double*>(p_->buf);
    // MEASURE overwrites the arrays it plans on: plan before anything is stored in them.
    for (int k = 1; k <= fields_; ++k) {
        p_->inverse.push_back(fftw_plan_many_dft_c2r(2, dims, k, c, embed_c, 1, int(m), r, embed_r, 1, int(2 * m), flags));
        p_->forward.push_back(fftw_plan_many_dft_r2c(2, dims, k, r, embed_r, 1, int(2 * m), c, embed_c, 1, int(m), flags));
        if (!p_->inverse.back() || !p_->forward.back()) throw std::runtime_error("FFTW could not plan the transforms");
    }
    std::fill(p_->buf, p_->buf + std::size_t(fields_) * m, cplx{});
    if (!o.wisdom_file.empty()) {
        // temporary + rename, so a concurrent reader never sees half a file
        const std::string tmp = o.wisdom_file + ".tmp" + std::to_string(reinterpret_cast<std::uintptr_t>(this));
        if (fftw_export_wisdom_to_filename(tmp.c_str())) std::rename(tmp.c_str(), o.wisdom_file.c_str());
    }
}

grid::~grid() = default;
grid::grid(grid&&) noexcept = default;
grid& grid::operator=(grid&&) noexcept = default;

std::string grid::fftw_wisdom() {
    char* w = fftw_export_wisdom_to_string();
    if (!w) return {};
    std::string s(w);
    fftw_free(w);
    return s;
}

cplx* grid::spectral(int j) const { return p_->buf + std::size_t(j) * size(); }
double* grid::physical(int j) const { return reinterpret_cast<double*>(spectral(j)); }

void grid::inverse(int count) const { fftw_execute(p_->inverse.at(std::size_t(count - 1))); }

void grid::forward(int first, int count) const {
    if (first == 0) return fftw_execute(p_->forward.at(std::size_t(count - 1)));
    // a batch that does not start at field 0: the new-array interface on the same layout (alignment is the same,
    // every field starts on a multiple of size() complex values)
    fftw_execute_dft_r2c(p_->forward.at(std::size_t(count - 1)), physical(first),
                         reinterpret_cast<fftw_complex*>(spectral(first)));
}

void grid::run_rows(void (*fn)(void*, int, int, int), void* ctx) const {
    const int nt = std::min(threads_, 64), rows = n_;
#pragma omp parallel num_threads(nt)
    {
        const int tid = omp_get_thread_num(), nth = omp_get_num_threads();
        fn(ctx, rows * tid / nth, rows * (tid + 1) / nth, tid);
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
    if (field.size() != points())
        throw std::invalid_argument("field has " + std::to_string(field.size()) + " values, the grid " +
                                    std::to_string(points()));
    double* r = physical(0);
    for (int y = 0; y < n_; ++y)
        std::copy(field.begin() + std::ptrdiff_t(y) * n_, field.begin() + std::ptrdiff_t(y + 1) * n_,
                  r + std::size_t(y) * padded());
    forward(0, 1);
    std::vector<cplx> w(size());
    const double scale = 1.0 / double(points());
    const cplx* c = spectral(0);
    for (std::size_t i = 0; i < size(); ++i) w[i] = retained(i) ? scale * c[i] : cplx{};
    make_hermitian(w.data());
    return w;
}

std::size_t grid::shell_count() const { return std::size_t(std::ceil(std::sqrt(2.0) * kmax())) + 2; }

}  // namespace eci::spectral
