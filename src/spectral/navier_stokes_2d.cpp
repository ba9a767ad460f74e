// The pseudo-spectral 2-D vorticity model of navier_stokes_2d.hpp: FFTW plans (made once, threaded, wisdom in a
// file), the dealiased nonlinear term, linear terms and forcing with their budget rates, diagnostics and fields.
#include "eci/models/navier_stokes_2d.hpp"

#include <fftw3.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <mutex>
#include <numbers>
#include <stdexcept>
#include <string>

namespace eci {

namespace {

using cplx = std::complex<double>;

// SplitMix64: a seed means the same field and forcing on every platform.
std::uint64_t splitmix_next(std::uint64_t& s) {
    std::uint64_t z = (s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}
double uniform(std::uint64_t& s) { return double(splitmix_next(s) >> 11) * 0x1.0p-53; }
// A complex Gaussian of unit variance E|g|^2 = 1 (Box-Muller; both outputs used, so no hidden cached value).
cplx complex_gaussian(std::uint64_t& s) {
    const double u1 = 1.0 - uniform(s), u2 = uniform(s);
    const double r = std::sqrt(-std::log(u1));
    return {r * std::cos(2.0 * std::numbers::pi * u2), r * std::sin(2.0 * std::numbers::pi * u2)};
}

void require(bool ok, const std::string& what) {
    if (!ok) throw std::invalid_argument(what);
}

std::once_flag fftw_threads_once;

// Per-thread partial sums combined in thread order: the same bits on every run with the same thread count
// (an OpenMP reduction clause combines in whatever order threads finish).
template <std::size_t K, class Body>
std::array<double, K> ordered_sum(int threads, int rows, Body body) {
    std::array<std::array<double, K>, 64> part{};
    const int nt = std::min(threads, 64);
#pragma omp parallel num_threads(nt)
    {
        const int tid = omp_get_thread_num(), nth = omp_get_num_threads();
        std::array<double, K> acc{};
        body(rows * tid / nth, rows * (tid + 1) / nth, acc);
        part[std::size_t(tid)] = acc;
    }
    std::array<double, K> total{};
    for (int t = 0; t < nt; ++t)
        for (std::size_t k = 0; k < K; ++k) total[k] += part[std::size_t(t)][k];
    return total;
}

}  // namespace

void ns2d_params::validate() const {
    require(n >= 8 && n % 2 == 0, "grid size N must be even and at least 8, not " + std::to_string(n));
    require(n <= 65536, "grid size N = " + std::to_string(n) + " is too large");
    require(std::isfinite(nu) && nu >= 0.0, "viscosity nu must be finite and >= 0");
    require(std::isfinite(hyper_nu) && hyper_nu >= 0.0, "hyperviscosity must be finite and >= 0");
    require(hyper_p >= 1 && hyper_p <= 16, "hyperviscosity power p must be in 1..16");
    require(std::isfinite(drag) && drag >= 0.0, "drag must be finite and >= 0");
    require(std::isfinite(forcing_k) && forcing_k > 0.0, "forcing wavenumber k_f must be positive");
    require(std::isfinite(forcing_amplitude) && forcing_amplitude >= 0.0, "forcing amplitude must be >= 0");
    require(std::isfinite(injection_rate) && injection_rate >= 0.0, "injection rate must be >= 0");
    require(threads >= 1 && threads <= 64, "threads must be in 1..64");
}

struct navier_stokes_2d::impl {
    ns2d_params p;
    int n = 0, nc = 0, kmax = 0;
    std::size_t m = 0, nr = 0;
    std::vector<double> inv_k2, k2, lin, sigma;  // per stored mode: 1/|k|^2 (0 if not retained), |k|^2, L, noise
    state_type force;
    cplx* c = nullptr;    // four spectral scratch arrays (inputs of the inverse transforms)
    double* r = nullptr;  // four real fields; the first also takes the product u . grad omega
    cplx* out = nullptr;  // the product's transform
    // inverse4: the four fields of the nonlinear term in one call; inverse2: the velocity alone (max|u|)
    fftw_plan inverse4 = nullptr, inverse2 = nullptr, inverse1 = nullptr, forward = nullptr;

