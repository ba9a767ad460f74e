// A model that splits the steppers' element-wise passes into ranges (detail/ranges.hpp): the stage combinations and
// every per-unknown finish give the same bits as the unsplit passes; the conditioned update files each range apart
// and merges in range order, so it repeats bit for bit for a given split whatever order the ranges run in, takes
// the unsplit pass's decisions and keeps the invariants to round-off.
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <cstring>
#include <limits>
#include <vector>

#include <eci/invariants.hpp>
#include <eci/models/n_wave.hpp>
#include <eci/steppers/conservative_rk.hpp>
#include <eci/steppers/explicit_rk.hpp>

namespace {

// The n-wave model whose passes run in `ranges` ranges of uneven length (not aligned to anything), one after the
// other, in reverse order when `reverse` (the order threads may finish in).
template <class M>
struct split_model {
    const M* m;
    int ranges = 1;
    bool reverse = false;
    void operator()(const typename M::state_type& x, typename M::state_type& dx, double t) const { (*m)(x, dx, t); }
    int range_threads() const { return ranges; }
    template <class Body>
    void for_ranges(std::size_t n, Body body) const {
        // range r starts at n r^2 / ranges^2 + 3: lengths growing with r
        const std::size_t rr = std::size_t(ranges) * std::size_t(ranges);
        const auto start = [&](int r) { return r == 0 ? std::size_t(0) : r == ranges ? n : n * std::size_t(r * r) / rr + 3; };
        for (int k = 0; k < ranges; ++k) {
            const int r = reverse ? ranges - 1 - k : k;
            body(start(r), start(r + 1), r);
        }
    }
};

template <class S>
bool same_bits(const S& a, const S& b) {
    return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(a[0])) == 0;
}

struct run_result {
    std::vector<std::complex<double>> x;
    eci::remedy_stats stats{};
    int failures = 0;
};

// `steps` steps of St (dt, halved on a failure) of the system f on the model's state; the model's weights declared.
template <class St, class F, class M>
run_result run(F& f, const M& model, typename M::state_type x, double dt, int steps,
               eci::update_kind update = eci::update_kind::conditioned) {
    St st;
    run_result r;
    if constexpr (requires { st.remedy; }) {
        st.set_quadratic_invariants(eci::quadratic_weights_of(model, x.size()));
        st.remedy.update = update;
    }
    double t = 0.0;
    for (int i = 0; i < steps; ++i) {
        double h = dt;
        while (!st.step(f, x, t, h)) h *= 0.5, ++r.failures;
        t += h;
    }
    if constexpr (requires { st.remedy; }) r.stats = st.remedy_statistics();
    r.x.assign(x.begin(), x.end());
    return r;
}

using cmodel = eci::n_wave<std::complex<double>>;
using cstate = cmodel::state_type;
using rmodel = eci::n_wave<double>;
using rstate = rmodel::state_type;

const cmodel& complex_model() {
    static const cmodel m = cmodel::random(3000, 20, 7);
    return m;
}
const rmodel& real_model() {
    static const rmodel m = rmodel::random(3000, 20, 7);
    return m;
}

// A step large enough that negative radicands and ill-conditioned square roots are common (the remedy works).
constexpr double dt_complex = 0.02, dt_real = 0.02;
constexpr int steps = 40;

TEST(SplitRanges, ConventionalStepsGiveTheUnsplitBits) {
    const cmodel& m = complex_model();
    const cstate x0 = m.random_state(3);
    const cmodel& plain = m;
    const run_result whole = run<eci::rk4<cstate>>(plain, m, x0, dt_complex, steps);
    for (int ranges : {2, 3, 5}) {
        split_model<cmodel> f{&m, ranges, true};
        EXPECT_TRUE(same_bits(run<eci::rk4<cstate>>(f, m, x0, dt_complex, steps).x, whole.x)) << ranges;
        EXPECT_TRUE(same_bits(run<eci::pc<cstate>>(f, m, x0, dt_complex, steps).x,
                              run<eci::pc<cstate>>(plain, m, x0, dt_complex, steps).x))
            << ranges;
    }
}

// The paper's update and C-PC's eq. (30) finish unknown by unknown: the same bits split or not (their failure
// counts, summed over the ranges, are whole numbers).
TEST(SplitRanges, PaperUpdateGivesTheUnsplitBits) {
    const rmodel& m = real_model();
    const rstate x0 = m.random_state(3);
    for (int ranges : {2, 3}) {
        split_model<rmodel> f{&m, ranges, true};
        const run_result split = run<eci::c_rk4<rstate>>(f, m, x0, dt_real, steps, eci::update_kind::paper);
        const run_result whole = run<eci::c_rk4<rstate>>(m, m, x0, dt_real, steps, eci::update_kind::paper);
        EXPECT_TRUE(same_bits(split.x, whole.x)) << ranges;
        EXPECT_EQ(split.failures, whole.failures);
        const run_result split_pc = run<eci::c_pc<rstate>>(f, m, x0, dt_real, steps, eci::update_kind::paper);
        const run_result whole_pc = run<eci::c_pc<rstate>>(m, m, x0, dt_real, steps, eci::update_kind::paper);
        EXPECT_TRUE(same_bits(split_pc.x, whole_pc.x)) << ranges;
        EXPECT_GT(whole_pc.failures + int(whole_pc.stats.remedied_steps), 0);  // the failure counts were exercised
    }
}

