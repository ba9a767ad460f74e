// The flow of flow.hpp: coefficient tables from the equation, the two nonlinear forms on the grid's primitives, one
// fused pass from the transforms to the right-hand side (with the budget rates when recording), diagnostics, fields.
#include "eci/spectral/flow.hpp"

#include "eci/compensated_sum.hpp"
#include "eci/detail/format.hpp"
#include "eci/detail/simd.hpp"
#include "eci/memory.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>

namespace eci::spectral {

namespace {

void require(bool ok, const std::string& what) {
    if (!ok) throw std::invalid_argument(what);
}

grid_options grid_options_of(const flow_params& p) {
    grid_options o{p.n, 4, p.threads, p.measure, p.pruned_transforms, p.wisdom_file, p.wisdom};
#ifdef ECI_MPI
    o.comm = p.comm;
#endif
    return o;
}

}  // namespace

void flow_params::validate() const { validate(find_equation(equation)); }

int flow_params::whole(std::string_view field, long long v) {
    const std::string value = std::to_string(v);
    if (field == "n") {
        require(v >= 8 && v % 2 == 0, "grid size N must be even and at least 8, not " + value);
        require(v <= 65536, "grid size N must be at most 65536, not " + value);
    } else if (field == "hyper_p") {
        require(v >= 1 && v <= 16, "hyperviscosity power p must be in 1..16, not " + value);
    } else if (field == "hypo_p") {
        require(v >= 1 && v <= 16, "hypoviscosity power must be in 1..16, not " + value);
    } else if (field == "threads") {
        require(v >= 1 && v <= 64, "threads must be in 1..64, not " + value);
    } else {
        throw std::logic_error("flow_params has no whole-number field " + std::string(field));
    }
    return int(v);
}

std::string flow_params::unused_setting(std::string_view field, std::string (*name)(std::string_view)) const {
    const auto without = [&](const char* what) {
        return name(field) + " sets " + what + ", and this run's " + name("forcing") + " is " +
               std::string(forcing_name(forcing));
    };
    if (field == "forcing_k" && forcing == forcing_kind::none) return without("the forced band");
    if (field == "forcing_seed" && forcing == forcing_kind::none) return without("the forcing's random numbers");
    if (field == "forcing_amplitude" && forcing != forcing_kind::deterministic)
        return without("the deterministic forcing");
    if (field == "injection_rate" && forcing != forcing_kind::stochastic) return without("the stochastic forcing");
    if (field == "hyper_p" && hyper_nu == 0.0)
        return name(field) + " is the hyperviscosity's power, and " + name("hyper_nu") + " is 0";
    if (field == "hypo_p" && hypo_nu == 0.0)
        return name(field) + " is the hypoviscosity's power, and " + name("hypo_nu") + " is 0";
    return {};
}

forcing_kind flow_params::forcing_named(std::string_view s, std::string (*name)(std::string_view)) {
    for (forcing_kind f : {forcing_kind::none, forcing_kind::deterministic, forcing_kind::stochastic})
        if (s == forcing_name(f)) return f;
    throw std::invalid_argument(name("forcing") + " must be none, deterministic or stochastic, not '" +
                                std::string(s) + "'");
}

std::string_view flow_params::forcing_name(forcing_kind f) {
    return f == forcing_kind::none ? "none" : f == forcing_kind::deterministic ? "deterministic" : "stochastic";
}

void flow_params::validate(const spectral::equation& e) const {
    whole("n", n);
    require(std::isfinite(nu) && nu >= 0.0, "viscosity nu must be finite and >= 0");
    require(std::isfinite(hyper_nu) && hyper_nu >= 0.0, "hyperviscosity must be finite and >= 0");
    whole("hyper_p", hyper_p);
    require(std::isfinite(hypo_nu) && hypo_nu >= 0.0, "hypoviscosity must be finite and >= 0");
    whole("hypo_p", hypo_p);
    require(std::isfinite(drag) && drag >= 0.0, "drag must be finite and >= 0");
    require(std::isfinite(forcing_k) && forcing_k > 0.0, "forcing wavenumber k_f must be a positive finite number");
    require(std::isfinite(forcing_amplitude) && forcing_amplitude >= 0.0, "forcing amplitude must be >= 0");
    require(std::isfinite(injection_rate) && injection_rate >= 0.0, "injection rate must be >= 0");
    whole("threads", threads);
    if (e.validate) e.validate(*this);
    // A subnormal setting (below 2.2e-308) has lost its digits already and its products underflow to 0: a viscosity
    // of 1e-320 ran as none, its dissipation and budget rows 0 or subnormal. 0 or a normal number, as the ODE models'.
    for (const auto& [v, what] : {std::pair{nu, "viscosity nu"}, {hyper_nu, "hyperviscosity"}, {hypo_nu, "hypoviscosity"},
                                  {drag, "drag"}, {forcing_k, "forcing wavenumber k_f"},
                                  {forcing_amplitude, "forcing amplitude"}, {injection_rate, "injection rate"},
                                  {beta, "beta"}, {deformation, "deformation F = 1/L_d^2"}})
        eci::detail::require_normal(v, what);
    // A grid that cannot fit is refused now, with its size, not as std::bad_alloc after planning: at least 10
    // copies of FFTW's half plane, the measured peak of C-RK4 at N = 4096 (docs/benchmarks.md); methods with more
    // stages need more, so this refuses only what cannot run. Spread over P processes each holds 1/P of it.
    double processes = 1.0;
#ifdef ECI_MPI
    if (comm != MPI_COMM_NULL) {
        int size = 1;
        MPI_Comm_size(comm, &size);
        processes = double(size);
    }
#endif
    check_fits_in_memory(10.0 * 16.0 * double(n) * double(n / 2 + 1) / processes,
                         "grid size N = " + std::to_string(n) +
                             (processes > 1.0 ? " on " + std::to_string(int(processes)) + " processes" : ""));
}

namespace {

// A run of the fused column pass's modes (nonlinear_runs): column k_x, rows k_y = ky0, ky0 + 1, ..., the transforms'
// outputs o0 (and o1) there, and the transforms' scale; the right-hand side's vector pass reads it.
struct column_run {
    const cplx* o0;
    const cplx* o1;
    double kx, ky0, scale;
    cplx* in[4];  // the run's rows in the transforms' input fields (the chain's next stage, next_stage::fill)
};

// The streamfunction's velocity (u, v) = (-i k_y psi, i k_x psi), psi = a q, of a mode q at (kx, ky) and, for the
// advective form, its gradient (i k_x q, i k_y q).
inline void velocity(cplx q, double a, double kx, double ky, cplx& u, cplx& v) {
    const double pr = a * q.real(), pi = a * q.imag();  // psi
    u = cplx(ky * pi, -ky * pr);                         // u = -d psi/dy
    v = cplx(-kx * pi, kx * pr);                         // v = d psi/dx
}
inline void gradient(cplx q, double kx, double ky, cplx& qx, cplx& qy) {
    qx = cplx(-kx * q.imag(), kx * q.real());  // dq/dx (k = 0 is zero in the state)
    qy = cplx(-ky * q.imag(), ky * q.real());  // dq/dy
}

// The next stage's state formed in a right-hand side's loop over a run (rhs_chain): where stage s + 1's row of the
// tableau has the one term (dt a) k_s, y = x + w k_s at each mode as soon as its k_s is made, with combine_column's
// operations (the same bits), while the modes are in registers: the separate pass over the column read k_s and wrote
// y again (2 % of a C-RK4 step at N = 1024). And its fill of the next stage's transforms (fill_column's: the
// velocity, and for the advective form the gradient) into the run's rows of the input fields (column_run::in), where
// the run has just read its outputs: the fill's own pass read y back. y null: none formed. y may be the run's own
// state (stage s's, read before it is overwritten, mode by mode).
struct next_stage {
    const cplx* x = nullptr;  // the step's start
    double w = 0.0;           // dt a_{s+1, s}
    cplx* y = nullptr;        // where the next stage's state goes (indexed as the run's modes)
};

#if ECI_DETAIL_X86_SIMD
// The fused column pass's loops over a column's modes for AVX2, two modes a vector, with the scalar code's
// operations in each lane (no FMA): the same bits. Each takes count modes from k_y = ky, k_y exact integers in
// doubles (so stepping them by 2 is exact).
using v4 = __m256d;
// (a, a, b, b) from a[0], a[1]
__attribute__((target("avx2"))) inline v4 pairs(const double* a) {
    return _mm256_permute4x64_pd(_mm256_castpd128_pd256(_mm_loadu_pd(a)), 0x50);
}
// (ky, ky, ky + 1, ky + 1) times (s0, s1, s0, s1)
__attribute__((target("avx2"))) inline v4 ky_pairs(double ky, double s0, double s1) {
    return _mm256_mul_pd(_mm256_set_pd(ky + 1.0, ky + 1.0, ky, ky), _mm256_set_pd(s1, s0, s1, s0));
}
// velocity (and gradient) of two modes qv = (q_r, q_i, ...) with inversion factors ap = (a, a, a', a'):
// u = (k_y psi_i, -k_y psi_r), v = (-k_x psi_i, k_x psi_r), psi = a q, from kyu = (ky, -ky, ...) and
// kxv = (-kx, kx, ...); with qx (the advective form) also qx = (-k_x q_i, k_x q_r), qy = (-k_y q_i, k_y q_r).
__attribute__((target("avx2"))) inline void velocity_pair(v4 qv, v4 ap, v4 kyu, v4 kxv, cplx* u, cplx* v, cplx* qx,
                                                          cplx* qy) {
    const v4 swapped = _mm256_permute_pd(_mm256_mul_pd(ap, qv), 0x5);  // (psi_i, psi_r)
    _mm256_storeu_pd(reinterpret_cast<double*>(u), _mm256_mul_pd(kyu, swapped));
    _mm256_storeu_pd(reinterpret_cast<double*>(v), _mm256_mul_pd(kxv, swapped));
    if (qx) {
        const v4 qs = _mm256_permute_pd(qv, 0x5);                  // (q_i, q_r)
        const v4 kyg = _mm256_xor_pd(kyu, _mm256_set1_pd(-0.0));  // (-ky, ky), as the scalar -ky (-0 at 0)
        _mm256_storeu_pd(reinterpret_cast<double*>(qx), _mm256_mul_pd(kxv, qs));
        _mm256_storeu_pd(reinterpret_cast<double*>(qy), _mm256_mul_pd(kyg, qs));
    }
}
// velocity() (and gradient()) of count modes (q, a) from k_y = ky. Returns the modes done (pairs); the caller
// finishes the odd one.
__attribute__((target("avx2"))) std::size_t velocity_pairs(const cplx* q, const double* a, double kx, double ky,
                                                          std::size_t count, cplx* u, cplx* v, cplx* qx, cplx* qy) {
    const v4 kxv = _mm256_set_pd(kx, -kx, kx, -kx), two = _mm256_set_pd(-2.0, 2.0, -2.0, 2.0);
    v4 kyu = ky_pairs(ky, 1.0, -1.0);  // (ky, -ky, ...): u's
    std::size_t k = 0;
    for (; k + 2 <= count; k += 2) {
        velocity_pair(_mm256_loadu_pd(reinterpret_cast<const double*>(q + k)), pairs(a + k), kyu, kxv, u + k, v + k,
                      qx ? qx + k : nullptr, qx ? qy + k : nullptr);
        kyu = _mm256_add_pd(kyu, two);
    }
    return k;
}
// rhs_pass's right-hand side at count modes of a column run, state modes i0 ..: v = N_k + L_k x_k (+ the
// dispersion) (+ F_k) into f, N_k = nl_of's, and when recording, each mode's terms of the budget's six sums added
// to acc in mode order (rhs_pass's). Returns the modes done (pairs).
template <nonlinear_form F, bool Dispersive, bool Forced, bool Record>
__attribute__((target("avx2"))) std::size_t rhs_pairs(const column_run& run, std::size_t count, std::size_t i0,
                                                     const cplx* x, const double* lin, const double* disp,
                                                     const cplx* fk, cplx* f, double weight, const double* a,
                                                     std::array<double, 6>& acc, const next_stage& next) {
    static_assert(F == nonlinear_form::basdevant || F == nonlinear_form::advective,
                  "a new nonlinear form needs its branch here (nl_of's operations, in each lane)");
    x += i0, lin += i0, f += i0;
    const cplx* xs = next.y ? next.x + i0 : nullptr;
    cplx* yn = next.y ? next.y + i0 : nullptr;
    const v4 wn = _mm256_set1_pd(next.w);
    // velocity_pair's factors for the next stage's fill: (-kx, kx), and (ky, -ky) from ky (exact: times +-1)
    const v4 kxv = _mm256_set_pd(run.kx, -run.kx, run.kx, -run.kx), flip = _mm256_set_pd(-1.0, 1.0, -1.0, 1.0);
    const bool grad = F == nonlinear_form::advective;  // (the fill's gradient)
    a += i0;
    if constexpr (Dispersive) disp += i0;  // (the tables of the other kinds of runs are empty)
    if constexpr (Forced) fk += i0;
    // the sums: (E injection, E dissipation, Z injection, Z dissipation) and (E transfer, Z transfer, -, -)
    v4 sums = _mm256_loadu_pd(acc.data()), transfer = _mm256_set_pd(0.0, 0.0, acc[5], acc[4]);
    const v4 sign = _mm256_set1_pd(-0.0);
    const v4 scale = _mm256_set1_pd(F == nonlinear_form::basdevant ? run.scale : -run.scale);
    const v4 kx = _mm256_set1_pd(run.kx), kx2 = _mm256_set1_pd(run.kx * run.kx), two = _mm256_set1_pd(2.0);
    v4 ky = ky_pairs(run.ky0, 1.0, 1.0);
    std::size_t k = 0;
    for (; k + 2 <= count; k += 2) {
        const v4 o0 = _mm256_loadu_pd(reinterpret_cast<const double*>(run.o0 + k));
        v4 nk;
        if constexpr (F == nonlinear_form::basdevant) {
            const v4 o1 = _mm256_loadu_pd(reinterpret_cast<const double*>(run.o1 + k));
            const v4 c1 = _mm256_sub_pd(kx2, _mm256_mul_pd(ky, ky)), c2 = _mm256_mul_pd(kx, ky);
            nk = _mm256_mul_pd(scale, _mm256_add_pd(_mm256_mul_pd(c1, o0), _mm256_mul_pd(c2, o1)));
        } else {
            nk = _mm256_mul_pd(scale, o0);
        }
        const v4 xv = _mm256_loadu_pd(reinterpret_cast<const double*>(x + k));
        v4 val = _mm256_add_pd(nk, _mm256_mul_pd(pairs(lin + k), xv));
        if constexpr (Dispersive) {
            const v4 d = _mm256_mul_pd(pairs(disp + k), _mm256_set_pd(1.0, -1.0, 1.0, -1.0));  // (-d, d): exact
            val = _mm256_add_pd(val, _mm256_mul_pd(d, _mm256_permute_pd(xv, 0x5)));
        }
        [[maybe_unused]] v4 fv = _mm256_setzero_pd();
        if constexpr (Forced) fv = _mm256_loadu_pd(reinterpret_cast<const double*>(fk + k));
        if constexpr (Forced || Record) val = _mm256_add_pd(val, fv);  // (recording adds the zero F_k: -0 -> +0)
        _mm256_storeu_pd(reinterpret_cast<double*>(f + k), val);
        if (yn) {  // the next stage's state (xv, this stage's, is read: yn may overwrite it), and its fill over the
                   // outputs o0, o1 read above
            const v4 start = _mm256_loadu_pd(reinterpret_cast<const double*>(xs + k));
            const v4 y = _mm256_add_pd(start, _mm256_mul_pd(wn, val));
            _mm256_storeu_pd(reinterpret_cast<double*>(yn + k), y);
            velocity_pair(y, pairs(a + k), _mm256_mul_pd(ky, flip), kxv, run.in[0] + k, run.in[1] + k,
                          grad ? run.in[2] + k : nullptr, grad ? run.in[3] + k : nullptr);
        }
        ky = _mm256_add_pd(ky, two);
        if constexpr (Record) {
            // per mode, in both lanes of its half: x . N_k, -L_k |x|^2, x . F_k, and the weights w_k |a_k|, w_k
            const v4 nl = _mm256_hadd_pd(_mm256_mul_pd(xv, nk), _mm256_mul_pd(xv, nk));
            const v4 norm = _mm256_hadd_pd(_mm256_mul_pd(xv, xv), _mm256_mul_pd(xv, xv));
            const v4 diss = _mm256_mul_pd(_mm256_xor_pd(pairs(lin + k), sign), norm);
            v4 inj = _mm256_setzero_pd();
            if constexpr (Forced) inj = _mm256_hadd_pd(_mm256_mul_pd(xv, fv), _mm256_mul_pd(xv, fv));
            // w_k: the run's weight (one k_x); w_k |a_k|, with |a_k| from a itself (the table ea holds the same
            // values), whose column the fill reads next: two state-sized tables less per recording right-hand side
            const v4 w = _mm256_set1_pd(weight), we = _mm256_mul_pd(w, _mm256_andnot_pd(sign, pairs(a + k)));
            const v4 rates = _mm256_unpacklo_pd(inj, diss);  // (inj, diss) of each mode
            const v4 weights = _mm256_unpacklo_pd(we, w);     // (we, w) of each mode
            // the first mode's terms, then the second's
            sums = _mm256_add_pd(sums, _mm256_mul_pd(_mm256_permute2f128_pd(we, w, 0x20),
                                                     _mm256_permute4x64_pd(rates, 0x44)));
            transfer = _mm256_add_pd(transfer, _mm256_mul_pd(_mm256_permute4x64_pd(weights, 0x44),
                                                             _mm256_permute4x64_pd(nl, 0x00)));
            sums = _mm256_add_pd(sums, _mm256_mul_pd(_mm256_permute2f128_pd(we, w, 0x31),
                                                     _mm256_permute4x64_pd(rates, 0xEE)));
            transfer = _mm256_add_pd(transfer, _mm256_mul_pd(_mm256_permute4x64_pd(weights, 0xEE),
                                                             _mm256_permute4x64_pd(nl, 0xAA)));
        }
    }
    if constexpr (Record) {
        _mm256_storeu_pd(acc.data(), sums);
        _mm_storeu_pd(acc.data() + 4, _mm256_castpd256_pd128(transfer));
    }
    return k;
}
#endif

}  // namespace

struct flow2d::impl {
    flow_params p;
    const equation* eq = nullptr;
    spectral::grid g;
    std::vector<double> a, ea, lin, disp;  // per stored mode: psi/q, |psi/q|, damping, dispersion
    state_type force;    // F_k (forced runs only: empty otherwise)
    double sigma = 0.0;  // the stochastic forcing's amplitude on every mode of the band
    bool dispersive = false;

