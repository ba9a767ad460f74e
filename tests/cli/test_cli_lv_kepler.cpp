// `eci run lotka-volterra` and `eci run kepler` end to end: exact CSV headers, Newton statistics in the JSON
// summary, the paper's runs through the binary, and bad input refused with one line and exit status 2.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>

#include "support.hpp"

namespace {

namespace fs = std::filesystem;

using eci::test_cli::run_eci;
using result = eci::test_cli::run_result;
using eci::test_cli::scratch_dir;

// A scratch directory per test, removed afterwards.
class CliLvKepler : public ::testing::Test {
   protected:
    // Runs `eci args` (through the shell) capturing stdout and stderr.
    result eci(const std::string& args) const { return run_eci(args, dir_); }

    // The value after "key": in a JSON text (numbers only), or NaN.
    static double json_number(const std::string& json, const std::string& key, std::size_t from = 0) {
        const std::size_t at = json.find("\"" + key + "\":", from);
        if (at == std::string::npos) return std::numeric_limits<double>::quiet_NaN();
        return std::stod(json.substr(at + key.size() + 3));
    }

    scratch_dir scratch_{"cli-lv-kepler"};
    fs::path dir_ = scratch_.path();
};

std::string first_line(const std::string& text) { return text.substr(0, text.find('\n')); }

}  // namespace

TEST_F(CliLvKepler, CsvHeadersAreExactlyTheDocumentedOnes) {
    for (const char* method : {"c-pc", "pc", "kahan", "rk4", "c-rk4"}) {
        const result r = eci(std::string("run lotka-volterra --steps 10 --output - --method ") + method);
        ASSERT_EQ(r.status, 0) << method << ": " << r.err;
        EXPECT_EQ(first_line(r.out), "t,x,y,hamiltonian") << method;
    }
    for (const char* method : {"c-pc", "pc", "rk4", "c-rk4"}) {
        const result r = eci(std::string("run kepler --steps 10 --output - --method ") + method);
        ASSERT_EQ(r.status, 0) << method << ": " << r.err;
        EXPECT_EQ(first_line(r.out), "t,r,v_r,theta,x,y,hamiltonian,runge_lenz_x,runge_lenz_y") << method;
    }
    // The first Kepler row is the paper's start: r = 1, v_r = theta = 0, so x = 1, y = 0, H = -1, A = (-0.5, 0).
    const result r = eci("run kepler --steps 1 --output -");
    const std::string row = r.out.substr(r.out.find('\n') + 1);
    EXPECT_EQ(first_line(row), "0,1,0,0,1,0,-1,-0.5,0");
}

// The JSON summary carries the Newton statistics of the transformed C-PC; the paper says 3 or 4 iterations
// for Kepler's angle.
TEST_F(CliLvKepler, SummaryJsonReportsNewtonIterations) {
    const result kepler = eci("run kepler --summary-json -");  // defaults: the paper's 1000 steps of 0.105
    ASSERT_EQ(kepler.status, 0) << kepler.err;
    EXPECT_EQ(json_number(kepler.out, "steps"), 1000.0);
    EXPECT_GE(json_number(kepler.out, "solves"), 1000.0);
    EXPECT_GE(json_number(kepler.out, "iterations_mean"), 2.0);
    EXPECT_LE(json_number(kepler.out, "iterations_mean"), 4.0);
    EXPECT_LE(json_number(kepler.out, "iterations_max"), 6.0);
    // H and both components of A to round-off: 4 eps * 5 (the largest term at r_min = 0.5) * sqrt(1000).
    const double tol = 4.0 * std::numeric_limits<double>::epsilon() * 5.0 * std::sqrt(1000.0);
    for (const char* inv : {"\"hamiltonian\"", "\"runge_lenz_x\"", "\"runge_lenz_y\""}) {
        const std::size_t at = kepler.out.find(inv);
        ASSERT_NE(at, std::string::npos) << inv;
        EXPECT_LE(json_number(kepler.out, "max_abs_drift", at), tol) << inv;
    }

    const result lv = eci("run lotka-volterra --steps 20000 --summary-json -");
    ASSERT_EQ(lv.status, 0) << lv.err;
    EXPECT_GE(json_number(lv.out, "solves"), 40000.0);  // two inverses (x and y) per step
    EXPECT_LE(json_number(lv.out, "iterations_mean"), 5.0);
    EXPECT_LE(json_number(lv.out, "iterations_max"), 12.0);

    // Conventional methods make no iterative solves: no solver entry.
    const result pc = eci("run kepler --method pc --summary-json -");
    ASSERT_EQ(pc.status, 0) << pc.err;
    EXPECT_EQ(pc.out.find("\"solver\""), std::string::npos);
}

