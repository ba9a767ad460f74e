// The `eci` command: parses `eci run MODEL ...`, `eci list` and `eci figures ...` with CLI11 and turns every
// error into one line "eci: error: ..." on stderr with a documented exit status.
#include <algorithm>
#include <cctype>
#include <charconv>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <new>
#include <regex>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include <CLI/CLI.hpp>
#ifdef ECI_MPI
#include <mpi.h>
#include <sys/time.h>

#include <csignal>
#endif
#include <eci/integrate.hpp>
#include <eci/registry.hpp>
#include <eci/version.hpp>

#include "command.hpp"
#include "figures.hpp"
#include "output.hpp"

namespace {

// CLI11's sentences for a value missing or given too often, said as a user would ("--dt: At Most 1 required but
// received 2" is "--dt is given more than once"); any other passes as it is.
std::string plain_parse_error(const std::string& what) {
    std::smatch m;
    static const std::regex at_most("^(--[A-Za-z0-9-]+): At Most ([0-9]+) required but received ([0-9]+)$");
    static const std::regex at_least("^(--[A-Za-z0-9-]+): At least ([0-9]+) required but received ([0-9]+)$");
    static const std::regex missing("^(--[A-Za-z0-9-]+): [0-9]+ required .+ missing$");
    static const std::regex not_in("^(--[A-Za-z0-9-]+): (.*) not in \\{(.*)\\}$");
    static const std::regex range("^(--[A-Za-z0-9-]+): Value (.*) not in range (.*) to (.*)$");
    if (std::regex_match(what, m, at_most))
        return m[2].str() == "1" ? m[1].str() + " is given more than once"
                                 : m[1].str() + " takes " + m[2].str() + " values, not " + m[3].str();
    if (std::regex_match(what, m, at_least))
        return m[1].str() + " needs " + m[2].str() + " values (separated by commas or spaces), not " + m[3].str();
    if (std::regex_match(what, m, missing)) return m[1].str() + " needs a value";
    if (std::regex_match(what, m, range))
        return m[1].str() + " must be in " + m[3].str() + ".." + m[4].str() + ", not " + m[2].str();
    if (std::regex_match(what, m, not_in)) {
        std::string choices = m[3].str();
        const std::size_t last = choices.rfind(',');
        if (last != std::string::npos) choices.replace(last, 1, " or ");
        // (each comma made ", " and the search goes on after it: from the start it found the same comma again, for
        // ever, given three choices or more)
        for (std::size_t c = 0; (c = choices.find(',', c)) != std::string::npos; c += 2) choices.replace(c, 1, ", ");
        return m[1].str() + " must be " + choices + ", not '" + m[2].str() + "'";
    }
    return what;
}

using namespace eci::cli;

constexpr const char* exit_status_help =
    "Exit status: 0 success; 1 a run that could not finish (a step failed even at dt * 2^-40, needed too many "
    "sub-steps or blew up; a write failed, e.g. a full disk) or a feature not built; 2 bad input (unknown model "
    "or method, bad number, invalid coefficients, unwritable output, ...); 128+N stopped by signal N (130 "
    "Ctrl-C; SIGINT, SIGTERM, SIGHUP, SIGQUIT, SIGPIPE). A run stopped by SIGINT, SIGTERM, SIGHUP or SIGQUIT "
    "after its first step keeps its outputs up to where it stopped, as complete files committed together (the CSV's "
    "rows so far, the snapshots taken, a summary JSON with \"interrupted\": true and t_stopped) and says what it "
    "kept; stopped before its first step, by SIGPIPE or by a second signal, it keeps nothing. On any other failure "
    "(but a --plot that cannot be drawn at the end of a finished run, which keeps the other outputs) "
    "no output file or directory is created "
    "or replaced (files of one run appear together), except what goes directly to standard output, a device "
    "or a FIFO (for --output, --summary-json and --plot; other outputs refuse devices and FIFOs), and a spectral run's "
    "checkpoint (replaced whole at each --checkpoint-every and on a stop, so the last good one stays) and FFTW "
    "wisdom file (written once the input is known good). No output may name an input file (--ic, --restart; "
    "--checkpoint may name the --restart file, continuing it in place).";

void print_error(std::string_view message) {
    std::string line(message);
    for (char& c : line)
        if (c == '\n' || c == '\r') c = ' ';
    std::fprintf(stderr, "eci: error: %s\n", line.c_str());
}

std::string model_names(const std::vector<std::unique_ptr<model_command>>& models) {
    std::string s;
    for (const auto& m : models) s += (s.empty() ? "" : ", ") + m->info().name;
    return s;
}

/// For `eci run MODEL ... --name ...` where --name is not MODEL's but another model's option (--beta of
/// charney-hasegawa-mima given to surface-qg): " (MODEL has no --name; it is an option of OTHER)", else "".
std::string other_models_option(const std::vector<std::unique_ptr<model_command>>& models, int argc, char** argv,
                                const std::vector<std::string>& extras) {
    if (argc < 3 || std::string_view(argv[1]) != "run") return "";
    const std::string model = argv[2];
    for (const std::string& extra : extras) {
        if (extra.size() < 3 || extra.rfind("--", 0) != 0) continue;
        const std::string name = extra.substr(2, extra.find('=') - 2);
        std::string owners;
        for (const auto& m : models)
            for (const option_spec& o : m->options())
                if (o.name == name && m->info().name != model)
                    owners.append(owners.empty() ? "" : ", ").append(m->info().name);
        if (!owners.empty()) return " (" + model + " has no --" + name + "; it is an option of " + owners + ")";
    }
    return "";
}

/// The long option a command-line token names, "--name" or "--name=value" -> "name"; "" for any other token.
std::string_view long_option_name(std::string_view token) {
    if (token.size() < 3 || token.substr(0, 2) != "--") return {};
    return token.substr(2, token.find('=') == std::string_view::npos ? std::string_view::npos : token.find('=') - 2);
}

/// For a mistyped option of the command `app` (`--metho`, `--t_end`, `--n` for --N): " (no option --metho; did you
/// mean --method?)", the option of `app` nearest to it: the same name but for case, else within
/// max(1, length / 3) edits (Levenshtein, case ignored); "" if no option is that near or no extra is an option.
std::string nearest_option(const CLI::App* app, const std::vector<std::string>& extras) {
    if (app == nullptr) return "";
    const auto lower = [](std::string s) {
        for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
        return s;
    };
    const auto distance = [](const std::string& a, const std::string& b) {
        std::vector<std::size_t> row(b.size() + 1);
        for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
        for (std::size_t i = 1; i <= a.size(); ++i) {
            std::size_t diagonal = row[0];
            row[0] = i;
            for (std::size_t j = 1; j <= b.size(); ++j) {
                const std::size_t up = row[j];
                row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
                diagonal = up;
            }
        }
        return row[b.size()];
    };
    for (const std::string& extra : extras) {
        const std::string name(long_option_name(extra));
        if (name.empty()) continue;
        std::string best;
        std::size_t best_d = std::max<std::size_t>(1, name.size() / 3) + 1;
        for (const CLI::Option* o : app->get_options())
            for (const std::string& l : o->get_lnames()) {
                const std::size_t d = distance(lower(name), lower(l));
                if (d < best_d) best = l, best_d = d;
            }
        if (!best.empty()) return " (no option --" + name + "; did you mean --" + best + "?)";
    }
    return "";
}

/// A CLI11 check that an option is a whole number >= min (CLI11 alone would wrap "-3" into a huge unsigned);
/// one beyond 2^64 - 1 is "too large", not "not a whole number".
CLI::Validator whole_number(std::uint64_t min) {
    return CLI::Validator(
        [min](std::string& s) -> std::string {
            const std::string bad = "must be a whole number >= " + std::to_string(min) + ", not '" + s + "'";
            if (s.empty() || s.find_first_not_of("0123456789") != std::string::npos) return bad;
            std::uint64_t v = 0;
            const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
            if (r.ec == std::errc::result_out_of_range)
                return "'" + s + "' is too large (at most 18446744073709551615)";
            return r.ec != std::errc() || v < min ? bad : std::string();
        },
        "");  // (the option's type name says it: whole_option)
}


/// A CLI11 check that an option is a decimal number: an optional sign, digits with an optional point, an optional
/// exponent ("1", "-0.5", ".5", "2.", "1e-3"); CLI11 alone would also take hexadecimal ("0x10" as 16, "0x1p-4" as
/// 0.0625), which the whole-number options and Python refuse. "inf" and "nan" (any case, signed) still reach the run,
/// which refuses them with the same sentence as Python. Spaces around the number are dropped (" 2" from "1, 2, 3").
/// A list ("1,0,2") is checked number by number (add_model_options).
CLI::Validator decimal_number() {
    return CLI::Validator(
        [](std::string& s) -> std::string {
            if (const std::size_t first = s.find_first_not_of(" \t"); first != std::string::npos)
                s = s.substr(first, s.find_last_not_of(" \t") - first + 1);
            const auto decimal = [](std::string_view v) {
                std::size_t i = 0;
                if (i < v.size() && (v[i] == '+' || v[i] == '-')) ++i;
                std::string lower;
                for (char c : v.substr(i)) lower.push_back(char(std::tolower(static_cast<unsigned char>(c))));
                if (lower == "inf" || lower == "infinity" || lower == "nan") return true;
                std::size_t digits = 0;
                for (; i < v.size() && std::isdigit(static_cast<unsigned char>(v[i])); ++i) ++digits;
                if (i < v.size() && v[i] == '.')
                    for (++i; i < v.size() && std::isdigit(static_cast<unsigned char>(v[i])); ++i) ++digits;
                if (digits == 0) return false;
                if (i < v.size() && (v[i] == 'e' || v[i] == 'E')) {
                    ++i;
                    if (i < v.size() && (v[i] == '+' || v[i] == '-')) ++i;
                    std::size_t exponent = 0;
                    for (; i < v.size() && std::isdigit(static_cast<unsigned char>(v[i])); ++i) ++exponent;
                    if (exponent == 0) return false;
                }
                return i == v.size();
            };
            return decimal(s) ? std::string() : "must be a decimal number, not '" + s + "'";
        },
        "");  // (the option's type name says it: "NUMBER")
}

/// Option o checked as whole_number(min), its help's type "INT>=min" (CLI11's own would read "UINT:INT>=min").
CLI::Option* whole_option(CLI::Option* o, std::uint64_t min) {
    return o->check(whole_number(min))->type_name("INT>=" + std::to_string(min));
}
/// Option o checked as decimal_number(), its help's type "NUMBER" (CLI11's own would read "FLOAT:NUMBER").
CLI::Option* number_option(CLI::Option* o) { return o->check(decimal_number())->type_name("NUMBER"); }

/// The numbers of a list option given as `tokens` (each "1,0,2", "1" or "1, 0"): every item a number
/// (decimal_number(), spaces around it dropped), no empty item, `count` of them.
std::vector<double> list_of_numbers(const std::string& flag, const std::vector<std::string>& tokens, std::size_t count) {
    const CLI::Validator number = decimal_number();
    // the tokens as one list: "1" "0" and "1," "0" (from an unquoted "1, 0") are "1,0"
    std::string given, list;
    for (const std::string& t : tokens) {
        const bool joined = list.empty() || list.back() == ',' || (!t.empty() && t.front() == ',');
        given += (given.empty() ? "" : " ") + t;
        list += (joined ? "" : ",") + t;
    }
    std::vector<double> values;
    for (std::size_t begin = 0;;) {
        const std::size_t comma = std::min(list.find(',', begin), list.size());
        std::string item = list.substr(begin, comma - begin);
        if (item.find_first_not_of(" \t") == std::string::npos)
            throw CLI::ValidationError(flag + " has an empty value in '" + given + "' (" + std::to_string(count) +
                                       " numbers separated by commas)");
        if (const std::string bad = number(item); !bad.empty()) throw CLI::ValidationError(flag, bad);
        values.push_back(std::strtod(item.c_str(), nullptr));  // (as CLI11 reads a number: 1e999 is inf)
        if (comma == list.size()) break;
        begin = comma + 1;
    }
    if (values.size() < count)
        throw CLI::ValidationError(flag + " needs " + std::to_string(count) +
                                   " values (separated by commas or spaces), not " + std::to_string(values.size()));
    if (values.size() > count)
        throw CLI::ValidationError(flag + " takes " + std::to_string(count) + " values, not " +
                                   std::to_string(values.size()));
    return values;
}

/// Binds a model's own options (its parameters, initial state or generator settings) on its subcommand.
void add_model_options(CLI::App& sub, std::vector<option_spec>& options) {
    for (option_spec& o : options) {
        const std::string flag = "--" + o.name;
        if (o.text) {
            sub.add_option(flag, *o.text, o.help);
        } else if (o.flag) {
            sub.add_flag(flag, *o.flag, o.help);
        } else if (o.whole) {
            whole_option(sub.add_option(flag, *o.whole, o.help), o.min);
        } else if (o.count == 1) {
            o.reals->resize(1);
            number_option(sub.add_option(flag, o.reals->front(), o.help));
        } else {
            // A list: "1,0,2" or "1 0 2" (or both), split here: CLI11's own splitting drops empty items, so "1,,2"
            // read as two values and "1,2,3," as three. Each item is a number as decimal_number() says.
            sub.add_option_function<std::vector<std::string>>(
                   flag, [&o, flag](const std::vector<std::string>& tokens) { *o.reals = list_of_numbers(flag, tokens, o.count); },
                   o.help)
                ->expected(1, int(o.count))
                ->type_name("NUMBER x " + std::to_string(o.count));
        }
    }
}

bool is_model_name(const std::vector<std::unique_ptr<model_command>>& models, std::string_view name) {
    for (const auto& m : models)
        if (m->info().name == name) return true;
    return false;
}

// CLI11 reads an empty value ("--t-end ''", "--theta=") as 0; no option of eci takes an empty value.
void check_no_empty_values(int argc, char** argv) {
    for (int i = 1; i < argc; ++i) {
        const std::string_view a = argv[i];
        if (a.size() < 3 || a.substr(0, 2) != "--") continue;
        const std::size_t eq = a.find('=');
        if (eq != std::string_view::npos) {
            if (eq + 1 == a.size())
                throw bad_input(std::string(a.substr(0, eq)) + " needs a value, got an empty string");
        } else if (i + 1 < argc && argv[i + 1][0] == '\0') {
            throw bad_input(std::string(a) + " needs a value, got an empty string");
        }
    }
}

/// `eci run MODEL --method --output run.csv`: CLI11 takes "--output" as --method's value, and the line was about the
/// stray "run.csv" ("unexpected arguments: run.csv"); an option of `command` where a value belongs is that value
/// missing: "--method needs a value, not the option --output".
void check_values_are_not_options(const CLI::App& command, int argc, char** argv) {
    const auto option_of = [&](std::string_view token) -> const CLI::Option* {
        const std::string name(long_option_name(token));
        if (name.empty()) return nullptr;
        for (const CLI::Option* o : command.get_options())
            for (const std::string& l : o->get_lnames())
                if (l == name) return o;
        return nullptr;
    };
    for (int i = 2; i + 1 < argc; ++i) {
        const std::string_view a = argv[i];
        if (a.find('=') != std::string_view::npos) continue;
        const CLI::Option* o = option_of(a);
        if (o == nullptr || o->get_items_expected_max() == 0) continue;  // (a flag takes no value)
        const std::string_view next = argv[i + 1];
        if (option_of(next) != nullptr)
            throw bad_input(std::string(a) + " needs a value, not the option " +
                            std::string(next.substr(0, next.find('='))));
    }
}

void print_list(const std::vector<std::unique_ptr<model_command>>& models) {
    std::printf("Methods (eci run MODEL --method NAME): name, order, whether it keeps every quadratic invariant\n"
                "to round-off (conservative) or not (conventional), how it is built (family), one line\n");
    for (const eci::method_info& m : eci::methods) {
        const std::string family(eci::family_name(m.family));
        std::printf("  %-17s order %d  %-12s  %-14s  %.*s\n", std::string(m.name).c_str(), m.order,
                    m.conservative ? "conservative" : "conventional", family.c_str(),
                    static_cast<int>(m.description.size()), m.description.data());
    }
    std::printf("\nModels (eci run MODEL --help for options):\n");
    for (const auto& model : models) {
        const model_info& i = model->info();
        std::printf("  %-15s %s\n", i.name.c_str(), i.description.c_str());
        std::string methods;
        for (const std::string& n : i.methods) methods += (methods.empty() ? "" : " ") + n;
        const std::string adaptive =
            i.default_adaptive_method.empty() ? std::string() : "; with --rtol/--atol " + i.default_adaptive_method;
        std::printf("  %-15s methods: %s (default %s%s); default dt %s, t-end %s\n", "", methods.c_str(),
                    i.default_method.c_str(), adaptive.c_str(), i.dt_text(shortest).c_str(),
                    shortest(i.default_t_end).c_str());
        std::string presets;
        for (const auto& p : i.presets) presets += (presets.empty() ? "" : " ") + p.first;
        std::printf("  %-15s presets (--preset): %s\n", "", presets.c_str());
    }
}

// How many processes this one was launched with: MPI_COMM_WORLD's size in the MPI build, else what the launcher
// tells its children (Open MPI's mpirun, MPICH's Hydra), 1 when run on its own.
int launched_processes() {
#ifdef ECI_MPI
    int init = 0, size = 1;
    MPI_Initialized(&init);
    if (init) MPI_Comm_size(MPI_COMM_WORLD, &size);
    return size;
#else
    for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE"}) {
        const char* v = std::getenv(name);
        if (v && *v) return std::max(1, std::atoi(v));
    }
    return 1;
#endif
}