    ~impl() {
        for (fftw_plan pl : {inverse4, inverse2, inverse1, forward})
            if (pl) fftw_destroy_plan(pl);
        fftw_free(c);
        fftw_free(r);
        fftw_free(out);
    }

    int ky_of(int row) const { return row <= n / 2 ? row : row - n; }

    // Fill c[0], c[1] with a(k) w_k and b(k) w_k for every retained mode (zero elsewhere), then transform both.
    template <class A>
    void inverse_pair(const cplx* w, A coef) {
#pragma omp parallel for num_threads(p.threads) schedule(static)
        for (int row = 0; row < n; ++row) {
            const double ky = ky_of(row);
            for (int col = 0; col < nc; ++col) {
                const std::size_t i = std::size_t(row) * std::size_t(nc) + std::size_t(col);
                const auto [a, b] = coef(double(col), ky, inv_k2[i], w[i]);
                c[i] = a;
                c[m + i] = b;
            }
        }
        fftw_execute(inverse2);
    }

    // Column k_x = 0 holds both k and -k: make them exact conjugates (a real field's transform is so only up to
    // round-off), so the state stays the transform of a real field bit for bit.
    void make_hermitian(cplx* w) const {
        const std::size_t cols = std::size_t(nc);
        for (std::size_t col : {std::size_t(0), cols - 1}) {
            for (int row = 1; row < n / 2; ++row)
                w[std::size_t(n - row) * cols + col] = std::conj(w[std::size_t(row) * cols + col]);
            w[col] = w[col].real();
            w[std::size_t(n / 2) * cols + col] = w[std::size_t(n / 2) * cols + col].real();
        }
    }

    // The transforms of -u . grad omega, leaving its undealiased, unscaled transform in `out`: one pass fills the
    // four spectral fields, one call transforms them, one pass forms the product, one forward transform. (Two
    // fills and two products, one per pair, cost 40 % more memory traffic: the pointwise work is what a step
    // adds to its FFTs.)
    void nonlinear_transform(const cplx* w) {
        const std::size_t nr_ = nr, m_ = m, ncol = std::size_t(nc);
        cplx* c0 = c;
        cplx* c1 = c + m_;
        cplx* c2 = c + 2 * m_;
        cplx* c3 = c + 3 * m_;
        const double* ik2 = inv_k2.data();
#pragma omp parallel for num_threads(p.threads) schedule(static)
        for (int row = 0; row < n; ++row) {
            const int kyi = ky_of(row);
            const double ky = kyi;
            const std::size_t i0 = std::size_t(row) * ncol;
            // Only the retained square |k_x|, |k_y| <= kmax (4/9 of the stored modes) reads omega; the rest is
            // zero, rewritten because a c2r transform overwrites its input.
            const std::size_t kept = std::abs(kyi) <= kmax ? std::size_t(kmax) + 1 : 0;
            for (std::size_t col = 0; col < kept; ++col) {
                const std::size_t i = i0 + col;
                const double kx = double(col), g = ik2[i], mask = g != 0.0 ? 1.0 : 0.0;
                const double re = w[i].real(), im = w[i].imag();
                // u_x = i k_y omega / |k|^2, d omega/dx = i k_x omega, u_y = -i k_x omega / |k|^2,
                // d omega/dy = i k_y omega (so that omega = dx u_y - dy u_x)
                c0[i] = cplx(-ky * g * im, ky * g * re);
                c1[i] = cplx(-kx * mask * im, kx * mask * re);
                c2[i] = cplx(kx * g * im, -kx * g * re);
                c3[i] = cplx(-ky * mask * im, ky * mask * re);
            }
            for (cplx* ci : {c0, c1, c2, c3}) std::fill(ci + i0 + kept, ci + i0 + ncol, cplx{});
        }
        fftw_execute(inverse4);
        double* r0 = r;
        const double* r1 = r + nr_;
        const double* r2 = r + 2 * nr_;
        const double* r3 = r + 3 * nr_;
#pragma omp parallel for num_threads(p.threads) schedule(static)
        for (std::size_t j = 0; j < nr_; ++j) r0[j] = r0[j] * r1[j] + r2[j] * r3[j];
        fftw_execute(forward);
    }

