// `eci run` reads every model from its own description: the defaults --help prints are the model's,
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

#include <eci/models/list.hpp>
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

/// The --help line of option `--name` (up to the end of its description, also when wrapped onto a second line).
std::string help_line(const std::string& help, const std::string& name) {
    const auto lines = lines_of(help);
    for (std::size_t i = 0; i < lines.size(); ++i)
        if (lines[i].find(cat("  --", name, " ")) == 0) {
            // a long option name puts its description on the next line, indented
            std::string line = lines[i];
            if (i + 1 < lines.size() && lines[i + 1].find("     ") == 0) line.append(lines[i + 1]);
            return line;
        }
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

/// Each parameter's and initial-state field's --help line ends with the value the model's first preset holds (for
/// a generated model, each setting's line with its recipe's default).
template <class Model>
void expect_help_prints_the_models_defaults(const result& help) {
    if constexpr (requires { Model::recipe_parameters(); }) {
        const typename Model::recipe defaults{};
        for (const auto& s : Model::recipe_parameters())
            EXPECT_NE(
                help_line(help.out, std::string(s.name)).find(cat("(default ", std::to_string(defaults.*s.value), ")")),
                std::string::npos)
                << Model::name << " --" << s.name << "\n"
                << help.out;
    } else {
        const auto p = Model::presets()[0];
        Model m = p.model;
        for (const auto& q : Model::parameters()) {
            const auto v = q.values(m);
            const std::string values = joined({v.begin(), v.end()});
            EXPECT_NE(help_line(help.out, std::string(q.name)).find(cat("(default ", values, ")")), std::string::npos)
                << Model::name << " --" << q.name << "\n"
                << help.out;
        }
        for (const auto& f : Model::initial_condition()) {
            const std::string values = joined({p.x0.begin() + f.first, p.x0.begin() + f.first + f.count});
            EXPECT_NE(help_line(help.out, std::string(f.name)).find(cat("(default ", values, ")")), std::string::npos)
                << Model::name << " --" << f.name << "\n"
                << help.out;
        }
    }
}

TEST_F(CliModels, HelpPrintsTheDefaultsTheModelsHold) {
    eci::for_each_ode_model([&]<class Model>() {
        const result help = eci(cat("run ", Model::name, " --help"));
        ASSERT_EQ(help.status, 0) << help.err;
        expect_help_prints_the_models_defaults<Model>(help);
    });
    const result tw = eci("run three-wave --help");
    EXPECT_NE(help_line(tw.out, "K").find("(default 1.7320508075688772)"), std::string::npos) << tw.out;  // sqrt 3
    const result kp = eci("run kepler --help");
    EXPECT_NE(help_line(kp.out, "K").find("> 0 (default 1.5)"), std::string::npos) << kp.out;
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
    eci::for_each_ode_model([&]<class Model>() { expect_listed_methods<Model>(r.out); });
}

// `eci list` and `eci run` offer exactly the models of the C++ list (include/eci/models/list.hpp), in its order,
// before the spectral equations.
TEST_F(CliModels, ListShowsTheModelsOfTheModelListInItsOrder) {
    const result r = eci("list");
    ASSERT_EQ(r.status, 0) << r.err;
    std::vector<std::string> expected;
    eci::for_each_ode_model([&]<class Model>() { expected.emplace_back(Model::name); });
    std::vector<std::string> listed;
    for (const std::string& line : lines_of(r.out))
        for (const std::string& name : expected)
            if (line.find(cat("  ", name, " ")) == 0) listed.push_back(name);
    EXPECT_EQ(listed, expected) << r.out;
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
