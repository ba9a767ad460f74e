// `eci run` with the relaxation, projection and symplectic methods and the comparison problems (issue 12): each
// method is offered where the model has what it needs, keeps what it promises, and is refused elsewhere.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include <eci/registry.hpp>

#include "support.hpp"

namespace {

namespace fs = std::filesystem;
using eci::test_cli::lines_of;
using eci::test_cli::run_eci;
using result = eci::test_cli::run_result;

constexpr double eps = std::numeric_limits<double>::epsilon();

class CliInvariantMethods : public ::testing::Test {
   protected:
    result eci(const std::string& args) const { return run_eci(args, dir_); }
    eci::test_cli::scratch_dir scratch_{"cli-invariant-methods"};
    fs::path dir_ = scratch_.path();
};

/// The number after `"name": {... "key": ` in the summary JSON.
double invariant_field(const std::string& json, const std::string& name, const std::string& key) {
    std::string tag = "\"";
    tag.append(name).append("\": {");
    const std::size_t at = json.find(tag);
    if (at == std::string::npos) return std::nan("");
    std::string k = "\"";
    k.append(key).append("\": ");
    const std::size_t v = json.find(k, at);
    return v == std::string::npos ? std::nan("") : std::strtod(json.c_str() + v + k.size(), nullptr);
}

/// The `methods:` line `eci list` prints under a model.
std::string methods_line(const std::string& list, const std::string& model) {
    const auto lines = lines_of(list);
    for (std::size_t i = 0; i + 1 < lines.size(); ++i)
        if (lines[i].rfind("  " + model + " ", 0) == 0) return lines[i + 1];
    return "";
}

TEST_F(CliInvariantMethods, ListOffersEachMethodWhereTheModelHasWhatItNeeds) {
    const result r = eci("list");
    ASSERT_EQ(r.status, 0) << r.err;
    for (const char* m : {"rrk-rk4", "idt-rk4", "mrrk-rk4", "projected-rk4", "stormer-verlet", "sb3a"})
        EXPECT_NE(r.out.find(std::string("  ") + m + " "), std::string::npos) << m << "\n" << r.out;
    // Multiple relaxation needs two independent invariants, symplectic methods a separable Hamiltonian.
    EXPECT_NE(methods_line(r.out, "three-wave").find("rrk-rk4 idt-rk4 mrrk-rk4 projected-rk4"), std::string::npos);
    EXPECT_NE(methods_line(r.out, "lotka-volterra").find("rrk-rk4 idt-rk4 projected-rk4"), std::string::npos);
    EXPECT_EQ(methods_line(r.out, "lotka-volterra").find("mrrk-rk4"), std::string::npos);
    EXPECT_EQ(methods_line(r.out, "three-wave").find("sb3a"), std::string::npos);
    EXPECT_NE(methods_line(r.out, "kepler-cartesian").find("projected-rk4 stormer-verlet sb3a"), std::string::npos);
    // H is not quadratic in Cartesian variables: no C-RK method on kepler-cartesian.
    EXPECT_EQ(methods_line(r.out, "kepler-cartesian").find("c-rk4"), std::string::npos);
    for (const char* model : {"rigid-body", "nonlinear-oscillator", "exp-entropy"})
        EXPECT_NE(methods_line(r.out, model).find("rrk-rk4"), std::string::npos) << model;
}

// Biswas & Ketcheson's rigid body, 10^4 steps: multiple relaxation keeps G1 and G2 to round-off (a few roundings
// per step adding up as a random walk), single relaxation keeps G1 and lets G2 drift.
TEST_F(CliInvariantMethods, RigidBodyMultipleRelaxationKeepsBothInvariants) {
    const double bound = 16.0 * eps * std::sqrt(1e4);
    const result mr = eci("run rigid-body --preset multiple-relaxation --summary-json -");
    ASSERT_EQ(mr.status, 0) << mr.err;
    EXPECT_LE(invariant_field(mr.out, "g1", "max_rel_drift"), bound) << mr.out;
    EXPECT_LE(invariant_field(mr.out, "g2", "max_rel_drift"), bound) << mr.out;
    const result one = eci("run rigid-body --method rrk-rk4 --summary-json -");
    ASSERT_EQ(one.status, 0) << one.err;
    EXPECT_LE(invariant_field(one.out, "g1", "max_rel_drift"), bound) << one.out;
    EXPECT_GT(invariant_field(one.out, "g2", "max_rel_drift"), 1e3 * bound) << one.out;
}

// Kepler e = 0.5 (Ranocha & Ketcheson) for one period: projection keeps H and L; SB3A keeps L (a quadratic
// invariant of the splitting) while H oscillates at its truncation error.
TEST_F(CliInvariantMethods, KeplerCartesianProjectionAndSymplectic) {
    const result p = eci("run kepler-cartesian --method projected-rk4 --t-end 6.283185307179586 --summary-json -");
    ASSERT_EQ(p.status, 0) << p.err;
    EXPECT_LE(invariant_field(p.out, "hamiltonian", "max_rel_drift"), 64.0 * eps) << p.out;
    EXPECT_LE(invariant_field(p.out, "angular_momentum", "max_rel_drift"), 64.0 * eps) << p.out;
    const result s = eci("run kepler-cartesian --preset symplectic --t-end 6.283185307179586 --summary-json -");
    ASSERT_EQ(s.status, 0) << s.err;
    EXPECT_LE(invariant_field(s.out, "angular_momentum", "max_rel_drift"), 16.0 * eps * std::sqrt(252.0)) << s.out;
    const double h = invariant_field(s.out, "hamiltonian", "max_rel_drift");
    EXPECT_GT(h, 1e-12);  // not conserved exactly ...
    EXPECT_LT(h, 1e-6);   // ... but bounded: fourth order at dt = 0.025
}

// The exponential entropy: e^u + e^v kept by relaxation's root solve and by C-RK4 through the transform.
TEST_F(CliInvariantMethods, ExponentialEntropyKeptByRelaxationAndTransform) {
    for (const char* preset : {"standard", "relaxation"}) {
        const result r = eci(std::string("run exp-entropy --preset ") + preset + " --summary-json -");
        ASSERT_EQ(r.status, 0) << r.err;
        EXPECT_LE(invariant_field(r.out, "entropy", "max_rel_drift"), 16.0 * eps * std::sqrt(500.0)) << preset;
    }
}

TEST_F(CliInvariantMethods, AMethodTheModelCannotRunIsBadInputAndWritesNothing) {
    const std::string out = (dir_ / "out.csv").string();
    const result r = eci("run three-wave --method sb3a --output " + out);
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("sb3a"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(dir_ / "out.csv"));
    const result k = eci("run kepler-cartesian --q 0 0 --output " + out);
    EXPECT_EQ(k.status, 2);
    EXPECT_NE(k.err.find("(0, 0)"), std::string::npos) << k.err;
    EXPECT_FALSE(fs::exists(dir_ / "out.csv"));
}

}  // namespace