    // -u . grad omega, dealiased, into `dst` (4 inverse and 1 forward transform).
    void nonlinear(const cplx* w, cplx* dst) {
        nonlinear_transform(w);
        // Zero every mode outside the retained square: with 3 kmax < n the kept modes are alias-free, so the
        // truncated system is a Galerkin one and each of its triads conserves E and Z.
        const double scale = -1.0 / double(nr);
#pragma omp parallel for num_threads(p.threads) schedule(static)
        for (std::size_t i = 0; i < m; ++i) dst[i] = inv_k2[i] != 0.0 ? scale * out[i] : cplx{};
        make_hermitian(dst);
    }
};

navier_stokes_2d::navier_stokes_2d(const ns2d_params& p) : n_(p.n), d_(std::make_unique<impl>()) {
    p.validate();
    impl& d = *d_;
    d.p = p;
    d.n = p.n;
    d.nc = p.n / 2 + 1;
    d.kmax = kmax();
    d.m = size();
    d.nr = std::size_t(p.n) * std::size_t(p.n);
    weights_.assign(d.m, 0.0);
    d.inv_k2.assign(d.m, 0.0);
    d.k2.assign(d.m, 0.0);
    d.lin.assign(d.m, 0.0);
    d.sigma.assign(d.m, 0.0);
    d.force.assign(d.m, cplx{});
    for (std::size_t i = 0; i < d.m; ++i) {
        const int x = kx(i), y = ky(i);
        const double k2 = double(x) * x + double(y) * y;
        d.k2[i] = k2;
        if (k2 == 0.0 || x > d.kmax || std::abs(y) > d.kmax) continue;
        weights_[i] = (x == 0 || x == p.n / 2) ? 1.0 : 2.0;
        d.inv_k2[i] = 1.0 / k2;
        d.lin[i] = -(p.nu * k2 + p.hyper_nu * std::pow(k2, p.hyper_p) + p.drag);
    }
    // The forced band k_f - 1/2 <= |k| < k_f + 1/2, retained modes only.
    double band_count = 0.0, band_inv_k2 = 0.0;
    for (std::size_t i = 0; i < d.m; ++i) {
        const double k = std::sqrt(d.k2[i]);
        if (!retained(i) || k < p.forcing_k - 0.5 || k >= p.forcing_k + 0.5) continue;
        d.sigma[i] = 1.0;
        band_count += weights_[i];
        band_inv_k2 += weights_[i] * d.inv_k2[i];
    }
    if (p.forcing != ns2d_forcing::none)
        require(band_count > 0.0, "the forcing band |k| = " + std::to_string(p.forcing_k) +
                                      " +- 1/2 holds no retained mode (kmax = " + std::to_string(d.kmax) + ")");
    rng_ = p.forcing_seed;
    if (p.forcing == ns2d_forcing::deterministic) {
        // Fixed random phases; rms of the forcing field sum_full |F_k|^2 = amplitude^2.
        std::uint64_t s = p.forcing_seed;
        const double a = p.forcing_amplitude / std::sqrt(band_count);
        for (std::size_t i = 0; i < d.m; ++i) {
            if (d.sigma[i] == 0.0) continue;
            const double phase = 2.0 * std::numbers::pi * uniform(s);
            d.force[i] = std::polar(a, phase);
        }
        d.make_hermitian(d.force.data());
    } else if (p.forcing == ns2d_forcing::stochastic) {
        // White noise held over a step of dt: F = sigma g / sqrt(dt) injects, on average, 1/2 sum_full sigma^2/|k|^2
        // per unit time, which is epsilon for this sigma.
        const double sig = std::sqrt(2.0 * p.injection_rate / band_inv_k2);
        for (double& v : d.sigma) v *= sig;
    }

    std::call_once(fftw_threads_once, [] { fftw_init_threads(); });
    if (!p.wisdom_file.empty()) fftw_import_wisdom_from_filename(p.wisdom_file.c_str());
    if (!p.wisdom.empty() && !fftw_import_wisdom_from_string(p.wisdom.c_str()))
        throw std::invalid_argument("FFTW wisdom could not be read");
    fftw_plan_with_nthreads(p.threads);
    d.c = reinterpret_cast<cplx*>(fftw_alloc_complex(4 * d.m));
    d.out = reinterpret_cast<cplx*>(fftw_alloc_complex(d.m));
    d.r = fftw_alloc_real(4 * d.nr);
    if (!d.c || !d.out || !d.r) throw std::bad_alloc();
    const unsigned flags = p.measure ? FFTW_MEASURE : FFTW_ESTIMATE;
    const int dims[2] = {p.n, p.n};
    d.inverse4 = fftw_plan_many_dft_c2r(2, dims, 4, reinterpret_cast<fftw_complex*>(d.c), nullptr, 1, int(d.m), d.r,
                                        nullptr, 1, int(d.nr), flags);
    d.inverse2 = fftw_plan_many_dft_c2r(2, dims, 2, reinterpret_cast<fftw_complex*>(d.c), nullptr, 1, int(d.m), d.r,
                                        nullptr, 1, int(d.nr), flags);
    d.inverse1 = fftw_plan_dft_c2r_2d(p.n, p.n, reinterpret_cast<fftw_complex*>(d.c), d.r, flags);
    d.forward = fftw_plan_dft_r2c_2d(p.n, p.n, d.r, reinterpret_cast<fftw_complex*>(d.out), flags);
    if (!d.inverse4 || !d.inverse2 || !d.inverse1 || !d.forward)
        throw std::runtime_error("FFTW could not plan the transforms");
    if (!p.wisdom_file.empty()) {
        // temporary + rename, so a concurrent reader never sees half a file
        const std::string tmp = p.wisdom_file + ".tmp" + std::to_string(reinterpret_cast<std::uintptr_t>(this));
        if (fftw_export_wisdom_to_filename(tmp.c_str())) std::rename(tmp.c_str(), p.wisdom_file.c_str());
    }
}

navier_stokes_2d::~navier_stokes_2d() = default;
navier_stokes_2d::navier_stokes_2d(navier_stokes_2d&&) noexcept = default;
navier_stokes_2d& navier_stokes_2d::operator=(navier_stokes_2d&&) noexcept = default;

const ns2d_params& navier_stokes_2d::params() const { return d_->p; }

std::string navier_stokes_2d::fftw_wisdom() {
    char* w = fftw_export_wisdom_to_string();
    if (!w) return {};
    std::string s(w);
    fftw_free(w);
    return s;
}

std::vector<std::vector<double>> navier_stokes_2d::quadratic_invariant_weights() const {
    std::vector<std::vector<double>> q(2, std::vector<double>(size()));
    for (std::size_t i = 0; i < size(); ++i) {
        q[0][i] = 0.5 * weights_[i] * d_->inv_k2[i];
        q[1][i] = 0.5 * weights_[i];
    }
    return q;
}

void navier_stokes_2d::execute_transforms() {
    fftw_execute(d_->inverse4);
    fftw_execute(d_->forward);
}

void navier_stokes_2d::nonlinear(const state_type& w, state_type& out) {
    if (w.size() != size()) throw std::invalid_argument("state size does not match the grid");
    out.resize(size());
    d_->nonlinear(w.data(), out.data());
}

void navier_stokes_2d::operator()(const state_type& w, state_type& dwdt, double /*t*/) {
    impl& d = *d_;
    dwdt.resize(d.m);
    d.nonlinear_transform(w.data());
    const cplx* x = w.data();
    const cplx* nl_hat = d.out;
    cplx* f = dwdt.data();
    const cplx* F = d.force.data();
    const std::size_t nc = std::size_t(d.nc);
    const double* wt = weights_.data();
    const double* lin = d.lin.data();
    const double* ik2 = d.inv_k2.data();
    const double scale = -1.0 / double(d.nr);
    // One pass from the product's transform to the right-hand side: dealias and scale it (impl::nonlinear), add
    // the linear terms and the forcing. The k_x = 0 and Nyquist columns are made exact conjugates after: the
    // linear terms and F are Hermitian there, so that equals symmetrising N first.
    // Outside the retained square (5/9 of the stored modes) omega, L and F are zero and so is the result: only
    // the square is read.
    const int kmax = d.kmax;
    auto kept = [&](int row) { return std::abs(d.ky_of(row)) <= kmax ? std::size_t(kmax) + 1 : 0; };
    if (!recording_) {
        const bool forced = d.p.forcing != ns2d_forcing::none;
#pragma omp parallel for num_threads(d.p.threads) schedule(static)
        for (int row = 0; row < d.n; ++row) {
            const std::size_t i0 = std::size_t(row) * nc, i1 = i0 + kept(row);
            if (forced) {
                for (std::size_t i = i0; i < i1; ++i)
                    f[i] = (ik2[i] != 0.0 ? scale * nl_hat[i] : cplx{}) + lin[i] * x[i] + F[i];
            } else {
                for (std::size_t i = i0; i < i1; ++i) f[i] = (ik2[i] != 0.0 ? scale * nl_hat[i] : cplx{}) + lin[i] * x[i];
            }
            std::fill(f + i1, f + i0 + nc, cplx{});
        }
        d.make_hermitian(f);
        return;
    }
    // The same pass sums what each part of the right-hand side does to E and Z (weights w_k / |k|^2 and w_k).
    const auto s = ordered_sum<6>(d.p.threads, d.n, [&](int r0, int r1, std::array<double, 6>& acc) {
        for (int row = r0; row < r1; ++row) {
            const std::size_t i0 = std::size_t(row) * nc, i1 = i0 + kept(row);
            for (std::size_t i = i0; i < i1; ++i) {
                const cplx nk = ik2[i] != 0.0 ? scale * nl_hat[i] : cplx{};
                const double nl = x[i].real() * nk.real() + x[i].imag() * nk.imag();
                const double diss = -lin[i] * std::norm(x[i]);
                const double inj = x[i].real() * F[i].real() + x[i].imag() * F[i].imag();
                f[i] = nk + lin[i] * x[i] + F[i];
                const double we = wt[i] * ik2[i];
                acc[0] += we * inj;
                acc[1] += we * diss;
                acc[2] += wt[i] * inj;
                acc[3] += wt[i] * diss;
                acc[4] += we * nl;
                acc[5] += wt[i] * nl;
            }
            std::fill(f + i1, f + i0 + nc, cplx{});
        }
    });
    d.make_hermitian(f);
    if (recorded_count_ < recorded_.size()) recorded_[recorded_count_++] = {s[0], s[1], s[2], s[3], s[4], s[5]};
}

ns2d_rates navier_stokes_2d::rates(const state_type& w) {
    state_type tmp;
    const auto saved = recorded_;
    const std::size_t count = recorded_count_;
    const bool was = recording_;
    recording_ = true;
    recorded_count_ = 0;
    (*this)(w, tmp, 0.0);
    const ns2d_rates r = recorded_[0];
    recorded_ = saved;
    recorded_count_ = count;
    recording_ = was;
    return r;
}

void navier_stokes_2d::start_recording() {
    recording_ = true;
    recorded_count_ = 0;
}

double navier_stokes_2d::energy(const state_type& w) const {
    const auto s = ordered_sum<1>(d_->p.threads, n_, [&](int r0, int r1, std::array<double, 1>& acc) {
        for (std::size_t i = std::size_t(r0) * std::size_t(columns()); i < std::size_t(r1) * std::size_t(columns()); ++i)
            acc[0] += weights_[i] * d_->inv_k2[i] * std::norm(w[i]);
    });
    return 0.5 * s[0];
}

double navier_stokes_2d::enstrophy(const state_type& w) const {
    const auto s = ordered_sum<1>(d_->p.threads, n_, [&](int r0, int r1, std::array<double, 1>& acc) {
        for (std::size_t i = std::size_t(r0) * std::size_t(columns()); i < std::size_t(r1) * std::size_t(columns()); ++i)
            acc[0] += weights_[i] * std::norm(w[i]);
    });
    return 0.5 * s[0];
}

double navier_stokes_2d::palinstrophy(const state_type& w) const {
    const auto s = ordered_sum<1>(d_->p.threads, n_, [&](int r0, int r1, std::array<double, 1>& acc) {
        for (std::size_t i = std::size_t(r0) * std::size_t(columns()); i < std::size_t(r1) * std::size_t(columns()); ++i)
            acc[0] += weights_[i] * d_->k2[i] * std::norm(w[i]);
    });
    return 0.5 * s[0];
}

double navier_stokes_2d::max_velocity(const state_type& w) {
    impl& d = *d_;
    if (w.size() != size()) throw std::invalid_argument("state size does not match the grid");
    d.inverse_pair(w.data(), [](double kx, double ky, double ik2, cplx v) {
        return std::pair{cplx(-ky * ik2 * v.imag(), ky * ik2 * v.real()), cplx(kx * ik2 * v.imag(), -kx * ik2 * v.real())};
    });
    double vmax = 0.0;
    for (std::size_t j = 0; j < d.nr; ++j) vmax = std::max(vmax, d.r[j] * d.r[j] + d.r[d.nr + j] * d.r[d.nr + j]);
    return std::sqrt(vmax);
}

double navier_stokes_2d::cfl(const state_type& w, double dt) {
    return max_velocity(w) * dt * double(n_) / (2.0 * std::numbers::pi);
}

std::vector<double> navier_stokes_2d::energy_spectrum(const state_type& w) const {
    std::vector<double> e(std::size_t(std::ceil(std::sqrt(2.0) * kmax())) + 2, 0.0);
    for (std::size_t i = 0; i < size(); ++i) {
        if (weights_[i] == 0.0) continue;
        const std::size_t shell = std::size_t(std::lround(std::sqrt(d_->k2[i])));
        e[shell] += 0.5 * weights_[i] * d_->inv_k2[i] * std::norm(w[i]);
    }
    return e;
}

navier_stokes_2d::state_type navier_stokes_2d::from_physical(std::span<const double> field) {
    impl& d = *d_;
    if (field.size() != d.nr)
        throw std::invalid_argument("field has " + std::to_string(field.size()) + " values, the grid " +
                                    std::to_string(d.nr));
    std::copy(field.begin(), field.end(), d.r);
    fftw_execute(d.forward);
    state_type w(d.m);
    const double scale = 1.0 / double(d.nr);
    for (std::size_t i = 0; i < d.m; ++i) w[i] = retained(i) ? scale * d.out[i] : cplx{};
    d.make_hermitian(w.data());
    return w;
}

std::vector<double> navier_stokes_2d::to_physical(const state_type& w) {
    impl& d = *d_;
    if (w.size() != size()) throw std::invalid_argument("state size does not match the grid");
    std::copy(w.begin(), w.end(), d.c);  // the inverse transform overwrites its input
    fftw_execute(d.inverse1);
    return std::vector<double>(d.r, d.r + d.nr);
}

navier_stokes_2d::state_type navier_stokes_2d::random_field(double k_peak, double energy_target, std::uint64_t seed) {
    require(std::isfinite(k_peak) && k_peak > 0.0, "peak wavenumber must be positive");
    require(std::isfinite(energy_target) && energy_target > 0.0, "initial energy must be positive");
    state_type w(size());
    std::uint64_t s = seed;
    for (std::size_t i = 0; i < size(); ++i) {
        // Every stored mode draws, so the field of a seed does not depend on which modes are retained.
        const double phase = 2.0 * std::numbers::pi * uniform(s);
        if (!retained(i)) continue;
        const double k = std::sqrt(d_->k2[i]), q = k / k_peak;
        // A shell of radius k holds about 2 pi k modes of energy |omega|^2 / (2 k^2) each. The tail is a power
        // law: an exponential one leaves the far modes below round-off, where their right-hand sides are FFT noise
        // of random sign and the conservative methods' radicands negative at any step size.
        const double shell_energy = q * q * q * q / std::pow(1.0 + q * q, 4);
        w[i] = std::polar(std::sqrt(shell_energy * k / std::numbers::pi), phase);
    }
    d_->make_hermitian(w.data());
    const double e = energy(w);
    require(e > 0.0, "no retained mode near the peak wavenumber");
    const double scale = std::sqrt(energy_target / e);
    for (cplx& v : w) v *= scale;
    return w;
}

navier_stokes_2d::state_type navier_stokes_2d::vortex_pair(double radius, double separation, double peak) {
    require(std::isfinite(radius) && radius > 0.0, "vortex radius must be positive");
    require(std::isfinite(separation) && separation >= 0.0 && separation < std::numbers::pi,
            "vortex separation must be in [0, pi)");
    require(std::isfinite(peak), "peak vorticity must be finite");
    const double h = 2.0 * std::numbers::pi / n_, L = 2.0 * std::numbers::pi;
    std::vector<double> f(std::size_t(n_) * std::size_t(n_));
    // The pair's centre is off the grid's symmetry points: centred on one, half the Fourier components would be
    // zero up to round-off, with right-hand sides of random sign, and their radicands negative at any step size.
    const double xc = std::numbers::pi + 0.1234, yc = std::numbers::pi + 0.0567;
    const double cx[2] = {xc - 0.5 * separation, xc + 0.5 * separation};
    for (int j = 0; j < n_; ++j)
        for (int i = 0; i < n_; ++i) {
            double v = 0.0;
            for (double c : cx) {
                double dx = std::remainder(i * h - c, L), dy = std::remainder(j * h - yc, L);
                v += peak * std::exp(-(dx * dx + dy * dy) / (radius * radius));
            }
            f[std::size_t(j) * std::size_t(n_) + std::size_t(i)] = v;
        }
    return from_physical(f);
}

navier_stokes_2d::state_type navier_stokes_2d::taylor_green(double velocity) {
    require(std::isfinite(velocity), "Taylor-Green velocity must be finite");
    // 2 U sin x sin y = -(U/2) (e^{i(x+y)} - e^{i(x-y)} - e^{i(-x+y)} + e^{-i(x+y)})
    state_type w(size());
    const std::size_t nc = std::size_t(columns());
    w[1 * nc + 1] = -0.5 * velocity;                    // (k_x, k_y) = (1, 1)
    w[std::size_t(n_ - 1) * nc + 1] = 0.5 * velocity;  // (1, -1)
    return w;
}

void navier_stokes_2d::draw_forcing(double dt) {
    impl& d = *d_;
    if (d.p.forcing != ns2d_forcing::stochastic) return;
    const double a = 1.0 / std::sqrt(dt);
    for (std::size_t i = 0; i < d.m; ++i)
        d.force[i] = d.sigma[i] != 0.0 ? d.sigma[i] * a * complex_gaussian(rng_) : cplx{};
    d.make_hermitian(d.force.data());
}

const navier_stokes_2d::state_type& navier_stokes_2d::forcing() const { return d_->force; }

}  // namespace eci