    int kmax = 0, rows = 0;
    std::size_t kept = 0, nc = 0;  // the state's columns kmax + 1 (on MPI: this process's), the grid's n/2 + 1
    int c0 = 0;                    // k_x of the state's (and the grid's local) first column
    std::size_t rs = 0;            // the grid's spectral index of (row, column c): row rs + c (grid::at)
    bool by_columns = false;       // the state stored by columns (flow2d::by_columns(): the fused column pass)
    // the fused column pass's loops over modes in AVX2 where the processor has it (flow2d::set_vector_passes)
#if ECI_DETAIL_X86_SIMD
    bool vector = eci::detail::cpu_has_avx2();
#else
    bool vector = false;
#endif
    // the forced band's modes in the order of the half plane (rows, then k_x), and where each is held in this
    // process's state (npos: another process's); the forcing is drawn over all of them, so it is the same at any
    // number of processes
    std::vector<std::size_t> band;
    static constexpr std::size_t npos = std::size_t(-1);

    // The grid's row of the state's row r.
    std::size_t full_row(int r) const { return std::size_t(r <= kmax ? r : r + g.n() - rows); }
    double ky_of(int r) const { return r <= kmax ? r : r - rows; }

    // k and -k on the k_x = 0 column exact conjugates (a real field's transform is so only up to round-off), so the
    // state stays the transform of a real field bit for bit.
    void hermitian(cplx* q) const {
        if (c0 != 0 || kept == 0) return;  // the k_x = 0 column is another process's
        for (int r = 1; r <= kmax; ++r) q[column0(rows - r)] = std::conj(q[column0(r)]);
        q[0] = q[0].real();
    }
    // The state's index of row r of the k_x = 0 column (on the process that holds it), in either layout.
    std::size_t column0(int r) const { return std::size_t(r) * (by_columns ? 1 : kept); }

    impl(const flow_params& p_, const equation& e)
        : p(p_), eq(&e), g(grid_options_of(p_)),
          kmax(g.kmax()),
          rows(2 * g.kmax() + 1),
          kept(std::size_t(std::clamp(g.kmax() + 1 - g.first_column(), 0, g.local_columns()))),
          nc(std::size_t(g.columns())),
          c0(g.first_column()),
          rs(g.spectral_stride()),
          by_columns(g.column_pass()) {}

    // The velocity of q into scratch fields 0 and 1 (and, for the advective form, the gradient into 2 and 3) in the
    // grid's layout (at()), zero outside the retained square; a transform overwrites its input, so every mode the
    // transforms read is rewritten: the columns k_x <= kmax (transform_product takes the rest as zero), every
    // column for the plain inverse transforms (spread over processes the transforms read the retained columns
    // alone, which are a row of the grid's spectral fields). A state stored by rows is read in order; one stored by
    // columns (max_velocity's inverse transforms) across its columns.
    void fill(const cplx* q, int fields, bool all_columns = false) {
        if (by_columns)
            fill_rows<true>(q, fields, all_columns);
        else
            fill_rows<false>(q, fields, all_columns);
    }
    template <bool ByColumns>
    void fill_rows(const cplx* q, int fields, bool all_columns) {
        cplx* f[4] = {g.spectral(0), g.spectral(1), fields > 2 ? g.spectral(2) : nullptr,
                      fields > 2 ? g.spectral(3) : nullptr};
        const double* av = a.data();
        const std::size_t end = g.distributed() ? rs : all_columns || !g.pruned() ? nc : kept;
        const std::size_t step = ByColumns ? std::size_t(rows) : 1;  // from one column of a row to the next
        const int n = g.n();
        g.for_rows([&](int r0, int r1) {
            for (int row = r0; row < r1; ++row) {
                // the grid's row: a row of the state (k_y = ky_of(r)) or a row of zeros
                const int ky_i = g.ky_of_row(row);
                const bool in = ky_i <= kmax && -ky_i <= kmax;
                const std::size_t i0 = std::size_t(row) * rs;
                if (in) {
                    const double ky = ky_i;
                    const std::size_t r = std::size_t(ky_i >= 0 ? ky_i : ky_i + rows);
                    const cplx* qr = q + (ByColumns ? r : r * kept);
                    const double* ar = av + (ByColumns ? r : r * kept);
                    for (std::size_t col = 0; col < kept; ++col) {
                        const std::size_t i = i0 + col;
                        const double kx = double(c0 + int(col));
                        velocity(qr[col * step], ar[col * step], kx, ky, f[0][i], f[1][i]);
                        if (fields > 2) gradient(qr[col * step], kx, ky, f[2][i], f[3][i]);
                    }
                }
                for (int j = 0; j < fields; ++j) std::fill(f[j] + i0 + (in ? kept : 0), f[j] + i0 + end, cplx{});
            }
        }, n);
    }