// Under mpirun -np P > 1 each process would run the whole command and write the same files: only a model whose run
// is spread over the processes (the spectral equations in the MPI build) is run there; anything else is refused.
void check_process_count(const std::string& what, const model_command* model) {
    const int p = launched_processes();
    if (p <= 1 || (model && model->spreads_over_processes())) return;
#ifdef ECI_MPI
    const std::string spread = " (only the spectral equations' runs are spread over MPI processes)";
#else
    const std::string spread = " (this eci is built without MPI: cmake -DECI_MPI=ON spreads the spectral equations)";
#endif
    throw bad_input(what + " runs on one process, not " + std::to_string(p) +
                    ": start it without mpirun, or with -np 1" + spread);
}

int run_cli(int argc, char** argv) {
    // (The signal handler is already installed: see eci_early_interrupt_handler below.)
    const auto models = registered_models();

    CLI::App app{"eci: explicit, exactly conservative ODE integrators (Shadwick, Bowman & Morrison)", "eci"};
    app.require_subcommand(1);
    app.set_version_flag("--version", std::string("eci ") + eci::version);
    app.footer(exit_status_help);

    CLI::App* run = app.add_subcommand("run", "integrate a model: eci run MODEL [options]; "
                                              "eci run MODEL --help lists them");
    run->require_subcommand(0, 1);
    run->footer(std::string("Models: ") + model_names(models) + ".\n" + exit_status_help);

    // One set of run options, bound on every model's subcommand; only one of them is ever parsed.
    run_settings settings;
    double dt = 0.0, t_end = 0.0, rtol = 0.0, atol = 0.0, output_dt = 0.0;
    std::uint64_t steps = 0;
    for (const auto& model : models) {
        const model_info& i = model->info();
        CLI::App* sub = run->add_subcommand(i.name, i.description);
        sub->add_option("--method", settings.method,
                        "integrator, one of `eci list` (default " + i.default_method +
                            (i.default_adaptive_method.empty() ? std::string()
                                                               : "; with --rtol/--atol " + i.default_adaptive_method) +
                            ")");
        number_option(sub->add_option("--dt", dt, "time step (default " + i.dt_text(shortest) + ")"));
        number_option(sub->add_option("--t-end", t_end,
                                      "end time, starting at t = 0 (default " + shortest(i.default_t_end) + ")"));
        whole_option(sub->add_option("--steps", steps, "number of steps instead of --t-end"), 0);
        whole_option(sub->add_option("--every", settings.every,
                                     "write a CSV row every K steps; the first and last always (default 1)"),
                     1);
        sub->add_option("--output", settings.output,
                        "CSV file: t, the state (a spectral model: its diagnostics and budget), the model's derived "
                        "columns (Kepler: the position x, y), the invariants, and, for a relaxation method "
                        "whose steps advance time by gamma tau, time_lag (the state belongs to t + time_lag), at full "
                        "precision; a name ending in .h5 or .hdf5 writes the same rows as HDF5 datasets (t, "
                        "state, derived, invariants, time_lag; a spectral model: diagnostics), each with its "
                        "columns' names. Without --output no CSV is written; '-' writes it to standard output");
        sub->add_option("--summary-json", settings.summary_json,
                        "also write the run summary as JSON to this file ('-': standard output)");
        sub->add_option("--plot", settings.plot,
                        "draw the run as a picture (FILE.png, .svg or .pdf, by gnuplot; '-' or a device: PNG), from "
                        "the same outputs as the CSV's rows (--every, --output-dt; --output not needed): an ODE "
                        "model's first components over time and each invariant's change relative to its initial "
                        "value; a spectral model's E and Z and each one's change beyond its budget. Drawn when the "
                        "run has finished: a run stopped by a signal draws none; a picture that cannot be drawn "
                        "fails the run (exit 1) and keeps its other outputs");
        number_option(sub->add_option(
            "--rtol", rtol,
            "relative tolerance: run with adaptive step control (an embedded pair: bs32, ck54, dp54, dp853, f78 and "
            "their c- versions); --dt is then the first step, at most the span. Below 100 eps it is raised to 100 "
            "eps with a warning, as in Python and SciPy's solve_ivp"));
        number_option(sub->add_option("--atol", atol,
                                      "absolute tolerance of adaptive step control (default: the --rtol value)"));
        number_option(sub->add_option(
            "--output-dt", output_dt,
            "write CSV rows at multiples of this time and at the end (adaptive: dense output or steps landing on "
            "them; fixed steps: a multiple of --dt, and without --dt a spectral equation's CFL step is shortened to "
            "divide it); not with --every"));
        sub->add_option("--output-mode", settings.output_mode,
                        "how an adaptive run reaches the --output-dt times: auto (default: dense output where it is as "
                        "accurate as the steps, else a step lands on each), dense (the dense output, fewer steps; a "
                        "conservative pair's keeps the invariants at every output but, above order 3, is 20-1000x "
                        "less accurate than its steps at rtol 1e-10) or landing; Python's t_eval_mode")
            ->check(CLI::IsMember({"auto", "dense", "landing"}));
        sub->add_option("--update", settings.update,
                        "conservative Runge-Kutta methods (c-pc, c-rk2, c-rk4, any conservative tableau at fixed steps; the c- "
                        "pairs with --rtol) on "
                        "systems of 16 or more real unknowns with declared invariants (n-wave, the spectral models): "
                        "conditioned (default: at the conventional method's error, docs/methods.md) or "
                        "paper (the paper's update, bit for bit as before the conditioned update); a spectral "
                        "checkpoint records it, and a --restart takes the checkpoint's")
            ->check(CLI::IsMember({"conditioned", "paper"}));
        std::string presets;
        for (const auto& [name, what] : i.presets) presets += (presets.empty() ? "" : "; ") + name + ": " + what;
        sub->add_option("--preset", settings.preset,
                        "a named set-up (the paper's runs for its models), whose values the other options override "
                        "(default " +
                            i.presets.front().first + "). " + presets);
        add_model_options(*sub, model->options());
        sub->footer("The summary (steps, step reductions, rhs evaluations, wall time, each invariant's drift "
                    "measured at every step) goes to stderr; a progress bar too when stderr is a terminal and "
                    "the run takes over a second.\n" +
                    std::string(exit_status_help));
    }

    CLI::App* list = app.add_subcommand("list", "list the methods (with their order) and the models");

    CLI::App* figures = app.add_subcommand("figures", "reproduce the paper's figures (PNG, SVG and CSV)");
    eci::figures::options figure_options;
    figures->add_option("--out", figure_options.out, "output directory (default figures)");
    int only = 0;
    whole_option(figures->add_option("--only", only,
                                     "make only figure N (1-9): its files, and its rows of the directory's "
                                     "summary.csv (the other figures' rows are kept)"),
                 1)
        ->check(CLI::Range(1, 9));

    // CLI11 would say only that a subcommand is required, or call an unknown model an unexpected argument.
    if (argc == 1) throw bad_input("missing command (commands: run, list, figures; see eci --help)");
    check_no_empty_values(argc, argv);
    // `eci run --dt 0.1 three-wave`: CLI11 would list the stray tokens in reverse order.
    if (argc > 2 && std::string_view(argv[1]) == "run" && argv[2][0] == '-' && std::string_view(argv[2]) != "--help" &&
        std::string_view(argv[2]) != "-h") {
        std::string stray;
        int i = 2;
        for (; i < argc && !is_model_name(models, argv[i]); ++i) stray.append(stray.empty() ? "" : " ").append(argv[i]);
        if (i < argc)
            throw bad_input("'" + stray + "' comes before the model " + argv[i] + ": options go after it (eci run " +
                            argv[i] + " " + stray + ")");
    }
    const auto named = [&](CLI::App* c) { return c->get_name() == argv[1]; };
    if (argv[1][0] != '-' && app.get_subcommands(named).empty())
        throw bad_input("unknown command '" + std::string(argv[1]) + "' (commands: run, list, figures)");
    if (argc > 2 && std::string_view(argv[1]) == "run" && argv[2][0] != '-') {
        bool known = false;
        for (const auto& m : models) known = known || m->info().name == argv[2];
        if (!known)
            throw bad_input("unknown model '" + std::string(argv[2]) + "' (models: " + model_names(models) + ")");
    }

    // The command whose options the line gives: eci run MODEL's, or eci figures'.
    const CLI::App* command = nullptr;
    if (std::string_view(argv[1]) == "figures") command = figures;
    if (argc > 2 && std::string_view(argv[1]) == "run" && is_model_name(models, argv[2]))
        command = run->get_subcommand(argv[2]);
    if (command != nullptr) check_values_are_not_options(*command, argc, argv);

    try {
        app.parse(argc, argv);
    } catch (const CLI::ExtrasError&) {
        // CLI11 lists the unexpected tokens last first; name them in the order they were typed.
        std::vector<std::string> extras;
        for (CLI::App* a : {&app, run, figures, list}) {
            for (const std::string& s : a->remaining()) extras.push_back(s);
            for (CLI::App* sub : a->get_subcommands({}))
                for (const std::string& s : sub->remaining()) extras.push_back(s);
        }
        std::string typed;
        for (int i = 1; i < argc; ++i)
            if (std::find(extras.begin(), extras.end(), argv[i]) != extras.end())
                typed.append(typed.empty() ? "" : " ").append(argv[i]);
        std::string hint = other_models_option(models, argc, argv, extras);
        if (hint.empty()) hint = nearest_option(command, extras);
        throw bad_input("unexpected arguments: " + typed + hint);
    } catch (const CLI::ParseError& e) {
        if (e.get_exit_code() == 0) return app.exit(e);  // --help, --version
        throw bad_input(plain_parse_error(e.what()));
    }

    if (list->parsed()) {
        print_list(models);
        return 0;
    }
    if (figures->parsed()) {
        check_process_count("eci figures", nullptr);
        if (figures->count("--only")) figure_options.only = only;
        return eci::figures::run_figures(figure_options);
    }
    for (const auto& model : models) {
        CLI::App* sub = run->get_subcommand(model->info().name);
        if (!sub->parsed()) continue;
        if (sub->count("--dt")) settings.dt = dt;
        if (sub->count("--t-end")) settings.t_end = t_end + 0.0;  // (-0 is 0: "t 0 to -0" said nothing true)
        if (sub->count("--steps")) settings.steps = steps;
        if (sub->count("--rtol")) settings.rtol = rtol;
        if (sub->count("--atol")) settings.atol = atol;
        if (sub->count("--output-dt")) settings.output_dt = output_dt;
        // (--output-dt sets the rows' interval itself: a --every beside it was silently replaced before)
        if (sub->count("--every") && settings.output_dt) throw bad_input("give --every or --output-dt, not both");
        if (!settings.output_mode.empty() && !(settings.output_dt && (settings.rtol || settings.atol)))
            throw bad_input("--output-mode is for an adaptive run's --output-dt times: give --output-dt and --rtol/--atol");
        for (option_spec& o : model->options()) o.given = sub->count("--" + o.name) > 0;
        check_process_count("eci run " + model->info().name, model.get());
        return model->run(settings);
    }
    throw bad_input("eci run needs a MODEL (models: " + model_names(models) + ")");
}

