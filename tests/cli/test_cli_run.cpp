// Tests of `eci run` and `eci list` through the real binary (ECI_CLI_PATH), each in a fresh temporary
// directory: bad input, CSV layout and thinning, the JSON summary, conservation, no partial output.
#include <gtest/gtest.h>


#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <eci/models/three_wave.hpp>
#include <eci/registry.hpp>

#include "support.hpp"

namespace {

namespace fs = std::filesystem;
using eci::test_cli::lines_of;
using eci::test_cli::read_text;
using eci::test_cli::run_result;
using eci::test_cli::split;

constexpr double eps = std::numeric_limits<double>::epsilon();

/// A test with its own directory tree (see work_dir), removed at the end.
class cli : public ::testing::Test {
   protected:
    /// Runs eci with args in work/; `wrapper` (a command prefix such as timeout) runs it, if given.
    run_result eci(const std::vector<std::string>& args, const std::string& wrapper = "") const {
        return dir_.run(args, wrapper);
    }
    std::set<std::string> work_files() const { return dir_.files(); }
    fs::path work(const std::string& name) const { return dir_.file(name); }

   private:
    eci::test_cli::work_dir dir_{"cli-test"};
};

/// A CSV file: its header and its rows as numbers.
struct csv_table {
    std::vector<std::string> header;
    std::vector<std::vector<double>> rows;

    std::size_t column(const std::string& name) const {
        for (std::size_t i = 0; i < header.size(); ++i)
            if (header[i] == name) return i;
        throw std::runtime_error("no column " + name);
    }
};

csv_table parse_csv(const std::string& text) {
    csv_table t;
    const auto lines = lines_of(text);
    if (lines.empty()) throw std::runtime_error("empty CSV");
    t.header = split(lines[0], ',');
    for (std::size_t i = 1; i < lines.size(); ++i) {
        std::vector<double> row;
        for (const std::string& cell : split(lines[i], ',')) {
            std::size_t used = 0;
            row.push_back(std::stod(cell, &used));
            if (used != cell.size()) throw std::runtime_error("bad CSV number " + cell);
        }
        if (row.size() != t.header.size()) throw std::runtime_error("CSV row " + std::to_string(i) + " is ragged");
        t.rows.push_back(row);
    }
    return t;
}

/// A minimal JSON reader: flattens a document into "a.b.c" -> scalar text (numbers, true/false/null, strings
/// without their quotes; an array's elements as "a.0", "a.1", ... with "a.length"). Throws on anything malformed, so a broken summary fails the test.
class json_reader {
   public:
    explicit json_reader(const std::string& text) : s_(text) {
        value("");
        skip_space();
        if (i_ != s_.size()) throw std::runtime_error("trailing text after JSON");
    }
    std::map<std::string, std::string> values;

    bool has(const std::string& key) const { return values.count(key) != 0; }
    double number(const std::string& key) const {
        const auto it = values.find(key);
        if (it == values.end()) throw std::runtime_error("missing JSON key " + key);
        std::size_t used = 0;
        const double v = std::stod(it->second, &used);
        if (used != it->second.size()) throw std::runtime_error("not a number: " + key);
        return v;
    }

   private:
    void skip_space() {
        while (i_ < s_.size() && std::isspace(static_cast<unsigned char>(s_[i_]))) ++i_;
    }
    void expect(char c) {
        skip_space();
        if (i_ >= s_.size() || s_[i_] != c) throw std::runtime_error(std::string("JSON: expected ") + c);
        ++i_;
    }
    std::string string() {
        expect('"');
        std::string out;
        while (i_ < s_.size() && s_[i_] != '"') {
            if (s_[i_] == '\\') ++i_;
            out += s_[i_++];
        }
        expect('"');
        return out;
    }
    void value(const std::string& path) {
        skip_space();
        if (i_ >= s_.size()) throw std::runtime_error("JSON ends early");
        if (s_[i_] == '{') {
            ++i_;
            skip_space();
            if (s_[i_] == '}') {
                ++i_;
                return;
            }
            for (;;) {
                const std::string key = string();
                expect(':');
                value(path.empty() ? key : path + "." + key);
                skip_space();
                if (s_[i_] == ',') {
                    ++i_;
                    continue;
                }
                expect('}');
                return;
            }
        }
        if (s_[i_] == '"') {
            values[path] = string();
            return;
        }
        if (s_[i_] == '[') {  // an array: "a.0", "a.1", ... and its length as "a.length"
            ++i_;
            std::size_t n = 0;
            skip_space();
            if (s_[i_] != ']') {
                for (;; ++n) {
                    value(path + "." + std::to_string(n));
                    skip_space();
                    if (s_[i_] != ',') break;
                    ++i_;
                }
                ++n;
            }
            expect(']');
            values[path + ".length"] = std::to_string(n);
            return;
        }
        const std::size_t start = i_;
        while (i_ < s_.size() && (std::isalnum(static_cast<unsigned char>(s_[i_])) || s_[i_] == '.' ||
                                  s_[i_] == '-' || s_[i_] == '+'))
            ++i_;
        if (i_ == start) throw std::runtime_error("JSON: unexpected character");
        values[path] = s_.substr(start, i_ - start);
    }

