// Property test of the whole CLI: random argument vectors (random models, methods, parameters, initial
// conditions, step sizes, outputs, malformed and extreme numbers), each run bounded in time, against the
// contract: exit 0 with finite numbers and conserved invariants kept to their round-off bound, or exit 1/2
// with exactly one line on stderr; never a leftover or destroyed file, never a hang.
// ECI_FUZZ_SECONDS (default 20) bounds the whole test, ECI_FUZZ_SEED (default 1) picks the sequence;
// tests/fuzz/long_fuzz.sh runs it for minutes with a fresh seed.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <eci/models/list.hpp>
#include <eci/registry.hpp>

#include "support.hpp"

namespace {

namespace fs = std::filesystem;
using eci::test_cli::lines_of;
using eci::test_cli::read_text;
using eci::test_cli::run_result;
using eci::test_cli::shell_quote;

constexpr double eps = std::numeric_limits<double>::epsilon();

class generator {
   public:
    explicit generator(std::uint64_t seed) : rng_(seed) {}

    double uniform(double a, double b) { return std::uniform_real_distribution<double>(a, b)(rng_); }
    bool chance(double p) { return uniform(0.0, 1.0) < p; }
    std::size_t below(std::size_t n) { return std::uniform_int_distribution<std::size_t>(0, n - 1)(rng_); }
    template <class T>
    const T& pick(const std::vector<T>& v) { return v[below(v.size())]; }

    static std::string text(double v) {
        std::ostringstream s;
        s.precision(17);
        s << v;
        return s.str();
    }

    /// A number: mostly of a sensible scale around `typical`, sometimes extreme, sometimes malformed.
    std::string number(double typical, bool positive) {
        const double r = uniform(0.0, 1.0);
        if (r < 0.70) {
            const double v = typical * std::pow(10.0, uniform(-1.5, 1.5));
            return text(positive || chance(0.7) ? v : -v);
        }
        if (r < 0.85)
            return pick<std::string>({"0", "-0", "1e-320", "4.9e-324", "1e-300", "1e300", "1.7e308", "1e-160",
                                      "1e160", "-1e300", "nan", "inf", "-inf", "1e400", "2.2250738585072014e-308"});
        if (r < 0.93)
            return pick<std::string>({"", "abc", "1,2", "0x1p3", " 1", "1e", "--", "1.5x", "18446744073709551616",
                                      "-", "1..2", "+", "e5"});
        return text(typical);
    }

    /// A count: mostly small, sometimes huge, negative or malformed.
    std::string count(std::uint64_t typical) {
        const double r = uniform(0.0, 1.0);
        if (r < 0.8) return std::to_string(1 + below(static_cast<std::size_t>(typical)));
        return pick<std::string>({"0", "-1", "", "1.5", "99999999999999999999", "18446744073709551615",
                                  "18446744073709551616", "9999999999999999999", "abc", "1e3", "4294967297"});
    }

    std::mt19937_64& engine() { return rng_; }

