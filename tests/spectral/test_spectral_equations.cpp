// Tests of the spectral core's equations (Navier-Stokes, Charney-Hasegawa-Mima, surface QG) on one grid: both
// invariants kept by the nonlinear term and by the conservative methods, Basdevant's form against the advective one,
// the Rossby-wave dispersion relation, closed budgets and bit-identical restart, for every equation.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <complex>
#include <cstdint>
#include <limits>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include <eci/eci.hpp>
#include <eci/spectral/step.hpp>

namespace {

using eci::spectral::flow2d;
using eci::spectral::flow_params;
using state = flow2d::state_type;
using cplx = std::complex<double>;
constexpr double eps = std::numeric_limits<double>::epsilon();

flow_params params(const std::string& equation, int n) {
    flow_params p;
    p.equation = equation;
    p.n = n;
    p.measure = false;  // FFTW_ESTIMATE: no planning time, the same plans every run
    if (equation == "charney-hasegawa-mima") {
        p.beta = 10.0;
        p.deformation = 1.0;
    }
    return p;
}

std::vector<std::string> all_equations() {
    std::vector<std::string> v;
    for (const auto* e : eci::spectral::equations()) v.emplace_back(e->name);
    return v;
}

double max_abs(const state& a) {
    double m = 0.0;
    for (const cplx& v : a) m = std::max(m, std::abs(v));
    return m;
}

class Equation : public ::testing::TestWithParam<std::string> {};

INSTANTIATE_TEST_SUITE_P(Spectral, Equation, ::testing::ValuesIn(all_equations()),
                         [](const auto& info) {
                             std::string s = info.param;
                             std::replace(s.begin(), s.end(), '-', '_');
                             return s;
                         });

// Every triad of the dealiased term conserves E = 1/2 sum |a_k| |q_k|^2 and Z = 1/2 sum |q_k|^2: the rates
// sum w |a| Re(conj(q) N) and sum w Re(conj(q) N) vanish to the round-off of sums of n^2 products, ~ eps times the
// Cauchy-Schwarz scale sqrt(sum w |a| |q|^2) sqrt(sum w |a| |N|^2); not vacuous: each weighted sum of |Re(conj(q) N)|
// is far larger.
TEST_P(Equation, NonlinearTermConservesBothInvariants) {
    flow2d m(params(GetParam(), 64));
    const state q = m.random_field(6.0, 0.5, 7);
    state nl;
    m.nonlinear(q, nl);
    for (bool energy : {true, false}) {
        double dot = 0.0, abs_sum = 0.0, nq = 0.0, nn = 0.0;
        for (std::size_t i = 0; i < m.size(); ++i) {
            const double w = m.weights()[i] * (energy ? std::abs(m.inversion()[i]) : 1.0);
            const double t = q[i].real() * nl[i].real() + q[i].imag() * nl[i].imag();
            dot += w * t;
            abs_sum += w * std::abs(t);
            nq += w * std::norm(q[i]);
            nn += w * std::norm(nl[i]);
        }
        const double scale = std::sqrt(nq * nn);
        EXPECT_LE(std::abs(dot), 64.0 * eps * scale) << (energy ? "energy" : "enstrophy");
        EXPECT_GE(abs_sum, 1e6 * 64.0 * eps * scale) << "the identity is vacuous";
    }
}

// Basdevant's 4 transforms equal the advective form's 5 up to the transforms' round-off: both are the exact Galerkin
// term of the same alias-free products; the bound, 8 eps log2(n^2) max|N|, is measured at ~0.5 of it.
TEST_P(Equation, NonlinearFormsAgree) {
    if (eci::spectral::find_equation(GetParam()).form != eci::spectral::nonlinear_form::basdevant)
        GTEST_SKIP() << GetParam() << " computes the advective form itself";
    for (int n : {32, 96}) {
        flow2d m(params(GetParam(), n));
        const state q = m.random_field(5.0, 0.5, 3);
        state a, b;
        m.nonlinear(q, a);
        m.nonlinear_advective(q, b);
        double diff = 0.0;
        for (std::size_t i = 0; i < m.size(); ++i) diff = std::max(diff, std::abs(a[i] - b[i]));
        EXPECT_LE(diff, 8.0 * eps * std::log2(double(n) * n) * max_abs(b)) << "n = " << n;
        EXPECT_GT(max_abs(b), 0.0);
    }
}

// max |u| (a CSV row's max_velocity, the CFL step) is the maximum over the grid of the velocity field formed here
// from the inversion operator and transformed alone, on either transforms (the pruned ones: the right-hand side's
// inverse half, no forward transforms) and threads: to the transforms' round-off (8 eps log2(n^2) max|u|).
TEST_P(Equation, MaxVelocityIsTheMaximumOfTheVelocityField) {
    for (const bool prune : {true, false})
        for (const int threads : {1, 2}) {
            flow_params p = params(GetParam(), 48);
            p.pruned_transforms = prune;
            p.threads = threads;
            flow2d m(p);
            const state q = m.random_field(5.0, 0.5, 3);
            state u(q.size()), v(q.size());
            for (std::size_t i = 0; i < q.size(); ++i) {
                const cplx psi = m.inversion()[i] * q[i];
                u[i] = cplx(0.0, -double(m.ky(i))) * psi;  // u = -d psi/dy
                v[i] = cplx(0.0, double(m.kx(i))) * psi;   // v = d psi/dx
            }
            const std::vector<double> uf = m.to_physical(u), vf = m.to_physical(v);
            double want = 0.0;
            for (std::size_t j = 0; j < uf.size(); ++j) want = std::max(want, std::hypot(uf[j], vf[j]));
            ASSERT_GT(want, 0.0);
            EXPECT_NEAR(m.max_velocity(q), want, 8.0 * eps * std::log2(48.0 * 48.0) * want)
                << (prune ? "pruned" : "full") << " transforms, " << threads << " threads";
        }
}

// max |u| of a flow whose squares overflow or underflow: the flow scaled by 2^600 or 2^-600 (exactly: the
// transforms and products of powers of two round alike) has max |u| scaled by the same power, bit for bit, on either
// transforms. Before, u^2 + v^2 was inf or 0 there (a CFL step of 0; "the initial velocity is zero").
TEST_P(Equation, MaxVelocityOfATinyOrHugeFlowIsScaledNotSquaredAway) {
    for (const bool prune : {true, false}) {
        flow_params p = params(GetParam(), 32);
        p.pruned_transforms = prune;
        flow2d m(p);
        const state q = m.random_field(5.0, 0.5, 3);
        const double u = m.max_velocity(q);
        ASSERT_GT(u, 0.0);
        for (const int e : {600, -600}) {
            state scaled = q;
            for (cplx& v : scaled) v *= std::ldexp(1.0, e);
            EXPECT_EQ(m.max_velocity(scaled), std::ldexp(u, e)) << (prune ? "pruned" : "full") << ", 2^" << e;
        }
        EXPECT_EQ(m.max_velocity(state(q.size())), 0.0);  // (a zero flow is still at rest)
    }
}

// A random field whose peak is far from the retained modes is its spectrum's power-law tail: k_p = 1e-300 (whose
// q^4 / (1 + q^2)^4 overflowed at every mode: "no retained mode near the peak wavenumber") gives the field of
// k_p = 1e-20 (where the shape is q^-4 to 1e-40), and k_p = 1e200 (underflowed to 0) that of 1e40 (q^4), to the
// round-off of the fields' scaling. An energy of 1e308 (whose ratio to the shape's energy overflowed: a field of inf,
// "initial condition is not finite") is that energy.
TEST_P(Equation, RandomFieldsOfAFarPeakOrAHugeEnergyAreMade) {
    flow2d m(params(GetParam(), 32));
    for (const auto& [far, near] : {std::pair{1e-300, 1e-20}, std::pair{1e200, 1e40}}) {
        const state a = m.random_field(far, 0.5, 3), b = m.random_field(near, 0.5, 3);
        double diff = 0.0;
        for (std::size_t i = 0; i < a.size(); ++i) diff = std::max(diff, std::abs(a[i] - b[i]));
        EXPECT_LE(diff, 16.0 * eps * max_abs(b)) << "k_p " << far << " against " << near;
        EXPECT_NEAR(m.energy(a), 0.5, 8.0 * eps) << "k_p " << far;
    }
    const state huge = m.random_field(5.0, 1e308, 3);
    for (const cplx& v : huge) ASSERT_TRUE(std::isfinite(v.real()) && std::isfinite(v.imag()));
    EXPECT_NEAR(m.energy(huge), 1e308, 1e308 * 64.0 * eps);
}

// The pruned transforms (columns without retained modes skipped, rows fused with the products; the default) give
// the same term as FFTW's 2-D plans to the transforms' round-off (8 eps log2(n^2) max|N|, as above), and a pruned
// run keeps both invariants as exactly (8 eps sqrt(steps)).
TEST_P(Equation, PrunedTransformsAgreeAndConserve) {
    flow_params p = params(GetParam(), 64);
    EXPECT_TRUE(p.pruned_transforms) << "the default";
    p.pruned_transforms = false;
    flow2d plain(p);
    p.pruned_transforms = true;
    flow2d pruned(p);
    EXPECT_FALSE(plain.grid().pruned());
    EXPECT_TRUE(pruned.grid().pruned());
    // (the two store the state differently: by rows, and by columns for the fused column pass)
    EXPECT_FALSE(plain.by_columns());
    EXPECT_TRUE(pruned.by_columns());
    const state q0 = pruned.random_field(6.0, 0.5, 8);
    EXPECT_EQ(plain.to_half_plane(plain.random_field(6.0, 0.5, 8)), pruned.to_half_plane(q0));
    state a, b;
    plain.nonlinear(plain.from_half_plane(pruned.to_half_plane(q0)), a);
    pruned.nonlinear(q0, b);
    double diff = 0.0;
    for (std::size_t i = 0; i < a.size(); ++i) diff = std::max(diff, std::abs(a[i] - b[pruned.index(plain.kx(i), plain.ky(i))]));
    EXPECT_LE(diff, 8.0 * eps * std::log2(64.0 * 64.0) * max_abs(a));
    EXPECT_GT(diff, 0.0) << "the same transforms: the test compares nothing";
    const double dt = 0.5 * (2.0 * std::numbers::pi / 64) / pruned.max_velocity(q0);
    const int steps = 100;
    state q = q0;
    eci::c_rk4<state> st;
    eci::ns2d_budget bud;
    eci::run_stats s;
    for (int i = 0; i < steps; ++i) eci::ns2d_step(st, pruned, q, i * dt, dt, bud, s);
    EXPECT_LE(std::abs(pruned.energy(q) - pruned.energy(q0)) / pruned.energy(q0), 8.0 * eps * std::sqrt(double(steps)));
    EXPECT_LE(std::abs(pruned.enstrophy(q) - pruned.enstrophy(q0)) / pruned.enstrophy(q0),
              8.0 * eps * std::sqrt(double(steps)));
}

// The right-hand side by the fused column pass (pruned transforms on one process, the default: each column of the
// state filled, transformed and formed into dq/dt in cache) against the same flow on FFTW's 2-D plans (the grid's
// own layout, a fill and a pass over it): dq/dt and every budget rate agree to the transforms' round-off, forced
// and damped, on one thread and on two (the columns split between them). Rates are sums of n^2 products of
// magnitude up to max |q| max |dq/dt| ~ their scale, so 8 eps log2(n^2) of that scale. N = 34 (N mod 4 = 2): the
// columns' starts are 32-byte aligned only, not 64.
TEST_P(Equation, ColumnPassRightHandSideAndRatesAgree) {
    for (const auto& [n, threads] : {std::pair{64, 1}, std::pair{64, 2}, std::pair{34, 1}, std::pair{34, 2}}) {
        flow_params p = params(GetParam(), n);
        p.nu = 1e-3;
        p.drag = 0.05;
        p.forcing = eci::spectral::forcing_kind::deterministic;
        p.forcing_k = 5.0;
        p.threads = threads;
        p.pruned_transforms = false;
        flow2d plain(p);
        p.pruned_transforms = true;
        flow2d fused(p);
        EXPECT_FALSE(plain.grid().column_pass());
        ASSERT_TRUE(fused.grid().column_pass()) << "the default serial grid fuses the column pass";
        const state q = plain.random_field(6.0, 0.5, 8), qf = fused.random_field(6.0, 0.5, 8);
        ASSERT_EQ(plain.to_half_plane(q), fused.to_half_plane(qf)) << "the same field in either layout";
        state a, b;
        plain(q, a, 0.0);
        fused(qf, b, 0.0);
        ASSERT_EQ(a.size(), b.size());
        double diff = 0.0;
        for (std::size_t i = 0; i < a.size(); ++i)
            diff = std::max(diff, std::abs(a[i] - b[fused.index(plain.kx(i), plain.ky(i))]));
        const double tol = 8.0 * eps * std::log2(double(n) * n);
        EXPECT_LE(diff, tol * max_abs(a)) << "N = " << n << ", " << threads << " thread(s)";
        // (at N = 34 FFTW's estimated plans take the same 1-D codelets both ways: the same bits)
        if (n == 64) {
            EXPECT_GT(diff, 0.0) << "the same transforms: the test compares nothing";
        }
        // k = 0 stays zero and the k_x = 0 column (the state's first 2 kmax + 1 modes) stays Hermitian
        EXPECT_EQ(b[0], cplx{});
        for (int ky = 1; ky <= fused.kmax(); ++ky) EXPECT_EQ(b[fused.index(0, -ky)], std::conj(b[fused.index(0, ky)]));
        const auto ra = plain.rates(q), rb = fused.rates(qf);
        const double scale = max_abs(q) * max_abs(a) * double(q.size());
        const double pa[6] = {ra.energy_injection, ra.energy_dissipation, ra.enstrophy_injection,
                              ra.enstrophy_dissipation, ra.energy_transfer, ra.enstrophy_transfer};
        const double pb[6] = {rb.energy_injection, rb.energy_dissipation, rb.enstrophy_injection,
                              rb.enstrophy_dissipation, rb.energy_transfer, rb.enstrophy_transfer};
        for (int k = 0; k < 6; ++k)
            EXPECT_LE(std::abs(pa[k] - pb[k]), tol * scale) << "rate " << k << ", N = " << n << ", " << threads;
        EXPECT_NE(rb.energy_injection, 0.0);
        EXPECT_NE(rb.enstrophy_dissipation, 0.0);
    }
}

// The cases of the bit-for-bit tests below: body(flow, n, forced, where) on a damped flow of the equation, unforced
// and forced, with runs of even and odd length (N = 64: kmax + 1 = 22 and kmax = 21 rows; N = 34: 12 and 11), on
// one thread and two.
template <class Body>
void for_each_damped_flow(const std::string& equation, Body body) {
    for (const auto& [n, threads] : {std::pair{64, 1}, std::pair{34, 2}}) {
        for (const auto forcing : {eci::spectral::forcing_kind::none, eci::spectral::forcing_kind::deterministic}) {
            flow_params p = params(equation, n);
            p.nu = 1e-3, p.drag = 0.05, p.threads = threads;
            p.forcing = forcing, p.forcing_k = 5.0;
            flow2d m(p);
            body(m, n, forcing != eci::spectral::forcing_kind::none,
                 "N = " + std::to_string(n) + ", forced " + std::to_string(int(forcing)));
        }
    }
}

// The fused column pass's loops over modes in AVX2 (the default where the processor has it) give the bits of the
// baseline loops, for each equation in its form and in the advective one, in each case of for_each_damped_flow; so
// do a right-hand side that records the budget's rates, its dq/dt and its six sums (each summed in mode order).
TEST_P(Equation, VectorPassesRoundLikeTheBaselineLoops) {
    for_each_damped_flow(GetParam(), [](flow2d& m, int, bool forced, const std::string& flow) {
        const state q = m.random_field(6.0, 0.5, 8);
        for (const auto form : {m.form(), eci::spectral::nonlinear_form::advective}) {
            m.set_form(form);
            state base, wide, recorded, recorded_wide;
            m.set_vector_passes(false);
            m(q, base, 0.0);
            const auto rates = m.rates(q);  // (a recording right-hand side)
            m(q, recorded, 0.0);
            m.set_vector_passes(true);
            m(q, wide, 0.0);
            const auto rates_wide = m.rates(q);
            const auto same = [](const state& a, const state& b) {
                return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(cplx)) == 0;
            };
            const std::string where = flow + ", form " + std::to_string(int(form));
            EXPECT_TRUE(same(base, wide)) << where;
            EXPECT_TRUE(same(base, recorded)) << where;
            EXPECT_GT(max_abs(base), 0.0) << where;
            const double r[6] = {rates.energy_injection, rates.energy_dissipation, rates.enstrophy_injection,
                                 rates.enstrophy_dissipation, rates.energy_transfer, rates.enstrophy_transfer};
            const double w[6] = {rates_wide.energy_injection, rates_wide.energy_dissipation,
                                 rates_wide.enstrophy_injection, rates_wide.enstrophy_dissipation,
                                 rates_wide.energy_transfer, rates_wide.enstrophy_transfer};
            EXPECT_EQ(std::memcmp(r, w, sizeof r), 0) << where;
            EXPECT_NE(r[1], 0.0) << where;
            EXPECT_NE(r[4], 0.0) << where;
            if (forced) {
                EXPECT_NE(r[0], 0.0) << where;
            }
        }
    });
}

