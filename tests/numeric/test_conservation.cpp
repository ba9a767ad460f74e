// Conservation over 10^5 steps: the conservative methods keep energy and enstrophy to round-off on the three-wave
// model and on random real and complex n-wave systems; the conventional methods, on the same runs, do not.
#include <gtest/gtest.h>

#include <complex>
#include <cstdio>
#include <string>

#include <eci/models/n_wave.hpp>
#include <eci/models/three_wave.hpp>

#include "numeric/support.hpp"

namespace {

using namespace eci::test;

constexpr std::uint64_t steps = 100000;

// Each conservative step sets psi_k^2 to the value that keeps every invariant sum_k w_k psi_k^2 exactly; what
// remains is the rounding of the radicand, of the square root and of the invariant's own sum, a relative error of
// a few eps per step with no preferred sign. Over n steps these add up as a random walk, c eps sqrt(n) with c of
// order 1 (measured: at most 0.4 eps sqrt(n) on every run below); k = 4 leaves room for the spread of the walk's
// maximum and for other compilers' rounding (FMA contraction), and is still 10^4 times below the drift of RK4.
constexpr double k_roundoff = 4.0;
const double tolerance = k_roundoff * eps * std::sqrt(double(steps));

// The setups: the Figure 2 initial condition (a mode starting at zero) and random systems of 45 modes, each mode
// in about 10 triads, with amplitudes O(1); the time steps are of the size where C-PC needs some step reductions.
struct three_wave_setup {
    static constexpr const char* name = "three-wave";
    static constexpr double dt = 0.01;
    eci::three_wave model{};
    eci::three_wave::state_type x0{std::sqrt(1.5), 0.0, std::sqrt(1.5)};
};
template <class T, std::uint64_t Seed>
struct n_wave_setup {
    static constexpr const char* name = eci::n_wave<T>::is_complex ? "complex n-wave" : "real n-wave";
    static constexpr double dt = 0.005;
    eci::n_wave<T> model = eci::n_wave<T>::random(45, 10, Seed);
    typename eci::n_wave<T>::state_type x0 = model.random_state(Seed + 1);
};
using real_n_wave_setup = n_wave_setup<double, 7>;
using complex_n_wave_setup = n_wave_setup<std::complex<double>, 11>;

template <class Method, class Setup>
drift_result run() {
    const Setup s;
    const drift_result r = measure_drift<Method>(s.model, s.x0, Setup::dt, steps);
    std::printf("  %-15s %-8s 10^5 steps of %g: max |dE|/E %.2e, max |dZ|/Z %.2e (%.2f eps sqrt(n)), %llu reductions\n",
                Setup::name, Method::name, Setup::dt, r.energy, r.enstrophy, r.worst() / (eps * std::sqrt(double(steps))),
                static_cast<unsigned long long>(r.stats.step_reductions));
    return r;
}

template <class Method>
class ConservativeMethodKeepsInvariants : public ::testing::Test {};


TYPED_TEST_SUITE(ConservativeMethodKeepsInvariants, registry_conservative_methods_on_any_state, method_names);

template <class Method, class Setup>
void expect_conserved() {
    const drift_result r = run<Method, Setup>();
    EXPECT_EQ(r.stats.steps, steps);
    EXPECT_LE(r.energy, tolerance) << Method::name << " on " << Setup::name;
    EXPECT_LE(r.enstrophy, tolerance) << Method::name << " on " << Setup::name;
}

TYPED_TEST(ConservativeMethodKeepsInvariants, OnThreeWaveFromFigure2) { expect_conserved<TypeParam, three_wave_setup>(); }
TYPED_TEST(ConservativeMethodKeepsInvariants, OnRandomRealNWave) { expect_conserved<TypeParam, real_n_wave_setup>(); }
TYPED_TEST(ConservativeMethodKeepsInvariants, OnRandomComplexNWave) {
    expect_conserved<TypeParam, complex_n_wave_setup>();
}

// The same runs with the conventional methods: the tolerance above is one they cannot meet, so it can fail.
// "Far above" is taken as 1000 times; the weakest, RK4, is measured at about 2*10^4 (n-wave) to 10^5 times.
template <class Setup>
void expect_drift_far_above_tolerance() {
    const double far = 1000.0 * tolerance;
    EXPECT_GT((run<euler_m, Setup>().worst()), far);
    EXPECT_GT((run<pc_m, Setup>().worst()), far);
    EXPECT_GT((run<rk2_m, Setup>().worst()), far);
    EXPECT_GT((run<rk4_m, Setup>().worst()), far);
}

TEST(ConventionalMethodsDrift, OnThreeWaveFromFigure2) { expect_drift_far_above_tolerance<three_wave_setup>(); }
TEST(ConventionalMethodsDrift, OnRandomRealNWave) { expect_drift_far_above_tolerance<real_n_wave_setup>(); }
TEST(ConventionalMethodsDrift, OnRandomComplexNWave) { expect_drift_far_above_tolerance<complex_n_wave_setup>(); }

// A state near the top of the range: at |psi| ~ 2^400 (1e120) a quadratic right-hand side has |S| ~ 2^800, and the
// radicand's rate sum_j 2 b_j Y_j S_j ~ 2^1200 overflows though psi^2, the update and the invariants are finite.
// The engine then forms that radicand with dt inside the rate (conservative_rk.hpp, finite_radicand): the run
// equals the same run 2^400 times smaller (a psi(a t) solves a quadratic system whenever psi does; the time step
// scaled by 2^-400) scaled back, to round-off, with the invariants exact. C-RK4 and C-RK2 failed there ("step
// failed ... even with the step halved 40 times") where RK4 and C-PC ran. Three-wave takes the paper's update (3
// unknowns), the n-wave systems (45 modes) the conditioned one.
template <class Method, class Setup>
void expect_the_scaled_run() {
    constexpr double a = 0x1p400;
    constexpr std::uint64_t n = 100;
    const Setup s;
    auto small = s.x0, big = s.x0;
    for (auto& v : big) v *= a;
    typename Method::template stepper<decltype(big)> one, two;
    const eci::run_stats rs = eci::integrate_to(one, s.model, small, 0.0, double(n) * Setup::dt, Setup::dt);
    const eci::run_stats rb = eci::integrate_to(two, s.model, big, 0.0, double(n) * Setup::dt / a, Setup::dt / a);
    EXPECT_EQ(rb.steps, n);
    EXPECT_EQ(rb.step_reductions, rs.step_reductions);
    double scale = 0.0, off = 0.0;
    for (std::size_t i = 0; i < small.size(); ++i) {
        scale = std::max(scale, std::abs(small[i]));
        off = std::max(off, std::abs(big[i] / a - small[i]));
    }
    // Each step rounds dt S_j where the unscaled run rounds the sum, a relative difference of a few eps per step
    // in the radicand, carried on by the flow: k eps sqrt(n) with k = 8 (measured: at most 1.01 on these runs).
    EXPECT_LE(off, 8.0 * eps * std::sqrt(double(n)) * scale) << Method::name << " on " << Setup::name;
    std::printf("  %-6s %-15s scaled by 2^400: max |difference| %.2f eps sqrt(n) of max |psi|\n", Method::name,
                Setup::name, off / (eps * std::sqrt(double(n)) * scale));
    const auto weights = eci::quadratic_weights_of(s.model, s.x0.size());
    for (const auto& w : weights)
        EXPECT_LE(relative_change(weighted_square_sum(big, w), weighted_square_sum(s.x0, w) * a * a),
                  8.0 * eps * std::sqrt(double(n)))
            << Method::name << " on " << Setup::name;  // (the bound of every conservative run here)
}

template <class Method>
class ConservativeRkNearTheTopOfTheRange : public ::testing::Test {};
using rk_tableaus = ::testing::Types<c_pc_m, c_rk2_m, c_rk4_m>;
TYPED_TEST_SUITE(ConservativeRkNearTheTopOfTheRange, rk_tableaus, method_names);
TYPED_TEST(ConservativeRkNearTheTopOfTheRange, RunsAsTheScaledRun) {
    expect_the_scaled_run<TypeParam, three_wave_setup>();
    expect_the_scaled_run<TypeParam, real_n_wave_setup>();
    expect_the_scaled_run<TypeParam, complex_n_wave_setup>();
}

}  // namespace
