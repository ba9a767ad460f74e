// The steppers' element-wise passes on the flow's threads (flow2d::for_ranges, detail/ranges.hpp). Replayed stage
// derivatives (one real RK4 step's, recorded) separate the passes from the transforms, whose threaded plans round
// differently: on the same data, RK4's stage combinations and finish give the one-thread bits, and C-RK4's
// conditioned update, filed per thread and merged in thread order, takes the one-thread decisions to round-off.
// A threaded run repeats bit for bit and keeps E and Z exact.
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <cstring>
#include <limits>
#include <numbers>
#include <vector>

#include <eci/eci.hpp>
#include <eci/spectral/step.hpp>

namespace {

using eci::navier_stokes_2d;
using state = navier_stokes_2d::state_type;
constexpr double eps = std::numeric_limits<double>::epsilon();

eci::ns2d_params params(int threads) {
    eci::ns2d_params p;
    p.n = 256;  // 171 x 86 modes: enough for the flow to split a pass between two threads
    p.threads = threads;
    p.measure = false;
    return p;
}

bool same_bits(const state& a, const state& b) {
    return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(a[0])) == 0;
}

// Replays the stage derivatives recorded from the flow; with `threaded`, lends the steppers the flow's threads.
struct replay {
    std::vector<state> k;
    std::size_t next = 0;
    void operator()(const state&, state& dx, double) { dx = k[next++ % k.size()]; }
};
struct threaded_replay : replay {
    const navier_stokes_2d* flow = nullptr;
    int range_threads() const { return flow->range_threads(); }
    template <class Body>
    void for_ranges(std::size_t n, Body body) const {
        flow->for_ranges(n, body);
    }
};

struct recording {
    navier_stokes_2d* flow;
    std::vector<state>* k;
    void operator()(const state& x, state& dx, double t) {
        (*flow)(x, dx, t);
        k->push_back(dx);
    }
};

template <class St, class F>
state step_once(F& f, const navier_stokes_2d& m, const state& w0, double dt, eci::remedy_stats* stats = nullptr) {
    St st;
    if constexpr (requires { st.remedy; }) st.set_quadratic_invariants(m.quadratic_invariant_weights());
    state w = w0;
    EXPECT_TRUE(bool(st.step(f, w, 0.0, dt)));
    if constexpr (requires { st.remedy; })
        if (stats) *stats = st.remedy_statistics();
    return w;
}

TEST(Ns2dThreads, ReplayedPassesOnTwoThreadsTakeTheOneThreadResults) {
    navier_stokes_2d m(params(2));
    ASSERT_EQ(m.range_threads(), 2);
    const state w0 = m.random_field(16.0, 0.5, 1);
    // CFL 1: many modes cross zero, so the conditioned update files and remedies (the merge is exercised)
    const double dt = 1.0 * (2.0 * std::numbers::pi / m.n()) / m.max_velocity(w0);
    std::vector<state> k;
    {
        recording rec{&m, &k};
        eci::rk4<state> r;
        state w = w0;
        r.step(rec, w, 0.0, dt);
    }
    replay serial{k};
    threaded_replay threaded{{k}, &m};
    serial.next = threaded.next = 0;
    EXPECT_TRUE(
        same_bits(step_once<eci::rk4<state>>(threaded, m, w0, dt), step_once<eci::rk4<state>>(serial, m, w0, dt)));
    eci::remedy_stats s1{}, s2{};
    const state one = step_once<eci::c_rk4<state>>(serial, m, w0, dt, &s1);
    const state two = step_once<eci::c_rk4<state>>(threaded, m, w0, dt, &s2);
    ASSERT_GT(s1.conditioned, 0u);
    EXPECT_EQ(s2.remedied_steps, s1.remedied_steps);
    EXPECT_EQ(s2.components_remedied, s1.components_remedied);
    EXPECT_EQ(s2.conditioned, s1.conditioned);
    // E and Z as the one-thread step leaves them, to a few roundings (the Gram sums are added in another order)
    EXPECT_NEAR(m.energy(two), m.energy(one), 8 * eps * m.energy(one));
    EXPECT_NEAR(m.enstrophy(two), m.enstrophy(one), 8 * eps * m.enstrophy(one));
    EXPECT_TRUE(same_bits(step_once<eci::c_rk4<state>>(threaded, m, w0, dt), two));  // it repeats
    EXPECT_TRUE(
        same_bits(step_once<eci::c_pc<state>>(threaded, m, w0, dt), step_once<eci::c_pc<state>>(serial, m, w0, dt)));
}

// 40 inviscid C-RK4 and C-PC steps on two threads at CFL 0.5: E and Z exact to k eps sqrt(steps), and a second run
// gives the same bits.
TEST(Ns2dThreads, ThreadedRunsKeepEAndZAndRepeat) {
    navier_stokes_2d m(params(2));
    const state w0 = m.random_field(16.0, 0.5, 1);
    const double dt = 0.5 * (2.0 * std::numbers::pi / m.n()) / m.max_velocity(w0);
    const double e0 = m.energy(w0), z0 = m.enstrophy(w0);
    constexpr int steps = 40;
    const auto run = [&]<class St>(St st) {
        state w = w0;
        eci::ns2d_budget b;
        eci::run_stats stats;
        for (int i = 0; i < steps; ++i) eci::ns2d_step(st, m, w, i * dt, dt, b, stats);
        return w;
    };
    for (const state& w : {run(eci::c_rk4<state>{}), run(eci::c_pc<state>{})}) {
        EXPECT_LE(std::abs(m.energy(w) - e0), 16 * eps * std::sqrt(double(steps)) * e0);
        EXPECT_LE(std::abs(m.enstrophy(w) - z0), 16 * eps * std::sqrt(double(steps)) * z0);
    }
    EXPECT_TRUE(same_bits(run(eci::c_rk4<state>{}), run(eci::c_rk4<state>{})));
}

}  // namespace