// E and Z at once (what a run's monitor takes at every step) are the bits of energy() and enstrophy(), and the
// monitor records them so.
TEST_P(Equation, InvariantsAtOnceAreEachInvariantsBits) {
    for_each_damped_flow(GetParam(), [](flow2d& m, int, bool, const std::string& flow) {
        const state q = m.random_field(6.0, 0.5, 8);
        double v[2];
        m.invariant_values(q, v);
        const double e = m.energy(q), z = m.enstrophy(q);
        EXPECT_EQ(std::memcmp(&v[0], &e, sizeof e), 0) << flow;
        EXPECT_EQ(std::memcmp(&v[1], &z, sizeof z), 0) << flow;
        EXPECT_GT(e, 0.0) << flow;
        eci::invariant_monitor<flow2d> monitor(m);
        monitor.record(q);
        EXPECT_EQ(std::memcmp(monitor.values().data(), v, sizeof v), 0) << flow;
    });
}

// The sums over modes (E, Z, both at once, palinstrophy) add in row order, so a field stored by columns (the fused
// column pass) gives the bits of the same field stored by rows; at N = 64 and 512 a block of 16 rows, at N = 2048
// (683 columns) the stack block holds 11 rows; on one thread and two.
TEST_P(Equation, SumsOverModesAreTheSameBitsInEitherLayout) {
    for (const auto& [n, threads] :
         {std::pair{64, 1}, std::pair{64, 2}, std::pair{512, 1}, std::pair{512, 2}, std::pair{2048, 2},
          std::pair{3200, 2}}) {  // (N = 3200: a state of 36 MB, summed in blocks of 64 rows)
        flow_params p = params(GetParam(), n);
        p.threads = threads;
        p.pruned_transforms = false;
        flow2d rows(p);
        p.pruned_transforms = true;
        flow2d cols(p);
        ASSERT_FALSE(rows.by_columns());
        ASSERT_TRUE(cols.by_columns());
        const state qr = rows.random_field(6.0, 0.5, 8), qc = cols.random_field(6.0, 0.5, 8);
        ASSERT_EQ(rows.to_half_plane(qr), cols.to_half_plane(qc)) << "the same field in either layout";
        double vr[2], vc[2];
        rows.invariant_values(qr, vr);
        cols.invariant_values(qc, vc);
        const double a[] = {rows.energy(qr), rows.enstrophy(qr), rows.palinstrophy(qr), vr[0], vr[1]};
        const double b[] = {cols.energy(qc), cols.enstrophy(qc), cols.palinstrophy(qc), vc[0], vc[1]};
        for (int j = 0; j < 5; ++j) {
            EXPECT_GT(a[j], 0.0);
            EXPECT_EQ(std::memcmp(&a[j], &b[j], sizeof a[j]), 0)
                << "sum " << j << ": " << a[j] << " vs " << b[j] << ", N = " << n << ", " << threads << " thread(s)";
        }
    }
}

