// `eci run` with the relaxation, projection and symplectic methods and the comparison problems: each
// method is offered where the model has what it needs, keeps what it promises, and is refused elsewhere.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include <eci/models/rigid_body_exact.hpp>
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
    EXPECT_NE(methods_line(r.out, "kepler-cartesian").find("projected-dp54 stormer-verlet sb3a"), std::string::npos);
    // H is not quadratic in Cartesian variables: no C-RK method on kepler-cartesian.
    EXPECT_EQ(methods_line(r.out, "kepler-cartesian").find("c-rk4"), std::string::npos);
    for (const char* model : {"rigid-body", "nonlinear-oscillator", "exp-entropy"})
        EXPECT_NE(methods_line(r.out, model).find("rrk-rk4"), std::string::npos) << model;
    // Relaxation and projection on other tableaux: listed, and multiple relaxation only with two invariants.
    for (const char* m : {"rrk-bs32", "rrk-dp54", "mrrk-bs32", "mrrk-dp54", "projected-dp54"})
        EXPECT_NE(r.out.find(std::string("  ") + m + " "), std::string::npos) << m << "\n" << r.out;
    EXPECT_NE(methods_line(r.out, "rigid-body").find("rrk-bs32 rrk-dp54 mrrk-bs32 mrrk-dp54 projected-dp54"),
              std::string::npos);
    EXPECT_NE(methods_line(r.out, "lotka-volterra").find("rrk-bs32 rrk-dp54 projected-dp54"), std::string::npos);
    EXPECT_EQ(methods_line(r.out, "lotka-volterra").find("mrrk-dp54"), std::string::npos);
}

// Multiple relaxation on Dormand-Prince 5(4) (directions b and b - bhat) keeps both of the rigid body's
// invariants over 10^4 steps, as on RK4's stages.
TEST_F(CliInvariantMethods, RigidBodyMultipleRelaxationOnAnEmbeddedPair) {
    const double bound = 16.0 * eps * std::sqrt(1e4);
    for (const char* m : {"mrrk-dp54", "mrrk-bs32"}) {
        const result r = eci(std::string("run rigid-body --method ") + m + " --summary-json -");
        ASSERT_EQ(r.status, 0) << r.err;
        EXPECT_LE(invariant_field(r.out, "g1", "max_rel_drift"), bound) << m << r.out;
        EXPECT_LE(invariant_field(r.out, "g2", "max_rel_drift"), bound) << m << r.out;
    }
}

/// The number after `"key": ` at the top level of the summary JSON (NaN if absent).
double json_number(const std::string& json, const std::string& key) {
    const std::string k = "\"" + key + "\": ";
    const std::size_t v = json.find(k);
    return v == std::string::npos ? std::nan("") : std::strtod(json.c_str() + v + k.size(), nullptr);
}

// RRK's state at grid time t belongs to t + time lag: the CSV's last column time_lag and the summary's t_reached
// say so. Rigid body, rrk-bs32, 100 steps of 0.1: the lag is one step's (gamma - 1) tau = O(dt^3), never
// accumulated. After one step the state is the exact solution at t + lag up to the local error O(dt^4), while at
// t it is off by the lag itself (u' ~ 1): the column is the time the state belongs to.
TEST_F(CliInvariantMethods, RelaxationReportsTheTimeActuallyReached) {
    const fs::path csv = dir_ / "rrk.csv", json = dir_ / "rrk.json";
    const result r = eci("run rigid-body --method rrk-bs32 --t-end 10 --output " + csv.string() + " --summary-json " +
                         json.string());
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_NE(r.err.find("time reached"), std::string::npos) << r.err;
    const auto lines = lines_of(eci::test_cli::read_text(csv));
    ASSERT_EQ(lines.size(), 102u);  // header, t = 0 and 100 steps
    const auto header = eci::test_cli::split(lines[0]);
    ASSERT_EQ(header.back(), "time_lag");
    double worst = 0.0;
    for (std::size_t i = 1; i < lines.size(); ++i) {
        const auto row = eci::test_cli::split(lines[i]);
        ASSERT_EQ(row.size(), header.size());
        const double lag = std::stod(row.back());
        if (i == 1) {
            EXPECT_EQ(lag, 0.0);  // the initial state is on its grid time
        }
        worst = std::max(worst, std::abs(lag));
    }
    EXPECT_GT(worst, 0.0);
    EXPECT_LT(worst, 1e-3);  // (gamma - 1) tau with gamma - 1 = O(tau^2): measured ~1.3e-4
    const auto last = eci::test_cli::split(lines.back());
    const double lag_end = std::stod(last.back());
    const std::string summary = eci::test_cli::read_text(json);
    EXPECT_EQ(json_number(summary, "time_lag"), lag_end);
    EXPECT_EQ(json_number(summary, "t_reached"), 10.0 + lag_end);
    const auto first = eci::test_cli::split(lines[2]);
    const double t = std::stod(first[0]), lag = std::stod(first.back());
    const eci::rigid_body::state_type at_t = eci::rigid_body_exact(t), at_reached = eci::rigid_body_exact(t + lag);
    double e_t = 0.0, e_reached = 0.0;
    for (std::size_t k = 0; k < 3; ++k) {
        const double u = std::stod(first[1 + k]);
        e_t = std::max(e_t, std::abs(u - at_t[k]));
        e_reached = std::max(e_reached, std::abs(u - at_reached[k]));
    }
    std::printf("  largest lag %.2e; after one step: error at t %.2e, at t + lag %.2e\n", worst, e_t, e_reached);
    EXPECT_LT(e_reached, 0.1 * e_t);
    // Methods on the grid (IDT, C-RK4) have no such column and no t_reached.
    for (const char* m : {"idt-rk4", "c-rk4"}) {
        const result g = eci(std::string("run rigid-body --steps 3 --method ") + m + " --output - ");
        ASSERT_EQ(g.status, 0) << g.err;
        EXPECT_EQ(g.out.find("time_lag"), std::string::npos) << m;
        EXPECT_EQ(g.err.find("time reached"), std::string::npos) << m;
    }
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
