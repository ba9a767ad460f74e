// The finishing passes that are also compiled for AVX2 and dispatched at load time (C-PC's and the compensated
// C-PC's) must round exactly like the inlined baseline loop, so that results never depend on the processor.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include <eci/steppers/compensated_c_pc.hpp>
#include <eci/steppers/conservative_rk.hpp>

namespace {

std::vector<double> random_values(std::size_t n, unsigned seed, double lo, double hi) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(lo, hi);
    std::vector<double> v(n);
    for (double& x : v) x = u(rng);
    return v;
}

bool same_bits(const std::vector<double>& a, const std::vector<double>& b) {
    return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0;
}

// 1001 unknowns: vector body and scalar tail; dt large enough that some radicands are negative.
constexpr std::size_t n = 1001;
constexpr double dt = 0.3;

TEST(FinishDispatch, CpcDispatchedPassRoundsLikeTheInlinedLoop) {
    const auto x = random_values(n, 1, -1.0, 1.0), k1 = random_values(n, 2, -2.0, 2.0);
    auto o_dispatched = random_values(n, 3, -1.0, 1.0), o_inline = o_dispatched;
    const double bad_dispatched = eci::detail::c_pc_finish(o_dispatched.data(), x.data(), k1.data(), dt, n);
    const double bad_inline = eci::detail::c_pc_finish_inline(o_inline.data(), x.data(), k1.data(), dt, n);
    EXPECT_GT(bad_inline, 0.0);  // the data exercise the failure count too
    EXPECT_EQ(bad_dispatched, bad_inline);
    EXPECT_TRUE(same_bits(o_dispatched, o_inline));
}

TEST(FinishDispatch, CompensatedDispatchedPassRoundsLikeTheInlinedLoop) {
    const auto x = random_values(n, 4, -1.0, 1.0), k1 = random_values(n, 5, -2.0, 2.0);
    const auto r = random_values(n, 6, -1e-17, 1e-17);
    auto p_dispatched = random_values(n, 7, -1.0, 1.0), p_inline = p_dispatched;
    auto k0_dispatched = random_values(n, 8, -2.0, 2.0), k0_inline = k0_dispatched;
    const double bad_dispatched = eci::detail::compensated_c_pc_finish(p_dispatched.data(), k0_dispatched.data(),
                                                                       x.data(), k1.data(), r.data(), dt, n);
    const double bad_inline = eci::detail::compensated_c_pc_finish_inline(p_inline.data(), k0_inline.data(),
                                                                          x.data(), k1.data(), r.data(), dt, n);
    EXPECT_GT(bad_inline, 0.0);
    EXPECT_EQ(bad_dispatched, bad_inline);
    // NaN payloads of failed unknowns compare by bits as well: both loops produce the same default NaN.
    EXPECT_TRUE(same_bits(p_dispatched, p_inline));
    EXPECT_TRUE(same_bits(k0_dispatched, k0_inline));
}

}  // namespace