    const std::string& s_;
    std::size_t i_ = 0;
};

// ---------------------------------------------------------------------------------------------------------
// Bad input: exit 2, one line "eci: error: ..." on stderr, nothing written, nothing clobbered.

struct bad_case {
    const char* label;
    std::vector<std::string> args;
};

// Test names show the label, not the bytes of the struct.
void PrintTo(const bad_case& c, std::ostream* os) { *os << c.label; }

// Every case also asks for out.csv and out.json, so each must fail before (or without) leaving them.
const std::vector<bad_case> bad_cases = {
    {"unknown_model", {"run", "bogus"}},
    {"unknown_method", {"run", "three-wave", "--method", "rk5"}},
    {"method_the_model_does_not_support", {"run", "three-wave", "--method", "kahan"}},
    {"zero_dt", {"run", "three-wave", "--dt", "0"}},
    {"negative_dt", {"run", "three-wave", "--dt", "-0.1"}},
    {"nan_dt", {"run", "three-wave", "--dt", "nan"}},
    {"infinite_dt", {"run", "three-wave", "--dt", "inf"}},
    {"dt_not_a_number", {"run", "three-wave", "--dt", "abc"}},
    {"negative_t_end", {"run", "three-wave", "--t-end", "-1"}},
    {"nan_t_end", {"run", "three-wave", "--t-end", "nan"}},
    {"nan_initial_condition", {"run", "three-wave", "--psi", "nan,0,1"}},
    {"infinite_initial_condition", {"run", "three-wave", "--psi", "1,inf,1"}},
    {"two_values_for_psi", {"run", "three-wave", "--psi", "1,2"}},
    {"coupling_violating_eq2", {"run", "three-wave", "--M", "1,1,1"}},
    {"wavenumbers_violating_eq3", {"run", "three-wave", "--K", "2"}},
    {"t_end_together_with_steps", {"run", "three-wave", "--t-end", "1", "--steps", "10"}},
    {"negative_steps", {"run", "three-wave", "--steps", "-3"}},
    {"every_zero", {"run", "three-wave", "--every", "0"}},
    {"n_wave_with_two_modes", {"run", "n-wave", "--modes", "2"}},
    {"n_wave_independent_triads_need_multiple_of_3", {"run", "n-wave", "--modes", "31", "--triads-per-mode", "1"}},
    {"unexpected_argument", {"run", "three-wave", "extra"}},
    {"option_of_another_model", {"run", "surface-qg", "--N", "16", "--beta", "1"}},
    {"unknown_command", {"bogus"}},
};

class cli_bad_input : public cli, public ::testing::WithParamInterface<bad_case> {};

void expect_one_error_line(const run_result& r, int status) {
    EXPECT_EQ(r.status, status);
    EXPECT_EQ(r.out, "");
    const auto lines = lines_of(r.err);
    ASSERT_EQ(lines.size(), 1u) << r.err;
    EXPECT_EQ(lines[0].rfind("eci: error: ", 0), 0u) << r.err;
    EXPECT_GT(lines[0].size(), std::string("eci: error: ").size() + 10) << "the message names no problem";
}

TEST_P(cli_bad_input, fails_with_one_line_and_status_2_and_writes_nothing) {
    auto args = GetParam().args;
    args.insert(args.end(), {"--output", "out.csv", "--summary-json", "out.json"});
    expect_one_error_line(eci(args), 2);
    EXPECT_TRUE(work_files().empty());
}

TEST_P(cli_bad_input, leaves_existing_output_files_untouched) {
    std::ofstream(work("out.csv")) << "precious csv\n";
    std::ofstream(work("out.json")) << "precious json\n";
    auto args = GetParam().args;
    args.insert(args.end(), {"--output", "out.csv", "--summary-json", "out.json"});
    expect_one_error_line(eci(args), 2);
    EXPECT_EQ(read_text(work("out.csv")), "precious csv\n");
    EXPECT_EQ(read_text(work("out.json")), "precious json\n");
    EXPECT_EQ(work_files(), (std::set<std::string>{"out.csv", "out.json"}));
}

INSTANTIATE_TEST_SUITE_P(cli, cli_bad_input, ::testing::ValuesIn(bad_cases),
                         [](const auto& info) { return std::string(info.param.label); });

TEST_F(cli, error_messages_name_the_problem) {
    EXPECT_NE(eci({"run", "bogus"}).err.find("unknown model 'bogus'"), std::string::npos);
    EXPECT_NE(eci({"run", "three-wave", "--method", "rk5"}).err.find("unknown method 'rk5'"), std::string::npos);
    EXPECT_NE(eci({"run", "three-wave", "--method", "kahan"}).err.find("not available for model three-wave"),
              std::string::npos);
    EXPECT_NE(eci({"run", "three-wave", "--M", "1,1,1"}).err.find("eq. 2"), std::string::npos);
    EXPECT_NE(eci({"run", "three-wave", "--K", "2"}).err.find("eq. 3"), std::string::npos);
    EXPECT_NE(eci({"run", "three-wave", "--psi", "1,nan,1"}).err.find("psi_P is not finite"), std::string::npos);
    // An option of another model is named as such, not only as an unexpected argument.
    const std::string beta = eci({"run", "surface-qg", "--beta", "1"}).err;
    EXPECT_NE(beta.find("unexpected arguments: --beta 1 (surface-qg has no --beta; it is an option of "), std::string::npos)
        << beta;
    EXPECT_NE(beta.find("charney-hasegawa-mima)"), std::string::npos) << beta;
    EXPECT_NE(eci({"run", "navier-stokes-2d", "--deformation=2"})
                  .err.find("(navier-stokes-2d has no --deformation; it is an option of charney-hasegawa-mima)"),
              std::string::npos);
    EXPECT_NE(eci({"run", "three-wave", "--N", "64"}).err.find("it is an option of navier-stokes-2d, "),
              std::string::npos);
    EXPECT_EQ(eci({"run", "three-wave", "--bogus"}).err.find("it is an option of"), std::string::npos);
    // A mistyped option is named with this command's nearest one (case, or a couple of edits), with exit 2.
    const auto typo = eci({"run", "three-wave", "--metho", "c-pc"});
    EXPECT_EQ(typo.status, 2);
    EXPECT_NE(typo.err.find("unexpected arguments: --metho c-pc (no option --metho; did you mean --method?)"),
              std::string::npos)
        << typo.err;
    EXPECT_NE(eci({"run", "navier-stokes-2d", "--n", "64"}).err.find("did you mean --N?"), std::string::npos);
    EXPECT_NE(eci({"run", "three-wave", "--t_end", "5"}).err.find("did you mean --t-end?"), std::string::npos);
    EXPECT_NE(eci({"figures", "--outt", "x"}).err.find("did you mean --out?"), std::string::npos);
    EXPECT_EQ(eci({"run", "three-wave", "--bogus"}).err.find("did you mean"), std::string::npos);
}

TEST_F(cli, an_option_where_a_value_belongs_is_the_value_missing) {
    // CLI11 took "--output" as --method's value and the line named only the stray "o.csv".
    const run_result r = eci({"run", "three-wave", "--method", "--output", "o.csv"});
    expect_one_error_line(r, 2);
    EXPECT_NE(r.err.find("--method needs a value, not the option --output"), std::string::npos) << r.err;
    EXPECT_TRUE(work_files().empty());
    EXPECT_NE(eci({"run", "three-wave", "--dt", "--t-end=5"}).err.find("--dt needs a value, not the option --t-end"),
              std::string::npos);
    EXPECT_NE(eci({"figures", "--out", "--only", "3"}).err.find("--out needs a value, not the option --only"),
              std::string::npos);
    // A flag takes no value: the option after it stands.
    const run_result flag = eci({"run", "navier-stokes-2d", "--fftw-estimate", "--N", "16", "--steps", "1",
                                 "--fftw-wisdom", "none"});
    EXPECT_EQ(flag.status, 0) << flag.err;
}

TEST_F(cli, unwritable_csv_path_fails_before_running_and_writes_nothing) {
    // The directory does not exist; the JSON path is fine, and must not be written either.
    const run_result r = eci({"run", "three-wave", "--output", "missing/out.csv", "--summary-json", "out.json"});
    expect_one_error_line(r, 2);
    EXPECT_NE(r.err.find("missing/out.csv"), std::string::npos);
    EXPECT_TRUE(work_files().empty());
}

TEST_F(cli, unwritable_json_path_removes_the_csv_already_opened) {
    std::ofstream(work("out.csv")) << "precious csv\n";
    const run_result r = eci({"run", "three-wave", "--output", "out.csv", "--summary-json", "missing/out.json"});
    expect_one_error_line(r, 2);
    EXPECT_EQ(read_text(work("out.csv")), "precious csv\n");
    EXPECT_EQ(work_files(), std::set<std::string>{"out.csv"});
}

TEST_F(cli, output_path_that_is_a_directory_fails) {
    fs::create_directory(work("dir"));
    expect_one_error_line(eci({"run", "three-wave", "--output", "dir"}), 2);
    EXPECT_EQ(work_files(), std::set<std::string>{"dir"});
    EXPECT_TRUE(fs::is_empty(work("dir")));
}

TEST_F(cli, csv_and_json_to_the_same_file_fails) {
    expect_one_error_line(eci({"run", "three-wave", "--output", "same", "--summary-json", "./same"}), 2);
    EXPECT_TRUE(work_files().empty());
}

// ---------------------------------------------------------------------------------------------------------
// A run that fails midway: rates of 1e10 at dt 0.01 need more sub-steps than one step may take.

TEST_F(cli, a_step_that_needs_too_much_work_names_its_time_and_leaves_nothing) {
    std::ofstream(work("out.csv")) << "precious csv\n";
    const run_result r = eci({"run", "three-wave", "--method", "c-pc", "--M", "1e10,1e10,-2e10", "--output",
                              "out.csv", "--summary-json", "out.json"});
    expect_one_error_line(r, 1);
    EXPECT_NE(r.err.find("at t = 0 "), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("sub-steps"), std::string::npos) << r.err;
    EXPECT_EQ(read_text(work("out.csv")), "precious csv\n");
    EXPECT_EQ(work_files(), std::set<std::string>{"out.csv"});
}

// A state whose products overflow (psi_P psi_Q = 1e400) is refused before the run, the old file kept.
TEST_F(cli, an_initial_condition_that_overflows_is_bad_input_and_leaves_nothing) {
    std::ofstream(work("out.csv")) << "precious csv\n";
    const run_result r = eci({"run", "three-wave", "--method", "c-pc", "--psi", "1,1e200,1e200", "--output",
                              "out.csv", "--summary-json", "out.json"});
    expect_one_error_line(r, 2);
    EXPECT_NE(r.err.find("overflows"), std::string::npos) << r.err;
    EXPECT_EQ(read_text(work("out.csv")), "precious csv\n");
    EXPECT_EQ(work_files(), std::set<std::string>{"out.csv"});
}

// Ctrl-C keeps what the run produced until then, as complete files (the old file replaced, no row cut), and says so.
TEST_F(cli, interrupt_keeps_the_complete_output_so_far_and_exits_130) {
    std::ofstream(work("out.csv")) << "precious csv\n";
    // A run of ~10^7 steps of 300 modes (minutes), stopped by SIGINT after 1.5 s: well inside the run (a signal
    // in the first half second, before main() installs the handler, was lost under ASan: an open defect).
    const run_result r = eci({"run", "n-wave", "--modes", "300", "--t-end", "100000", "--output", "out.csv",
                              "--summary-json", "out.json"},
                             "timeout -s INT --preserve-status 1.5");
    expect_one_error_line(r, 130);
    EXPECT_NE(r.err.find("interrupted by SIGINT at t = "), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("; kept: CSV output 'out.csv' (rows to t = "), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("), summary JSON 'out.json'"), std::string::npos) << r.err;
    const std::string csv = read_text(work("out.csv")), json = read_text(work("out.json"));
    EXPECT_EQ(eci::test_cli::incomplete_csv(csv), "");
    EXPECT_GT(lines_of(csv).size(), 2u);
    EXPECT_EQ(eci::test_cli::incomplete_interrupted_json(json), "") << json;
    EXPECT_EQ(work_files(), (std::set<std::string>{"out.csv", "out.json"}));
}

// ---------------------------------------------------------------------------------------------------------
// CSV layout.

TEST_F(cli, three_wave_csv_header_and_initial_row) {
    const run_result r = eci({"run", "three-wave", "--steps", "4", "--output", "out.csv"});
    ASSERT_EQ(r.status, 0) << r.err;
    const std::string text = read_text(work("out.csv"));
    EXPECT_EQ(lines_of(text).at(0), "t,psi_K,psi_P,psi_Q,energy,enstrophy");
    const csv_table t = parse_csv(text);
    ASSERT_EQ(t.rows.size(), 5u);
    // The paper's initial condition, read back exactly (17 significant digits round-trip a double).
    const auto& first = t.rows.front();
    EXPECT_EQ(first[0], 0.0);
    EXPECT_EQ(first[1], std::sqrt(1.5));
    EXPECT_EQ(first[2], 0.0);
    EXPECT_EQ(first[3], std::sqrt(1.5));
    // The invariants are the library's own functions of that state.
    const eci::three_wave model;
    const eci::three_wave::state_type psi0{std::sqrt(1.5), 0.0, std::sqrt(1.5)};
    EXPECT_EQ(first[4], model.energy(psi0));
    EXPECT_EQ(first[5], model.enstrophy(psi0));
    EXPECT_EQ(t.rows.back()[0], 4 * 0.01);
    EXPECT_EQ(work_files(), std::set<std::string>{"out.csv"});  // no temporary left behind
}

TEST_F(cli, n_wave_csv_headers_real_and_complex) {
    ASSERT_EQ(eci({"run", "n-wave", "--modes", "4", "--triads-per-mode", "2", "--steps", "2", "--output", "r.csv"})
                  .status,
              0);
    EXPECT_EQ(lines_of(read_text(work("r.csv"))).at(0), "t,psi_0,psi_1,psi_2,psi_3,energy,enstrophy");
    ASSERT_EQ(eci({"run", "n-wave-complex", "--modes", "3", "--steps", "2", "--output", "c.csv"}).status, 0);
    EXPECT_EQ(lines_of(read_text(work("c.csv"))).at(0),
              "t,re_psi_0,im_psi_0,re_psi_1,im_psi_1,re_psi_2,im_psi_2,energy,enstrophy");
    EXPECT_EQ(parse_csv(read_text(work("c.csv"))).rows.size(), 3u);
}

TEST_F(cli, every_thins_rows_but_keeps_first_and_last) {
    // 10 steps, a row every 3: steps 0, 3, 6, 9 and the last, 10.
    ASSERT_EQ(eci({"run", "three-wave", "--dt", "0.01", "--steps", "10", "--every", "3", "--output", "a.csv"})
                  .status,
              0);
    const csv_table a = parse_csv(read_text(work("a.csv")));
    ASSERT_EQ(a.rows.size(), 5u);
    const std::vector<int> steps{0, 3, 6, 9, 10};
    for (std::size_t i = 0; i < steps.size(); ++i) EXPECT_EQ(a.rows[i][0], steps[i] * 0.01);  // t0 + i dt

    // --t-end 0.1 with dt 0.03: three full steps and a shortened fourth; rows at steps 0, 2 and the end.
    ASSERT_EQ(eci({"run", "three-wave", "--dt", "0.03", "--t-end", "0.1", "--every", "2", "--output", "b.csv"})
                  .status,
              0);
    const csv_table b = parse_csv(read_text(work("b.csv")));
    ASSERT_EQ(b.rows.size(), 3u);
    EXPECT_EQ(b.rows[1][0], 2 * 0.03);
    EXPECT_EQ(b.rows[2][0], 0.1);  // lands on t-end exactly

    // every larger than the run: the first and the last row only; no steps: the initial row only.
    ASSERT_EQ(eci({"run", "three-wave", "--steps", "5", "--every", "100", "--output", "c.csv"}).status, 0);
    EXPECT_EQ(parse_csv(read_text(work("c.csv"))).rows.size(), 2u);
    ASSERT_EQ(eci({"run", "three-wave", "--steps", "0", "--output", "d.csv"}).status, 0);
    EXPECT_EQ(parse_csv(read_text(work("d.csv"))).rows.size(), 1u);
}

TEST_F(cli, default_run_covers_t_end_10_with_dt_0_01) {
    const run_result r = eci({"run", "three-wave", "--every", "100", "--output", "out.csv"});
    ASSERT_EQ(r.status, 0) << r.err;
    const csv_table t = parse_csv(read_text(work("out.csv")));
    ASSERT_EQ(t.rows.size(), 11u);
    EXPECT_EQ(t.rows.back()[0], 10.0);
    EXPECT_NE(r.err.find("steps 1000,"), std::string::npos) << r.err;
}

TEST_F(cli, dash_writes_csv_to_stdout_and_no_output_writes_no_file) {
    const run_result r = eci({"run", "three-wave", "--steps", "3", "--output", "-"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(parse_csv(r.out).rows.size(), 4u);
    EXPECT_EQ(parse_csv(r.out).header.at(1), "psi_K");
    const run_result quiet = eci({"run", "three-wave", "--steps", "3"});
    ASSERT_EQ(quiet.status, 0) << quiet.err;
    EXPECT_EQ(quiet.out, "");
    EXPECT_NE(quiet.err.find("energy"), std::string::npos);  // the summary
    EXPECT_TRUE(work_files().empty());
}

TEST_F(cli, a_successful_run_replaces_an_existing_file) {
    std::ofstream(work("out.csv")) << "old\n";
    ASSERT_EQ(eci({"run", "three-wave", "--steps", "2", "--output", "out.csv"}).status, 0);
    EXPECT_EQ(parse_csv(read_text(work("out.csv"))).rows.size(), 3u);
    EXPECT_EQ(work_files(), std::set<std::string>{"out.csv"});
}

// ---------------------------------------------------------------------------------------------------------
// The JSON summary.

TEST_F(cli, summary_json_is_consistent_with_the_csv_and_with_itself) {
    // dt 0.2 is large enough that C-PC meets negative radicands and halves steps (Fig. 4 of the paper).
    const run_result r = eci({"run", "three-wave", "--method", "c-pc", "--dt", "0.2", "--t-end", "100", "--output",
                              "out.csv", "--summary-json", "out.json"});
    ASSERT_EQ(r.status, 0) << r.err;
    const json_reader j(read_text(work("out.json")));
    const csv_table t = parse_csv(read_text(work("out.csv")));
    EXPECT_EQ(j.values.at("model"), "three-wave");
    EXPECT_EQ(j.values.at("method"), "c-pc");
    EXPECT_EQ(j.number("order"), 2.0);
    EXPECT_EQ(j.number("dt"), 0.2);
    const double steps = j.number("steps"), reductions = j.number("step_reductions");
    EXPECT_EQ(steps, 500.0);
    EXPECT_GT(reductions, 0.0);
    // Each attempt costs C-PC two evaluations; a reduction turns one attempt into three (the failed one and
    // two halves), so attempts = steps + 2 reductions.
    EXPECT_EQ(j.number("rhs_evals"), 2.0 * (steps + 2.0 * reductions));
    EXPECT_GE(j.number("wall_seconds"), 0.0);
    EXPECT_FALSE(j.has("solver"));  // C-PC makes no iterative solve
    ASSERT_EQ(t.rows.size(), 501u);
    for (const std::string name : {"energy", "enstrophy"}) {
        const std::string k = "invariants." + name + ".";
        const std::size_t c = t.column(name);
        EXPECT_EQ(j.number(k + "initial"), t.rows.front()[c]);
        EXPECT_EQ(j.number(k + "final"), t.rows.back()[c]);
        // The drift is tracked at every step: at least what the rows show.
        double row_drift = 0.0;
        for (const auto& row : t.rows) row_drift = std::max(row_drift, std::abs(row[c] - t.rows.front()[c]));
        EXPECT_GE(j.number(k + "max_abs_drift"), row_drift);
        EXPECT_NEAR(j.number(k + "max_rel_drift"), j.number(k + "max_abs_drift") / j.number(k + "initial"),
                    4 * eps * j.number(k + "max_rel_drift"));
    }
}

TEST_F(cli, summary_json_shows_conservation_for_conservative_methods_only) {
    // Every conservative step rounds each mode's new square a few times (radicand, sqrt, the invariant's own
    // sum); independent roundings add like a random walk, so the relative drift after n accepted steps stays
    // below k eps sqrt(n). Measured: at most 0.6 eps sqrt(n) here; k = 4.
    auto bound = [](double accepted_steps) { return 4.0 * eps * std::sqrt(accepted_steps); };
    for (const std::string method : {"c-pc", "c-rk2", "c-rk4", "c-euler"}) {
        for (const std::string dt : {"0.2", "0.01"}) {
            const run_result r =
                eci({"run", "three-wave", "--method", method, "--dt", dt, "--t-end", "100", "--summary-json", "s.json"});
            ASSERT_EQ(r.status, 0) << r.err;
            const json_reader j(read_text(work("s.json")));
            const double n = j.number("steps") + j.number("step_reductions");
            for (const std::string name : {"energy", "enstrophy"})
                EXPECT_LE(j.number("invariants." + name + ".max_rel_drift"), bound(n)) << method << " dt " << dt;
            EXPECT_EQ(j.values.at("conservative"), "true");
            EXPECT_EQ(j.values.at("keeps.length"), "2");
            EXPECT_EQ(j.values.at("keeps.0") + "," + j.values.at("keeps.1"), "energy,enstrophy");
        }
    }
    // The same bound fails for the conventional PC by orders of magnitude: the test can fail.
    const run_result r =
        eci({"run", "three-wave", "--method", "pc", "--dt", "0.01", "--t-end", "100", "--summary-json", "s.json"});
    ASSERT_EQ(r.status, 0) << r.err;
    const json_reader j(read_text(work("s.json")));
    EXPECT_GT(j.number("invariants.energy.max_rel_drift"), 1e6 * bound(j.number("steps")));
    EXPECT_EQ(j.values.at("conservative"), "false");
    EXPECT_EQ(j.values.at("keeps.length"), "0");
}

TEST_F(cli, summary_json_reports_iterative_solves_when_there_are_some) {
    // psi_P = 0 at t = 0 puts C-Euler next to a zero mode, where it takes implicit midpoint steps.
    const run_result r = eci({"run", "three-wave", "--method", "c-euler", "--summary-json", "s.json"});
    ASSERT_EQ(r.status, 0) << r.err;
    const json_reader j(read_text(work("s.json")));
    ASSERT_TRUE(j.has("solver.solves"));
    EXPECT_GT(j.number("solver.solves"), 0.0);
    EXPECT_GE(j.number("solver.iterations_max"), 1.0);
    EXPECT_GE(j.number("solver.iterations_mean"), 1.0);
    EXPECT_LE(j.number("solver.iterations_mean"), j.number("solver.iterations_max"));
    EXPECT_DOUBLE_EQ(j.number("solver.iterations"), j.number("solver.iterations_mean") * j.number("solver.solves"));
    EXPECT_NE(r.err.find("iterative solves"), std::string::npos);
}

// The negative-radicand remedy: at the CLI's default step a 1000-mode n-wave system meets negative radicands;
// they are remedied in the step (counted in the summary), with no halving and exactly PC's two evaluations per
// step.
TEST_F(cli, n_wave_at_default_step_remedies_instead_of_halving) {
    const run_result r = eci({"run", "n-wave", "--modes", "1000", "--steps", "100", "--summary-json", "-"});
    ASSERT_EQ(r.status, 0) << r.err;
    const json_reader j(r.out);
    EXPECT_EQ(j.values.at("method"), "c-pc");
    EXPECT_EQ(j.number("step_reductions"), 0.0);
    EXPECT_EQ(j.number("rhs_evals"), 200.0);
    EXPECT_GT(j.number("remedied_steps"), 0.0);
    EXPECT_GE(j.number("components_remedied"), j.number("remedied_steps"));
    EXPECT_NE(r.err.find("remedied steps"), std::string::npos) << r.err;
    // Invariants exact to round-off: a few roundings per step over 100 steps, measured by a plain sum of 1000
    // terms (sqrt(1000) eps): 64 eps sqrt(steps) has room for both.
    EXPECT_LE(j.number("invariants.energy.max_rel_drift"), 64 * 2.2e-16 * std::sqrt(100.0));
    EXPECT_LE(j.number("invariants.enstrophy.max_rel_drift"), 64 * 2.2e-16 * std::sqrt(100.0));
}

TEST_F(cli, summary_json_to_stdout) {
    const run_result r = eci({"run", "n-wave", "--modes", "6", "--steps", "10", "--summary-json", "-"});
    ASSERT_EQ(r.status, 0) << r.err;
    const json_reader j(r.out);
    EXPECT_EQ(j.number("steps"), 10.0);
    EXPECT_EQ(j.values.at("model"), "n-wave");
    EXPECT_TRUE(work_files().empty());
}

// ---------------------------------------------------------------------------------------------------------
// eci list and help.

/// The whitespace-separated words of each line of text.
std::vector<std::vector<std::string>> words_per_line(const std::string& text) {
    std::vector<std::vector<std::string>> out;
    for (const std::string& line : lines_of(text)) {
        std::istringstream in(line);
        std::vector<std::string> words;
        for (std::string w; in >> w;) words.push_back(w);
        out.push_back(words);
    }
    return out;
}

TEST_F(cli, list_shows_every_registered_method_with_its_order_and_every_model) {
    const run_result r = eci({"list"});
    ASSERT_EQ(r.status, 0) << r.err;
    const auto lines = words_per_line(r.out);
    auto has_line_starting = [&](const std::vector<std::string>& start) {
        for (const auto& words : lines)
            if (words.size() >= start.size() && std::equal(start.begin(), start.end(), words.begin())) return true;
        return false;
    };
    for (const eci::method_info& m : eci::methods)
        EXPECT_TRUE(has_line_starting({std::string(m.name), "order", std::to_string(m.order),
                                       m.conservative ? "conservative" : "conventional",
                                       std::string(eci::family_name(m.family))}))
            << m.name << "\n"
            << r.out;
    for (const std::string model : {"three-wave", "n-wave", "n-wave-complex"})
        EXPECT_TRUE(has_line_starting({model})) << model;
    // three-wave's methods in the registry's order, computed (a method added to the list is in them)
    std::string three_wave_methods;
    for (const eci::method_info& m : eci::methods_for<eci::three_wave>())
        three_wave_methods += (three_wave_methods.empty() ? "" : " ") + std::string(m.name);
    EXPECT_NE(r.out.find("methods: " + three_wave_methods + " (default"), std::string::npos) << three_wave_methods;
}

TEST_F(cli, registry_lists_the_issue_s_methods_and_every_method_dispatches) {
    for (const char* name : {"euler", "pc", "rk2", "rk4", "c-euler", "c-pc", "c-rk2", "c-rk4"}) {
        const auto m = eci::find_method(name);
        ASSERT_TRUE(m.has_value()) << name;
        int order = 0;
        EXPECT_TRUE(eci::with_method<std::vector<double>>(name, [&](auto stepper) { order = stepper.order; }));
        EXPECT_EQ(order, m->order) << name;
    }
    EXPECT_FALSE(eci::with_method<std::vector<double>>("kahan", [](auto) {}));  // model-specific
    EXPECT_FALSE(eci::find_method("rk5").has_value());
}

TEST_F(cli, help_states_defaults_and_exit_statuses) {
    const run_result r = eci({"run", "three-wave", "--help"});
    ASSERT_EQ(r.status, 0);
    EXPECT_NE(r.out.find("(default 0.01)"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("(default 10)"), std::string::npos);
    EXPECT_NE(r.out.find("'-' writes it to standard output"), std::string::npos);
    EXPECT_NE(r.out.find("Exit status"), std::string::npos);
    EXPECT_TRUE(work_files().empty());
}

}  // namespace