    // The same into column kx of transform_product_columns's fields (col[j][y], y the grid's row).
    void fill_column(const cplx* q, int fields, int kx, cplx* const* col) const {
        const std::size_t R = std::size_t(rows), s0 = std::size_t(kx - c0) * R;
        const double* ac = a.data() + s0;
        const cplx* qc = q + s0;
        const std::size_t K = std::size_t(kmax), shift = std::size_t(g.n()) - R;  // row r > kmax: the grid's r + shift
        const bool grad = fields > 2;
        // count rows from r0 (k_y = ky, ky + 1, ...) to the grid's rows from dst: pairs in AVX2 (vector), the rest
        // (all, or an odd one) here
        const auto run = [&](std::size_t r0, std::size_t count, std::size_t dst, double ky) {
            std::size_t done = 0;
#if ECI_DETAIL_X86_SIMD
            if (vector)
                done = velocity_pairs(qc + r0, ac + r0, kx, ky, count, col[0] + dst, col[1] + dst,
                                      grad ? col[2] + dst : nullptr, grad ? col[3] + dst : nullptr);
#endif
            for (std::size_t k = done; k < count; ++k) {
                const double y = ky + double(k);
                velocity(qc[r0 + k], ac[r0 + k], kx, y, col[0][dst + k], col[1][dst + k]);
                if (grad) gradient(qc[r0 + k], kx, y, col[2][dst + k], col[3][dst + k]);
            }
        };
        run(0, K + 1, 0, 0.0);                                             // k_y = 0 .. kmax
        run(K + 1, R - K - 1, K + 1 + shift, double(K + 1) - double(R));  // k_y = -kmax .. -1
    }

    // The pointwise products between the transforms: Basdevant's (u, v) -> (uv, v^2 - u^2), or the advective
    // u q_x + v q_y into field 0.
    // (Always inlined into each version below: the baseline's, and AVX2's without FMA, the same bits.)
    [[gnu::always_inline]] static void basdevant_body(double* const* f, std::size_t nx) {
        double* u = f[0];
        double* v = f[1];
        for (std::size_t x = 0; x < nx; ++x) {
            const double uu = u[x], vv = v[x];
            u[x] = uu * vv;
            v[x] = (vv - uu) * (vv + uu);
        }
    }
    [[gnu::always_inline]] static void advective_body(double* const* f, std::size_t nx) {
        for (std::size_t x = 0; x < nx; ++x) f[0][x] = f[0][x] * f[2][x] + f[1][x] * f[3][x];
    }
    static void basdevant_product(double* const* f, std::size_t nx) { basdevant_body(f, nx); }
    static void advective_product(double* const* f, std::size_t nx) { advective_body(f, nx); }
#if ECI_DETAIL_X86_SIMD
    __attribute__((target("avx2"))) static void basdevant_product_avx2(double* const* f, std::size_t nx) {
        basdevant_body(f, nx);
    }
    __attribute__((target("avx2"))) static void advective_product_avx2(double* const* f, std::size_t nx) {
        advective_body(f, nx);
    }
#endif
    // the product of form F for the column pass (vector: the AVX2 version)
    template <nonlinear_form F>
    void (*product() const)(double* const*, std::size_t) {
#if ECI_DETAIL_X86_SIMD
        if (vector) return F == nonlinear_form::basdevant ? basdevant_product_avx2 : advective_product_avx2;
#endif
        return F == nonlinear_form::basdevant ? basdevant_product : advective_product;
    }
    static constexpr int inputs(nonlinear_form f) { return f == nonlinear_form::basdevant ? 2 : 4; }
    static constexpr int outputs(nonlinear_form f) { return f == nonlinear_form::basdevant ? 2 : 1; }

    // run_stages' per-thread sums of each stage (rhs_chain), held here: a vector made per step was a heap block
    // of 12 kB per step, whose allocation consolidated the heap's free lists (malloc_consolidate, 0.4-1.4 % of a
    // step's profile at N = 1024 and 256)
    std::vector<std::array<std::array<double, 6>, 64>> chain_sums;

    // Where the transforms' results are: mode j (the grid's index) of output k at nl_out[k][j].
    const cplx* nl_out[2] = {nullptr, nullptr};

    // The transforms of the nonlinear term in the grid's layout, leaving their results at nl_out
    // (spread over processes, or without pruned transforms: transform_product_columns is the serial default).
    void nonlinear_transforms(const cplx* q, nonlinear_form form) {
        nl_out[0] = g.spectral(0);
        nl_out[1] = g.spectral(1);
        fill(q, inputs(form));
        if (form == nonlinear_form::basdevant)
            g.transform_product(2, 2, basdevant_product);
        else
            g.transform_product(4, 1, advective_product);
    }

    // The dealiased nonlinear term at a retained mode (kx, ky) from the transforms' outputs o0 (and o1) there:
    // Basdevant's -u . grad q = (k_x^2 - k_y^2) (uv)_k + k_x k_y (v^2 - u^2)_k, or -(u . grad q)_k.
    template <nonlinear_form F>
    static cplx nl_of(cplx o0, [[maybe_unused]] cplx o1, double kx, double ky, double scale) {
        if constexpr (F == nonlinear_form::basdevant)
            return scale * ((kx * kx - ky * ky) * o0 + (kx * ky) * o1);
        else
            return -scale * o0;
    }

    // The nonlinear term's transforms of q, and then body(i0, count, nl, thread, run) over runs of modes i0 .. i0 +
    // count - 1 of the state that cover it: nl(k) the term at mode i0 + k. By columns, fused with the column
    // transforms (nonlinear_chain, one stage). By rows, after the transforms in the grid's layout: a run per row,
    // the rows split between the threads, run null.
    template <nonlinear_form F, class Body>
    void nonlinear_runs(const cplx* q, Body body) {
        if (by_columns) {
            nonlinear_chain<F>(
                1, [&](int, int) { return q; },
                [&](int, std::size_t i0, std::size_t count, const auto& nl, int tid, const column_run* run) {
                    body(i0, count, nl, tid, run);
                },
                [](int, int, int) {});
            return;
        }
        const double scale = 1.0 / double(g.points());
        nonlinear_transforms(q, F);
        g.for_blocks(rows, [&](int r0, int r1, int tid) {
            for (int r = r0; r < r1; ++r) {
                const double ky = ky_of(r);
                const std::size_t j0 = full_row(r) * rs;
                const cplx* o0 = nl_out[0] + j0;
                const cplx* o1 = F == nonlinear_form::basdevant ? nl_out[1] + j0 : o0;
                body(std::size_t(r) * kept, kept,
                     [&](std::size_t k) { return nl_of<F>(o0[k], o1[k], double(c0 + int(k)), ky, scale); }, tid,
                     static_cast<const column_run*>(nullptr));
            }
        });
    }

    // The nonlinear terms of `stages` states in a row, by columns (grid::transform_product_chain): input(s, kx) is
    // stage s's state (the state's base pointer) with column k_x ready to read, asked for on the thread that then
    // reads it, after column k_x of stage s - 1 is done, or null where stage s - 1's body filled the column's
    // transforms itself (column_run::in); body(s, i0, count, nl, thread, run) over the two runs of each column
    // (k_y >= 0 and k_y < 0, so that nl has no branch), each thread its columns, run the column_run the run's nl
    // reads (for a vector loop); done(s, kx, thread) after both.
    template <nonlinear_form F, class Input, class Body, class Done>
    void nonlinear_chain(int stages, Input input, Body body, Done done) {
        const double scale = 1.0 / double(g.points());
        const std::size_t R = std::size_t(rows), K = std::size_t(kmax), shift = std::size_t(g.n()) - R;
        g.transform_product_chain(
            stages, inputs(F), outputs(F),
            [&](int s, int kx, cplx* const* col, int) {
                if (const cplx* q = input(s, kx)) fill_column(q, inputs(F), kx, col);
            },
            product<F>(),
            [&](int s, int kx, cplx* const* col, int tid) {
                const double x = kx;
                const std::size_t i0 = std::size_t(kx - c0) * R;
                const cplx* o0 = col[0];
                const cplx* o1 = F == nonlinear_form::basdevant ? col[1] : col[0];
                // a run's nl read from its column_run (k_y exact integers: ky0 + k is exact)
                const auto emit = [&](std::size_t first, std::size_t count, const column_run& r) {
                    const auto nl = [&](std::size_t k) {
                        return nl_of<F>(r.o0[k], r.o1[k], r.kx, r.ky0 + double(k), r.scale);
                    };
                    body(s, first, count, nl, tid, &r);
                };
                // the run's rows of the input fields from row `from` (the next stage's fill, column_run::in)
                const auto in = [&](std::size_t from, column_run r) {
                    for (int j = 0; j < inputs(F); ++j) r.in[j] = col[j] + from;
                    return r;
                };
                // rows k_y = 0 .. kmax at the grid's rows 0 .. kmax, then k_y = -kmax .. -1 at r + shift
                emit(i0, K + 1, in(0, {o0, o1, x, 0.0, scale, {}}));
                emit(i0 + K + 1, R - K - 1,
                     in(K + 1 + shift, {o0 + (K + 1 + shift), o1 + (K + 1 + shift), x, -double(K), scale, {}}));
                done(s, kx, tid);
            });
    }

