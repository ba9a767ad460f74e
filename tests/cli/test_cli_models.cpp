// `eci run` reads every model from its own description (issue 8): the defaults --help prints are the model's,
// the methods `eci list` shows are the registry's computation, presets run the paper's set-ups, and the options
// given override them.
#include <gtest/gtest.h>

#include <charconv>
#include <complex>
#include <filesystem>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include <eci/models/kepler.hpp>
#include <eci/models/lotka_volterra.hpp>
#include <eci/models/n_wave.hpp>
#include <eci/models/three_wave.hpp>
#include <eci/registry.hpp>

#include "support.hpp"

namespace {

namespace fs = std::filesystem;

using eci::test_cli::lines_of;
using eci::test_cli::run_eci;
using result = eci::test_cli::run_result;
using eci::test_cli::scratch_dir;

class CliModels : public ::testing::Test {
   protected:
    result eci(const std::string& args) const { return run_eci(args, dir_); }

    scratch_dir scratch_{"cli-models"};
    fs::path dir_ = scratch_.path();
};

/// The pieces one after the other (appends only: GCC 12 warns, falsely, on some operator+ chains of strings).
template <class... T>
std::string cat(const T&... pieces) {
    std::string s;
    (s.append(std::string_view(pieces)), ...);
    return s;
}

/// The value after "key": in a JSON text, as text up to the next ',' or '}'.
std::string json_field(const std::string& json, const std::string& key) {
    const std::size_t at = json.find(cat("\"", key, "\": "));
    if (at == std::string::npos) return "";
    const std::size_t from = at + key.size() + 4;
    return json.substr(from, json.find_first_of(",}\n", from) - from);
}

std::string shortest(double v) {
    char buffer[32];
    const auto r = std::to_chars(buffer, buffer + sizeof buffer, v);
    return std::string(buffer, r.ptr);
}

/// The --help line of option `--name` (up to the end of its description).
std::string help_line(const std::string& help, const std::string& name) {
    for (const std::string& line : lines_of(help))
        if (line.find(cat("  --", name, " ")) == 0) return line;
    return "";
}

/// "a,b,c": the values as --help prints them (appends only: GCC 12 warns, falsely, on operator+ chains).
std::string joined(const std::vector<double>& values) {
    std::string s;
    for (double v : values) {
        if (!s.empty()) s.push_back(',');
        s.append(shortest(v));
    }
    return s;
}

/// Each parameter's and initial-state field's --help line ends with the value the model's first preset holds.
template <class Model>
void expect_help_prints_the_models_defaults(const result& help) {
    const auto p = Model::presets()[0];
    Model m = p.model;
    for (const auto& q : Model::parameters()) {
        const auto v = q.values(m);
        const std::string values = joined({v.begin(), v.end()});
        EXPECT_NE(help_line(help.out, std::string(q.name)).find(cat("(default ", values, ")")), std::string::npos)
            << q.name << "\n"
            << help.out;
    }
    for (const auto& f : Model::initial_condition()) {
        const std::string values = joined({p.x0.begin() + f.first, p.x0.begin() + f.first + f.count});
        EXPECT_NE(help_line(help.out, std::string(f.name)).find(cat("(default ", values, ")")), std::string::npos)
            << f.name << "\n"
            << help.out;
    }
}

TEST_F(CliModels, HelpPrintsTheDefaultsTheModelsHold) {
    const result tw = eci("run three-wave --help");
    ASSERT_EQ(tw.status, 0) << tw.err;
    expect_help_prints_the_models_defaults<eci::three_wave>(tw);
    EXPECT_NE(help_line(tw.out, "K").find("(default 1.7320508075688772)"), std::string::npos) << tw.out;  // sqrt 3
    const result lv = eci("run lotka-volterra --help");
    ASSERT_EQ(lv.status, 0) << lv.err;
    expect_help_prints_the_models_defaults<eci::lotka_volterra>(lv);
    const result kp = eci("run kepler --help");
    ASSERT_EQ(kp.status, 0) << kp.err;
    expect_help_prints_the_models_defaults<eci::kepler>(kp);
    EXPECT_NE(help_line(kp.out, "K").find("> 0 (default 1.5)"), std::string::npos) << kp.out;
    const result nw = eci("run n-wave --help");
    ASSERT_EQ(nw.status, 0) << nw.err;
    const eci::n_wave<double>::recipe defaults{};
    EXPECT_NE(help_line(nw.out, "modes").find(cat("(default ", std::to_string(defaults.modes), ")")), std::string::npos)
        << nw.out;
}

/// The methods line of `eci list` for a model: the registry's methods_for<Model>, in list order.
template <class Model>
void expect_listed_methods(const std::string& list) {
    std::string expected = "methods:";
    for (std::string_view m : eci::method_names_for<Model>()) expected.append(" ").append(m);
    const auto lines = lines_of(list);
    for (std::size_t i = 0; i + 1 < lines.size(); ++i)
        if (lines[i].find(cat("  ", Model::name, " ")) == 0) {
            EXPECT_NE(lines[i + 1].find(cat(expected, " (default")), std::string::npos) << lines[i + 1];
            return;
        }
    ADD_FAILURE() << Model::name << " is not listed:\n" << list;
}

TEST_F(CliModels, ListShowsTheMethodsTheRegistryComputesForEachModel) {
    const result r = eci("list");
    ASSERT_EQ(r.status, 0) << r.err;
    expect_listed_methods<eci::three_wave>(r.out);
    expect_listed_methods<eci::n_wave<double>>(r.out);
    expect_listed_methods<eci::n_wave<std::complex<double>>>(r.out);
    expect_listed_methods<eci::lotka_volterra>(r.out);
    expect_listed_methods<eci::kepler>(r.out);
}

// The review found `eci run kepler --method implicit-midpoint` refused although the bench runs it.
TEST_F(CliModels, KeplerRunsImplicitMidpoint) {
    const result r = eci("run kepler --method implicit-midpoint --summary-json -");
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(json_field(r.out, "method"), "\"implicit-midpoint\"");
    EXPECT_EQ(json_field(r.out, "steps"), "1000");
    EXPECT_NE(r.out.find("\"solver\""), std::string::npos);  // its fixed-point iterations are reported
}

TEST_F(CliModels, PresetRunsThePapersSetUpAndOptionsOverrideIt) {
    const auto fig8 = eci::find_preset<eci::kepler>("fig8");
    const result r = eci("run kepler --preset fig8 --summary-json -");
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(json_field(r.out, "method"), cat("\"", fig8.method, "\""));
    EXPECT_EQ(json_field(r.out, "steps"), std::to_string(fig8.steps()));  // 1313
    EXPECT_EQ(json_field(r.out, "dt"), "0.080000000000000002");
    const result o = eci("run kepler --preset fig8 --dt 0.01 --steps 7 --K 2 --summary-json -");
    ASSERT_EQ(o.status, 0) << o.err;
    EXPECT_EQ(json_field(o.out, "method"), "\"pc\"");
    EXPECT_EQ(json_field(o.out, "steps"), "7");
    EXPECT_EQ(json_field(o.out, "dt"), "0.01");
    // K = 2 moved the energy: H(0) = ell^2 / (2 m r^2) - K / r = 0.5 - 2 at r = 1.
    EXPECT_NE(o.out.find("\"hamiltonian\": {\"initial\": -1.5,"), std::string::npos) << o.out;
}

TEST_F(CliModels, DefaultRunIsTheFirstPreset) {
    const auto first = eci::lotka_volterra::presets()[0];
    const result r = eci("run lotka-volterra --steps 3 --summary-json -");
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(json_field(r.out, "method"), cat("\"", first.method, "\""));
    EXPECT_EQ(json_field(r.out, "dt"), shortest(first.dt));
}

TEST_F(CliModels, UnknownPresetIsBadInputNamingThePresets) {
    const result r = eci("run kepler --preset fig1 --output out.csv");
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(lines_of(r.err).size(), 1u) << r.err;
    EXPECT_NE(r.err.find("unknown preset 'fig1' (presets: fig9, fig8)"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(dir_ / "out.csv"));
}

TEST_F(CliModels, VectorOptionNeedsAllItsValues) {
    const result r = eci("run three-wave --M 1,-1");
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(lines_of(r.err).size(), 1u) << r.err;
}

}  // namespace