// Fig. 8 through the binary: PC with 1313 steps of 0.08 gains 13.7% of |H|.
TEST_F(CliLvKepler, KeplerPaperPcRunGainsEnergy) {
    const result r = eci("run kepler --method pc --dt 0.08 --steps 1313 --summary-json -");
    ASSERT_EQ(r.status, 0) << r.err;
    const std::size_t at = r.out.find("\"hamiltonian\"");
    ASSERT_NE(at, std::string::npos);
    EXPECT_NEAR(json_number(r.out, "final", at), -0.8632, 1e-3);
    // ... and its orbit's axis turns by about -80 degrees, which the summary reports.
    EXPECT_NEAR(json_number(r.out, "runge_lenz_turn_degrees"), -80.0, 0.5);
    EXPECT_NE(r.err.find("runge_lenz_turn_degrees"), std::string::npos) << r.err;
}

// Fig. 9 through the binary: C-PC keeps the axis; its turn is round-off, bounded by a few eps per step
// (|A| is 0.5, so each step's rounding of A turns it by ~eps/0.5 rad; 1000 steps random-walk to ~sqrt(1000) of it).
TEST_F(CliLvKepler, KeplerPaperCpcRunKeepsTheOrbitAxis) {
    const result r = eci("run kepler --summary-json -");
    ASSERT_EQ(r.status, 0) << r.err;
    const double bound_degrees = 16.0 * 2.22e-16 / 0.5 * std::sqrt(1000.0) * 180.0 / 3.141592653589793;
    EXPECT_LE(std::abs(json_number(r.out, "runge_lenz_turn_degrees")), bound_degrees);
}

// Bad input: one line on stderr naming the problem, exit status 2, no CSV file left behind.
TEST_F(CliLvKepler, BadInputExitsTwoWithOneLine) {
    const std::pair<const char*, const char*> cases[] = {
        {"lotka-volterra --x 0", "x must be positive"},
        {"lotka-volterra --x -1", "x must be positive"},
        {"lotka-volterra --y 0", "y must be positive"},
        {"lotka-volterra --y -0.5", "y must be positive"},
        {"lotka-volterra --mu 0", "mu must be positive"},
        {"lotka-volterra --mu -1.5", "mu must be positive"},
        {"lotka-volterra --x nan", "x is not finite"},
        {"lotka-volterra --y inf", "y is not finite"},
        {"lotka-volterra --mu nan", "mu must be finite"},
        {"kepler --r 0", "r must be positive"},
        {"kepler --r -1", "r must be positive"},
        {"kepler --m 0", "m must be positive"},
        {"kepler --m -1", "m must be positive"},
        {"kepler --K 0", "K must be positive"},
        {"kepler --K -1.5", "K must be positive"},
        {"kepler --ell 0", "radial fall"},
        {"kepler --v-r 3", "unbound"},
        {"kepler --r nan", "r is not finite"},
        {"kepler --theta inf", "theta is not finite"},
        {"kepler --method kahan", "not available"},
    };
    for (const auto& [args, message] : cases) {
        const fs::path csv = dir_ / "out.csv";
        const result r = eci(std::string("run ") + args + " --steps 5 --output '" + csv.string() + "'");
        EXPECT_EQ(r.status, 2) << args;
        EXPECT_NE(r.err.find(message), std::string::npos) << args << ": " << r.err;
        EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << args << ": more than one line: " << r.err;
        EXPECT_TRUE(r.out.empty()) << args;
        EXPECT_FALSE(fs::exists(csv)) << args;
    }
}

