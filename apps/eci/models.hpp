// The models `eci run` knows: what every model adapter provides (its name, methods, defaults, options and run)
// and the list of them. Each adapter lives in its own model_*.cpp; the list is in models.cpp.
#pragma once

#include <charconv>
#include <cstdint>
#include <system_error>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <CLI/CLI.hpp>

namespace eci::cli {

/// The options of `eci run MODEL` that every model shares.
struct run_settings {
    std::string method;                  ///< registry name; empty means the model's default
    std::optional<double> dt;            ///< time step; unset means the model's default
    std::optional<double> t_end;         ///< end time (exclusive with steps)
    std::optional<std::uint64_t> steps;  ///< number of steps (exclusive with t_end)
    std::uint64_t every = 1;             ///< a CSV row every `every` steps
    std::string output;                  ///< CSV path; "-" is stdout, empty writes no CSV
    std::string summary_json;            ///< JSON summary path; "-" is stdout, empty writes none
};

/// What `eci list` and `eci run MODEL --help` show about a model, and its run defaults.
struct model_info {
    std::string name;                  ///< the MODEL argument of `eci run`
    std::string description;           ///< one line
    std::vector<std::string> methods;  ///< registry names of the methods it supports
    std::string default_method;        ///< used without --method
    double default_dt;                 ///< used without --dt
    double default_t_end;              ///< used without --t-end and --steps
};

/// A model adapter: declares its own options on its `eci run NAME` subcommand, then runs once they are parsed.
class model_command {
   public:
    virtual ~model_command() = default;
    /// Name, description, methods and defaults.
    virtual const model_info& info() const = 0;
    /// Adds the model's parameters and initial condition to its subcommand, bound to members of this object.
    virtual void add_options(CLI::App& app) = 0;
    /// Builds the model from the parsed options and runs it (through run_model in run.hpp); returns the exit
    /// status. Throws bad_input (or std::invalid_argument) for input it rejects.
    virtual int run(const run_settings& settings) = 0;
};

/// A CLI11 check that an option is a whole number >= min (CLI11 alone would wrap "-3" into a huge unsigned);
/// one beyond 2^64 - 1 is "too large", not "not a whole number".
inline CLI::Validator whole_number(std::uint64_t min) {
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
        "INT>=" + std::to_string(min));
}

/// Every model, in the order `eci list` shows them.
std::vector<std::unique_ptr<model_command>> registered_models();

}  // namespace eci::cli
