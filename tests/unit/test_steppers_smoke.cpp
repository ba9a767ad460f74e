#include <gtest/gtest.h>

#include <eci/eci.hpp>
#include <eci/models/n_wave.hpp>
#include <eci/models/three_wave.hpp>

TEST(Smoke, CpcConservesThreeWave) {
    eci::three_wave m;
    eci::three_wave::state_type x{std::sqrt(1.5), 0.0, std::sqrt(1.5)};
    eci::c_pc<eci::three_wave::state_type> st;
    const double e0 = m.energy(x), z0 = m.enstrophy(x);
    auto stats = eci::integrate_n_steps(st, m, x, 0.0, 0.01, 10000);
    EXPECT_EQ(stats.steps, 10000u);
    EXPECT_NEAR(m.energy(x), e0, 1e-13);
    EXPECT_NEAR(m.enstrophy(x), z0, 1e-12);
}