// The conditioned update split into ranges: one range is the unsplit pass (bit for bit); several repeat bit for bit
// whatever order the ranges run in, take the unsplit pass's decisions (the same elements remedied in the same
// steps: the merged histogram and Gram sums differ from the unsplit ones by round-off alone), and keep E and Z to a
// few roundings per step.
template <class M>
void check_conditioned(const M& m, double dt) {
    using S = typename M::state_type;
    const S x0 = m.random_state(3);
    const run_result whole = run<eci::c_rk4<S>>(m, m, x0, dt, steps);
    ASSERT_GT(whole.stats.remedied_steps, 0u);  // the data exercise the remedy
    ASSERT_GT(whole.stats.conditioned, 0u);
    split_model<M> one{&m, 1, false};
    EXPECT_TRUE(same_bits(run<eci::c_rk4<S>>(one, m, x0, dt, steps).x, whole.x));
    const double e0 = m.energy(x0), z0 = m.enstrophy(x0);
    const double bound = 16.0 * std::numeric_limits<double>::epsilon() * std::sqrt(double(steps));
    for (int ranges : {2, 3, 5}) {
        split_model<M> forward{&m, ranges, false}, backward{&m, ranges, true};
        const run_result a = run<eci::c_rk4<S>>(forward, m, x0, dt, steps);
        const run_result b = run<eci::c_rk4<S>>(backward, m, x0, dt, steps);
        EXPECT_TRUE(same_bits(a.x, b.x)) << ranges;
        EXPECT_EQ(a.failures, whole.failures) << ranges;
        EXPECT_EQ(a.stats.remedied_steps, whole.stats.remedied_steps) << ranges;
        EXPECT_EQ(a.stats.components_remedied, whole.stats.components_remedied) << ranges;
        EXPECT_EQ(a.stats.conditioned, whole.stats.conditioned) << ranges;
        EXPECT_EQ(a.stats.declined, whole.stats.declined) << ranges;
        S x(a.x.size());
        for (std::size_t i = 0; i < x.size(); ++i) {
            if constexpr (std::is_same_v<typename S::value_type, double>)
                x[i] = a.x[i].real();
            else
                x[i] = a.x[i];
        }
        EXPECT_LE(std::abs(m.energy(x) - e0), bound * e0) << ranges;
        EXPECT_LE(std::abs(m.enstrophy(x) - z0), bound * z0) << ranges;
        double diff = 0.0, norm = 0.0;
        for (std::size_t i = 0; i < x.size(); ++i)
            diff += std::norm(a.x[i] - whole.x[i]), norm += std::norm(whole.x[i]);
        EXPECT_LE(std::sqrt(diff / norm), 1e-10) << ranges;  // round-off apart, not another trajectory
    }
}

TEST(SplitRanges, ConditionedUpdateOfComplexModesMergesInRangeOrder) { check_conditioned(complex_model(), dt_complex); }

TEST(SplitRanges, ConditionedUpdateOfRealUnknownsMergesInRangeOrder) { check_conditioned(real_model(), dt_real); }

// splitter::count: on one range (a model without the hook, or one thread) the pass itself over [0, n), called once;
// split, the sum in range order of the ranges the model ran, and nothing from the slots it did not use.
TEST(SplitRanges, CountOnOneRangeIsThePassItselfAndSplitSumsTheUsedRanges) {
    const auto whole = eci::detail::splitter::of(eci::n_wave<double>::random(6, 1, 1));
    int calls = 0;
    EXPECT_EQ(whole.count(10, [&](std::size_t i0, std::size_t i1) {
        ++calls;
        EXPECT_EQ(i0, 0u);
        EXPECT_EQ(i1, 10u);
        return 2.0;
    }), 2.0);
    EXPECT_EQ(calls, 1);
    const auto m = eci::n_wave<double>::random(6, 1, 1);
    const split_model<eci::n_wave<double>> three{&m, 3, false};
    const auto split = eci::detail::splitter::of(three);
    EXPECT_EQ(split.threads, 3);
    std::size_t covered = 0;
    calls = 0;
    EXPECT_EQ(split.count(100, [&](std::size_t i0, std::size_t i1) {
        ++calls;
        covered += i1 - i0;
        return double(i1 - i0 > 0 ? 1 : 0);
    }), 3.0);
    EXPECT_EQ(calls, 3);
    EXPECT_EQ(covered, 100u);
}

}  // namespace
