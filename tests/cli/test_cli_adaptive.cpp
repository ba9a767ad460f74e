// `eci run` with adaptive step control: --rtol/--atol, rows at --output-dt times, the new counters in
// --summary-json, and bad input refused with exit status 2 and no output file.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "cli/support.hpp"

namespace {

namespace fs = std::filesystem;
using eci::test_cli::lines_of;
using eci::test_cli::read_text;
using eci::test_cli::run_result;
using eci::test_cli::split;

constexpr double eps = std::numeric_limits<double>::epsilon();

/// Each test runs eci in its own scratch tree (see work_dir).
class cli_adaptive : public ::testing::Test {
   protected:
    run_result eci(const std::string& args) const { return dir_.run(args); }
    fs::path file(const std::string& name) const { return dir_.file(name); }
    eci::test_cli::work_dir dir_{"adaptive"};
};

/// The number after "key": in a JSON text (NaN if absent).
double json_number(const std::string& json, const std::string& key) {
    const auto at = json.find("\"" + key + "\": ");
    return at == std::string::npos ? std::nan("") : std::stod(json.substr(at + key.size() + 4));
}

// Rows at t = 0, 0.5, ..., 10 by steps landing on them; both invariants to round-off at every row; the JSON
// summary carries the adaptive counters.
TEST_F(cli_adaptive, ConservativeDp54WritesRowsAtOutputTimesAndKeepsInvariants) {
    const run_result r = eci("run three-wave --method c-dp54 --rtol 1e-8 --atol 1e-8 --t-end 10 --output-dt 0.5 "
                             "--output out.csv --summary-json sum.json");
    ASSERT_EQ(r.status, 0) << r.err;
    const auto lines = lines_of(read_text(file("out.csv")));
    ASSERT_EQ(lines.size(), 1u + 21u) << "header, t = 0 and 20 output times";
    const auto header = split(lines[0]);
    ASSERT_EQ(header.back(), "enstrophy");
    double e0 = 0, z0 = 0;
    for (std::size_t i = 1; i < lines.size(); ++i) {
        const auto cells = split(lines[i]);
        EXPECT_NEAR(std::stod(cells[0]), 0.5 * double(i - 1), 1e-12);
        const double e = std::stod(cells[cells.size() - 2]), z = std::stod(cells.back());
        if (i == 1) e0 = e, z0 = z;
        // round-off of a few hundred steps: 4 eps sqrt(steps) with steps < 10^4
        EXPECT_NEAR(e, e0, 400.0 * eps * e0) << "row " << i;
        EXPECT_NEAR(z, z0, 400.0 * eps * z0) << "row " << i;
    }
    const std::string json = read_text(file("sum.json"));
    EXPECT_NE(json.find("\"adaptive\": true"), std::string::npos) << json;
    EXPECT_EQ(json_number(json, "rtol"), 1e-8);
    EXPECT_GT(json_number(json, "accepted_steps"), 10.0);
    EXPECT_GE(json_number(json, "rejected_error"), 0.0);
    EXPECT_GE(json_number(json, "rejected_radicand"), 0.0);
    EXPECT_LE(json_number(json, "dt_smallest"), json_number(json, "dt_largest"));
    // c-dp54's automatic output lands a step on every output time (its xi interpolant is not as accurate as its
    // steps near zero crossings: docs/methods.md); t = 0 is the start
    EXPECT_EQ(json_number(json, "landed_outputs"), 20.0) << json;
    EXPECT_NE(r.err.find("accepted steps"), std::string::npos) << r.err;
}

// Without --output-dt: a row per accepted step; Kepler through its transform, the orbit's axis kept.
TEST_F(cli_adaptive, KeplerThroughTheTransformEveryAcceptedStep) {
    const run_result r = eci("run kepler --method c-dp54 --rtol 1e-9 --t-end 50 --output k.csv --summary-json k.json");
    ASSERT_EQ(r.status, 0) << r.err;
    const auto lines = lines_of(read_text(file("k.csv")));
    EXPECT_GT(lines.size(), 50u);
    const std::string json = read_text(file("k.json"));
    // the axis turns by round-off only (theta is known to ~eps |theta| radians)
    EXPECT_LT(std::abs(json_number(json, "runge_lenz_turn_degrees")), 1e-9) << json;
}

// Fixed steps with --output-dt: rows every k steps when output-dt = k dt, refused otherwise.
TEST_F(cli_adaptive, OutputDtWithFixedSteps) {
    run_result r = eci("run three-wave --method c-rk4 --dt 0.01 --t-end 1 --output-dt 0.25 --output f.csv");
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(lines_of(read_text(file("f.csv"))).size(), 1u + 5u);
    r = eci("run three-wave --method c-rk4 --dt 0.03 --t-end 1 --output-dt 0.25 --output g.csv");
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("not a multiple of --dt"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(file("g.csv")));
}

// Bad input: a one-line error, exit status 2, no output file.
TEST_F(cli_adaptive, BadInputIsRefused) {
    const std::vector<std::pair<std::string, std::string>> cases{
        {"--method c-dp54 --rtol -1", "rtol"},
        {"--method c-dp54 --rtol 0 --atol 0", "cannot both be zero"},
        {"--method c-dp54 --rtol nan", "rtol"},
        {"--method c-rk4 --rtol 1e-6", "no error estimate"},
        {"--method c-dp54 --rtol 1e-6 --steps 10", "--steps"},
        {"--method c-dp54 --rtol 1e-6 --output-dt 0", "--output-dt"},
        // --output-dt sets the rows' interval: a --every beside it was silently replaced by it
        {"--method c-rk4 --dt 0.01 --every 5 --output-dt 0.25", "give --every or --output-dt, not both"},
        // a first step given beyond the span, refused as Python's first_step is (the default --dt is not refused)
        {"--method c-dp54 --rtol 1e-6 --dt 2 --t-end 1", "--dt 2 exceeds the span of the run, 1"},
    };
    for (const auto& [args, what] : cases) {
        const run_result r = eci("run three-wave " + args + " --output bad.csv");
        EXPECT_EQ(r.status, 2) << args << ": " << r.err;
        EXPECT_NE(r.err.find(what), std::string::npos) << args << ": " << r.err;
        EXPECT_FALSE(fs::exists(file("bad.csv"))) << args;
    }
}

// An adaptive run's --dt is its first step only: a tiny one (t_end / dt beyond 2^53) was refused as "--t-end / --dt
// is 1e+16 steps, too many", a fixed-step grid's count, though the controller grows it within a few dozen steps (and
// Python's first_step = 1e-15 ran). Fixed steps of that size are still refused.
TEST_F(cli_adaptive, ATinyFirstStepIsNoStepCount) {
    run_result r = eci("run three-wave --method c-dp54 --rtol 1e-6 --dt 1e-15 --t-end 10 --output tiny.csv");
    ASSERT_EQ(r.status, 0) << r.err;
    const auto lines = lines_of(read_text(file("tiny.csv")));
    ASSERT_GT(lines.size(), 2u);
    EXPECT_EQ(split(lines[1])[0], "0");
    EXPECT_EQ(split(lines[2])[0], "1.0000000000000001e-15") << "the first step is the --dt given";
    EXPECT_EQ(split(lines.back())[0], "10");
    EXPECT_LT(lines.size(), 300u);
    r = eci("run three-wave --method c-rk4 --dt 1e-15 --t-end 10 --output fixed.csv");
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_NE(r.err.find("steps, too many"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(file("fixed.csv")));
}

// The minimum-step path from the command line: a step the solution cannot be followed through (a near-collision
// Kepler orbit: angular momentum 5e-16, its pericentre at ~1e-30) stops the run with exit status 1, naming the
// time and component, and leaves no output file.
TEST_F(cli_adaptive, UnreachableToleranceStopsWithAClearError) {
    const run_result r =
        eci("run kepler-cartesian --method dp54 --rtol 1e-10 --q 0.5,0 --p 0,1e-15 --t-end 10 --output m.csv");
    EXPECT_EQ(r.status, 1) << r.err;
    EXPECT_NE(r.err.find("below the minimum at t = "), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("[component p"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(file("m.csv")));
}

// An rtol below 100 eps is raised to it with a one-line warning, as Python's eci.solve and SciPy's solve_ivp do
// (it ran its 5e7 attempts before, 8 s, and failed): the run is the one asked with rtol = 100 eps, bit for bit,
// and the summary reports the rtol used. rtol = 0 with atol > 0 is raised alike.
TEST_F(cli_adaptive, RtolBelowHundredEpsIsRaisedWithAWarning) {
    const std::string floor = "2.220446049250313e-14";  // 100 eps, eci::min_rtol
    const run_result raised = eci("run three-wave --method c-dp54 --rtol 1e-30 --t-end 1 --output a.csv "
                                  "--summary-json a.json");
    ASSERT_EQ(raised.status, 0) << raised.err;
    EXPECT_NE(raised.err.find("eci: warning: the relative tolerance 1e-30 is below 100 eps; raised to " + floor),
              std::string::npos)
        << raised.err;
    EXPECT_EQ(json_number(read_text(file("a.json")), "rtol"), 100 * eps);
    const run_result given =
        eci("run three-wave --method c-dp54 --rtol " + floor + " --atol 1e-30 --t-end 1 --output b.csv");
    ASSERT_EQ(given.status, 0) << given.err;
    EXPECT_EQ(given.err.find("warning"), std::string::npos) << given.err;
    EXPECT_EQ(read_text(file("a.csv")), read_text(file("b.csv")));
    const run_result zero = eci("run three-wave --method dp54 --rtol 0 --atol 1e-300 --t-end 1 --output c.csv");
    EXPECT_EQ(zero.status, 0) << zero.err;
    EXPECT_NE(zero.err.find("the relative tolerance 0 is below 100 eps"), std::string::npos) << zero.err;
    // the default --dt (three-wave's 0.01) is the first step, shortened to a shorter span rather than refused
    const run_result short_span = eci("run three-wave --method c-dp54 --rtol 1e-8 --t-end 0.004 --output d.csv");
    ASSERT_EQ(short_span.status, 0) << short_span.err;
    const auto last = split(lines_of(read_text(file("d.csv"))).back());
    EXPECT_EQ(std::stod(last[0]), 0.004);
}

}  // namespace