// The signal handler is installed before anything else of the program runs: from .preinit_array, which the dynamic
// loader runs once the libraries are loaded, before their constructors, the program's static constructors and main
// (and MPI_Init, which can take seconds). A signal arriving later, at start-up too, is honoured like one during the
// run. One arriving while the libraries load has been blocked by build/eci (launcher.cpp), which started this
// program: it is pending, and install_interrupt_handler's unblocking delivers it to the handler.
void install_interrupt_handler_early(int, char**, char**) { install_interrupt_handler(); }
__attribute__((section(".preinit_array"), used)) void (*eci_early_interrupt_handler)(int, char**, char**) =
    install_interrupt_handler_early;

}  // namespace

int main_inner(int argc, char** argv) {
    try {
        const int status = run_cli(argc, argv);
        // A command that never polls the flag (list, --help, --version): a signal that arrived is still an
        // interrupt. (A run's commit blocks the signals, so one after its outputs are committed is not seen.)
        if (status == 0 && interrupt_requested()) throw_if_interrupted();
        return status;
    } catch (const bad_input& e) {
        print_error(e.what());
        return 2;
    } catch (const std::invalid_argument& e) {
        print_error(e.what());
        return 2;
    } catch (const run_error& e) {
        print_error(e.what());
        return 1;
    } catch (const interrupted& e) {
        print_error(e.what());
        return interrupt_exit_status();
    } catch (const eci::interrupted& e) {
        print_error(e.what());
        return interrupt_exit_status();
    } catch (const std::bad_alloc&) {
        print_error("out of memory: the run needs more than this process could allocate (a smaller N or model, or "
                    "a higher ulimit -v)");
        return 1;
    } catch (const std::exception& e) {
        print_error(e.what());
        return 1;
    }
}