    template <nonlinear_form F>
    void nonlinear_out(const cplx* q, cplx* dst) {
        nonlinear_runs<F>(q, [&](std::size_t i0, std::size_t count, const auto& nl, int, const column_run*) {
            for (std::size_t k = 0; k < count; ++k) dst[i0 + k] = nl(k);
        });
        if (c0 == 0 && kept > 0) dst[0] = 0.0;  // k = 0
        hermitian(dst);
    }
};

flow2d::flow2d(const flow_params& p) : flow2d(p, find_equation(p.equation)) {}

flow2d::flow2d(const flow_params& p, const equation& e) : n_(p.n), form_(e.form) {
    p.validate(e);
    d_ = std::make_unique<impl>(p, e);
    impl& d = *d_;
    col0_ = d.c0;
    cols_ = int(d.kept);
    by_columns_ = d.by_columns;
    const std::size_t m = size();
    weights_.assign(m, 0.0);
    for (std::size_t i = 0; i < m; ++i) weights_[i] = kx(i) == 0 ? (ky(i) == 0 ? 0.0 : 1.0) : 2.0;
    d.a.assign(m, 0.0);
    d.ea.assign(m, 0.0);
    d.lin.assign(m, 0.0);
    if (e.dispersion) d.disp.assign(m, 0.0);  // (only an equation with waves holds the table)
    // F_k, a state's worth, is held only by a forced run (an unforced run's budgets count no injection)
    if (p.forcing != forcing_kind::none) d.force.assign(m, cplx{});
    for (std::size_t i = 0; i < m; ++i) {
        if (!retained(i)) continue;
        const double x = kx(i), y = ky(i), k2 = x * x + y * y;
        d.a[i] = e.inversion(p, x, y);
        d.ea[i] = std::abs(d.a[i]);
        d.lin[i] = -(p.nu * k2 + p.hyper_nu * std::pow(k2, p.hyper_p) + p.drag +
                     (p.hypo_nu != 0.0 ? p.hypo_nu * std::pow(k2, -p.hypo_p) : 0.0));
        const double c = e.dispersion ? (d.disp[i] = e.dispersion(p, x, y)) : 0.0;
        if (c != 0.0) d.dispersive = true;
        // a coefficient that overflows is a parameter too large for this grid, not a failed step
        require(std::isfinite(d.lin[i]) && std::isfinite(c) && std::isfinite(d.a[i]),
                "the linear terms overflow at k = (" + std::to_string(kx(i)) + ", " + std::to_string(ky(i)) + ")" +
                    " (viscosity, hyperviscosity, hypoviscosity, drag or beta too large for N = " +
                    std::to_string(p.n) + ")");
    }
    // The forced band k_f - 1/2 <= |k| < k_f + 1/2, retained modes only: over the whole state (in its order), so
    // that every process knows the band and the sums are those of one process.
    double band_count = 0.0, band_energy_weight = 0.0;
    const int K = kmax();
    for (int r = 0; r < rows(); ++r)
        for (int x = 0; x <= K; ++x) {
            const int y = r <= K ? r : r - rows();
            const double k = std::sqrt(double(x) * x + double(y) * y);
            if ((x == 0 && y == 0) || k < p.forcing_k - 0.5 || k >= p.forcing_k + 0.5) continue;
            const double w = x == 0 ? 1.0 : 2.0;
            band_count += w;
            band_energy_weight += w * std::abs(e.inversion(p, x, y));
            const bool mine = owns_column(x);
            d.band.push_back(mine ? index(x, y) : impl::npos);
        }
    if (p.forcing != forcing_kind::none)
        require(band_count > 0.0, "the forcing band |k| = " + eci::detail::shortest_text(p.forcing_k) +
                                      " +- 1/2 holds no retained mode (kmax = " + std::to_string(kmax()) + ")");
    rng_ = p.forcing_seed;
    if (p.forcing == forcing_kind::deterministic) {
        // Fixed random phases; rms of the forcing field sum_full |F_k|^2 = amplitude^2.
        std::uint64_t s = p.forcing_seed;
        const double amp = p.forcing_amplitude / std::sqrt(band_count);
        for (std::size_t i : d.band) {
            const double phase = 2.0 * std::numbers::pi * uniform(s);
            if (i != impl::npos) d.force[i] = std::polar(amp, phase);
        }
        d.hermitian(d.force.data());
    } else if (p.forcing == forcing_kind::stochastic) {
        // White noise held over a step of dt: F = sigma g / sqrt(dt) injects, on average, 1/2 sum_full sigma^2 |a_k|
        // per unit time, which is epsilon for this sigma.
        d.sigma = std::sqrt(2.0 * p.injection_rate / band_energy_weight);
    }
    // a forcing that overflows is a parameter too large, not a failed step: the band's energy at its amplitude must
    // be a number (from the whole band's sums, so that every process decides alike)
    const double amplitude = p.forcing == forcing_kind::deterministic ? p.forcing_amplitude / std::sqrt(band_count)
                                                                      : d.sigma;
    require(std::isfinite(amplitude * amplitude * band_energy_weight),
            "the forcing overflows (" +
                std::string(p.forcing == forcing_kind::stochastic ? "injection rate" : "forcing amplitude") +
                " too large for N = " + std::to_string(p.n) + ")");
}

flow2d::~flow2d() = default;
flow2d::flow2d(flow2d&&) noexcept = default;
flow2d& flow2d::operator=(flow2d&&) noexcept = default;

const flow_params& flow2d::params() const { return d_->p; }
const equation& flow2d::eq() const { return *d_->eq; }
const spectral::grid& flow2d::grid() const { return d_->g; }
const std::vector<double>& flow2d::inversion() const { return d_->a; }

std::array<std::string, 2> flow2d::invariant_names() const {
    return {std::string(d_->eq->invariant_names[0]), std::string(d_->eq->invariant_names[1])};
}

std::vector<std::vector<double>> flow2d::quadratic_invariant_weights() const {
    std::vector<std::vector<double>> q(2, std::vector<double>(size()));
    for (std::size_t i = 0; i < size(); ++i) {
        q[0][i] = 0.5 * weights_[i] * d_->ea[i];
        q[1][i] = 0.5 * weights_[i];
    }
    return q;
}

int flow2d::transforms_per_rhs() const { return form_ == nonlinear_form::basdevant ? 4 : 5; }

void flow2d::set_form(nonlinear_form f) {
    if (f == nonlinear_form::basdevant && d_->eq->form != nonlinear_form::basdevant)
        throw std::invalid_argument(std::string(d_->eq->name) + " has no Basdevant form");
    form_ = f;
}

void flow2d::set_vector_passes([[maybe_unused]] bool on) {
#if ECI_DETAIL_X86_SIMD
    d_->vector = on && eci::detail::cpu_has_avx2();
#endif
}

void flow2d::execute_transforms(int stages) {
    // as the right-hand side makes them (with its pass over the rows, here doing nothing): a step's stages as one
    // chain where run_stages takes them so
    const auto none = [](double* const*, std::size_t) {};
    const int in = impl::inputs(form_), out = impl::outputs(form_);
    if (d_->g.column_pass())
        d_->g.transform_product_chain(stages, in, out, [](int, int, cplx* const*, int) {}, none,
                                      [](int, int, const cplx* const*, int) {});
    else
        for (int s = 0; s < stages; ++s) d_->g.transform_product(in, out, none);
}

void flow2d::nonlinear(const state_type& q, state_type& out) {
    if (q.size() != size()) throw std::invalid_argument("state size does not match the grid");
    out.resize(size());
    if (form_ == nonlinear_form::basdevant)
        d_->nonlinear_out<nonlinear_form::basdevant>(q.data(), out.data());
    else
        d_->nonlinear_out<nonlinear_form::advective>(q.data(), out.data());
}

void flow2d::nonlinear_advective(const state_type& q, state_type& out) {
    if (q.size() != size()) throw std::invalid_argument("state size does not match the grid");
    out.resize(size());
    d_->nonlinear_out<nonlinear_form::advective>(q.data(), out.data());
}

namespace {

// y = x + sum_{j < s} (dt a_j) k_j over n doubles of the state from double 2 i0 (a column), over the nonzero a_j in
// order: each element's operations those of detail::combine_stages (acc = x, then acc += (dt a_j) k_j), one term at
// a time over the column (in cache), so the same bits.
[[gnu::always_inline]] inline void combine_body(double* y, const double* x, const cplx* const* k, std::size_t i0,
                                                const double* a, int s, double dt, std::size_t n) {
    bool first = true;
    for (int j = 0; j < s; ++j) {
        if (a[j] == 0.0) continue;
        const double w = dt * a[j];
        const double* kj = reinterpret_cast<const double*>(k[j] + i0);
        if (first) {
            for (std::size_t i = 0; i < n; ++i) y[i] = x[i] + w * kj[i];
        } else {
            for (std::size_t i = 0; i < n; ++i) y[i] += w * kj[i];
        }
        first = false;
    }
    if (first) std::copy(x, x + n, y);
}
#if ECI_DETAIL_X86_SIMD
__attribute__((target("avx2"))) void combine_avx2(double* y, const double* x, const cplx* const* k, std::size_t i0,
                                                  const double* a, int s, double dt, std::size_t n) {
    combine_body(y, x, k, i0, a, s, dt, n);
}
#endif
void combine_column(double* y, const double* x, const cplx* const* k, std::size_t i0, const double* a, int s,
                    double dt, std::size_t n, [[maybe_unused]] bool vector) {
#if ECI_DETAIL_X86_SIMD
    if (vector) return combine_avx2(y, x, k, i0, a, s, dt, n);
#endif
    combine_body(y, x, k, i0, a, s, dt, n);
}

// One pass from the transforms to the right-hand side, over the runs of nonlinear_runs (columns fused with their
// transforms, or rows): the dealiased nonlinear term plus L q + F, and when recording, the sums of what each
// part does to E and Z (weights w_k |a_k| and w_k), per thread and then in thread order. The k_x = 0 column is
// made exact conjugates after (L and F are Hermitian there, so that equals symmetrising N first).
// A run's modes of the right-hand side into f, from the state x, the thread's sums added to `sums`.
template <nonlinear_form F, bool Dispersive, bool Forced, bool Record>
struct rhs_runs {
    const double* wt;
    const double* lin;
    const double* disp;
    const double* ea;
    const double* a;
    const cplx* Fk;
    // The weight is zero at k = 0 alone (index 0 of the process holding the k_x = 0 column): the nonlinear term is
    // zero there, tested by index rather than by reading the weights, which the pass then reads only when recording
    // (a state-sized array less per right-hand side).
    std::size_t zero_mode;
    bool vector;

    rhs_runs(const flow2d& m, const auto& d)
        : wt(m.weights().data()), lin(d.lin.data()), disp(d.disp.data()), ea(d.ea.data()), a(d.a.data()),
          Fk(d.force.data()),
          zero_mode(d.c0 == 0 ? 0 : std::size_t(-1)), vector(d.vector) {}

