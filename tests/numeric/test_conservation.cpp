// Conservation over 10^5 steps: the conservative methods keep energy and enstrophy to round-off on the three-wave
// model and on random real and complex n-wave systems; the conventional methods, on the same runs, do not.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdio>
#include <string>
#include <type_traits>

#include <eci/models/n_wave.hpp>
#include <eci/models/three_wave.hpp>

#include "numeric/support.hpp"
#include "unit/solve_tests.hpp"

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

// The range. A quadratic system is free of scale: if psi(t) solves it, so does a psi(a t). With a = 2^k, the state
// times a and the step over a, each product a method forms is the unscaled run's times a power of two, exactly, so
// the run is the unscaled run times a, bit for bit, as long as no intermediate value leaves the range of double.
// The conservative steppers' rate of psi^2, sum_j 2 b_j Y_j S_j, is cubic in the scale: at |psi| ~ 2^400 it
// overflowed (C-RK4 and C-RK2 failed "even with the step halved 40 times" where RK4 ran), at 2^-400 it underflowed
// to zero and C-RK2, C-RK4, C-PC-compensated and the conservative pairs left the state where it was, silently,
// while RK4 moved it; the relaxation methods' production sum_i b_i B(Y_i - x, S_i) failed at both ends, and the
// multiple-relaxation and projection Newton's tolerance |x| |grad I| overflowed (1e-10 off at 2^400). Each is now
// formed with the step's power of two inside (detail::split_step): the same bits as before wherever the old form
// was representable, and exactly the scaled run at both ends. Each method the model offers (eci::methods_for:
// relaxation and projection included), through the library's run (eci::solve), at fixed steps and, for the pairs,
// adaptive with rows at fixed times by dense output (atol scaled with the state), from x0 and from x0 2^k with every
// time 2^-k: on the paper's three-wave system (the paper's update; C-PC halves at dt = 0.2) and on the random n-wave
// systems (45 unknowns: the conditioned update, with its remedy at dt = 0.05).
template <class Setup>
void expect_every_scaled_run(int k, double dt, double t_end) {
    const double a = std::ldexp(1.0, k);
    const Setup s;
    using state = typename decltype(s.model)::state_type;
    using model_type = decltype(s.model);
    const auto adaptive = eci::adaptive_methods_for<model_type>();
    int runs = 0;
    for (const eci::method_info& m : eci::methods_for<model_type>()) {
        const bool pair = std::ranges::any_of(adaptive, [&](const eci::method_info& p) { return p.name == m.name; });
        for (bool controlled : {false, true}) {
            if (controlled && !pair) continue;
            auto run = [&](double scale, state& x) {
                for (auto& v : x) v *= scale;
                eci::run_config cfg;
                cfg.t_end = t_end / scale;
                cfg.dt = dt / scale;
                if (controlled) {
                    eci::adaptive_options o;
                    o.rtol = 1e-8;
                    o.atol = 1e-8 * scale;
                    cfg.adaptive = o;
                    for (int i = 1; i <= 10; ++i) cfg.times.push_back(t_end * i / 10.0 / scale);
                    cfg.mode = eci::output_mode::dense;
                }
                // the front ends' compiled runs of the model (src/models): this file compiles none of them again
                solve_tests::discard<state> none;
                return eci::solve_model<model_type>(s.model, x, m.name, cfg, none);
            };
            state small = s.x0, big = s.x0;
            const eci::solve_report rs = run(1.0, small), rb = run(a, big);
            const std::string what = std::string(m.name) + (controlled ? " (adaptive)" : "") + " on " + Setup::name +
                                     " scaled by 2^" + std::to_string(k);
            ++runs;
            // A run that blows up (forward Euler on three-wave at dt = 0.2) stops where its values leave the range,
            // which the scaled run does elsewhere: only runs that complete are compared.
            if (!rs.completed()) continue;
            ASSERT_TRUE(rb.completed()) << what << ": " << rb.failure->message;
            EXPECT_EQ(rb.stats.steps, rs.stats.steps) << what;
            EXPECT_EQ(rb.stats.step_reductions, rs.stats.step_reductions) << what;
            EXPECT_EQ(rb.stats.rhs_evals, rs.stats.rhs_evals) << what;
            EXPECT_EQ(rb.stats.components_remedied, rs.stats.components_remedied) << what;
            std::size_t differ = 0;
            double scale = 0.0, off = 0.0;
            for (std::size_t i = 0; i < small.size(); ++i) {
                differ += big[i] / a == small[i] ? 0 : 1;
                scale = std::max(scale, std::abs(small[i]));
                off = std::max(off, std::abs(big[i] / a - small[i]));
            }
            if constexpr (std::is_same_v<Setup, complex_n_wave_setup>) {
                // The conditioned update rounds a complex mode whose two moduli agree to 2^-46 stochastically, with
                // a number hashed from xi's bits, exponent included (radicand_remedy.hpp, modulus_update): the
                // scaled run draws other numbers, a difference of an ulp here and there, carried on by the flow as
                // any rounding: k eps sqrt(n) with k = 8 (the bound of every conservative run in this file).
                const double n = double(rs.stats.steps) + 1.0;
                EXPECT_LE(off, 8.0 * eps * std::sqrt(n) * scale) << what;
            } else {
                EXPECT_EQ(differ, 0u) << what << ": " << differ << " of " << small.size()
                                      << " unknowns differ from the unscaled run's, by up to " << off / (eps * scale)
                                      << " eps of max |psi|";
            }
        }
    }
    EXPECT_GE(runs, 30) << Setup::name;  // every method of the model ran (29 on these, 10 of them also adaptive)
}

TEST(EveryMethodAcrossTheRange, AScaledRunIsTheRunScaledBitForBit) {
    for (int k : {-400, 400}) {
        expect_every_scaled_run<three_wave_setup>(k, 0.01, 3.0);
        expect_every_scaled_run<three_wave_setup>(k, 0.2, 10.0);  // C-PC halves here
        expect_every_scaled_run<real_n_wave_setup>(k, 0.005, 0.5);
        expect_every_scaled_run<real_n_wave_setup>(k, 0.05, 1.0);  // the conditioned update's remedy
        expect_every_scaled_run<complex_n_wave_setup>(k, 0.005, 0.5);
    }
}

}  // namespace