// The sums over modes are right to a few roundings, not to the ~sqrt(n) eps of a plain sum (65 eps for E at N = 256,
// 200 at N = 1024), which a run's summary would report as the drift of an invariant that the conservative methods
// keep: against error-free sums of the same terms (the declared weights times |q_k|^2, sorted, compensated), within
// 8 eps: each term rounds a few times (weights, |a|, |q|^2) in either form, by at most ~4 eps relative together.
TEST_P(Equation, SumsOverModesAreRightToRoundOff) {
    for (const auto& [n, threads] : {std::pair{256, 1}, std::pair{256, 2}, std::pair{512, 1}}) {
        flow_params p = params(GetParam(), n);
        p.threads = threads;
        flow2d m(p);
        const state q = m.random_field(n / 16.0, 0.5, 3);
        const auto w = m.quadratic_invariant_weights();
        const auto exact = [&](auto weight) {
            std::vector<double> t(q.size());
            for (std::size_t i = 0; i < q.size(); ++i) t[i] = weight(i) * std::norm(q[i]);
            std::sort(t.begin(), t.end());
            eci::compensated_sum s;
            for (double v : t) s.add(v);
            return s.value();
        };
        double v[2];
        m.invariant_values(q, v);
        const double e = exact([&](std::size_t i) { return w[0][i]; });
        const double z = exact([&](std::size_t i) { return w[1][i]; });
        const double pal = exact([&](std::size_t i) {
            const double kx = m.kx(i), ky = m.ky(i);
            return w[1][i] * (kx * kx + ky * ky);
        });
        const double eps = std::numeric_limits<double>::epsilon();
        const std::pair<double, double> sums[] = {{m.energy(q), e}, {v[0], e}, {m.enstrophy(q), z}, {v[1], z},
                                                  {m.palinstrophy(q), pal}};
        for (const auto& [got, want] : sums)
            EXPECT_LE(std::abs(got - want), 8.0 * eps * want)
                << got << " vs " << want << " (" << (got - want) / want / eps << " eps), N = " << n << ", " << threads
                << " thread(s)";
    }
}