    template <class Nl>
    void operator()(const cplx* x, cplx* f, std::size_t i0, std::size_t count, const Nl& nl,
                    [[maybe_unused]] const column_run* run, std::array<double, 6>& sums,
                    const next_stage& next = {}) const {
        std::size_t k = 0;
        std::array<double, 6> acc = sums;  // (in registers through the loop, not the threads' adjacent slots)
#if ECI_DETAIL_X86_SIMD
        // a column's run, two modes a vector (the run of the zero mode is the scalar loop's below), whose weight
        // w_k is one number: 1 on the k_x = 0 column but at k = 0, 2 elsewhere (flow2d::weights)
        if (run && vector && i0 != zero_mode)
            k = rhs_pairs<F, Dispersive, Forced, Record>(*run, count, i0, x, lin, disp, Fk, f,
                                                         run->kx == 0.0 ? 1.0 : 2.0, a, acc, next);
#endif
        for (; k < count; ++k) {
            const std::size_t i = i0 + k;
            const cplx nk = i != zero_mode ? nl(k) : cplx{};
            cplx v = nk + lin[i] * x[i];
            if constexpr (Dispersive) v += cplx(-disp[i] * x[i].imag(), disp[i] * x[i].real());
            if constexpr (Forced)
                v += Fk[i];
            else if constexpr (Record)
                v += cplx{};  // the zero F_k unforced runs once held, still added: the same bits (-0 becomes +0)
            f[i] = v;
            if constexpr (Record) {
                const double nl = x[i].real() * nk.real() + x[i].imag() * nk.imag();
                const double diss = -lin[i] * std::norm(x[i]);
                double inj = 0.0;
                if constexpr (Forced) inj = x[i].real() * Fk[i].real() + x[i].imag() * Fk[i].imag();
                const double we = wt[i] * ea[i];
                acc[0] += we * inj;
                acc[1] += we * diss;
                acc[2] += wt[i] * inj;
                acc[3] += wt[i] * diss;
                acc[4] += we * nl;
                acc[5] += wt[i] * nl;
            }
            if (next.y) {  // last: x[i] may be the mode it overwrites
                const double* xs = reinterpret_cast<const double*>(next.x + i);
                double* y = reinterpret_cast<double*>(next.y + i);
                y[0] = xs[0] + next.w * v.real(), y[1] = xs[1] + next.w * v.imag();
                // its fill (fill_column's), over the outputs nl(k) read above
                const double ky = run->ky0 + double(k);
                velocity(next.y[i], a[i], run->kx, ky, run->in[0][k], run->in[1][k]);
                if constexpr (F == nonlinear_form::advective)
                    gradient(next.y[i], run->kx, ky, run->in[2][k], run->in[3][k]);
            }
        }
        sums = acc;
    }
};

// Per-thread sums added in thread order.
inline std::array<double, 6> thread_total(const std::array<std::array<double, 6>, 64>& part, int threads) {
    std::array<double, 6> total{};
    for (int t = 0; t < std::min(threads, 64); ++t)
        for (std::size_t k = 0; k < 6; ++k) total[k] += part[std::size_t(t)][k];
    return total;
}

template <nonlinear_form F, bool Dispersive, bool Forced, bool Record>
std::array<double, 6> rhs_pass(const flow2d& m, auto& d, const cplx* x, cplx* f) {
    const rhs_runs<F, Dispersive, Forced, Record> runs(m, d);
    std::array<std::array<double, 6>, 64> part{};
    d.template nonlinear_runs<F>(x, [&](std::size_t i0, std::size_t count, const auto& nl, int tid,
                                        const column_run* run) {
        runs(x, f, i0, count, nl, run, part[std::size_t(tid)]);
    });
    return thread_total(part, d.g.threads());
}

// The stages of an explicit Runge-Kutta step as one chain of column passes (flow2d::run_stages): stage s's state
// formed column by column just before its column is filled (Y_0 = x; Y_s in `y`, each column once the previous
// stage's is done), its right-hand side into k[s], the k_x = 0 column made exact conjugates as soon as it is done;
// sums[s] as rhs_pass's.
template <nonlinear_form F, bool Dispersive, bool Forced, bool Record>
void rhs_chain(const flow2d& m, auto& d, int stages, const double* a, double dt, const cplx* x, cplx* const* k,
               cplx* y, std::array<double, 6>* sums) {
    const rhs_runs<F, Dispersive, Forced, Record> runs(m, d);
    auto& part = d.chain_sums;
    part.assign(static_cast<std::size_t>(stages), {});
    const std::size_t R = std::size_t(d.rows);
    // whether stage s + 1's row of the tableau is the one term (dt a) k_s: its state is then formed in stage s's
    // right-hand-side loop (next_stage), but on the k_x = 0 column, whose k_s is made Hermitian after that loop
    std::array<bool, 16> one_term{};
    for (int s = 0; s + 1 < stages; ++s) {
        const double* row = a + std::size_t(s + 1) * std::size_t(stages);
        one_term[std::size_t(s)] = row[s] != 0.0 && std::all_of(row, row + s, [](double v) { return v == 0.0; });
    }
    d.template nonlinear_chain<F>(
        stages,
        [&](int s, int kx) -> const cplx* {
            if (s == 0) return x;
            if (one_term[std::size_t(s - 1)] && kx != 0) return nullptr;  // formed and filled by stage s - 1's loop
            // Y_s's column: x + sum_j (dt a_sj) k_j over the nonzero a_sj in order, element by element
            // (detail::combine_stages's operations: the same bits as the stages one at a time)
            const std::size_t i0 = std::size_t(kx - d.c0) * R;
            combine_column(reinterpret_cast<double*>(y + i0), reinterpret_cast<const double*>(x + i0), k, i0,
                           a + std::size_t(s) * std::size_t(stages), s, dt, 2 * R, d.vector);
            return y;
        },
        [&](int s, std::size_t i0, std::size_t count, const auto& nl, int tid, const column_run* run) {
            next_stage next;
            if (one_term[std::size_t(s)] && d.c0 + int(i0 / R) != 0)
                next = {x, dt * a[std::size_t(s + 1) * std::size_t(stages) + std::size_t(s)], y};
            runs(s == 0 ? x : y, k[s], i0, count, nl, run, part[std::size_t(s)][std::size_t(tid)], next);
        },
        [&](int s, int kx, int) {
            if (kx == 0) d.hermitian(k[s]);  // (the k_x = 0 column alone; hermitian checks it is this process's)
        });
    for (int s = 0; s < stages; ++s) sums[s] = thread_total(part[std::size_t(s)], d.g.threads());
}

// run.template operator()<F, Dispersive, Forced, Record>() for the flags of a right-hand side: the one place its
// passes are instantiated from (rhs_pass's and rhs_chain's callers).
template <class Run>
void with_pass_flags(nonlinear_form form, bool dispersive, bool forced, bool record, Run run) {
    const auto kinds = [&]<nonlinear_form F, bool Dispersive>() {
        if (record && forced)
            run.template operator()<F, Dispersive, true, true>();
        else if (record)
            run.template operator()<F, Dispersive, false, true>();
        else if (forced)
            run.template operator()<F, Dispersive, true, false>();
        else
            run.template operator()<F, Dispersive, false, false>();
    };
    const bool basdevant = form == nonlinear_form::basdevant;
    if (basdevant && !dispersive)
        kinds.template operator()<nonlinear_form::basdevant, false>();
    else if (basdevant)
        kinds.template operator()<nonlinear_form::basdevant, true>();
    else if (!dispersive)
        kinds.template operator()<nonlinear_form::advective, false>();
    else
        kinds.template operator()<nonlinear_form::advective, true>();
}

}  // namespace

void flow2d::operator()(const state_type& q, state_type& dqdt, double /*t*/) {
    impl& d = *d_;
    dqdt.resize(size());
    std::array<double, 6> s{};
    with_pass_flags(form_, d.dispersive, d.p.forcing != forcing_kind::none, recording_,
                    [&]<nonlinear_form F, bool Dispersive, bool Forced, bool Record>() {
                        s = rhs_pass<F, Dispersive, Forced, Record>(*this, d, q.data(), dqdt.data());
                    });
    d.hermitian(dqdt.data());
    if (recording_) d.g.sum_over_ranks(s.data(), s.size());  // (recording is on or off on every process alike)
    if (recording_ && recorded_count_ < recorded_.size())
        recorded_[recorded_count_++] = {s[0], s[1], s[2], s[3], s[4], s[5]};
}

bool flow2d::run_stages(int stages, const double* a, double dt, const state_type& x, state_type* k, state_type& y,
                        double /*t*/) {
    impl& d = *d_;
    if (!d.by_columns || stages < 1 || std::size_t(stages) > recorded_.size() || x.size() != size()) return false;
    std::array<cplx*, 16> kp{};
    for (int s = 0; s < stages; ++s) {
        k[s].resize(size());
        kp[std::size_t(s)] = k[s].data();
    }
    y.resize(size());
    std::array<std::array<double, 6>, 16> sums{};
    with_pass_flags(form_, d.dispersive, d.p.forcing != forcing_kind::none, recording_,
                    [&]<nonlinear_form F, bool Dispersive, bool Forced, bool Record>() {
                        rhs_chain<F, Dispersive, Forced, Record>(*this, d, stages, a, dt, x.data(), kp.data(),
                                                                 y.data(), sums.data());
                    });
    for (int s = 0; s < stages; ++s) {
        const auto& v = sums[std::size_t(s)];
        if (recording_ && recorded_count_ < recorded_.size())
            recorded_[recorded_count_++] = {v[0], v[1], v[2], v[3], v[4], v[5]};
    }
    return true;
}

flow_rates flow2d::rates(const state_type& q) {
    state_type tmp;
    const auto saved = recorded_;
    const std::size_t count = recorded_count_;
    const bool was = recording_;
    recording_ = true;
    recorded_count_ = 0;
    (*this)(q, tmp, 0.0);
    const flow_rates r = recorded_[0];
    recorded_ = saved;
    recorded_count_ = count;
    recording_ = was;
    return r;
}

void flow2d::start_recording() {
    recording_ = true;
    recorded_count_ = 0;
}

void flow2d::begin_step(double dt) {
    draw_forcing(dt);
    step_budget_ = {};
}

void flow2d::end_attempt(bool accepted, double dt, std::span<const double> b) {
    stop_recording();
    if (!accepted) return;
    if (b.size() > recorded_count_)
        throw std::logic_error("flow2d records the rates of at most " + std::to_string(recorded_.size()) +
                               " stages; this attempt had " + std::to_string(b.size()));
    for (std::size_t j = 0; j < b.size(); ++j) {
        const double w = dt * b[j];
        step_budget_.energy_injection += w * recorded_[j].energy_injection;
        step_budget_.energy_dissipation += w * recorded_[j].energy_dissipation;
        step_budget_.enstrophy_injection += w * recorded_[j].enstrophy_injection;
        step_budget_.enstrophy_dissipation += w * recorded_[j].enstrophy_dissipation;
    }
}

bool flow2d::begin_retry() {
    if (form_ != nonlinear_form::basdevant) return false;
    set_form(nonlinear_form::advective);
    return true;
}

void flow2d::end_retry(bool completed) {
    set_form(nonlinear_form::basdevant);
    if (completed) ++form_retries_;
}

namespace {

// f(i, c, r) over the modes of rows r0 .. r1 - 1 in row order (flow2d::in_row_order's: each row's columns in turn):
// mode i of the state at its column c (this process's, from 0) and row r, whose wavenumbers a term takes from c and
// r (kx_of_column, ky_of_row) rather than from i (kx(i), ky(i): a division each; palinstrophy took 2.2 ms at
// N = 1024, more than E and Z together).
template <class F>
void in_row_order_over(const flow2d& m, std::size_t r0, std::size_t r1, F f) {
    const std::size_t nc = std::size_t(m.columns()), nr = std::size_t(m.rows());
    for (std::size_t r = r0; r < r1; ++r) {
        if (m.by_columns())
            for (std::size_t c = 0; c < nc; ++c) f(c * nr + r, c, r);
        else
            for (std::size_t c = 0; c < nc; ++c) f(r * nc + c, c, r);
    }
}

// sum[j] + term(i, c, r)[j] over the modes of rows r0 .. r1 - 1, added in row order (so the same bits from either
// layout). A state stored by columns has its terms formed a block of rows at a time column by column, where the
// block's rows of a column are contiguous, then added row by row from the block: read in row order, every mode was a
// cache line of its own, 11 kB from the last, and E took 1.1 ms at N = 1024 (Z 0.6), at every step of a run. The
// block is on the stack (a heap block per call was an allocation per step of every run, in each thread), up to 16
// rows, fewer where rows are long; a state beyond the caches has blocks of 64 rows in a block of the thread's own.
// (A block on the stack of 2048 terms held 5 rows at N = 1024 and 1 at N = 4096, where each mode was again a line of
// its own: E and Z took 0.34, 4.1 and 40 ms at N = 1024, 2048 and 4096; with 8192 terms 0.26, 2.7 and 17 ms on that
// machine. On another, E and Z at N = 4096 took 41-42 ms with 8192 terms (5 rows), 26 with 16 rows and 20 with 64,
// the thread's block; at N = 2048 2.4-3.0 ms with 11 rows on the stack, 3.6 with 64; at N = 1024 and 2048 the
// palinstrophy took 40 % longer with 16 rows in the thread's block than on the stack.) The order of the additions is
// row order whatever the block, so the same bits.
// The terms are added 32 at a time (in row order) and each run of 32 into the total with compensation (error-free
// additions): a plain sum of the ~2e5 terms of E at N = 1024 erred by 2e-14 relative (7e-15 at N = 256, 6e-14 at
// 2048), which is what a run's summary then reported as the drift of an invariant that C-RK4 keeps to 1e-17; now
// the sums are right to about one rounding, at the plain sum's cost (0.39 against 0.40 ms at N = 1024, paired).
template <std::size_t K, class Term>
void add_in_row_order(const flow2d& m, std::size_t r0, std::size_t r1, std::array<double, K>& total, Term term) {
    const std::size_t nc = std::size_t(m.columns()), nr = std::size_t(m.rows());
    // (locals: the terms' buffer below is doubles too, which total may alias)
    std::array<compensated_sum, K> sum;
    for (std::size_t j = 0; j < K; ++j) sum[j].s = total[j];
    std::array<double, K> run{};
    unsigned count = 0;
    const auto flush = [&] {
        for (std::size_t j = 0; j < K; ++j) sum[j].add(run[j]), run[j] = 0.0;
        count = 0;
    };
    const auto add = [&](const std::array<double, K>& v) {
        for (std::size_t j = 0; j < K; ++j) run[j] += v[j];
        if (++count == 32) flush();
    };
    // the rows in blocks of B, each block's terms formed into t column by column, then added row by row
    const auto blocks = [&](std::array<double, K>* t, std::size_t B) {
        for (std::size_t b0 = r0; b0 < r1; b0 += B) {
            const std::size_t nb = std::min(B, r1 - b0);
            for (std::size_t c = 0; c < nc; ++c)
                for (std::size_t q = 0; q < nb; ++q) t[q * nc + c] = term(c * nr + b0 + q, c, b0 + q);
            for (std::size_t k = 0; k < nb * nc; ++k) add(t[k]);
        }
    };
    constexpr std::size_t capacity = 8192;  // terms in a block on the stack: 128 kB for E and Z
    const bool beyond_caches = m.size() * sizeof(flow2d::state_type::value_type) >= (std::size_t(32) << 20);
    if (m.by_columns() && beyond_caches) {
        // A state beyond the caches (from 32 MB, N ~ 3000), whose modes come from memory: 64 rows, runs of 1 kB a
        // column that the prefetchers follow, in the thread's own block, kept from call to call
        static thread_local std::vector<std::array<double, K>> block;
        if (block.size() < 64 * nc) block.resize(64 * nc);
        blocks(block.data(), 64);
    } else if (m.by_columns() && nc <= capacity) {
        // up to 16 rows: a column's run of 256 bytes of modes, 128 of weights
        std::array<std::array<double, K>, capacity> t;
        blocks(t.data(), std::min<std::size_t>(16, capacity / nc));
    } else {  // a state stored by rows, read in place (and one by columns whose rows outgrow the stack's block)
        in_row_order_over(m, r0, r1, [&](std::size_t i, std::size_t c, std::size_t r) { add(term(i, c, r)); });
    }
    flush();
    // (a sum that overflowed stays inf: its error term is then NaN)
    for (std::size_t j = 0; j < K; ++j) total[j] = std::isfinite(sum[j].s) ? sum[j].value() : sum[j].s;
}

}  // namespace

double flow2d::energy(const state_type& q) const {
    const double* ea = d_->ea.data();
    auto s = d_->g.sum_rows<1>([&](int r0, int r1, std::array<double, 1>& acc) {
        add_in_row_order(*this, std::size_t(r0), std::size_t(r1), acc, [&](std::size_t i, std::size_t, std::size_t) {
            return std::array<double, 1>{weights_[i] * ea[i] * std::norm(q[i])};
        });
    }, rows());
    d_->g.sum_over_ranks(s.data(), 1);
    return 0.5 * s[0];
}

double flow2d::enstrophy(const state_type& q) const {
    auto s = d_->g.sum_rows<1>([&](int r0, int r1, std::array<double, 1>& acc) {
        add_in_row_order(*this, std::size_t(r0), std::size_t(r1), acc, [&](std::size_t i, std::size_t, std::size_t) {
            return std::array<double, 1>{weights_[i] * std::norm(q[i])};
        });
    }, rows());
    d_->g.sum_over_ranks(s.data(), 1);
    return 0.5 * s[0];
}

void flow2d::invariant_values(const state_type& q, std::span<double> out) const {
    if (out.size() != 2) throw std::invalid_argument("flow2d::invariant_values gives E and Z: two values");
    const double* ea = d_->ea.data();
    auto s = d_->g.sum_rows<2>([&](int r0, int r1, std::array<double, 2>& acc) {
        add_in_row_order(*this, std::size_t(r0), std::size_t(r1), acc, [&](std::size_t i, std::size_t, std::size_t) {
            const double z = std::norm(q[i]);
            return std::array<double, 2>{weights_[i] * ea[i] * z, weights_[i] * z};
        });
    }, rows());
    d_->g.sum_over_ranks(s.data(), 2);
    out[0] = 0.5 * s[0];
    out[1] = 0.5 * s[1];
}

double flow2d::palinstrophy(const state_type& q) const {
    auto s = d_->g.sum_rows<1>([&](int r0, int r1, std::array<double, 1>& acc) {
        add_in_row_order(*this, std::size_t(r0), std::size_t(r1), acc, [&](std::size_t i, std::size_t c, std::size_t r) {
            const double x = kx_of_column(c), y = ky_of_row(r);
            return std::array<double, 1>{weights_[i] * (x * x + y * y) * std::norm(q[i])};
        });
    }, rows());
    d_->g.sum_over_ranks(s.data(), 1);
    return 0.5 * s[0];
}

namespace {
// max(u^2 + v^2) over n points (0 if none; a NaN is passed over, as std::max passes it). Eight running maxima, not
// one: one was a chain of dependent maxima, 4 cycles a point, 1.4 ms of a row's max |u| at N = 1024.
double max_speed_squared(const double* u, const double* v, std::size_t n) {
    double m[8] = {};
    std::size_t x = 0;
    for (; x + 8 <= n; x += 8)
        for (std::size_t l = 0; l < 8; ++l) {
            const double s = u[x + l] * u[x + l] + v[x + l] * v[x + l];
            m[l] = m[l] < s ? s : m[l];
        }
    for (; x < n; ++x) m[0] = std::max(m[0], u[x] * u[x] + v[x] * v[x]);
    return std::max({m[0], m[1], m[2], m[3], m[4], m[5], m[6], m[7]});
}

// Whether max_speed_squared's maximum is the square of the maximum speed: a normal number, neither overflowed nor
// underflowed (below DBL_MIN a subnormal or zero square has lost the speed's digits, or all of them).
bool normal_square(double m) { return m >= std::numeric_limits<double>::min() && m <= std::numeric_limits<double>::max(); }

// max sqrt(u^2 + v^2) over n points without a square that overflows or underflows: the components scaled by the power
// of two 2^-e that brings the largest to [1, 2) (exact), squared, and the root scaled back, so that a point whose
// squares are normal numbers gives the bits of sqrt(u^2 + v^2). max_velocity's other pass, taken only where
// max_speed_squared's maximum is not normal: a flow of |u| ~ 1e-160 or 1e160 (--deformation 1e300, a vortex of
// peak 1e-300), whose square was 0 ("the initial velocity is zero") or inf (a CFL step of 0).
double max_speed_scaled(const double* u, const double* v, std::size_t n) {
    double big = 0.0;  // (a NaN is passed over, as max_speed_squared passes it)
    for (std::size_t x = 0; x < n; ++x) big = std::max({big, std::abs(u[x]), std::abs(v[x])});
    if (!(big > 0.0) || !std::isfinite(big)) return big;
    const int e = std::ilogb(big);
    double m = 0.0;
    for (std::size_t x = 0; x < n; ++x) {
        const double a = std::scalbn(u[x], -e), b = std::scalbn(v[x], -e);
        m = std::max(m, a * a + b * b);
    }
    return std::scalbn(std::sqrt(m), e);
}
}  // namespace

double flow2d::max_velocity(const state_type& q) {
    impl& d = *d_;
    if (q.size() != size()) throw std::invalid_argument("state size does not match the grid");
    if (d.g.column_pass()) {
        // The right-hand side's inverse transforms (the retained columns along y, then row by row in cache) and the
        // maximum over each row, no forward transforms; a maximum is the same whatever order the rows come in. FFTW's
        // 2-D transforms of the whole half plane and a pass over the fields took 6.6-7.5 ms at N = 1024 against 5.0
        // (one thread, eci_bench_ns2d_step's diagnostics row): a CSV row's max |u|, at every step of `eci run` by
        // default, where a C-RK4 step takes ~36 ms.
        // (the largest of a row's maxima: of the squares, or where they are not normal, of the speeds)
        const auto largest = [&](double (*row)(const double*, const double*, std::size_t)) {
            std::atomic<double> vmax{0.0};
            d.g.transform_product_columns(
                2, 0, [&](int kx, cplx* const* col, int) { d.fill_column(q.data(), 2, kx, col); },
                [&](double* const* f, std::size_t nx) {
                    const double m = row(f[0], f[1], nx);
                    for (double seen = vmax.load(); m > seen && !vmax.compare_exchange_weak(seen, m);) {
                    }
                },
                [](int, cplx* const*, int) {});
            return vmax.load();
        };
        if (const double m = largest(max_speed_squared); normal_square(m)) return std::sqrt(m);
        return largest(max_speed_scaled);
    }
    d.fill(q.data(), 2, true);
    d.g.inverse(2);
    const double* u = d.g.physical(0);
    const double* v = d.g.physical(1);
    const auto largest = [&](double (*row)(const double*, const double*, std::size_t)) {
        double vmax = 0.0;
        for (std::size_t y = 0; y < std::size_t(d.g.local_rows()); ++y)
            vmax = std::max(vmax, row(u + y * d.g.padded(), v + y * d.g.padded(), std::size_t(n_)));
        d.g.max_over_ranks(&vmax, 1);  // (the same verdict below on every process)
        return vmax;
    };
    if (const double m = largest(max_speed_squared); normal_square(m)) return std::sqrt(m);
    return largest(max_speed_scaled);
}

void flow2d::check_initial_state(const state_type& q) const {
    if (q.size() != size()) throw std::invalid_argument("state size does not match the grid");
    // (each process checks its own modes; the verdict is every process's, so that all refuse together)
    // One pass: whether a mode is not finite, ||q||^2, and the largest component (below)
    double bad = 0.0, norm2 = 0.0, largest = 0.0;
    for (const auto& v : q) {
        if (!std::isfinite(v.real()) || !std::isfinite(v.imag())) bad = 1.0;
        norm2 += std::norm(v);
        largest = std::max({largest, std::abs(v.real()), std::abs(v.imag())});
    }
    d_->g.sum_over_ranks(&bad, 1);
    if (bad != 0.0) throw std::invalid_argument("initial condition is not finite");
    // A real field's state: the k_x = 0 column Hermitian, q(0, -k_y) = conj q(0, k_y), and the mean q(0, 0) zero (no
    // equation here evolves it; the file fields are projected so). A transform of a real field is so to its
    // round-off, |dQ| <= ||dQ|| <= c eps log2(N^2) ||Q||: within 16 eps log2(N) ||q|| it is taken (the front ends
    // then make it exact, make_hermitian); beyond it the state is not one of a real field and is refused.
    // worst: the largest |q(0, -k_y) - conj q(0, k_y)|, its k_y, |q(0, 0)|, and the largest component
    double worst[4] = {0.0, 0.0, 0.0, largest};
    if (d_->c0 == 0 && d_->kept > 0) {
        for (int r = 1; r <= d_->kmax; ++r) {
            const double m = std::abs(q[d_->column0(d_->rows - r)] - std::conj(q[d_->column0(r)]));
            if (m > worst[0]) worst[0] = m, worst[1] = r;
        }
        worst[2] = std::abs(q[0]);
    }
    d_->g.sum_over_ranks(&norm2, 1);
    d_->g.max_over_ranks(worst, 4);
    largest = worst[3];
    const double round_off = 16.0 * std::numeric_limits<double>::epsilon() * std::log2(double(n_)) * std::sqrt(norm2);
    using eci::detail::shortest_text;
    if (worst[0] > round_off)
        throw std::invalid_argument(
            "initial condition is not the state of a real field: its k_x = 0 column is not Hermitian (|q(0, -" +
            shortest_text(worst[1]) + ") - conj q(0, " + shortest_text(worst[1]) + ")| = " + shortest_text(worst[0]) +
            ", beyond the round-off " + shortest_text(round_off) + " of a transform)");
    if (worst[2] > round_off)
        throw std::invalid_argument("initial condition has a mean: its k = 0 mode is " + shortest_text(worst[2]) +
                                    " (round-off of a transform: " + shortest_text(round_off) +
                                    "), and the equations hold the mean at 0: subtract it");
    // E and Z below the smallest normal double lose their precision to subnormal arithmetic (and squares of the
    // modes underflow): refused, as the other models' initial-state check does
    const double e = energy(q), z = enstrophy(q);
    // ... and a field whose modes are not all zero but whose E or Z is 0: its squares underflowed whole (a vortex
    // pair of peak 1e-300 ran with E = Z = 0, the invariants' drifts measured against nothing)
    if ((e != 0.0 && !std::isnormal(e)) || (z != 0.0 && !std::isnormal(z)) || !std::isfinite(e) || !std::isfinite(z) ||
        (largest > 0.0 && (e == 0.0 || z == 0.0))) {
        const auto names = invariant_names();
        throw std::invalid_argument("initial condition: " + names[0] + " " + eci::detail::shortest_text(e) + " and " +
                                    names[1] + " " + eci::detail::shortest_text(z) + " must be finite normal numbers" +
                                    (std::isfinite(e) && std::isfinite(z) && (e == 0.0 || z == 0.0)
                                         ? " (its largest mode, " + eci::detail::shortest_text(largest) +
                                               ", squares below the smallest double)"
                                         : ""));
    }
}

void flow2d::check_initial_rates(const state_type& q) {
    // dq/dt at q, without recording (a step's budget is not touched)
    state_type dq;
    const bool was = recording_;
    recording_ = false;
    (*this)(q, dq, 0.0);
    recording_ = was;
    double bad = 0.0;
    for (const auto& v : dq)
        if (!std::isfinite(v.real()) || !std::isfinite(v.imag())) bad = 1.0;
    d_->g.sum_over_ranks(&bad, 1);
    if (bad != 0.0)
        throw std::invalid_argument("initial condition: its rate dq/dt is not finite (the nonlinear term overflows "
                                    "double precision): no step of any size can take it");
}

void flow2d::check_blow_up(const state_type& q, std::span<const double> invariants, double e0, double injected,
                           std::uint64_t step, double t, double dt) {
    const double e = invariants[0], z = invariants[1];
    const bool finite = std::isfinite(e) && std::isfinite(z);
    if (finite && !(e > 1e3 * (e0 + injected))) return;
    const std::size_t j = std::isfinite(e) && !finite ? 1 : 0;  // (Z alone not finite: named; else E)
    throw flow_blow_up("blow-up at step " + std::to_string(step) + ", t = " + eci::detail::shortest_text(t) + ": " +
                           invariant_names()[j] + " " + eci::detail::shortest_text(invariants[j]) + " (CFL " +
                           eci::detail::shortest_text(cfl(q, dt)) + ")",
                       step, t, j, finite);
}

double flow2d::initial_cfl_step(const state_type& q, double cfl, std::string_view dt_name,
                                std::string_view cfl_name) {
    if (!(std::isfinite(cfl) && cfl > 0.0))
        throw std::invalid_argument(std::string(cfl_name) + " must be a positive number");
    check_initial_state(q);
    const double u = max_velocity(q);
    if (!(u > 0.0)) throw std::invalid_argument("the initial velocity is zero: give " + std::string(dt_name));
    double dt = cfl * (2.0 * std::numbers::pi / n_) / u;
    // ... and no longer than cfl / max |omega| of the linear waves (Rossby waves omega = -beta k_x / (k^2 + F)), a
    // phase of cfl radians per step at most: a beta-plane flow's fastest wave can be far faster than its velocity
    // (beta = 1e10 took ~2^30 halvings per step of the velocity's step, with no message).
    double omega = 0.0;
    for (const double c : d_->disp) omega = std::max(omega, std::abs(c));
    d_->g.max_over_ranks(&omega, 1);
    if (omega > 0.0) dt = std::min(dt, cfl / omega);
    // ... and no longer than 2 cfl / max rate of the linear damping: at the default cfl 0.5 one e-fold per step,
    // within every explicit method's real stability interval ([-2, 0] for Euler, Heun and the midpoint rule). Without
    // it a stiff viscosity failed the first step after 40 halvings, or took 65536 sub-steps (--drag 1e10).
    const double rate = linear_rate();
    if (rate > 0.0) dt = std::min(dt, 2.0 * cfl / rate);
    if (!(dt > 0.0) || !std::isfinite(dt))
        throw std::invalid_argument("the time step from " + std::string(cfl_name) + " " +
                                    eci::detail::shortest_text(cfl) + ", CFL dx / max|u| = " +
                                    eci::detail::shortest_text(dt) + ", is not a positive finite number");
    return dt;
}

double flow2d::linear_rate() const {
    double rate = 0.0;
    for (const double c : d_->lin) rate = std::max(rate, -c);  // lin = -(nu k^2 + ...) <= 0, 0 where not retained
    d_->g.max_over_ranks(&rate, 1);
    return rate;
}

std::string flow2d::stiffness_hint(double dt) const {
    const double rate = linear_rate();
    if (!(dt * rate > 2.0)) return {};
    return "the linear damping (viscosity, hyperviscosity, drag, hypoviscosity) decays at up to " +
           eci::detail::shortest_text(rate) + " per unit time, so dt " + eci::detail::shortest_text(dt) +
           " is beyond an explicit step's stability; dt <= " + eci::detail::shortest_text(2.0 / rate) +
           " (the default step keeps within it) or a smaller coefficient";
}

double flow2d::invariant_floor() const {
    return double(rows()) * double(kmax() + 1) * std::numeric_limits<double>::min();
}

std::string flow2d::decay_hint(const state_type& q) const {
    const double z = enstrophy(q);
    if (!(z < invariant_floor())) return {};
    return "the field has decayed below double precision's normal range (" + invariant_names()[1] + " " +
           eci::detail::shortest_text(z) + " at the last good step): its squares are subnormal round-off, from "
           "which no conservative update can be formed at any step size; a conventional method (rk4) takes it on to "
           "zero";
}

double flow2d::cfl(const state_type& q, double dt) { return max_velocity(q) * dt * double(n_) / (2.0 * std::numbers::pi); }

template <class Value>
std::vector<double> flow2d::shells(Value value) const {
    std::vector<double> e(d_->g.shell_count(), 0.0);
    in_row_order_over(*this, 0, std::size_t(rows()), [&](std::size_t i, std::size_t c, std::size_t r) {
        if (weights_[i] != 0.0)
            e[std::size_t(std::lround(std::hypot(double(kx_of_column(c)), double(ky_of_row(r)))))] += value(i);
    });
    d_->g.sum_over_ranks(e.data(), e.size());
    return e;
}

std::vector<double> flow2d::energy_spectrum(const state_type& q) const {
    return shells([&](std::size_t i) { return 0.5 * weights_[i] * d_->ea[i] * std::norm(q[i]); });
}

std::vector<double> flow2d::enstrophy_spectrum(const state_type& q) const {
    return shells([&](std::size_t i) { return 0.5 * weights_[i] * std::norm(q[i]); });
}

flow_fluxes flow2d::fluxes(const state_type& q) {
    state_type nl;
    nonlinear(q, nl);
    auto transfer = [&](bool energy) {
        return shells([&](std::size_t i) {
            const double t = weights_[i] * (q[i].real() * nl[i].real() + q[i].imag() * nl[i].imag());
            return energy ? d_->ea[i] * t : t;
        });
    };
    flow_fluxes f{transfer(true), transfer(false)};
    for (auto* v : {&f.energy, &f.enstrophy}) {
        double acc = 0.0;
        for (double& x : *v) x = -(acc += x);
    }
    return f;
}

flow2d::state_type flow2d::from_physical(std::span<const double> field) {
    const spectral::grid& g = d_->g;
    if (!g.distributed()) return from_half_plane(g.from_physical(field));
    if (field.size() != g.points())
        throw std::invalid_argument("field has " + std::to_string(field.size()) + " values, the grid " +
                                    std::to_string(g.points()));
    return from_physical_rows(field.subspan(std::size_t(g.first_row()) * std::size_t(n_),
                                            std::size_t(g.local_rows()) * std::size_t(n_)));
}

flow2d::state_type flow2d::from_physical_rows(std::span<const double> rows) {
    const spectral::grid& g = d_->g;
    if (!g.distributed()) return from_physical(rows);
    // this process's rows of the field, forward, and its retained modes of the transposed layout
    if (rows.size() != std::size_t(g.local_rows()) * std::size_t(n_))
        throw std::invalid_argument("rows hold " + std::to_string(rows.size()) + " values, this process's " +
                                    std::to_string(g.local_rows()) + " rows " +
                                    std::to_string(std::size_t(g.local_rows()) * std::size_t(n_)));
    const double s = g.load_physical_rows(rows, g.first_row());
    g.forward(0, 1);
    const double scale = s * (1.0 / double(g.points()));  // (s a power of two: the unscaled product where s = 1)
    state_type q(size());
    for (std::size_t i = 0; i < size(); ++i) {
        const int row = int(row_of(i));
        q[i] = scale * g.spectral(0)[g.at(int(d_->full_row(row)), int(column_of(i)))];
    }
    if (col0_ == 0 && cols_ > 0) q[0] = 0.0;
    d_->hermitian(q.data());
    return q;
}

std::vector<double> flow2d::to_physical_rows(const state_type& q) {
    if (q.size() != size()) throw std::invalid_argument("state size does not match the grid");
    const spectral::grid& g = d_->g;
    if (!g.distributed()) return g.to_physical(to_half_plane(q).data());
    // this process's columns into the transposed layout (zero elsewhere), inverse: this process's rows
    cplx* f = g.spectral(0);
    std::fill(f, f + g.spectral_stride() * std::size_t(n_), cplx{});
    for (std::size_t i = 0; i < size(); ++i) {
        const int row = int(row_of(i));
        f[g.at(int(d_->full_row(row)), int(column_of(i)))] = q[i];
    }
    g.inverse(1);
    std::vector<double> mine(std::size_t(g.local_rows()) * std::size_t(n_));
    for (int y = 0; y < g.local_rows(); ++y)
        std::copy_n(g.physical(0) + std::size_t(y) * g.padded(), n_, mine.begin() + std::ptrdiff_t(y) * n_);
    return mine;
}

#ifdef ECI_MPI
namespace {

// Every process's rows of a field gathered, in rank order (the rows' order), on `root` (root < 0: on every process),
// counted in rows of n values, so that no count overflows an int however large the grid.
std::vector<double> gather_rows(const grid& g, const std::vector<double>& mine, int root) {
    const int P = g.ranks(), rows = g.local_rows(), n = g.n();
    const bool here = root < 0 || g.rank() == root;
    std::vector<int> counts(here ? std::size_t(P) : 0), offsets(here ? std::size_t(P) : 0);
    if (root < 0)
        MPI_Allgather(&rows, 1, MPI_INT, counts.data(), 1, MPI_INT, g.comm());
    else
        MPI_Gather(&rows, 1, MPI_INT, counts.data(), 1, MPI_INT, root, g.comm());
    for (int k = 1; k < int(counts.size()); ++k)
        offsets[std::size_t(k)] = offsets[std::size_t(k - 1)] + counts[std::size_t(k - 1)];
    MPI_Datatype row;
    MPI_Type_contiguous(n, MPI_DOUBLE, &row);
    MPI_Type_commit(&row);
    std::vector<double> out(here ? g.points() : 0);
    if (root < 0)
        MPI_Allgatherv(mine.data(), rows, row, out.data(), counts.data(), offsets.data(), row, g.comm());
    else
        MPI_Gatherv(mine.data(), rows, row, out.data(), counts.data(), offsets.data(), row, root, g.comm());
    MPI_Type_free(&row);
    return out;
}

}  // namespace
#endif

std::vector<double> flow2d::to_physical(const state_type& q) {
    if (q.size() != size()) throw std::invalid_argument("state size does not match the grid");
    const spectral::grid& g = d_->g;
    if (!g.distributed()) return g.to_physical(to_half_plane(q).data());
#ifdef ECI_MPI
    return gather_rows(g, to_physical_rows(q), -1);
#else
    return {};
#endif
}

std::vector<double> flow2d::to_physical(const state_type& q, int root) {
    if (q.size() != size()) throw std::invalid_argument("state size does not match the grid");
    const spectral::grid& g = d_->g;
    if (root < 0 || root >= g.ranks())
        throw std::invalid_argument("root " + std::to_string(root) + " is not a process of the flow's " +
                                    std::to_string(g.ranks()));
    if (!g.distributed()) return to_physical(q);
#ifdef ECI_MPI
    return gather_rows(g, to_physical_rows(q), root);
#else
    return {};
#endif
}

flow2d::state_type flow2d::to_half_plane(const state_type& q) const {
    if (q.size() != size()) throw std::invalid_argument("state size does not match the grid");
#ifdef ECI_MPI
    if (d_->g.distributed()) {
        // every process's columns gathered (with where they start), then laid out in the half plane
        const spectral::grid& g = d_->g;
        const int P = g.ranks();
        int mine[2] = {col0_, cols_};
        std::vector<int> cols(2 * static_cast<std::size_t>(P));
        MPI_Allgather(mine, 2, MPI_INT, cols.data(), 2, MPI_INT, g.comm());
        std::vector<int> counts(static_cast<std::size_t>(P)), offsets(static_cast<std::size_t>(P));
        for (int k = 0; k < P; ++k) {
            counts[std::size_t(k)] = 2 * rows() * cols[2 * std::size_t(k) + 1];
            if (k > 0) offsets[std::size_t(k)] = offsets[std::size_t(k - 1)] + counts[std::size_t(k - 1)];
        }
        std::vector<cplx> all(std::size_t(offsets.back() + counts.back()) / 2);
        MPI_Allgatherv(q.data(), 2 * int(q.size()), MPI_DOUBLE, reinterpret_cast<double*>(all.data()),
                       counts.data(), offsets.data(), MPI_DOUBLE, g.comm());
        state_type h(g.size());
        for (int k = 0; k < P; ++k) {
            const std::size_t c0 = std::size_t(cols[2 * std::size_t(k)]), lc = std::size_t(cols[2 * std::size_t(k) + 1]);
            const cplx* part = all.data() + offsets[std::size_t(k)] / 2;
            for (int r = 0; r < rows(); ++r)  // (spread over processes the state is stored by rows)
                for (std::size_t c = 0; c < lc; ++c) h[d_->full_row(r) * d_->nc + c0 + c] = part[std::size_t(r) * lc + c];
        }
        return h;
    }
#endif
    state_type h(d_->g.size());
    for (std::size_t i = 0; i < q.size(); ++i) h[d_->full_row(int(row_of(i))) * d_->nc + column_of(i)] = q[i];
    return h;
}

flow2d::state_type flow2d::from_half_plane(const state_type& h) const {
    if (h.size() != d_->g.size())
        throw std::invalid_argument("half plane has " + std::to_string(h.size()) + " modes, the grid " +
                                    std::to_string(d_->g.size()));
    state_type q(size());
    for (std::size_t i = 0; i < q.size(); ++i)
        q[i] = h[d_->full_row(int(row_of(i))) * d_->nc + std::size_t(col0_) + column_of(i)];
    if (col0_ == 0 && cols_ > 0) q[0] = 0.0;
    d_->hermitian(q.data());
    return q;
}

flow2d::state_type flow2d::to_half_plane_columns(const state_type& q) const {
    const spectral::grid& g = d_->g;
    if (!g.distributed()) return to_half_plane(q);
    if (q.size() != size()) throw std::invalid_argument("state size does not match the grid");
    const std::size_t local = std::size_t(g.local_columns());
    state_type h(std::size_t(n_) * local);
    for (std::size_t i = 0; i < q.size(); ++i) h[d_->full_row(int(row_of(i))) * local + column_of(i)] = q[i];
    return h;
}

flow2d::state_type flow2d::from_half_plane_columns(const state_type& columns) const {
    const spectral::grid& g = d_->g;
    if (!g.distributed()) return from_half_plane(columns);
    const std::size_t local = std::size_t(g.local_columns());
    if (columns.size() != std::size_t(n_) * local)
        throw std::invalid_argument("columns hold " + std::to_string(columns.size()) + " modes, this process's " +
                                    std::to_string(local) + " columns " + std::to_string(std::size_t(n_) * local));
    state_type q(size());
    for (std::size_t i = 0; i < q.size(); ++i)
        q[i] = columns[d_->full_row(int(row_of(i))) * local + column_of(i)];
    if (col0_ == 0 && cols_ > 0) q[0] = 0.0;
    d_->hermitian(q.data());
    return q;
}

void flow2d::make_hermitian(state_type& q) const {
    if (q.size() != size()) throw std::invalid_argument("state size does not match the grid");
    d_->hermitian(q.data());
    if (d_->c0 == 0 && d_->kept > 0) q[0] = 0.0;  // (the mean: held at 0, as every field the library makes)
}

flow2d::state_type flow2d::random_field(double k_peak, double energy_target, std::uint64_t seed) {
    require(std::isfinite(k_peak) && k_peak > 0.0, "peak wavenumber must be a positive finite number");
    require(std::isfinite(energy_target) && energy_target > 0.0, "initial energy must be a positive finite number");
    const spectral::grid& g = d_->g;
    // The field with the shell energies `shell(k)`, before it is scaled to the energy asked for.
    const auto field_of = [&](auto shell) {
        state_type w(size());
        std::uint64_t s = seed;
        for (std::size_t j = 0; j < g.size(); ++j) {
            // Every mode of the half plane draws, in its order, so the field of a seed does not depend on which
            // modes are retained (nor on the state's layout).
            const double phase = 2.0 * std::numbers::pi * uniform(s);
            if (!g.retained(j) || !owns_column(g.kx(j))) continue;
            const std::size_t i = index(g.kx(j), g.ky(j));
            const double k2 = g.k2(j), k = std::sqrt(k2);
            // A shell of radius k holds about 2 pi k modes of energy |a_k| |q_k|^2 / 2 each. The tail is a power
            // law: an exponential one leaves the far modes below round-off, where their right-hand sides are FFT
            // noise of random sign and the conservative methods' radicands negative at any step size. (For
            // Navier-Stokes, |a_k| = 1/k^2 and the factor sqrt((1/k^2) / |a_k|) is 1 exactly.)
            w[i] = std::polar(std::sqrt(shell(k) * k / std::numbers::pi) * std::sqrt((1.0 / k2) / d_->ea[i]), phase);
        }
        d_->hermitian(w.data());
        return w;
    };
    state_type w = field_of([&](double k) {
        const double sq = k / k_peak;
        return sq * sq * sq * sq / std::pow(1.0 + sq * sq, 4);
    });
    double e = energy(w);
    if (!(e > 0.0 && e <= std::numeric_limits<double>::max())) {
        // A peak far from the retained modes (k_peak 1e-300, or 1e80 in a program of one's own): q^4 / (1 + q^2)^4
        // overflows (inf / inf) or underflows at every mode, and the field was refused as having no mode near its
        // peak, though the spectrum is only its power-law tail. The same shape divided by its value at k = 1 (its
        // scale is the energy's, below): (r(k) / r(1))^4, r(k) = q / (1 + q^2), formed without a square of the peak
        // that overflows or underflows.
        const double r1 = k_peak >= 1.0 ? 1.0 + 1.0 / (k_peak * k_peak) : k_peak * k_peak + 1.0;
        w = field_of([&](double k) {
            const double ratio = k_peak >= 1.0 ? k * r1 / (1.0 + (k / k_peak) * (k / k_peak))
                                               : k * r1 / (k_peak * k_peak + k * k);
            return ratio * ratio * ratio * ratio;
        });
        e = energy(w);
    }
    require(e > 0.0, "no retained mode near the peak wavenumber");
    // (the ratio's square root, or where the ratio overflows or underflows (an energy of 1e308), the roots' ratio)
    const double ratio = energy_target / e;
    const double scale = ratio > 0.0 && ratio <= std::numeric_limits<double>::max()
                             ? std::sqrt(ratio)
                             : std::sqrt(energy_target) / std::sqrt(e);
    for (cplx& v : w) v *= scale;
    return w;
}

flow2d::state_type flow2d::vortex_pair(double radius, double separation, double peak) {
    require(std::isfinite(radius) && radius > 0.0, "vortex radius must be a positive finite number");
    // narrower than half the grid spacing, the Gaussians fall between the grid points: a near-zero field, not a pair
    if (!(radius * double(n_) >= std::numbers::pi)) {
        char half[32];
        std::snprintf(half, sizeof half, "%.3g", std::numbers::pi / double(n_));
        throw std::invalid_argument("vortex radius " + eci::detail::shortest_text(radius) +
                                    " is below half the grid spacing (pi / N = " + half + " at N = " +
                                    std::to_string(n_) + "): the vortices would fall between the grid points");
    }
    require(std::isfinite(separation) && separation >= 0.0 && separation < std::numbers::pi,
            "vortex separation must be in [0, pi)");
    require(std::isfinite(peak), "peak vorticity must be finite");
    const double h = 2.0 * std::numbers::pi / n_, L = 2.0 * std::numbers::pi;
    // this process's rows (every row on one process): no process holds the whole field
    const int y0 = d_->g.first_row(), ny = d_->g.local_rows();
    std::vector<double> f(std::size_t(ny) * std::size_t(n_));
    // The pair's centre is off the grid's symmetry points: centred on one, half the Fourier components would be
    // zero up to round-off, with right-hand sides of random sign, and their radicands negative at any step size.
    const double xc = std::numbers::pi + 0.1234, yc = std::numbers::pi + 0.0567;
    const double cx[2] = {xc - 0.5 * separation, xc + 0.5 * separation};
    for (int j = y0; j < y0 + ny; ++j)
        for (int i = 0; i < n_; ++i) {
            double v = 0.0;
            for (double c : cx) {
                const double dx = std::remainder(i * h - c, L), dy = std::remainder(j * h - yc, L);
                v += peak * std::exp(-(dx * dx + dy * dy) / (radius * radius));
            }
            f[std::size_t(j - y0) * std::size_t(n_) + std::size_t(i)] = v;
        }
    return from_physical_rows(f);
}

flow2d::state_type flow2d::taylor_green(double velocity) {
    require(std::isfinite(velocity), "Taylor-Green velocity must be finite");
    // 2 U sin x sin y = -(U/2) (e^{i(x+y)} - e^{i(x-y)} - e^{i(-x+y)} + e^{-i(x+y)})
    state_type w(size());
    if (owns_column(1)) {
        w[index(1, 1)] = -0.5 * velocity;
        w[index(1, -1)] = 0.5 * velocity;
    }
    return w;
}

void flow2d::draw_forcing(double dt) {
    impl& d = *d_;
    if (d.p.forcing != forcing_kind::stochastic) return;
    const double amp = 1.0 / std::sqrt(dt);
    // one draw per mode of the band, in the half plane's order, kept by the process that holds the mode
    for (std::size_t i : d.band) {
        const cplx g = complex_gaussian(rng_);
        if (i != impl::npos) d.force[i] = d.sigma * amp * g;
    }
    d.hermitian(d.force.data());
}

const flow2d::state_type& flow2d::forcing() const { return d_->force; }

}  // namespace eci::spectral