// A conventional method's large step can take Kepler's r through 0, outside the polar coordinates: the run stops
// there (exit 1, one line, no output), where it went on to t_end with r = -6134 and a "final" H of 1.9e7. A step
// that keeps r > 0 runs on (the paper's fig. 8: PC, dt 0.08).
TEST_F(CliLvKepler, KeplerStopsWhereRLeavesThePolarCoordinates) {
    const fs::path csv = dir_ / "ke.csv";
    const result r = eci("run kepler --method euler --dt 0.5 --t-end 1000 --output '" + csv.string() + "'");
    EXPECT_EQ(r.status, 1) << r.err;
    EXPECT_NE(r.err.find("the invariant hamiltonian is undefined (NaN) at t = "), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("the state left where the model is defined"), std::string::npos) << r.err;
    const std::size_t at = r.err.find("at t = ");
    ASSERT_NE(at, std::string::npos);
    EXPECT_LT(std::stod(r.err.substr(at + 7)), 10.0) << r.err;
    EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << "more than one line: " << r.err;
    EXPECT_FALSE(fs::exists(csv));
    const result fig8 = eci("run kepler --preset fig8 --output '" + csv.string() + "'");
    EXPECT_EQ(fig8.status, 0) << fig8.err;
}

// The summary's first line says what the method keeps of this model's invariants, not what it keeps elsewhere:
// the implicit midpoint rule keeps quadratic invariants, and Kepler's are not (it said "conservative" while H drifted
// 1.7e-3); projection keeps the independent ones (H, not the Runge-Lenz vector); relaxation the first (it said
// "conventional" while H stayed at round-off). The JSON lists them.
TEST_F(CliLvKepler, TheSummarySaysWhichInvariantsTheMethodKeeps) {
    const struct {
        const char* run;
        const char* says;
        const char* keeps;
    } cases[] = {
        {"kepler --method implicit-midpoint", "(order 2, conventional)", "[]"},
        {"kepler --method projected-rk4", "(order 4, keeps hamiltonian)", "[\"hamiltonian\"]"},
        {"kepler --method rrk-rk4", "(order 4, keeps hamiltonian)", "[\"hamiltonian\"]"},
        {"kepler --method c-pc", "(order 2, conservative)", "[\"hamiltonian\", \"runge_lenz_x\", \"runge_lenz_y\"]"},
        {"kepler --method rk4", "(order 4, conventional)", "[]"},
        {"kepler-cartesian --method mrrk-rk4", "(order 4, keeps hamiltonian, angular_momentum)",
         "[\"hamiltonian\", \"angular_momentum\"]"},
        {"three-wave --method implicit-midpoint", "(order 2, conservative)", "[\"energy\", \"enstrophy\"]"},
        {"three-wave --method rrk-rk4", "(order 4, keeps energy)", "[\"energy\"]"},
        {"three-wave --method mrrk-rk4", "(order 4, conservative)", "[\"energy\", \"enstrophy\"]"},
    };
    for (const auto& c : cases) {
        const fs::path json = dir_ / "s.json";
        const result r = eci(std::string("run ") + c.run + " --steps 3 --summary-json '" + json.string() + "'");
        ASSERT_EQ(r.status, 0) << c.run << ": " << r.err;
        EXPECT_NE(first_line(r.err).find(c.says), std::string::npos) << c.run << ": " << first_line(r.err);
        std::ifstream in(json);
        const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
        EXPECT_NE(text.find(std::string("\"keeps\": ") + c.keeps + ","), std::string::npos) << c.run << ": " << text;
    }
}