// Shu and Osher's third-order tableau: a stage (the third) that sums two earlier ones.
inline constexpr eci::butcher_tableau<3> ssp_rk3{
    3, {{{0.0, 0.0, 0.0}, {1.0, 0.0, 0.0}, {0.25, 0.25, 0.0}}}, {1.0 / 6.0, 1.0 / 6.0, 2.0 / 3.0}, {0.0, 1.0, 0.5}};

// The flow seen through a system of one's own that only evaluates: the engines then take the stages one at a time.
struct one_at_a_time {
    flow2d* m;
    void operator()(const state& x, state& k, double t) const { (*m)(x, k, t); }
    int range_threads() const { return m->range_threads(); }
    template <class Body>
    void for_ranges(std::size_t n, Body body) const {
        m->for_ranges(n, body);
    }
};

// A step's stages run by the flow as one chain of column passes (flow2d::run_stages, which the Runge-Kutta engines
// take where the flow offers it) give the bits of the stages one at a time: the new state, the stages' recorded
// budget rates and the evaluations counted, for each equation in both forms, forced and not, vector passes on and
// off, in each case of for_each_damped_flow, for conventional and conservative engines of one to four stages and a
// tableau whose stage sums two earlier ones.
TEST_P(Equation, StagesInOneChainRoundLikeTheStagesOneAtATime) {
    for_each_damped_flow(GetParam(), [](flow2d& m, int n, bool, const std::string& flow) {
        const one_at_a_time plain{&m};
        const state q0 = m.random_field(6.0, 0.5, 8);
        const double dt = 0.5 * (2.0 * std::numbers::pi / n) / m.max_velocity(q0);
        for (const auto form : {m.form(), eci::spectral::nonlinear_form::advective}) {
            for (const bool vector : {true, false}) {
                m.set_form(form);
                m.set_vector_passes(vector);
                const std::string where =
                    flow + ", form " + std::to_string(int(form)) + ", vector " + std::to_string(vector);
                const auto compare = [&](auto stepper, const char* name) {
                    if constexpr (requires { stepper.set_quadratic_invariants(m.quadratic_invariant_weights()); })
                        stepper.set_quadratic_invariants(m.quadratic_invariant_weights());
                    auto other = stepper;
                    // one recorded step each way from q0, then two more unrecorded
                    state a = q0, b = q0;
                    m.start_recording();
                    ASSERT_TRUE(bool(stepper.step(m, a, 0.0, dt))) << name << ", " << where;
                    const std::vector<eci::spectral::flow_rates> ra(m.recorded().begin(), m.recorded().end());
                    m.start_recording();
                    ASSERT_TRUE(bool(other.step(plain, b, 0.0, dt))) << name << ", " << where;
                    const std::vector<eci::spectral::flow_rates> rb(m.recorded().begin(), m.recorded().end());
                    m.stop_recording();
                    for (int i = 0; i < 2; ++i) {
                        stepper.step(m, a, 0.0, dt);
                        other.step(plain, b, 0.0, dt);
                    }
                    EXPECT_EQ(std::memcmp(a.data(), b.data(), a.size() * sizeof(cplx)), 0) << name << ", " << where;
                    EXPECT_NE(std::memcmp(a.data(), q0.data(), a.size() * sizeof(cplx)), 0) << name;
                    ASSERT_EQ(ra.size(), rb.size()) << name << ", " << where;
                    EXPECT_EQ(ra.size(), std::remove_cvref_t<decltype(stepper)>::tableau.stages) << name;
                    EXPECT_EQ(std::memcmp(ra.data(), rb.data(), ra.size() * sizeof(ra[0])), 0)
                        << name << ", " << where;
                };
                compare(eci::rk4<state>{}, "rk4");
                compare(eci::c_rk4<state>{}, "c-rk4");
                compare(eci::c_pc<state>{}, "c-pc");
                compare(eci::euler<state>{}, "euler");
                compare(eci::explicit_rk<ssp_rk3, state>{}, "ssp-rk3");
            }
        }
        // the chain is taken (a serial grid has the column pass) and counted as the stages it evaluates
        state k[4], y;
        const double a[16] = {};
        EXPECT_TRUE(m.run_stages(4, a, dt, q0, k, y, 0.0));
        std::uint64_t evaluations = 0;
        const eci::detail::counting_system<flow2d> counted(m, evaluations);
        state x = q0;
        eci::rk4<state>{}.step(counted, x, 0.0, dt);
        EXPECT_EQ(evaluations, 4u);
    });
}