int main(int argc, char** argv) {
#ifdef ECI_MPI
    // The MPI build: under mpirun the spectral equations run spread over the processes (model_spectral.cpp). Only
    // rank 0 speaks: the others' messages (each process meets the same errors) and their standard output (--help,
    // --version and `eci list`, printed by every process; a run's CSV or JSON to '-' is rank 0's) go nowhere.
    MPI_Init(&argc, &argv);
    int rank = 0;
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    if (rank != 0 && (!std::freopen("/dev/null", "w", stderr) || !std::freopen("/dev/null", "w", stdout))) return 1;
    int status = main_inner(argc, argv);
    // Ctrl-C reaches mpirun alone, which sends every process SIGTERM: an interrupted run spread over processes
    // exits 130 on every one (each has written its part of the checkpoint's agreement), whichever signal came.
    int size = 1;
    MPI_Comm_size(MPI_COMM_WORLD, &size);
    if (size > 1 && status > 128) status = 130;
    if (size > 1) {
        // The run is over (its checkpoint written): the interrupt watchdog and a second SIGTERM from mpirun must not
        // cut MPI_Finalize short with another status.
        itimerval off{};
        ::setitimer(ITIMER_VIRTUAL, &off, nullptr);
        ::setitimer(ITIMER_REAL, &off, nullptr);
        std::signal(SIGINT, SIG_IGN);
        std::signal(SIGTERM, SIG_IGN);
    }
    std::fflush(stdout);
    MPI_Finalize();
    return status;
#else
    return main_inner(argc, argv);
#endif
}
