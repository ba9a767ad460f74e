// What `eci run MODEL` knows about a model, without the command-line parser: its name, methods and defaults, its
// options as data (main.cpp binds them with CLI11, the only file that includes it) and the run itself.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace eci::cli {

/// The options of `eci run MODEL` that every model shares.
struct run_settings {
    std::string preset;                  ///< a preset of the model; empty means its first (the default run)
    std::string method;                  ///< registry name; empty means the preset's
    std::optional<double> dt;            ///< time step; unset means the preset's
    std::optional<double> t_end;         ///< end time (exclusive with steps)
    std::optional<std::uint64_t> steps;  ///< number of steps (exclusive with t_end)
    std::uint64_t every = 1;             ///< a CSV row every `every` steps
    std::string output;                  ///< CSV path; "-" is stdout, empty writes no CSV
    std::string summary_json;            ///< JSON summary path; "-" is stdout, empty writes none
    std::string plot;                    ///< picture of the run (.png, .svg, .pdf); empty draws none
    std::optional<double> rtol;          ///< relative tolerance: with or without atol, adaptive step control
    std::optional<double> atol;          ///< absolute tolerance (adaptive); unset means rtol's value
    std::optional<double> output_dt;     ///< CSV rows at multiples of this time (and the end) instead of steps
    /// How an adaptive run reaches the --output-dt times: "auto" (the library's rule), "dense" or "landing";
    /// empty when not given (Python's t_eval_mode).
    std::string output_mode;
    /// Conservative RK methods at fixed steps on large systems (n-wave, the spectral models): "conditioned" (the
    /// default, when empty) or "paper", the paper's update bit for bit (docs/methods.md). Empty: not
    /// given (a spectral --restart then takes its checkpoint's).
    std::string update;
};

/// What `eci list` and `eci run MODEL --help` show about a model, and its defaults (its first preset).
struct model_info {
    std::string name;                  ///< the MODEL argument of `eci run`
    std::string description;           ///< one line
    std::vector<std::string> methods;  ///< registry names of the methods it runs, computed by the registry
    std::string default_method;
    double default_dt = 0.0;
    double default_t_end = 0.0;
    std::vector<std::pair<std::string, std::string>> presets;  ///< name and one line of each preset
    std::string default_dt_text;  ///< the default dt when it is no fixed number (e.g. "from CFL 0.5"); else empty
    std::string default_adaptive_method;  ///< with --rtol/--atol and no --method (empty: the model has none)

    /// The default dt as `eci list` and --help print it.
    std::string dt_text(std::string (*number)(double)) const {
        return default_dt_text.empty() ? number(default_dt) : default_dt_text;
    }
};

/// One model option of `eci run MODEL` (a parameter, a part of the initial state, a generator setting): main.cpp
/// binds it to `reals` (`count` comma-separated numbers) or, for a whole number >= min, to `whole`.
struct option_spec {
    std::string name;  ///< without the leading "--"
    std::string help;  ///< one line, with the real default
    std::size_t count = 1;
    std::vector<double>* reals = nullptr;
    std::uint64_t* whole = nullptr;
    std::uint64_t min = 0;
    std::string* text = nullptr;  ///< a text option (a file, a choice) instead of numbers
    bool* flag = nullptr;         ///< a flag without a value instead of numbers
    bool given = false;  ///< set by main.cpp after parsing
};

/// A model as `eci run` sees it. model_command.hpp implements it once for every model from its description.
class model_command {
   public:
    virtual ~model_command() = default;
    /// Name, description, methods and defaults.
    virtual const model_info& info() const = 0;
    /// The model's own options, bound to storage inside this object.
    virtual std::vector<option_spec>& options() = 0;
    /// Builds the model from the preset and the options given, and runs it; returns the exit status. Throws
    /// bad_input, run_error or interrupted (output.hpp).
    virtual int run(const run_settings& settings) = 0;
    /// Whether a run of this model is spread over the processes of an MPI launch (the spectral equations in the
    /// MPI build); any other model runs on one process only, and main.cpp refuses it under mpirun -np > 1.
    virtual bool spreads_over_processes() const { return false; }
};

/// The shortest text that reads back as v: what a person typed (0.2, not 0.20000000000000001).
std::string shortest(double v);

/// Every model, in the order `eci list` shows them (the list is in apps/eci/CMakeLists.txt).
std::vector<std::unique_ptr<model_command>> registered_models();

}  // namespace eci::cli