// Inviscid and unforced, C-RK4 and C-PC keep E and Z to round-off per step (a random walk: k eps sqrt(steps) with
// k = 8 for the per-step error of a sum of n^2/2 terms), while RK4 at the same step drifts far beyond it.
TEST_P(Equation, ConservativeMethodsKeepBothInvariantsRk4Drifts) {
    flow2d m(params(GetParam(), 32));
    const state q0 = m.random_field(4.0, 0.5, 11);
    const double dt = 0.5 * (2.0 * std::numbers::pi / 32) / m.max_velocity(q0);
    const int steps = 400;
    const double e0 = m.energy(q0), z0 = m.enstrophy(q0);
    auto drift = [&](auto stepper) {
        state q = q0;
        eci::ns2d_budget b;
        eci::run_stats s;
        double de = 0.0, dz = 0.0;
        for (int i = 0; i < steps; ++i) {
            eci::ns2d_step(stepper, m, q, i * dt, dt, b, s);
            de = std::max(de, std::abs(m.energy(q) - e0) / e0);
            dz = std::max(dz, std::abs(m.enstrophy(q) - z0) / z0);
        }
        return std::pair{de, dz};
    };
    const double bound = 8.0 * eps * std::sqrt(double(steps));
    for (auto [de, dz] : {drift(eci::c_rk4<state>{}), drift(eci::c_pc<state>{})}) {
        EXPECT_LE(de, bound);
        EXPECT_LE(dz, bound);
    }
    const auto [de, dz] = drift(eci::rk4<state>{});
    EXPECT_GT(std::max(de, dz), 100.0 * bound) << "RK4 drifts no more than the bound: the test cannot fail";
}