   private:
    std::mt19937_64 rng_;
};

struct fuzz_case {
    std::vector<std::string> args;
    std::string model, method;
    std::string checkpoint, wisdom;  // a spectral run's --checkpoint and --fftw-wisdom, if given
    std::string plot;                // --plot, if given
    bool csv = false, json = false, csv_old = false, json_old = false, adaptive = false;
};

// What `eci list` and `eci run MODEL --help` say, read once: the models (a model added to the list is fuzzed without
// a line here), and each model's own options (those after --preset), for a model without a branch of its own below.
struct model_option {
    std::string flag;
    std::size_t count = 1;  // comma-separated values
    bool whole = false, text = false;
};

std::vector<std::string> fuzzed_models() {
    static const std::vector<std::string> models = [] {
        const eci::test_cli::work_dir dir("fuzz-models");
        std::vector<std::string> listed;
        bool in_models = false;
        for (const std::string& line : lines_of(dir.run(std::vector<std::string>{"list"}).out)) {
            if (line.rfind("Models", 0) == 0) in_models = true;
            else if (line.rfind("Methods", 0) == 0) in_models = false;
            else if (in_models && line.size() > 2 && line.rfind("  ", 0) == 0 && line[2] != ' ')
                listed.push_back(line.substr(2, line.find(' ', 2) - 2));
        }
        return listed;
    }();
    return models;
}

const std::vector<model_option>& model_options(const std::string& model) {
    static std::map<std::string, std::vector<model_option>> known;
    if (const auto it = known.find(model); it != known.end()) return it->second;
    const eci::test_cli::work_dir dir("fuzz-help");
    std::vector<model_option> options;
    bool after_preset = false;
    for (const std::string& line : lines_of(dir.run(std::vector<std::string>{"run", model, "--help"}).out)) {
        if (line.rfind("  --", 0) != 0) continue;
        const std::size_t end = line.find(' ', 2);
        const std::string flag = line.substr(2, end - 2), rest = end == std::string::npos ? "" : line.substr(end);
        if (flag == "--preset") {
            after_preset = true;
            continue;
        }
        if (!after_preset) continue;
        model_option o{flag};
        if (const std::size_t x = rest.find(" x "); x != std::string::npos && x < 30) o.count = std::stoul(rest.substr(x + 3));
        o.whole = rest.find("INT>=") != std::string::npos;
        o.text = rest.find("TEXT") != std::string::npos;
        options.push_back(o);
    }
    return known[model] = options;
}

bool is_spectral(const std::string& model) {
    const auto& o = model_options(model);
    return std::ranges::any_of(o, [](const model_option& m) { return m.flag == "--N"; });
}

// Whether `model` is one of THE ODE list (include/eci/models/list.hpp); every other model `eci list` names is a
// spectral equation.
bool is_ode_model(const std::string& model) {
    bool found = false;
    eci::for_each_ode_model([&]<class M>() { found = found || M::name == model; });
    return found;
}

// The checkpoint a spectral run writes when stopped without --checkpoint.
std::string default_checkpoint(const std::string& model) {
    return model == "navier-stokes-2d" ? "ns2d-checkpoint.h5" : model + "-checkpoint.h5";
}

fuzz_case make_case(generator& g) {
    // Every model `eci run` offers (a test below checks this list against `eci list`).
    const std::vector<std::string>& models = fuzzed_models();
    std::vector<std::string> methods;
    for (const eci::method_info& m : eci::methods) methods.emplace_back(m.name);
    fuzz_case c;
    c.model = g.pick(models);
    std::vector<std::pair<std::string, std::string>> options;  // (flag, value); value may hold commas
    auto opt = [&](const std::string& flag, const std::string& value, double p = 0.5) {
        if (g.chance(p)) options.emplace_back(flag, value);
    };
    if (c.model == "three-wave") {
        // Half the time coefficients obeying eqs. (2)-(3) for random K, P, Q; otherwise whatever comes.
        const double K = g.uniform(0.3, 5), P = g.uniform(0.3, 5), Q = g.uniform(0.3, 5);
        if (g.chance(0.5)) {
            opt("--K", generator::text(K), 1.0), opt("--P", generator::text(P), 1.0), opt("--Q", generator::text(Q), 1.0);
            const double s = std::pow(10.0, g.uniform(-2, 2));
            opt("--M", generator::text(s * (P * P - Q * Q)) + "," + generator::text(s * (Q * Q - K * K)) + "," +
                           generator::text(s * (K * K - P * P)), 0.9);
        } else {
            opt("--K", g.number(1.7, true)), opt("--P", g.number(3, true)), opt("--Q", g.number(2.4, true));
            opt("--M", g.number(1, false) + "," + g.number(1, false) + "," + g.number(2, false));
        }
        opt("--psi", g.number(1, false) + "," + g.number(1, false) + "," + g.number(1, false));
    } else if (c.model == "lotka-volterra") {
        opt("--mu", g.number(1.5, true)), opt("--x", g.number(1, true)), opt("--y", g.number(0.4, true));
    } else if (c.model == "kepler") {
        opt("--m", g.number(1, true)), opt("--K", g.number(1.5, true)), opt("--ell", g.number(1, false));
        opt("--r", g.number(1, true)), opt("--v-r", g.number(0.3, false)), opt("--theta", g.number(1, false));
    } else if (c.model == "rigid-body") {
        opt("--alpha", g.number(1.8, true)), opt("--beta", g.number(0.6, true));
        opt("--u", g.number(0.1, false) + "," + g.number(1, false) + "," + g.number(1, false));
    } else if (c.model == "kepler-cartesian") {
        opt("--q", g.number(0.5, false) + "," + g.number(0.1, false));
        opt("--p", g.number(0.1, false) + "," + g.number(1.7, false));
    } else if (c.model == "nonlinear-oscillator") {
        opt("--u", g.number(1, false) + "," + g.number(0.2, false));
    } else if (c.model == "exp-entropy") {
        opt("--uv", g.number(1, false) + "," + g.number(0.5, false));
    } else if (is_spectral(c.model)) {
        // Small grids (odd and tiny ones are bad input); no wisdom file outside the scratch directory.
        opt("--N", g.chance(0.9) ? std::to_string(2 * (4 + g.below(13))) : g.count(40), 1.0);
        opt("--fftw-estimate", "", 1.0);
        // The files written by name: good names, names of other outputs, missing directories
        opt("--fftw-wisdom", g.chance(0.7) ? "none" : g.pick<std::string>({"w", "o.csv", "ck.h5", "nodir/w"}), 1.0);
        opt("--checkpoint", g.pick<std::string>({"ck.h5", "o.csv", "s.json", "nodir/ck.h5", "snaps"}), 0.3);
        opt("--checkpoint-every", g.count(20), 0.2);
        opt("--snapshot-every", g.count(10), 0.1);
        opt("--snapshot-dir", g.pick<std::string>({"snaps", "o.csv", "nodir/snaps"}), 0.1);
        if (c.model == "charney-hasegawa-mima") opt("--beta", g.number(1, false), 0.3), opt("--deformation", g.number(1, true), 0.3);
        opt("--nu", g.number(0.01, true), 0.3), opt("--cfl", g.number(0.5, true), 0.3);
        opt("--output-dt", g.number(0.05, true), 0.15);  // the CFL step shortened to divide it, or a --dt checked
        opt("--ic", g.pick<std::string>({"random", "vortex-pair", "taylor-green", "missing.h5"}), 0.5);
        opt("--forcing", g.pick<std::string>({"none", "deterministic", "stochastic", "x"}), 0.3);
    } else if (c.model == "n-wave" || c.model == "n-wave-complex") {
        opt("--modes", g.count(60)), opt("--triads-per-mode", g.count(25));
        opt("--seed", g.chance(0.8) ? std::to_string(g.engine()()) : g.count(1000));
    } else {
        // a model without a branch of its own: each of its options (from its --help) at a sensible scale, or not
        for (const model_option& o : model_options(c.model)) {
            std::string value;
            for (std::size_t i = 0; i < o.count; ++i)
                value += (i ? "," : "") + (o.whole ? g.count(10) : o.text ? g.pick<std::string>({"x", ""}) : g.number(1, false));
            opt(o.flag, value, 0.3);
        }
    }
    opt("--preset", g.pick<std::string>({"standard", "default", "fig2", "nope"}), 0.1);
    c.method = g.chance(0.85) ? g.pick(methods) : g.pick<std::string>({"", "nope", "c-pc "});
    if (!c.method.empty() || g.chance(0.5)) opt("--method", c.method, 0.85);
    opt("--dt", g.chance(0.8) ? generator::text(std::pow(10.0, g.uniform(-3.5, 0.3))) : g.number(0.01, true), 0.7);
    const double span = g.uniform(0.0, 1.0);
    if (span < 0.45)
        opt("--t-end", g.chance(0.85) ? generator::text(std::pow(10.0, g.uniform(-3, 2.5))) : g.number(10, true), 1.0);
    else if (span < 0.9)
        opt("--steps", g.chance(0.85) ? std::to_string(g.below(20000)) : g.count(1000), 1.0);
    opt("--every", g.count(50), 0.2);
    // Adaptive step control now and then (its own counters, rejections and dense output rows).
    if (g.chance(0.15)) {
        c.adaptive = true;
        opt("--rtol", g.chance(0.85) ? generator::text(std::pow(10.0, g.uniform(-12, -1))) : g.number(1e-6, true), 1.0);
        opt("--atol", generator::text(std::pow(10.0, g.uniform(-12, -1))), 0.3);
        opt("--output-dt", g.number(0.5, true), 0.3);
    } else if (!is_spectral(c.model)) {
        opt("--output-dt", g.number(0.1, true), 0.05);  // fixed steps: a multiple of --dt, or refused
    }
    if (g.chance(0.5)) {
        c.csv = true;
        opt("--output", g.chance(0.9) ? "o.csv" : "-", 1.0);
        if (options.back().second == "-") c.csv = false;
        c.csv_old = c.csv && g.chance(0.3);
    }
    // a picture now and then (drawn by gnuplot: slow), under good, bad and shared names
    opt("--plot", g.pick<std::string>({"p.png", "p.svg", "p.gif", "o.csv", "nodir/p.png"}), 0.04);
    if (g.chance(0.35)) {
        c.json = true;
        c.json_old = g.chance(0.3);
        opt("--summary-json", "s.json", 1.0);
    }
    if (g.chance(0.03)) options.emplace_back("--bogus", "1");
    for (const auto& [flag, value] : options)
        if (flag == "--checkpoint") c.checkpoint = value;
        else if (flag == "--plot") c.plot = value;
        else if (flag == "--fftw-wisdom" && value != "none") c.wisdom = value;
    std::shuffle(options.begin(), options.end(), g.engine());
    c.args = {"run"};
    // Now and then an option before the model name, as `eci run --dt 0.1 three-wave` would have it.
    if (!options.empty() && g.chance(0.05)) {
        c.args.push_back(options.front().first), c.args.push_back(options.front().second);
        options.erase(options.begin());
    }
    c.args.push_back(c.model);
    for (const auto& [flag, value] : options) {
        if (flag == "--fftw-estimate") {  // a flag without a value
            c.args.push_back(flag);
        } else if (g.chance(0.2) && !value.empty() && value.find(',') == std::string::npos) {
            c.args.push_back(flag + "=" + value);
        } else {
            c.args.push_back(flag);
            c.args.push_back(value);
        }
    }
    return c;
}

std::string describe(const fuzz_case& c) {
    std::string s = "eci";
    for (const std::string& a : c.args) s.append(" ").append(shell_quote(a));
    return s;
}

/// The numbers of "  steps N, step reductions M, ..." and of each invariant row of the summary.
struct summary_view {
    double steps = -1, reductions = -1;
    std::map<std::string, std::vector<std::string>> invariants;  // name -> initial, final, abs, rel
};

summary_view parse_summary(const std::string& err) {
    summary_view v;
    bool table = false;
    for (const std::string& line : lines_of(err)) {
        std::istringstream in(line);
        std::vector<std::string> words;
        for (std::string w; in >> w;) words.push_back(w);
        if (words.size() >= 5 && words[0] == "steps" && words[2] == "step") {
            v.steps = std::strtod(words[1].c_str(), nullptr);
            v.reductions = std::strtod(words[4].c_str(), nullptr);
        } else if (!words.empty() && words[0] == "invariant") {
            table = true;
        } else if (table && words.size() == 5) {
            v.invariants[words[0]] = {words[1], words[2], words[3], words[4]};
        } else {
            table = false;
        }
    }
    return v;
}

bool is_non_finite_token(std::string t) {
    while (!t.empty() && (t.back() == ',' || t.back() == ')')) t.pop_back();
    std::transform(t.begin(), t.end(), t.begin(), [](unsigned char ch) { return char(std::tolower(ch)); });
    if (!t.empty() && (t[0] == '-' || t[0] == '+')) t.erase(0, 1);
    return t == "inf" || t == "nan" || t == "infinity";
}

/// Checks one run against the contract; returns the failures (empty if none).
std::vector<std::string> check(const fuzz_case& c, const run_result& r, const fs::path& work) {
    std::vector<std::string> bad;
    const auto err_lines = lines_of(r.err);
    if (r.status == 137 || r.status == -1) bad.push_back("hang: killed after ignoring SIGINT");
    if (r.status != 0 && r.status != 1 && r.status != 2 && r.status != 130)
        bad.push_back("exit status " + std::to_string(r.status));
    if (r.status != 0) {
        if (err_lines.size() != 1 || r.err.rfind("eci: error: ", 0) != 0)
            bad.push_back("a failure must print one line 'eci: error: ...', got:\n" + r.err);
    } else {
        std::istringstream in(r.err);
        for (std::string w; in >> w;)
            if (is_non_finite_token(w)) bad.push_back("non-finite number in the summary:\n" + r.err);
        const summary_view s = parse_summary(r.err);
        const auto method = eci::find_method(c.method.empty() ? "c-pc" : c.method);
        // The invariants of these models are sums of non-negative terms, so |I(0)| is their scale and the
        // relative drift of an exactly conservative method is a few eps per step, k eps (steps + reductions)
        // at worst (rounding errors that do not cancel). The implicit midpoint rule stops its iteration within
        // 1e3 eps of round-off (implicit_midpoint.hpp), so its per-step bound is that.
        // Lotka-Volterra's H is not quadratic: there only the transformed methods (c-*) conserve it; the
        // implicit midpoint rule conserves quadratic invariants only.
        const bool sums_of_squares =
            c.model == "three-wave" || c.model == "n-wave" || c.model == "n-wave-complex" || c.model == "lotka-volterra";
        const bool conserves_here =
            method && method->conservative && (c.model != "lotka-volterra" || method->name.substr(0, 2) == "c-");
        if (conserves_here && sums_of_squares && !c.adaptive && s.steps >= 0) {
            const double per_step = method->name == "implicit-midpoint" ? 2048.0 : 64.0;
            const double bound = per_step * eps * (s.steps + s.reductions + 1.0);
            for (const auto& [name, v] : s.invariants) {
                const double rel = v[3] == "n/a" ? 0.0 : std::strtod(v[3].c_str(), nullptr);
                if (!(rel <= bound))
                    bad.push_back(name + " drifted by " + v[3] + " relative, bound " + generator::text(bound));
            }
        }
        for (std::string w : {"o.csv"})
            if (c.csv && !fs::exists(work / w)) bad.push_back("exit 0 without " + w);
        if (c.json && !fs::exists(work / "s.json")) bad.push_back("exit 0 without s.json");
    }
    // Files: on failure the old ones untouched and no new one; never a temporary.
    std::set<std::string> expected;
    if (c.csv_old || (r.status == 0 && c.csv)) expected.insert("o.csv");
    if (c.json_old || (r.status == 0 && c.json)) expected.insert("s.json");
    if (r.status == 0 && (c.plot == "p.png" || c.plot == "p.svg")) expected.insert(c.plot);
    // an interrupted run (the 5 s limit) keeps its outputs so far, if it had stepped, as complete files
    if (r.status == 130) {
        if (c.csv && fs::exists(work / "o.csv")) {
            expected.insert("o.csv");
            if (const std::string why = eci::test_cli::incomplete_csv(read_text(work / "o.csv")); !why.empty())
                bad.push_back("interrupted, o.csv kept incomplete: " + why);
        }
        if (c.json && fs::exists(work / "s.json")) expected.insert("s.json");
    }
    // A spectral run that started (its input good) may leave its checkpoint (an interrupted or failed run keeps
    // its state there: that is its contract), its wisdom file and, on success, its snapshots; a refused one nothing.
    std::set<std::string> allowed;
    if (is_spectral(c.model) && r.status != 2) {
        allowed = {default_checkpoint(c.model), "ck.h5", "w"};
        // the checkpoint and the wisdom file by the names given (a run accepted with --checkpoint s.json and no
        // --summary-json keeps its checkpoint there: only names that two outputs share are refused)
        for (const std::string& name : {c.checkpoint, c.wisdom})
            if (!name.empty()) allowed.insert(name);
        if (r.status == 0 || r.status == 130) {  // (an interrupted run keeps the snapshots it took)
            allowed.insert("snaps");
            allowed.insert(c.model == "navier-stokes-2d" ? "ns2d-snapshots" : c.model + "-snapshots");
        }
    }
    std::set<std::string> present;
    for (const auto& e : fs::directory_iterator(work)) {
        const std::string name = e.path().filename().string();
        if (allowed.count(name) && !expected.count(name)) expected.insert(name);
        present.insert(name);
    }
    for (const std::string& dir : present)
        if (fs::is_directory(work / dir))
            for (const auto& e : fs::directory_iterator(work / dir))
                if (e.path().filename().string().find("tmp") != std::string::npos)
                    bad.push_back("temporary left: " + dir + "/" + e.path().filename().string());
    if (present != expected) {
        std::string list;
        for (const auto& p : present) list += " " + p;
        bad.push_back("files left:" + list);
    }
    if (r.status != 0 && r.status != 130) {
        if (c.csv_old && read_text(work / "o.csv") != "old\n") bad.push_back("a failed run changed o.csv");
        if (c.json_old && read_text(work / "s.json") != "old\n") bad.push_back("a failed run changed s.json");
    }
    return bad;
}

double env_number(const char* name, double fallback) {
    const char* v = std::getenv(name);
    return v && *v ? std::strtod(v, nullptr) : fallback;
}

// The fuzz reaches every model `eci list` names (read from it: a model added to the list is fuzzed, with the
// options its --help lists if it has no branch of its own in make_case), and each one's options are found.
TEST(fuzz, covers_every_model_eci_lists) {
    const std::vector<std::string>& models = fuzzed_models();
    ASSERT_GE(models.size(), 9u);
    EXPECT_EQ(std::set<std::string>(models.begin(), models.end()).size(), models.size());
    for (const char* m : {"three-wave", "n-wave", "lotka-volterra", "kepler", "exp-entropy"})
        EXPECT_NE(std::ranges::find(models, m), models.end()) << m;
    for (const std::string& m : models) {
        EXPECT_FALSE(model_options(m).empty()) << m << ": no options of its own found in its --help";
        EXPECT_EQ(is_spectral(m), !is_ode_model(m)) << m;  // not a list of names: a new equation is spectral too
    }
    const auto& three_wave = model_options("three-wave");
    ASSERT_EQ(three_wave.size(), 5u);  // --K --P --Q --M x 3 --psi x 3
    EXPECT_EQ(three_wave[3].flag, "--M");
    EXPECT_EQ(three_wave[3].count, 3u);
}

TEST(fuzz, random_command_lines_keep_the_contract) {
    const double budget = env_number("ECI_FUZZ_SECONDS", 20.0);
    const auto seed = static_cast<std::uint64_t>(env_number("ECI_FUZZ_SEED", 1.0));
    generator g(seed);
    const eci::test_cli::work_dir dir("fuzz");
    const fs::path& work = dir.path();
    std::map<int, int> statuses;
    int cases = 0, failures = 0;
    const auto start = std::chrono::steady_clock::now();
    while (std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() < budget) {
        const fuzz_case c = make_case(g);
        dir.clear();
        if (c.csv_old) std::ofstream(work / "o.csv") << "old\n";
        if (c.json_old) std::ofstream(work / "s.json") << "old\n";
        std::string args;
        for (const std::string& a : c.args) args.append(" ").append(shell_quote(a));
        // Each run gets 5 s, then SIGINT (which it must honour: 130), then SIGKILL 2 s later (a hang: 137).
        const run_result r = dir.run(args, "timeout --preserve-status -s INT -k 2 5");
        ++cases;
        ++statuses[r.status];
        const auto bad = check(c, r, work);
        if (!bad.empty()) {
            ++failures;
            std::string all;
            for (const auto& b : bad) all += "\n  " + b;
            ADD_FAILURE() << "seed " << seed << ", case " << cases << ": " << describe(c) << all;
            if (failures >= 10) break;
        }
    }
    std::string histogram;
    for (const auto& [status, n] : statuses) histogram += " exit " + std::to_string(status) + ": " + std::to_string(n) + ";";
    std::printf("fuzz: seed %llu, %d cases in %.0f s;%s\n", static_cast<unsigned long long>(seed), cases,
                std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), histogram.c_str());
    ::testing::Test::RecordProperty("cases", cases);
    EXPECT_GT(cases, 10);
    EXPECT_GT(statuses[0], 0);  // the generator must also make valid runs, or it tests only the parser
}

}  // namespace