// With every linear term and stochastic forcing, E and Z change over each step by exactly the injection minus the
// dissipation integrated with the stepper's stages and weights (errata item 9): the residual is the round-off of the
// sums, k eps (E + the step's terms) with k = 64.
TEST_P(Equation, BudgetClosesPerStep) {
    flow_params p = params(GetParam(), 32);
    p.nu = 1e-2;
    p.hyper_nu = 1e-7;
    p.hypo_nu = 0.05;
    p.drag = 0.1;
    p.forcing = eci::ns2d_forcing::stochastic;
    p.forcing_k = 3.0;
    p.injection_rate = 0.3;
    flow2d m(p);
    state q = m.random_field(4.0, 0.5, 5);
    const double dt = 0.4 * (2.0 * std::numbers::pi / 32) / m.max_velocity(q);
    eci::c_rk4<state> st;
    eci::run_stats s;
    double worst_e = 0.0, worst_z = 0.0, moved = 0.0;
    for (int i = 0; i < 100; ++i) {
        const double e0 = m.energy(q), z0 = m.enstrophy(q);
        eci::ns2d_budget b;
        eci::ns2d_step(st, m, q, i * dt, dt, b, s);
        const double de = b.energy_injection - b.energy_dissipation, dz = b.enstrophy_injection - b.enstrophy_dissipation;
        worst_e = std::max(worst_e, std::abs(m.energy(q) - e0 - de) /
                                        (e0 + b.energy_injection + b.energy_dissipation));
        worst_z = std::max(worst_z, std::abs(m.enstrophy(q) - z0 - dz) /
                                        (z0 + b.enstrophy_injection + b.enstrophy_dissipation));
        moved = std::max(moved, std::abs(de) / e0);
    }
    EXPECT_LE(worst_e, 64.0 * eps);
    EXPECT_LE(worst_z, 64.0 * eps);
    EXPECT_GT(moved, 1e-6) << "the terms do nothing: the budget is vacuous";
    EXPECT_EQ(s.step_reductions, 0u);
}

// The step hooks weigh the stages with whatever tableau runs: the conservative engine over Fehlberg's 13 stages
// closes the budget per step to the same round-off as C-RK4's (k eps (E + the step's terms), k = 64), which a
// recorder sized for fewer stages could not.
TEST_P(Equation, BudgetClosesPerStepForThirteenStages) {
    flow_params p = params(GetParam(), 32);
    p.nu = 1e-2;
    p.drag = 0.1;
    p.forcing = eci::ns2d_forcing::stochastic;
    p.forcing_k = 3.0;
    p.injection_rate = 0.3;
    flow2d m(p);
    state q = m.random_field(4.0, 0.5, 5);
    const double dt = 0.4 * (2.0 * std::numbers::pi / 32) / m.max_velocity(q);
    eci::conservative_rk<eci::tableaus::fehlberg_78, state> st;
    static_assert(decltype(st)::tableau.stages == 13);
    eci::run_stats s;
    double worst_e = 0.0, worst_z = 0.0, moved = 0.0;
    for (int i = 0; i < 20; ++i) {
        const double e0 = m.energy(q), z0 = m.enstrophy(q);
        eci::ns2d_budget b;
        eci::ns2d_step(st, m, q, i * dt, dt, b, s);
        const double de = b.energy_injection - b.energy_dissipation, dz = b.enstrophy_injection - b.enstrophy_dissipation;
        worst_e = std::max(worst_e, std::abs(m.energy(q) - e0 - de) / (e0 + b.energy_injection + b.energy_dissipation));
        worst_z = std::max(worst_z, std::abs(m.enstrophy(q) - z0 - dz) /
                                        (z0 + b.enstrophy_injection + b.enstrophy_dissipation));
        moved = std::max(moved, std::abs(de) / e0);
    }
    EXPECT_LE(worst_e, 64.0 * eps);
    EXPECT_LE(worst_z, 64.0 * eps);
    EXPECT_GT(moved, 1e-6) << "the terms do nothing: the budget is vacuous";
    EXPECT_EQ(s.steps, 20u);
    EXPECT_EQ(s.rhs_evals, 13u * (s.steps + 2u * s.step_reductions));  // 13 per attempt, stages all weighed
}

// eci::solve runs a flow as a loop of ns2d_step does (the forcing drawn per step, the budget from the step hooks),
// bit for bit, also continued from a later step (first_step), and resolves its methods through the registry.
TEST_P(Equation, SolveRunsTheStepsOfNs2dStep) {
    flow_params p = params(GetParam(), 32);
    p.nu = 1e-3;
    p.forcing = eci::ns2d_forcing::stochastic;
    flow2d a(p), c(p);
    const state q0 = a.random_field(4.0, 0.5, 9);
    const double dt = 1e-3;
    const int steps = 12;
    state q = q0;
    eci::c_rk4<state> st;
    eci::ns2d_budget b;
    eci::run_stats s;
    std::vector<double> injected;  // the budget after every step
    for (int i = 0; i < steps; ++i) {
        eci::ns2d_step(st, a, q, i * dt, dt, b, s);
        injected.push_back(b.energy_injection);
    }
    struct sink_t {
        flow2d& m;
        std::vector<double>& seen;
        double total = 0.0;
        std::vector<std::uint64_t> outputs;
        void output(const state&, const eci::output_point& pt) { outputs.push_back(pt.index); }
        void after_step(const state&, const eci::output_point& pt) {
            total += m.step_budget().energy_injection;
            seen.push_back(total);
            EXPECT_EQ(pt.stats->steps, pt.index - 4);
        }
    };
    std::vector<double> seen;
    state r = q0;
    eci::run_config cfg;
    cfg.dt = dt;
    cfg.steps = 4;
    const eci::solve_report first = eci::solve<flow2d>(c, r, "c-rk4", cfg, eci::no_sink{});
    ASSERT_TRUE(first.completed());
    EXPECT_EQ(first.stats.rhs_evals, 4u * 4u);
    cfg.first_step = 4;  // continue the grid i dt from step 4: outputs every 3 steps on the grid's numbering
    cfg.steps = steps - 4;
    cfg.every = 3;
    double total0 = 0.0;
    for (int i = 0; i < 4; ++i) total0 = injected[i];
    sink_t sink{c, seen, total0, {}};
    const eci::solve_report rest = eci::solve<flow2d>(c, r, "c-rk4", cfg, sink);
    ASSERT_TRUE(rest.completed());
    EXPECT_EQ(rest.t, double(steps) * dt);
    EXPECT_EQ(sink.outputs, (std::vector<std::uint64_t>{4, 6, 9, 12}));
    ASSERT_EQ(q.size(), r.size());
    for (std::size_t i = 0; i < q.size(); ++i) ASSERT_EQ(q[i], r[i]) << "mode " << i;
    ASSERT_EQ(seen.size(), std::size_t(steps - 4));
    for (int i = 4; i < steps; ++i) EXPECT_EQ(seen[std::size_t(i - 4)], injected[std::size_t(i)]) << "step " << i + 1;
    // The flows' methods: the registry's (its fixed-step tableaux, so a tableau added there joins them), the
    // conservative ones first and higher orders first, C-RK4 the default; the paper's and the classical ones among them.
    const std::vector<std::string>& names = eci::ns2d_methods();
    const std::vector<eci::method_info> offered = eci::methods_for<eci::navier_stokes_2d>();
    ASSERT_EQ(names.size(), offered.size());
    ASSERT_FALSE(names.empty());
    EXPECT_EQ(names.front(), "c-rk4");
    const auto info = [&](const std::string& n) {
        const auto it = std::ranges::find_if(offered, [&](const eci::method_info& m) { return m.name == n; });
        EXPECT_NE(it, offered.end()) << n;
        return it == offered.end() ? eci::method_info{} : *it;
    };
    for (std::size_t i = 1; i < names.size(); ++i) {
        const eci::method_info a = info(names[i - 1]), b = info(names[i]);
        EXPECT_TRUE(a.conservative > b.conservative || (a.conservative == b.conservative && a.order >= b.order))
            << names[i - 1] << " before " << names[i];
    }
    for (const char* m : {"c-rk4", "c-pc", "c-rk2", "rk4", "pc", "rk2", "euler"})
        EXPECT_NE(std::ranges::find(names, m), names.end()) << m;
    EXPECT_THROW(eci::solve<flow2d>(c, r, "dp54", cfg, eci::no_sink{}), std::invalid_argument);
}

// A run continued from its state and generator on a fresh model repeats the uninterrupted run bit for bit.
TEST_P(Equation, RestartFromStateAndGeneratorIsBitIdentical) {
    flow_params p = params(GetParam(), 32);
    p.nu = 1e-3;
    p.forcing = eci::ns2d_forcing::stochastic;
    flow2d a(p);
    state q = a.random_field(4.0, 0.5, 9);
    const double dt = 1e-3;
    eci::c_rk4<state> st;
    eci::ns2d_budget b;
    eci::run_stats s;
    for (int i = 0; i < 10; ++i) eci::ns2d_step(st, a, q, i * dt, dt, b, s);
    state r = q;
    const std::uint64_t rng = a.rng_state();
    for (int i = 10; i < 20; ++i) eci::ns2d_step(st, a, q, i * dt, dt, b, s);
    flow2d c(p);
    c.set_rng_state(rng);
    eci::c_rk4<state> st2;
    for (int i = 10; i < 20; ++i) eci::ns2d_step(st2, c, r, i * dt, dt, b, s);
    ASSERT_EQ(q.size(), r.size());
    for (std::size_t i = 0; i < q.size(); ++i) ASSERT_EQ(q[i], r[i]) << "mode " << i;
}

// The spectra sum to the invariants, and the fluxes of the nonlinear term vanish beyond the last shell (the transfer
// conserves both), to the round-off of the sums.
TEST_P(Equation, SpectraSumToInvariantsAndFluxesClose) {
    flow2d m(params(GetParam(), 64));
    const state q = m.random_field(6.0, 0.5, 4);
    double se = 0.0, sz = 0.0;
    for (double v : m.energy_spectrum(q)) se += v;
    for (double v : m.enstrophy_spectrum(q)) sz += v;
    EXPECT_NEAR(se, m.energy(q), 64.0 * eps * m.energy(q));
    EXPECT_NEAR(sz, m.enstrophy(q), 64.0 * eps * m.enstrophy(q));
    const auto f = m.fluxes(q);
    double pe = 0.0, pz = 0.0;
    for (double v : f.energy) pe = std::max(pe, std::abs(v));
    for (double v : f.enstrophy) pz = std::max(pz, std::abs(v));
    EXPECT_GT(pe, 0.0);
    EXPECT_LE(std::abs(f.energy.back()), 1e3 * eps * pe);
    EXPECT_LE(std::abs(f.enstrophy.back()), 1e3 * eps * pz);
}

// Navier-Stokes in Basdevant's form continues the advective form's run (the form older versions used) to round-off:
// 100 RK4 steps at CFL 0.5 from the same random field at N = 64 differ by at most 1e3 eps max|omega| (measured:
// ~1e-14 relative; the difference grows with the flow's sensitivity, not with the step count alone).
TEST(SpectralNavierStokes, BasdevantContinuesTheAdvectiveFormsRun) {
    eci::spectral::equation advective = eci::spectral::navier_stokes_2d_equation;
    advective.form = eci::spectral::nonlinear_form::advective;
    const flow_params p = params("navier-stokes-2d", 64);
    flow2d a(p), b(p, advective);
    EXPECT_EQ(a.transforms_per_rhs(), 4);
    EXPECT_EQ(b.transforms_per_rhs(), 5);
    state qa = a.random_field(8.0, 0.5, 1), qb = qa;
    const double dt = 0.5 * (2.0 * std::numbers::pi / 64) / a.max_velocity(qa);
    eci::rk4<state> sa, sb;
    eci::ns2d_budget bud;
    eci::run_stats s;
    for (int i = 0; i < 100; ++i) {
        eci::ns2d_step(sa, a, qa, i * dt, dt, bud, s);
        eci::ns2d_step(sb, b, qb, i * dt, dt, bud, s);
    }
    double diff = 0.0;
    for (std::size_t i = 0; i < qa.size(); ++i) diff = std::max(diff, std::abs(qa[i] - qb[i]));
    EXPECT_LE(diff, 1e3 * eps * max_abs(qb));
    EXPECT_GT(diff, 0.0) << "the two forms are the same code: the test compares nothing";
}

// Any superposition of Rossby waves of one |k| is an exact nonlinear solution of Charney-Hasegawa-Mima (q is a
// multiple of psi, so J(psi, q) = 0) with omega = -beta k_x / (k^2 + F): the right-hand side is i c(k) q_k with
// c = -omega, to round-off, at any amplitude. The round-off scale is the linear term's plus the nonlinear products'
// (each ~ K^4 A^2 / (K^2 + F)^2 before cancelling), times 64 eps.
TEST(SpectralCharneyHasegawaMima, RossbyWavesOfOneWavenumberAreExactWithTheirDispersion) {
    flow_params p = params("charney-hasegawa-mima", 32);
    flow2d m(p);
    // |k|^2 = 25: (3, 4), (4, 3), (5, 0), (0, 5), (3, -4), (4, -3), with random complex amplitudes
    const int modes[][2] = {{3, 4}, {4, 3}, {5, 0}, {0, 5}, {3, -4}, {4, -3}};
    const double K2 = 25.0, F = p.deformation;
    std::uint64_t seed = 42;
    for (double amplitude : {1e-3, 1.0, 1e3}) {
        state q(m.size());
        for (const auto& k : modes)
            q[m.index(k[0], k[1])] =
                amplitude * cplx(eci::spectral::uniform(seed) - 0.5, eci::spectral::uniform(seed) - 0.5);
        // the k_x = 0 mode (0, 5) and its conjugate (0, -5) are both stored: make the field real
        m.make_hermitian(q);
        state dq;
        m(q, dq, 0.0);
        const double scale = 64.0 * eps *
                             (p.beta * 5.0 / (K2 + F) * amplitude + K2 * K2 * amplitude * amplitude / ((K2 + F) * (K2 + F)));
        double worst = 0.0, moved = 0.0;
        for (std::size_t i = 0; i < m.size(); ++i) {
            const double kx = m.kx(i), omega = -p.beta * kx / (K2 + F);
            const cplx expected = cplx(0.0, -omega) * q[i];
            worst = std::max(worst, std::abs(dq[i] - expected));
            moved = std::max(moved, std::abs(expected));
        }
        EXPECT_LE(worst, scale) << "amplitude " << amplitude;
        EXPECT_GT(moved, 100.0 * scale) << "amplitude " << amplitude;
    }
}

// With the waves' frequencies, RK4 steps each mode by its stability polynomial R(i c dt): after n steps the state is
// R^n q0 to the round-off of n steps (k eps n |q0| with k = 16; the rounding of each step's phase adds up).
TEST(SpectralCharneyHasegawaMima, RossbyWavesStepByTheStabilityPolynomial) {
    const flow_params p = params("charney-hasegawa-mima", 32);
    flow2d m(p);
    state q0(m.size());
    q0[m.index(3, 4)] = cplx(0.3, -0.2);
    q0[m.index(3, -4)] = 0.25;
    q0[m.index(4, 3)] = cplx(-0.1, 0.4);
    state q = q0;
    const double dt = 0.05;
    const int steps = 200;
    eci::rk4<state> st;
    eci::ns2d_budget b;
    eci::run_stats s;
    for (int i = 0; i < steps; ++i) eci::ns2d_step(st, m, q, i * dt, dt, b, s);
    double worst = 0.0;
    for (std::size_t i = 0; i < m.size(); ++i) {
        const double c = p.beta * m.kx(i) / (25.0 + p.deformation);
        const cplx z(0.0, c * dt);
        const cplx R = 1.0 + z + z * z / 2.0 + z * z * z / 6.0 + z * z * z * z / 24.0;
        worst = std::max(worst, std::abs(q[i] - std::pow(R, steps) * q0[i]));
    }
    EXPECT_LE(worst, 16.0 * eps * steps * max_abs(q0));
}

TEST(SpectralEquations, UnknownNamesAndForeignParametersAreRefused) {
    try {
        eci::spectral::find_equation("navier-stokes-3d");
        FAIL();
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("charney-hasegawa-mima"), std::string::npos) << e.what();
    }
    flow_params p = params("navier-stokes-2d", 16);
    p.beta = 1.0;
    EXPECT_THROW(flow2d{p}, std::invalid_argument);
    p = params("charney-hasegawa-mima", 16);
    p.deformation = -1.0;
    EXPECT_THROW(flow2d{p}, std::invalid_argument);
    p = params("surface-qg", 16);
    p.hypo_p = 0;
    EXPECT_THROW(flow2d{p}, std::invalid_argument);
}

}  // namespace
