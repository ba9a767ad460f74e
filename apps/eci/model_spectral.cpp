// `eci run EQUATION` for every spectral equation (navier-stokes-2d, charney-hasegawa-mima, surface-qg; the list is
// eci::spectral::equations()): 2-D turbulence with eci::spectral, CSV of the diagnostics and exact budgets, field
// snapshots (PNG, HDF5), spectra and fluxes, checkpoint/restart, blow-up detection.
#include <algorithm>
#include <chrono>
#include <climits>
#include <cmath>
#include <complex>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <limits>
#include <numbers>
#include <memory>
#include <set>
#include <optional>
#include <stdexcept>
#include <string>

#include <sys/stat.h>
#include <unistd.h>

#include <eci/spectral/step.hpp>
#include <eci/solve.hpp>

#include "command.hpp"
#include "h5_series.hpp"
#include "ns2d_output.hpp"
#include "output.hpp"
#include "run_model.hpp"

#ifdef ECI_MPI
#include <mpi.h>
#endif

namespace eci::cli {

namespace {

// The stem of an equation's field files ("vorticity", "buoyancy"): its field with spaces as underscores.
std::string field_stem(std::string_view field) {
    std::string stem(field);
    for (char& c : stem)
        if (c == ' ') c = '_';
    return stem;
}

// Whether --ic names one of the built-in initial fields (else it names a file).
bool named_initial_field(std::string_view ic) { return ic == "random" || ic == "vortex-pair" || ic == "taylor-green"; }

// A problem of the --ic file, as every one is said: "--ic 'FILE': what". The readers' messages that name the file
// themselves have it once ("cannot read FILE: no such file", "FILE holds a 16^2 grid", "FILE: omega_hat ...").
std::string ic_problem(const std::string& file, std::string what) {
    if (const std::string read = "cannot read " + file + ": "; what.rfind(read, 0) == 0)
        what.erase(0, read.size());
    else if (what.rfind(file + ": ", 0) == 0)
        what.erase(0, file.size() + 2);
    else if (what.rfind(file + " ", 0) == 0)
        what = "it" + what.substr(file.size());
    return "--ic '" + file + "': " + what;
}

// ---- MPI (the MPI build under mpirun with more than one process): the run is spread over MPI_COMM_WORLD. Every
// process validates the same input (each reads the files' headers); the verdict is agreed once, before the first
// collective, so a bad input exits 2 on every process with nothing written. Each process then reads its own part
// of an --ic or --restart file (its rows or columns; a failure there is agreed too). From there every decision is
// global (the model's sums are reduced in rank order, the stop flag is agreed once per step). Rank 0 writes CSV,
// JSON, progress, pictures and spectra; the snapshots and checkpoints are written by every process, each its own
// rows or columns of the file (ns2d_output.hpp), so no process holds a whole field but rank 0 for a picture. A
// failure of those is agreed: every process exits 1 with the first failing one's reason. A failure of what rank 0
// alone writes at the end (the commit) aborts every process (MPI_Abort) rather than leave them waiting.
struct mpi_run {
    bool on = false;  // more than one process
    int rank = 0, size = 1;
    bool agreed = false;  // the input verdict has been agreed
};
mpi_run mpi;

void mpi_setup() {
#ifdef ECI_MPI
    int init = 0;
    MPI_Initialized(&init);
    if (!init) return;
    MPI_Comm_rank(MPI_COMM_WORLD, &mpi.rank);
    MPI_Comm_size(MPI_COMM_WORLD, &mpi.size);
    mpi.on = mpi.size > 1;
#endif
}

// Why the input was refused on the lowest-ranked process that refused it, empty if none did (collective: every
// process calls it exactly once, from the normal flow with an empty reason or from the error path of run()).
std::string mpi_refusal([[maybe_unused]] const std::string& mine) {
#ifdef ECI_MPI
    if (!mpi.on || mpi.agreed) return mine;
    mpi.agreed = true;
    return first_failure(MPI_COMM_WORLD, mine);
#else
    return mine;
#endif
}

// Rank 0's text on every process (collective).
std::string agreed_text(const std::string& mine) {
#ifdef ECI_MPI
    if (mpi.on) {
        int size = mpi.rank == 0 ? int(mine.size()) : 0;
        MPI_Bcast(&size, 1, MPI_INT, 0, MPI_COMM_WORLD);
        std::string text = mpi.rank == 0 ? mine : std::string(std::size_t(size), ' ');
        MPI_Bcast(text.data(), size, MPI_CHAR, 0, MPI_COMM_WORLD);
        return text;
    }
#endif
    return mine;
}

// The interrupt flag agreed over every process (collective; the flag alone on one process).
bool stop_requested() {
#ifdef ECI_MPI
    if (mpi.on) {
        int mine = interrupt_requested() ? 1 : 0, any = 0;
        MPI_Allreduce(&mine, &any, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
        return any != 0;
    }
#endif
    return interrupt_requested();
}

// Whether the interrupt that stopped the run keeps its outputs (interrupt_keeps_outputs), agreed over every process
// (collective): SIGPIPE on any process keeps nothing.
bool agreed_keeps_outputs() {
#ifdef ECI_MPI
    if (mpi.on) {
        // 0: keeps nothing (SIGPIPE), 1: keeps, 2: no interrupt here (another process's)
        int mine = interrupt_requested() ? (interrupt_keeps_outputs() ? 1 : 0) : 2, least = 2;
        MPI_Allreduce(&mine, &least, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
        return least != 0;
    }
#endif
    return interrupt_keeps_outputs();
}

// fn() on rank 0 only, its failure known to every process (collective): each throws run_error with its reason.
template <class Fn>
void on_root_agreed(Fn&& fn) {
    if (!mpi.on) return fn();
#ifdef ECI_MPI
    std::string failure;
    if (mpi.rank == 0) {
        try {
            fn();
        } catch (const std::exception& e) {
            failure = e.what();
        }
    }
    if (failure = first_failure(MPI_COMM_WORLD, failure); !failure.empty()) throw run_error(failure);
#endif
}

// fn() on rank 0 only, opening what the run writes: its failure known to every process (collective), each
// throwing what rank 0 threw, bad input (exit 2: an output that cannot be written, said once) as bad input. (It
// was on_root, whose MPI_Abort ended the run with exit 1 and mpirun's banner.)
template <class Fn>
void on_root_opening(Fn&& fn) {
    if (!mpi.on) return fn();
#ifdef ECI_MPI
    std::string failure;  // the kind ('2' bad input, '1' any other) and the reason
    if (mpi.rank == 0) {
        try {
            fn();
        } catch (const bad_input& e) {
            failure = std::string("2") + e.what();
        } catch (const std::exception& e) {
            failure = std::string("1") + e.what();
        }
    }
    if (failure = first_failure(MPI_COMM_WORLD, failure); !failure.empty()) {
        if (failure[0] == '2') throw bad_input(failure.substr(1));
        throw run_error(failure.substr(1));
    }
#endif
}

// fn() on rank 0 only (every process on one); a failure there ends every process.
template <class Fn>
void on_root(Fn&& fn) {
    if (mpi.rank != 0) return;
    if (!mpi.on) return fn();
    try {
        fn();
    } catch (const std::exception& e) {
        std::fprintf(stderr, "eci: error: %s\n", e.what());
#ifdef ECI_MPI
        MPI_Abort(MPI_COMM_WORLD, 1);
#endif
    }
}

using state = navier_stokes_2d::state_type;

std::string num(double v) {
    char b[32];
    return std::string(format_double(v, b));
}

/// A sink of eci::solve made of three callables: output, after_step, progress.
template <class Output, class AfterStep, class Progress>
struct callback_sink {
    Output on_output;
    AfterStep on_step;
    Progress on_progress;
    void output(const state& x, const output_point& p) { on_output(x, p); }
    void after_step(const state& x, const output_point& p) { on_step(x, p); }
    void progress(double t, std::uint64_t i) { on_progress(t, i); }
};

class spectral_command final : public model_command {
   public:
    explicit spectral_command(const spectral::equation& e)
        : eq_(e),
          name_(e.name),
          field_(e.field),
          inv_{std::string(e.invariant_names[0]), std::string(e.invariant_names[1])},
          info_{name_,
                std::string(e.title),
                ns2d_methods(),
                ns2d_methods().front(),
                0.0,  // none: dt comes from --cfl (0.5) unless --dt is given
                10.0,
                {{"default", "random field peaked at k = 8, inviscid, dt from CFL 0.5 (see --help for the "
                             "initial conditions, forcing and outputs)"}},
                "from --cfl 0.5: 0.5 dx / max|u| at t = 0, shorter for fast linear waves or a stiff damping "
                "(docs/turbulence.md)",
                ""} {
        const bool ns = name_ == "navier-stokes-2d";
        default_snapshot_dir_ = ns ? "ns2d-snapshots" : name_ + "-snapshots";
        default_checkpoint_ = ns ? "ns2d-checkpoint.h5" : name_ + "-checkpoint.h5";
        stem_ = field_stem(field_);
        // name, help, and where the value goes: a real, a whole number >= min, a text or a flag
        real("nu", "viscosity nu (default 0)");
        const std::string sym(e.symbol);  // the evolved field's symbol: omega, q, theta
        real("hyper-nu", "hyperviscosity nu_h of -nu_h |k|^(2p) " + sym + " (default 0)");
        real("drag", "linear drag mu of -mu " + sym + " (default 0)");
        real("hypo-nu", "hypoviscosity (large-scale friction) of -nu_hypo |k|^(-2 p') " + sym + " (default 0)");
        if (e.dispersion) {
            real("beta", "planetary vorticity gradient beta: Rossby waves omega = -beta k_x / (k^2 + F) (default 0)");
            real("deformation", "F = 1 / L_d^2 >= 0 in q = lap psi - F psi (default 0: Navier-Stokes with beta)");
        }
        real("forcing-k", "forced band k_f - 1/2 <= |k| < k_f + 1/2 (default 4; with --forcing)");
        real("forcing-amplitude", "--forcing deterministic: rms of the forcing field (default 1)");
        real("injection-rate", "--forcing stochastic: mean energy injection rate (default 1)");
        real("k-peak", "random: peak wavenumber k_p of E(k) ~ q^4 / (1 + q^2)^4, q = k/k_p (default 8)");
        real("energy", "random: initial energy (default 0.5)");
        real("vortex-radius", "vortex-pair: radius of each Gaussian vortex (default 0.25)");
        real("vortex-separation", "vortex-pair: distance of the centres (default 0.7)");
        real("vortex-peak", "vortex-pair: peak " + std::string(e.field) +
                                "; taylor-green: U of q = 2U sin x sin y, the peak velocity for navier-stokes-2d "
                                "(2U/(2 + F) for charney-hasegawa-mima, sqrt(2) U for surface-qg) (default 10, 1)");
        real("cfl", "dt = CFL dx / max|u| at the start (default 0.5; exclusive with --dt)");
        whole("N", "grid points per side, even, >= 8 (default 256); |k_x|, |k_y| <= (N - 1)/3 kept", 0);
        whole("hyper-p", "hyperviscosity power p, 1..16 (default 2; with --hyper-nu)", 0);
        whole("hypo-p", "hypoviscosity power p', 1..16 (default 1; with --hypo-nu)", 0);
        whole("forcing-seed", "seed of the forcing (default 1; with --forcing)", 0);
        whole("seed", "random: seed of the initial field (default 1)", 0);
        whole("threads", "FFTW and OpenMP threads (default 1)", 0);
        whole("snapshot-every", "every K steps the field as HDF5 + PNG, its spectra and fluxes as CSV + PNG "
                                 "(default none)", 1);
        whole("checkpoint-every", "write the checkpoint every K steps and at the end (default: a checkpoint asked "
                                   "for with --checkpoint or --restart at the end and when stopped by a signal)", 1);
        text("forcing", "none, deterministic (fixed band, random phases) or stochastic (white in time) (default none)");
        text("ic", "initial condition: random, vortex-pair, taylor-green, or FILE (an eci snapshot or checkpoint "
                   ".h5; its grid is the default --N) (default random)");
        text("snapshot-dir", "directory of the snapshots (default " + default_snapshot_dir_ + ")");
        text("checkpoint", "checkpoint file, written at the end and when stopped by SIGINT, SIGTERM, SIGHUP or SIGQUIT "
                           "(default " + default_checkpoint_ + "; with --restart, the restart file, continued in "
                           "place; a run that asks for no checkpoint writes the default on a stop only if no such "
                           "file exists)");
        text("restart", "continue, bit for bit, from a checkpoint");
        text("fftw-wisdom", "FFTW wisdom file read before (a restart: after; it plans with its checkpoint's) and "
                            "written after planning, so that every run plans the "
                            "same transforms and repeats bit for bit; 'none' for no file (default "
                            "$XDG_CACHE_HOME/eci/fftw-wisdom, else ~/.cache/eci/fftw-wisdom)");
        flag("fftw-estimate", "FFTW_ESTIMATE plans instead of FFTW_MEASURE (no planning time; not bit-identical "
                              "across FFTW versions or machines either way)");
        flag("full-transforms", "FFTW's 2-D transforms of the whole half plane instead of the transforms of the "
                                "retained columns fused with the products (the default: the same terms to round-off, "
                                "10-40 % faster); --update paper on a field symmetric about grid points needs them");
    }

    const model_info& info() const override { return info_; }
    std::vector<option_spec>& options() override { return specs_; }
    int run(const run_settings& settings) override;
#ifdef ECI_MPI
    bool spreads_over_processes() const override { return true; }
#endif

   private:
    int run_spread(const run_settings& settings);
    void real(const char* name, const std::string& help) {
        helps_.push_back(std::make_unique<std::string>(help));
        reals_.push_back(std::make_unique<std::vector<double>>(1, 0.0));
        specs_.push_back({name, helps_.back()->c_str(), 1, reals_.back().get(), nullptr, 0, nullptr, nullptr, false});
    }
    void whole(const char* name, const char* help, std::uint64_t min) {
        wholes_.push_back(std::make_unique<std::uint64_t>(0));
        specs_.push_back({name, help, 1, nullptr, wholes_.back().get(), min, nullptr, nullptr, false});
    }
    void text(const char* name, const std::string& help) {
        helps_.push_back(std::make_unique<std::string>(help));
        texts_.push_back(std::make_unique<std::string>());
        specs_.push_back({name, helps_.back()->c_str(), 1, nullptr, nullptr, 0, texts_.back().get(), nullptr, false});
    }
    void flag(const char* name, const char* help) {
        flags_.push_back(std::make_unique<bool>(false));
        specs_.push_back({name, help, 1, nullptr, nullptr, 0, nullptr, flags_.back().get(), false});
    }
    const option_spec& spec(const std::string& name) const {
        for (const option_spec& o : specs_)
            if (o.name == name) return o;
        throw std::logic_error("no option " + name);
    }
    // The value of an option if given, else nothing.
    std::optional<double> given_real(const std::string& n) const {
        const option_spec& o = spec(n);
        return o.given ? std::optional<double>(o.reals->front()) : std::nullopt;
    }
    std::optional<std::uint64_t> given_whole(const std::string& n) const {
        const option_spec& o = spec(n);
        return o.given ? std::optional<std::uint64_t>(*o.whole) : std::nullopt;
    }
    std::optional<std::string> given_text(const std::string& n) const {
        const option_spec& o = spec(n);
        return o.given ? std::optional<std::string>(*o.text) : std::nullopt;
    }

    const spectral::equation& eq_;
    std::string name_, field_;
    std::array<std::string, 2> inv_;  // the invariants' names: energy, enstrophy (or variance)
    model_info info_;
    std::string default_snapshot_dir_, default_checkpoint_, stem_;
    std::vector<option_spec> specs_;
    std::vector<std::unique_ptr<std::string>> helps_;
    std::vector<std::unique_ptr<std::vector<double>>> reals_;
    std::vector<std::unique_ptr<std::uint64_t>> wholes_;
    std::vector<std::unique_ptr<std::string>> texts_;
    std::vector<std::unique_ptr<bool>> flags_;
    bool warned_ = false;
};

// The user's wisdom cache, $XDG_CACHE_HOME/eci/fftw-wisdom or ~/.cache/eci/fftw-wisdom; empty if there is no home to
// put it in. Its directory is created only when the wisdom is written, after the run's input is known to be good.
std::string default_wisdom_file() {
    const char* xdg = std::getenv("XDG_CACHE_HOME");
    const char* home = std::getenv("HOME");
    if (xdg && *xdg) return (std::filesystem::path(xdg) / "eci" / "fftw-wisdom").string();
    if (home && *home) return (std::filesystem::path(home) / ".cache" / "eci" / "fftw-wisdom").string();
    return {};
}

// The snapshot files a run writes: "<stem>_<step>.h5", "<stem>_<step>.png", "spectrum_<step>.csv" and
// "spectrum_<step>.png" (step at least 8 digits); the step a name belongs to, or nothing.
std::optional<std::uint64_t> snapshot_step(const std::string& name, const std::string& stem) {
    for (const std::string& prefix : {stem + "_", std::string("spectrum_")}) {
        if (name.compare(0, prefix.size(), prefix) != 0) continue;
        const std::size_t dot = name.find('.', prefix.size());
        if (dot == std::string::npos) continue;
        const std::string digits = name.substr(prefix.size(), dot - prefix.size()), ext = name.substr(dot);
        const bool known = prefix == "spectrum_" ? (ext == ".csv" || ext == ".png") : (ext == ".h5" || ext == ".png");
        if (!known || digits.size() < 8 || digits.size() > 19 ||
            digits.find_first_not_of("0123456789") != std::string::npos)
            continue;
        return std::stoull(digits);
    }
    return std::nullopt;
}

// The equation (other than this run's, whose field stem is `stem`) whose snapshot `name` is, or null: its spectra
// share this run's names, so the two runs' files would mix and the other's spectra be replaced.
const spectral::equation* other_equations_snapshot(const std::string& name, const std::string& stem) {
    for (const spectral::equation* e : spectral::equations()) {
        const std::string other = field_stem(e->field);
        // (snapshot_step takes the spectra too, whose names every equation shares: the field's own prefix decides)
        if (other != stem && name.compare(0, other.size() + 1, other + "_") == 0 && snapshot_step(name, other))
            return e;
    }
    return nullptr;
}

// A setting's CLI option: "--forcing-k" for the library's "forcing_k".
std::string option_name(std::string_view field) {
    std::string o = "--" + std::string(field);
    std::replace(o.begin(), o.end(), '_', '-');
    return o;
}

ns2d_forcing parse_forcing(const std::string& s) {
    try {
        return ns2d_params::forcing_named(s, option_name);
    } catch (const std::invalid_argument& e) {
        throw bad_input(e.what());
    }
}

int spectral_command::run(const run_settings& settings) {
    mpi_setup();
    if (!mpi.on) return run_spread(settings);
    try {
        return run_spread(settings);
    } catch (const std::exception& e) {
        // an error before the verdict was agreed: this process's part of it (the others get its reason there)
        if (!mpi.agreed) mpi_refusal(*e.what() ? e.what() : "the input was refused");
        throw;
    } catch (...) {
        if (!mpi.agreed) mpi_refusal("the input was refused");
        throw;
    }
}

int spectral_command::run_spread(const run_settings& settings) {
    // ---- options this command has no use for are refused, not ignored
    if (settings.rtol || settings.atol) {  // (Python's sentences for its spectral models, the CLI's names in them)
        try {
            (void)tolerances_from(settings.rtol, settings.atol);  // a bad value is named first, as for every model
        } catch (const std::invalid_argument& e) {
            throw bad_input(std::string("--rtol/--atol: ") + e.what());
        }
        if (settings.method.empty()) {  // the library's rule for a run that names no method, as Python's
            try {
                (void)default_method_for<navier_stokes_2d>(info_.default_method, true, "model " + name_);
            } catch (const std::invalid_argument& e) {
                throw bad_input(e.what());
            }
        }
        throw bad_input("--rtol/--atol: method " + settings.method + " has no error estimate for rtol/atol; " + name_ +
                        " runs fixed steps (give --dt, or none for the CFL 0.5 step)");
    }
    // ---- parameters, from the options or the checkpoint (options that contradict it are an error)
    ns2d_checkpoint ck;
    const std::string restart_ = given_text("restart").value_or("");
    const bool restart = !restart_.empty();
    if (restart) {
        try {
            // (spread over processes: the header here, each process's columns of the state once the grid is made)
            ck = read_checkpoint(restart_, 0, !mpi.on);
        } catch (const std::exception& e) {
            throw bad_input(std::string("cannot restart: ") + e.what());
        }
        if (ck.params.equation != name_)
            throw bad_input(restart_ + " is a " + ck.params.equation + " checkpoint, not " + name_ + "'s");
        auto same = [&](const char* name, auto given, auto stored) {
            if (given && *given != stored)
                throw bad_input(std::string("--") + name + " " + shortest(double(*given)) +
                                " does not match the restart file's " + shortest(double(stored)) + " (" + restart_ +
                                ")");
        };
        // The forcing first: the settings that act only with it (and the powers that act only with their
        // coefficients) are then refused as a fresh run refuses them, naming what the checkpoint's run has, not
        // compared with values its run never used (an unforced checkpoint's forcing_k of 4 is the default).
        if (const auto f = given_text("forcing"); f && parse_forcing(*f) != ck.params.forcing)
            throw bad_input("--forcing " + *f + " does not match the restart file's " +
                            std::string(ns2d_params::forcing_name(ck.params.forcing)) + " (" + restart_ +
                            "; a restart continues its checkpoint's forcing)");
        for (const char* field :
             {"forcing_k", "forcing_seed", "forcing_amplitude", "injection_rate", "hyper_p", "hypo_p"})
            if (spec(option_name(field).substr(2)).given)
                if (const std::string why = ck.params.unused_setting(field, option_name); !why.empty())
                    throw bad_input(why + ": the restart file's ('" + restart_ +
                                    "'), which a restart cannot change");
        same("N", given_whole("N"), std::uint64_t(ck.params.n));
        same("nu", given_real("nu"), ck.params.nu);
        same("hyper-nu", given_real("hyper-nu"), ck.params.hyper_nu);
        same("hyper-p", given_whole("hyper-p"), std::uint64_t(ck.params.hyper_p));
        same("drag", given_real("drag"), ck.params.drag);
        same("hypo-nu", given_real("hypo-nu"), ck.params.hypo_nu);
        same("hypo-p", given_whole("hypo-p"), std::uint64_t(ck.params.hypo_p));
        if (eq_.dispersion) {
            same("beta", given_real("beta"), ck.params.beta);
            same("deformation", given_real("deformation"), ck.params.deformation);
        }
        same("forcing-k", given_real("forcing-k"), ck.params.forcing_k);
        if (!settings.method.empty() && settings.method != ck.method)
            throw bad_input("--method " + settings.method + " does not match the restart file's " + ck.method);
        if (settings.dt && *settings.dt != ck.dt)
            throw bad_input("--dt does not match the restart file's " + shortest(ck.dt));
        same("forcing-amplitude", given_real("forcing-amplitude"), ck.params.forcing_amplitude);
        same("injection-rate", given_real("injection-rate"), ck.params.injection_rate);
        same("forcing-seed", given_whole("forcing-seed"), ck.params.forcing_seed);
        // bit-identity needs the plans and the thread count that wrote the checkpoint (its sums are per thread)
        same("threads", given_whole("threads"), std::uint64_t(ck.params.threads));
        if (*spec("fftw-estimate").flag && ck.params.measure)
            throw bad_input("--fftw-estimate does not match the restart file's FFTW_MEASURE plans (" + restart_ +
                            "; the run continues bit for bit only with the plans it started with)");
        if (*spec("full-transforms").flag && ck.params.pruned_transforms)
            throw bad_input("--full-transforms does not match the restart file's transforms of the retained columns (" +
                            restart_ + "; the run continues bit for bit only with the transforms it started with)");
        // the conservative methods' update changes the numbers: the checkpoint's
        if (!settings.update.empty() && settings.update != ck.update)
            throw bad_input("--update " + settings.update + " does not match the restart file's " + ck.update + " (" +
                            restart_ + "; the run continues bit for bit only with the update it started with)");
        if (given_real("cfl")) throw bad_input("--cfl cannot be combined with --restart (the time step is the checkpoint's)");
        if (given_text("ic")) throw bad_input("--ic cannot be combined with --restart");
        for (const char* o : {"seed", "energy", "k-peak", "vortex-radius", "vortex-separation", "vortex-peak"})
            if (spec(o).given)
                throw bad_input(std::string("--") + o + " sets the initial condition; a restart continues from " +
                                restart_ + "'s state");
    }
    ns2d_params p = restart ? ck.params : ns2d_params{};
    // (the library's range and sentence for each whole number, as Python's: flow_params::whole)
    const auto whole_setting = [&](const char* option, const char* field, std::uint64_t fallback) {
        const std::uint64_t v = given_whole(option).value_or(fallback);
        try {
            return ns2d_params::whole(field, (long long)std::min<std::uint64_t>(v, LLONG_MAX));
        } catch (const std::invalid_argument& e) {
            throw bad_input(name_ + ": " + e.what());
        }
    };
    if (!restart) {
        p.equation = name_;
        // --ic FILE without --N: the file's grid (its field is loaded on the grid it was written on)
        std::uint64_t default_n = 256;
        const std::string ic_file = given_text("ic").value_or("random");
        const bool n_of_ic = !given_whole("N") && !named_initial_field(ic_file);
        if (n_of_ic) {
            try {
                default_n = std::uint64_t(is_checkpoint(ic_file) ? read_checkpoint(ic_file, 0, false).params.n
                                                                 : read_vorticity(ic_file, 0, false, stem_).first);
            } catch (const std::exception& e) {
                throw bad_input(ic_problem(ic_file, e.what()));
            }
            // a field of a grid no run takes (33 x 33) is the file's problem, said as such
            try {
                (void)ns2d_params::whole("n", (long long)default_n);
            } catch (const std::invalid_argument& e) {
                throw bad_input(ic_problem(ic_file, "its " + std::to_string(default_n) + "^2 grid is not one " +
                                                        name_ + " runs on: " + e.what()));
            }
        }
        p.n = whole_setting("N", "n", default_n);
        p.hyper_p = whole_setting("hyper-p", "hyper_p", 2);
        p.hypo_p = whole_setting("hypo-p", "hypo_p", 1);
        p.hypo_nu = given_real("hypo-nu").value_or(0.0);
        if (eq_.dispersion) {
            p.beta = given_real("beta").value_or(0.0);
            p.deformation = given_real("deformation").value_or(0.0);
        }
        p.nu = given_real("nu").value_or(0.0);
        p.hyper_nu = given_real("hyper-nu").value_or(0.0);
        p.drag = given_real("drag").value_or(0.0);
        p.forcing = parse_forcing(given_text("forcing").value_or("none"));
        p.forcing_k = given_real("forcing-k").value_or(4.0);
        p.forcing_amplitude = given_real("forcing-amplitude").value_or(1.0);
        p.injection_rate = given_real("injection-rate").value_or(1.0);
        p.forcing_seed = given_whole("forcing-seed").value_or(1);
    }
    if (given_whole("threads")) p.threads = whole_setting("threads", "threads", 1);
    p.measure = restart ? ck.params.measure : !*spec("fftw-estimate").flag;
    p.pruned_transforms = restart ? ck.params.pruned_transforms : !*spec("full-transforms").flag;
    // (a grid that cannot fit in memory is refused by p.validate(), below, as Python's models refuse it)
    // The wisdom file is read and written here, through the CLI's checked output path, not opened by FFTW (a FIFO
    // there would hang it, a device be replaced; a refused run must not create it).
    const std::string wisdom_option = given_text("fftw-wisdom").value_or("");
    const bool default_wisdom = wisdom_option.empty();
    std::string wisdom_path = wisdom_option == "none" ? std::string() : default_wisdom ? default_wisdom_file() : wisdom_option;
    p.wisdom_file.clear();
    const std::string ic_ = given_text("ic").value_or("random");
    using field = spectral::flow2d::field_defaults;
    const double k_peak_ = given_real("k-peak").value_or(field::k_peak);
    const double energy_ = given_real("energy").value_or(field::energy);
    const std::uint64_t seed_ = given_whole("seed").value_or(field::seed);
    const double vortex_radius_ = given_real("vortex-radius").value_or(field::vortex_radius);
    const double vortex_separation_ = given_real("vortex-separation").value_or(field::vortex_separation);
    const double vortex_peak_ = given_real("vortex-peak").value_or(ic_ == "taylor-green" ? field::taylor_green_velocity
                                                                                           : field::vortex_peak);
    // A setting that cannot change this run is refused, not ignored (a forgotten --forcing stochastic ran unforced
    // with the --injection-rate typed): the library's rule for the equation's settings, as Python's, and here the
    // options of another initial field. (A restart's settings are the checkpoint's, compared above.)
    if (!restart) {
        for (const char* field :
             {"forcing_k", "forcing_seed", "forcing_amplitude", "injection_rate", "hyper_p", "hypo_p"})
            if (spec(option_name(field).substr(2)).given)
                if (const std::string why = p.unused_setting(field, option_name); !why.empty()) throw bad_input(why);
        const bool named_field = named_initial_field(ic_);
        const auto for_ic = [&](const char* option, bool used, const char* what) {
            if (spec(option).given && !used)
                throw bad_input(std::string("--") + option + " sets " + what + ", and this run's --ic is " +
                                (named_field ? ic_ : "the file '" + ic_ + "'"));
        };
        for (const char* o : {"k-peak", "energy", "seed"}) for_ic(o, ic_ == "random", "the random initial field");
        for (const char* o : {"vortex-radius", "vortex-separation"})
            for_ic(o, ic_ == "vortex-pair", "the vortex-pair initial field");
        for_ic("vortex-peak", ic_ == "vortex-pair" || ic_ == "taylor-green", "the vortex-pair or taylor-green field");
    }
    const std::optional<double> cfl_ = given_real("cfl");
    const std::uint64_t snapshot_every_ = given_whole("snapshot-every").value_or(0);
    const std::uint64_t checkpoint_every_ = given_whole("checkpoint-every").value_or(0);
    const std::string snapshot_dir_ = given_text("snapshot-dir").value_or(default_snapshot_dir_);
    // A checkpoint asked for (--checkpoint, --checkpoint-every) is written at those steps and on a stop. A restart
    // continues its checkpoint in place by default. A run that asked for none keeps one on a stop only where no file
    // is replaced: the default name of a run in the same directory must not lose another run's (keep_on_stop below).
    const bool checkpoint_asked = given_text("checkpoint").has_value() || checkpoint_every_ > 0 || restart;
    const std::string checkpoint_ = given_text("checkpoint").value_or(restart ? restart_ : default_checkpoint_);
    if (given_text("snapshot-dir") && snapshot_every_ == 0)
        throw bad_input("--snapshot-dir is where --snapshot-every K writes its snapshots, and --snapshot-every is not "
                        "given");
    if (!settings.preset.empty() && settings.preset != "default")
        throw bad_input(name_ + " has one preset, default; set the initial condition with --ic");
    try {
        p.validate();
    } catch (const std::invalid_argument& e) {
        throw bad_input(name_ + ": " + e.what());
    }
    const std::string method = restart ? ck.method : settings.method.empty() ? info_.default_method : settings.method;
    try {  // (the library's sentence, as Python's spectral models refuse a method)
        (void)resolve_named_method(method, info_.methods, "model " + name_);
    } catch (const std::invalid_argument& e) {
        throw bad_input(e.what());
    }
    if (settings.dt && cfl_) throw bad_input("give --dt or --cfl, not both");
    if (cfl_ && !(std::isfinite(*cfl_) && *cfl_ > 0.0)) throw bad_input("--cfl must be a positive number");
    if (settings.dt && !(std::isfinite(*settings.dt) && *settings.dt > 0.0))
        throw bad_input("--dt must be a positive finite number, not " + shortest(*settings.dt));
    if (settings.t_end && settings.steps) throw bad_input("give --t-end or --steps, not both");
    if (settings.t_end && !(std::isfinite(*settings.t_end) && *settings.t_end >= 0.0))
        throw bad_input("--t-end must be a finite number >= 0, not " + shortest(*settings.t_end));
    // beyond max_grid_steps (2^53) the grid i dt is no longer exact (and the run would never end): as for every model
    if (settings.steps && *settings.steps > max_grid_steps)
        throw bad_input("--steps " + std::to_string(*settings.steps) + " is too many (at most 2^53)");
    if (settings.every == 0) throw bad_input("--every must be at least 1");
    check_distinct_outputs(settings);

    // ---- every file the run will write, checked before any work: a regular file or
    // a symlink to one (written through), in a directory where a file can be created, no two outputs the same file;
    // FIFOs, devices, directories and read-only files are refused, never replaced
    namespace fs = std::filesystem;
    std::vector<std::pair<std::string, std::string>> named = {
        {"--output", settings.output}, {"--summary-json", settings.summary_json}, {"--plot", settings.plot}};
    if (checkpoint_asked) named.emplace_back("--checkpoint", checkpoint_);
    if (!default_wisdom) named.emplace_back("--fftw-wisdom", wisdom_path);
    check_distinct_files(named);
    // ... nor one of the files the run reads: --ic and --restart (the wisdom file, read and written, is in `named`).
    // A checkpoint written over the one the run restarts from is the run continued in place, replaced whole once
    // read: allowed, as with the default name.
    std::vector<std::pair<std::string, std::string>> inputs;
    if (restart) inputs.emplace_back("--restart", restart_);
    if (const std::string ic = given_text("ic").value_or("");
        !ic.empty() && !named_initial_field(ic))
        inputs.emplace_back("--ic", ic);
    {
        std::vector<std::pair<std::string, std::string>> outputs;
        for (const auto& o : named)
            if (!(restart && o.first == "--checkpoint")) outputs.push_back(o);
        check_outputs_spare_inputs(outputs, inputs);
    }
    // Where a stop keeps the run: the checkpoint asked for; else the default name if it is free and writable.
    std::string no_checkpoint_why;
    // the default name taken: another run's checkpoint in this directory (unless named, or the one restarted)
    std::error_code taken_ec;
    const bool default_taken = !restart && !given_text("checkpoint") &&
                               fs::exists(fs::symlink_status(checkpoint_, taken_ec));
    if (checkpoint_asked) {
        // --checkpoint-every would replace it (a stop without one asked for keeps it, below)
        if (default_taken)
            throw bad_input("--checkpoint-every would replace '" + checkpoint_ + "', another run's checkpoint: "
                            "--checkpoint FILE names this run's (that file, to replace it)");
        check_output_path(checkpoint_, "checkpoint");
    } else {
        if (default_taken)
            no_checkpoint_why = "'" + checkpoint_ + "' exists, another run's; --checkpoint FILE keeps one";
        else
            try {
                check_output_path(checkpoint_, "checkpoint");
            } catch (const bad_input& e) {
                no_checkpoint_why = std::string(e.what()) + "; --checkpoint FILE keeps one elsewhere";
            }
    }
    std::optional<std::string> wisdom_text;
    if (!wisdom_path.empty()) {
        try {
            wisdom_text = read_small_file(wisdom_path, "FFTW wisdom file", std::size_t(64) << 20);
            // written back after the run: a file that is not wisdom (a mistyped --output's name) is refused, not
            // replaced; the default cache holding something else is left alone, unused
            if (wisdom_text && !navier_stokes_2d::is_fftw_wisdom(*wisdom_text)) {
                if (!default_wisdom)
                    throw bad_input("--fftw-wisdom '" + wisdom_path + "' is not an FFTW wisdom file, and the run "
                                    "would replace it: name a wisdom file, a new file, or none");
                if (mpi.rank == 0)
                    std::fprintf(stderr, "eci: warning: '%s' is not FFTW wisdom: the run neither reads nor replaces it\n",
                                 wisdom_path.c_str());
                wisdom_text.reset();
                wisdom_path.clear();
            } else {
                const fs::path parent = fs::path(wisdom_path).parent_path();
                if (!default_wisdom || fs::is_directory(parent.empty() ? fs::path(".") : parent))
                    check_output_path(wisdom_path, "FFTW wisdom file");
            }
        } catch (const bad_input&) {
            if (!default_wisdom) throw;
            wisdom_path.clear();  // the default cache cannot be written (or read): use what could be read, as before
        }
    }
    if (snapshot_every_ > 0) {
        const std::uint64_t first_step = restart ? ck.step : 0;
        const std::string dir = snapshot_dir_.empty() ? std::string(".") : snapshot_dir_;
        struct stat st {};
        if (::stat(dir.c_str(), &st) == 0) {
            if (!S_ISDIR(st.st_mode))
                throw bad_input("cannot write snapshots into '" + snapshot_dir_ + "': it is not a directory");
            if (::access(dir.c_str(), W_OK | X_OK) != 0)
                throw bad_input("cannot write snapshots into '" + snapshot_dir_ + "': " + std::strerror(errno));
            std::error_code ec;
            for (const auto& entry : fs::directory_iterator(dir, ec)) {
                const auto step = snapshot_step(entry.path().filename().string(), stem_);
                if (!step || *step < first_step) continue;
                const std::string target = check_output_path(entry.path().string(), "snapshot");
                // a name linked elsewhere is written through: its target must be on the directory's file system
                struct stat t {};
                const fs::path target_dir = fs::path(target).parent_path();
                if (::stat(target_dir.empty() ? "." : target_dir.c_str(), &t) == 0 && t.st_dev != st.st_dev)
                    throw bad_input("cannot write snapshot '" + entry.path().string() +
                                    "': it links to another file system");
            }
            if (ec) throw bad_input("cannot read snapshot directory '" + snapshot_dir_ + "': " + ec.message());
        } else {
            check_data_directory(dir, "snapshots");
            const fs::path parent = fs::path(dir).parent_path().empty() ? fs::path(".") : fs::path(dir).parent_path();
            if (!fs::is_directory(parent))
                throw bad_input("cannot create snapshot directory '" + snapshot_dir_ + "': " +
                                (fs::exists(parent) ? "'" + parent.string() + "' is not a directory"
                                                    : "directory '" + parent.string() + "' does not exist"));
            if (::access(parent.c_str(), W_OK | X_OK) != 0)
                throw bad_input("cannot create snapshot directory '" + snapshot_dir_ + "': " + std::strerror(errno));
        }
        // no other output may be one of the snapshot files
        std::error_code ec;
        const fs::path snapshots = fs::weakly_canonical(fs::absolute(dir, ec), ec);
        for (const auto& [option, path] : named) {
            if (path.empty() || path == "-") continue;
            if (fs::weakly_canonical(fs::absolute(path, ec), ec) == snapshots)
                throw bad_input(option + " and --snapshot-dir name the same file '" + path + "'");
            if (!snapshot_step(fs::path(path).filename().string(), stem_)) continue;
            const fs::path parent = fs::path(path).parent_path().empty() ? fs::path(".") : fs::path(path).parent_path();
            if (fs::weakly_canonical(fs::absolute(parent, ec), ec) == snapshots)
                throw bad_input(option + " and --snapshot-dir name the same file '" + path + "' (a snapshot's)");
        }
    }

    // ---- the initial condition (a file of another grid is an error)
    std::optional<ns2d_checkpoint> ic_checkpoint;
    std::optional<std::pair<int, std::vector<double>>> ic_field;
    if (!restart && !named_initial_field(ic_)) {
        try {
            if (is_checkpoint(ic_))
                ic_checkpoint = read_checkpoint(ic_, p.n, !mpi.on);
            else
                ic_field = read_vorticity(ic_, p.n, !mpi.on, stem_);
        } catch (const std::exception& e) {
            throw bad_input(ic_problem(ic_, e.what()));
        }
        const int file_n = ic_checkpoint ? ic_checkpoint->params.n : ic_field->first;
        if (file_n != p.n)
            throw bad_input(ic_problem(ic_, "it holds a " + std::to_string(file_n) + "^2 grid, not N = " +
                                                std::to_string(p.n)));
    }

    if (mpi.on && mpi.size > p.n)
        throw bad_input(std::to_string(mpi.size) + " MPI processes for N = " + std::to_string(p.n) +
                        ": at most one process per grid row");
    // (on any number of processes: its decisions are taken from sums over all of them)
    // (a restart takes the checkpoint's, checked above)
    const std::string update = restart ? ck.update : settings.update.empty() ? "conditioned" : settings.update;
    // every process has checked the same input: one verdict for all, before the first collective
    if (const std::string why = mpi_refusal({}); !why.empty()) throw bad_input(why);
    // (rank 0's file system decides where a stop keeps the run, for every process: the write is collective)
    if (!checkpoint_asked) no_checkpoint_why = agreed_text(no_checkpoint_why);
    const bool keep_on_stop = no_checkpoint_why.empty();
#ifdef ECI_MPI
    if (mpi.on) {
        p.comm = MPI_COMM_WORLD;
        // A wisdom file named on the command line is neither read nor written, where the serial run writes it: said
        // once, rather than leaving the user to find no file (the default cache is left alone silently)
        if (!default_wisdom && !wisdom_path.empty() && mpi.rank == 0)
            std::fprintf(stderr,
                         "eci: warning: --fftw-wisdom '%s' is not used by a run spread over %d processes (each plans "
                         "its own part of the transforms): it is neither read nor written\n",
                         wisdom_path.c_str(), mpi.size);
        wisdom_text.reset();  // (each process plans its own part; the MPI plans are not kept in a wisdom file)
        wisdom_path.clear();
        p.wisdom.clear();  // (nor taken from a checkpoint: another process count plans other transforms)
    }
#endif
    // A restart plans with the checkpoint's wisdom alone, so that it continues bit for bit whatever the wisdom file
    // holds for this N (FFTW keeps the plan imported first where two disagree); the file's wisdom is imported after
    // planning, so that writing the file back keeps its plans for other sizes.
    const bool wisdom_after = restart && !p.wisdom.empty();
    if (wisdom_text && !wisdom_after) navier_stokes_2d::import_fftw_wisdom(*wisdom_text);  // not wisdom: ignored
    navier_stokes_2d model = [&] {
        try {
            // FFTW_MEASURE plans a new size or thread count for seconds (N = 1024) to minutes (8192): said on a
            // terminal, where a run would otherwise show nothing until they are made
            std::optional<delayed_status> planning;
            if (mpi.rank == 0 && p.measure)
                planning.emplace("eci: planning the FFTW transforms (N = " + std::to_string(p.n) + ", " +
                                 std::to_string(p.threads) + (p.threads == 1 ? " thread" : " threads") +
                                 ", FFTW_MEASURE; " +
                                 (wisdom_path.empty() ? "not kept: --fftw-wisdom none)..."
                                                      : "kept in " + wisdom_path + " for later runs)..."));
            return navier_stokes_2d(p);
        } catch (const std::invalid_argument& e) {
            throw bad_input(name_ + ": " + e.what());
        }
    }();
    if (wisdom_text && wisdom_after) navier_stokes_2d::import_fftw_wisdom(*wisdom_text);
    // Spread over processes, each reads its own part of an --ic or --restart file: its columns of a checkpoint's
    // state, its rows of a snapshot's field (the headers were read and agreed above).
    state part_columns;
    std::vector<double> part_rows;
    if (mpi.on && (restart || ic_checkpoint || ic_field)) {
#ifdef ECI_MPI
        const spectral::grid& g = model.grid();
        std::string failure;
        try {
            if (restart || ic_checkpoint)
                part_columns = read_checkpoint_columns(restart ? restart_ : ic_, restart ? ck : *ic_checkpoint,
                                                       g.first_column(), g.local_columns());
            else
                part_rows = read_vorticity_rows(ic_, p.n, g.first_row(), g.local_rows(), stem_);
        } catch (const std::exception& e) {
            failure = restart ? "cannot restart: " + std::string(e.what()) : ic_problem(ic_, e.what());
        }
        if (failure = first_failure(MPI_COMM_WORLD, failure); !failure.empty()) throw bad_input(failure);
        // a checkpoint's state against its checksum: every process's part, summed (the same verdict on all)
        const ns2d_checkpoint& header = restart ? ck : ic_checkpoint ? *ic_checkpoint : ck;
        if ((restart || ic_checkpoint) && header.checksum) {
            const std::uint64_t part = state_checksum(part_columns.data(), p.n, g.first_column(), g.local_columns());
            std::uint64_t whole = 0;
            MPI_Allreduce(&part, &whole, 1, MPI_UINT64_T, MPI_SUM, MPI_COMM_WORLD);
            if (whole != *header.checksum)
                throw bad_input(restart ? "cannot restart: " + checksum_mismatch(restart_, header.params.equation)
                                        : ic_problem(ic_, checksum_mismatch(ic_, header.params.equation)));
        }
#endif
    }
    state w;
    const bool ic_of_file = !restart && !named_initial_field(ic_);  // (its problems are said as --ic 'FILE': ...)
    try {
        if (restart && mpi.on) {
            w = model.from_half_plane_columns(part_columns);
            model.set_rng_state(ck.rng_state);
        } else if (restart) {
            w = model.from_half_plane(ck.state);
            ck.state = state();  // (the file's half plane is not needed again)
            model.set_rng_state(ck.rng_state);
        } else if (ic_ == "random") {
            // a peak asked for beyond the retained modes would pile the spectrum up at the cut-off (the default 8 is
            // kept on a small grid: the field of every N, as before)
            if (const std::string why = model.grid().beyond_retained(k_peak_); given_real("k-peak") && !why.empty())
                throw bad_input("--k-peak " + shortest(k_peak_) + " " + why);
            w = model.random_field(k_peak_, energy_, seed_);
        } else if (ic_ == "vortex-pair") {
            w = model.vortex_pair(vortex_radius_, vortex_separation_, vortex_peak_);
        } else if (ic_ == "taylor-green") {
            w = model.taylor_green(vortex_peak_);
        } else if (ic_checkpoint) {
            w = mpi.on ? model.from_half_plane_columns(part_columns) : model.from_half_plane(ic_checkpoint->state);
        } else {
            w = mpi.on ? model.from_physical_rows(part_rows) : model.from_physical(ic_field->second);
        }
    } catch (const std::invalid_argument& e) {
        throw bad_input(ic_of_file ? ic_problem(ic_, e.what()) : std::string("initial condition: ") + e.what());
    }
    try {  // the library's check, as Python's (collective: every process gives the same verdict)
        model.check_initial_state(w);
        model.check_initial_rates(w);
    } catch (const std::invalid_argument& e) {
        throw bad_input(ic_of_file ? ic_problem(ic_, e.what()) : std::string(e.what()));
    }
    // A field file's mean and its modes beyond the retained ones are not evolved: the run takes its projection. A
    // user's own field may hold much there (an eci snapshot holds nothing but round-off): said, not silently run.
    if (ic_field) {
        const std::span<const double> given = mpi.on ? std::span<const double>(part_rows)
                                                     : std::span<const double>(ic_field->second);
        const std::vector<double> kept = model.to_physical_rows(w);  // (collective)
        double scale = 0.0;  // (sums of squares of f / max|f|: a field of 1e200 is finite and so are they)
        for (const double f : given) scale = std::max(scale, std::abs(f));
        model.grid().max_over_ranks(&scale, 1);
        std::array<double, 2> sums{0.0, 0.0};  // sum f^2, sum (f - P f)^2
        for (std::size_t j = 0; scale > 0.0 && j < given.size(); ++j) {
            const double f = given[j] / scale, d = (given[j] - kept[j]) / scale;
            sums[0] += f * f;
            sums[1] += d * d;
        }
        model.grid().sum_over_ranks(sums.data(), sums.size());
        // above 1e-10 of the mean square (1e-5 of the rms): more than any rounding of a field written by eci
        if (mpi.rank == 0 && sums[1] > 1e-10 * sums[0])
            std::fprintf(stderr,
                         "eci: warning: --ic '%s': %.3g %% of the field's mean square is in its mean and its modes "
                         "beyond |k_x|, |k_y| <= kmax = %d, which the run drops (it evolves the dealiased, zero-mean "
                         "field)\n",
                         ic_.c_str(), 100.0 * sums[1] / sums[0], model.kmax());
    }

    // ---- time step and span
    const double dx = 2.0 * std::numbers::pi / p.n;
    double dt = restart ? ck.dt : 0.0;
    bool damping_limited = false;  // the default step is the linear damping's bound (flow2d::initial_cfl_step)
    if (!restart) {
        if (settings.dt) {
            dt = *settings.dt;
        } else {
            // the library's rule and sentences, as Python's default dt (refused here, before the wisdom file is
            // written: a --cfl of 4.9e-324 gave dt = 0)
            try {
                dt = model.initial_cfl_step(w, cfl_.value_or(spectral::flow2d::default_cfl), "--dt", "--cfl");
            } catch (const std::invalid_argument& e) {
                // (of the file's field: a zero one has no CFL step)
                throw bad_input(ic_of_file ? ic_problem(ic_, e.what()) : std::string(e.what()));
            }
            // (the library's bound, formed as it forms it)
            const double rate = model.linear_rate();
            damping_limited = rate > 0.0 && dt == 2.0 * cfl_.value_or(spectral::flow2d::default_cfl) / rate;
            // rows every --output-dt of time: the CFL step shortened to divide it (steps.hpp), as Python's
            if (settings.output_dt) dt = step_dividing(*settings.output_dt, dt);
        }
    }
    const std::uint64_t first = restart ? ck.step : 0;
    // The run's end: --steps whole steps of dt, or an end time (--t-end, the restart file's, the default) landed on
    // as every model's run and Python's eci.solve land on it, the last step shortened to it. (A checkpoint of an
    // earlier version holds no end time: its run goes on to its total_steps.)
    double t_end = std::numeric_limits<double>::quiet_NaN();  // NaN: by steps
    std::uint64_t last = 0;
    if (settings.steps) {
        last = *settings.steps;
    } else {
        t_end = settings.t_end ? *settings.t_end : restart ? ck.t_end : info_.default_t_end;
        // (a --dt of 1e-20 took one step of the whole span before: the count overflowed)
        if (t_end / dt > double(max_grid_steps)) {
            const std::string steps = shortest(t_end / dt) + " steps, too many";
            if (settings.dt || restart) throw bad_input("--t-end / --dt is " + steps);
            throw bad_input("--t-end / the default step " + shortest(dt) + " is " + steps +
                            (damping_limited ? " (the step of the linear damping's stability: it decays at up to " +
                                                   shortest(model.linear_rate()) + " per unit time)"
                                             : std::string()));
        }
        last = std::isnan(t_end) ? ck.total_steps : steps_to_reach(0.0, t_end, dt);
    }
    // whether the last step is shorter than dt: the state at the end is then off the grid t = i dt, and a
    // checkpoint there keeps the step before it (so that a restart goes on as the uninterrupted run would)
    const bool short_end = !std::isnan(t_end) && last > 0 && last_step_to_reach(0.0, t_end, dt, last) != dt;
    if (last < first)
        throw bad_input("the restart file is at step " + std::to_string(first) + " (t = " + num(double(first) * dt) +
                        "), beyond the requested " +
                        (std::isnan(t_end) ? "--steps " + std::to_string(last) : "--t-end " + shortest(t_end)));
    // the steps whose snapshots this run writes
    const auto written = [&](std::uint64_t i) {
        return restart ? i > first && i <= last && (i % snapshot_every_ == 0 || i == last)
                       : i == first || (i <= last && (i % snapshot_every_ == 0 || i == last));
    };
    // The steps of a restart's earlier part: up to its checkpoint's step, and where that part's last step was
    // shortened to land on its end (the checkpoint keeps the step before it) that step too, taken again here as a
    // whole step of dt (its rows and snapshot, at t_end, are the earlier part's; docs/turbulence.md).
    const bool earlier_short_end = restart && !std::isnan(ck.t_end) && ck.step + 1 == ck.total_steps &&
                                   last_step_to_reach(0.0, ck.t_end, ck.dt, ck.total_steps) != ck.dt;
    const auto earlier_part = [&](std::uint64_t i) {
        return restart && (i <= first || (earlier_short_end && i == first + 1));
    };
    // One look at the snapshot directory. No snapshot this run writes may replace its --ic or --restart file (nor a
    // file a snapshot's name links to). A directory holding another run's snapshots at steps this run does not write
    // would mix the two runs (its own earlier part's belong to it): refused, nothing replaced (after the inputs'
    // check, which names the more particular problem).
    if (snapshot_every_ > 0) {
        const std::string shown =
            "--snapshot-dir '" + (snapshot_dir_.empty() ? std::string(".") : snapshot_dir_) + "'";
        std::set<std::uint64_t> stale;
        std::string other_grid;  // the first snapshot this run would replace of another grid (rank 0's verdict, below)
        std::uint64_t other_step = 0;
        std::error_code ec;
        for (const auto& entry : fs::directory_iterator(snapshot_dir_.empty() ? "." : snapshot_dir_, ec)) {
            const std::string file = entry.path().filename().string();
            if (const spectral::equation* other = other_equations_snapshot(file, stem_))
                throw bad_input(shown + " holds another equation's snapshots ('" + file + "', " +
                                std::string(other->name) + "'s): this run's spectra would replace its; give another "
                                "directory");
            const auto step = snapshot_step(file, stem_);
            if (!step) continue;
            if (!written(*step)) {
                if (!earlier_part(*step)) stale.insert(*step);
                continue;
            }
            // a snapshot this run replaces must be of its grid: the same steps of another run are not its own
            if (entry.path().extension() == ".h5" && file.rfind(stem_ + "_", 0) == 0) {
                int n_file = p.n;
                try {
                    n_file = read_vorticity(entry.path().string(), 0, false).first;
                } catch (const std::exception&) {
                    // (unreadable: not a run's snapshot, replaced like any file of this name)
                }
                if (n_file != p.n && (other_grid.empty() || *step < other_step)) {
                    other_step = *step;
                    other_grid = shown + " holds another run's snapshots ('" + file + "' is of N = " +
                                 std::to_string(n_file) + ", this run's N = " + std::to_string(p.n) +
                                 "): give another directory or remove them";
                }
            }
            if (inputs.empty()) continue;
            char digits[32];
            std::snprintf(digits, sizeof digits, "%08llu", (unsigned long long)*step);
            const std::string ext = entry.path().extension().string();
            if (file != stem_ + "_" + digits + ext && file != std::string("spectrum_") + digits + ext) continue;
            check_outputs_spare_inputs({{"--snapshot-dir", entry.path().string()}}, inputs);
        }
        other_grid = agreed_text(other_grid);  // (collective: a header one process could not read decides nothing)
        if (!stale.empty())
            throw bad_input(shown + " holds another run's snapshots at steps this run does not write (step " +
                            std::to_string(*stale.begin()) +
                            (stale.size() > 1 ? " and " + std::to_string(stale.size() - 1) + " more" : std::string()) +
                            "): they would mix with this run's; give another directory or remove them");
        if (!other_grid.empty()) throw bad_input(other_grid);
    }
    // The run's span and rows, here, before any output is opened (its other settings below, with the sink)
    run_config cfg;
    cfg.dt = dt;
    cfg.first_step = first;  // a restart continues the grid i dt and its step numbers
    if (std::isnan(t_end))
        cfg.steps = last - first;
    else
        cfg.t_end = t_end;  // (the library lands on it: steps first + 1 .. last, the last one shortened if need be)
    cfg.every = settings.every;
    // rows every --output-dt of time: every k = output-dt / dt steps, k whole (the library's rule and sentences)
    cfg.output_dt = settings.output_dt;
    try {
        resolve_output_dt(cfg, {.output_dt = "--output-dt",
                                .dt = restart ? "the restart file's time step" : "--dt",
                                .tolerances = ""});
    } catch (const std::invalid_argument& e) {
        throw bad_input(e.what());
    }

    // ---- outputs: opened (or their directories created) only now that the input is known to be good
    // The snapshot directory is created now if missing (and removed again if the run fails while it is empty); the
    // snapshots go into a staging directory inside it and are moved in only when the run has succeeded, so a run
    // that blows up or is stopped creates and replaces none of them.
    std::optional<created_directory> created_snapshot_dir;
    std::optional<staging_dir> staged_snapshots;
    std::optional<output_file> csv_file, json_file, plot_file;
    on_root_opening([&] {
        // A restart writes its own steps to its outputs: a CSV, HDF5 or JSON file of that name (the first part of the
        // run, as a rerun of the same command line would name it) would be replaced by them, its rows lost
        if (restart)
            for (const auto& [option, path] : {std::pair{"--output", settings.output},
                                               std::pair{"--summary-json", settings.summary_json}}) {
                std::error_code ec;
                if (!path.empty() && path != "-" && fs::is_regular_file(path, ec))
                    throw bad_input(std::string(option) + " '" + path + "' exists: the restarted run writes steps " +
                                    std::to_string(ck.step + 1) + " on and would replace it (name a new file)");
            }
        check_plot_request(settings.plot);
        if (snapshot_every_ > 0) {
            const std::string dir = snapshot_dir_.empty() ? std::string(".") : snapshot_dir_;
            if (::mkdir(dir.c_str(), 0777) == 0)
                created_snapshot_dir.emplace(dir);
            else if (errno != EEXIST)
                throw bad_input("cannot create snapshot directory '" + snapshot_dir_ + "': " + std::strerror(errno));
            staged_snapshots.emplace(dir, "snapshots");
        }
        check_hdf5_request(settings.output);
        if (!settings.output.empty())
            csv_file.emplace(settings.output, is_hdf5_path(settings.output) ? "HDF5 output" : "CSV output");
        if (csv_file && is_hdf5_path(settings.output) && csv_file->temporary().empty())
            throw bad_input("--output '" + settings.output +
                            "': HDF5 is written to a regular file, not a device or FIFO");
        if (!settings.summary_json.empty()) json_file.emplace(settings.summary_json, "summary JSON");
        if (!settings.plot.empty()) plot_file.emplace(settings.plot, "plot");
    });
    output_file no_csv, no_json, no_plot;
    output_file& csv = csv_file ? *csv_file : no_csv;
    output_file& json = json_file ? *json_file : no_json;
    output_file& picture = plot_file ? *plot_file : no_plot;
    // The wisdom (the model's plans), now that the input is known to be good; the default cache's directory is made
    // here, and a cache that cannot be written is no error.
    if (!wisdom_path.empty()) {
        const std::string text = navier_stokes_2d::fftw_wisdom();
        const auto write = [&] {
            write_replacing(wisdom_path, "FFTW wisdom file", [&](const std::string& tmp) {
                write_new_file(tmp, "FFTW wisdom file", [&](std::FILE* f) { std::fputs(text.c_str(), f); }, false);
            });
        };
        if (!default_wisdom) {
            write();
        } else {
            try {
                std::error_code ec;
                fs::create_directories(fs::path(wisdom_path).parent_path(), ec);
                write();
            } catch (const std::exception&) {
            }
        }
    }

    ns2d_checkpoint run = restart ? ck : ns2d_checkpoint{};
    run.params = p;
    run.keep_wisdom = !mpi.on;
    run.method = method;
    run.update = update;
    run.dt = dt;
    run.total_steps = last;
    run.t_end = t_end;
    if (!restart) {
        run.energy0 = model.energy(w);
        run.enstrophy0 = model.enstrophy(w);
    }
    // --output FILE.h5 (rank 0's): the CSV's columns as HDF5 datasets, t and the diagnostics
    const std::vector<std::string> diagnostics{"step", inv_[0], inv_[1], "palinstrophy", inv_[0] + "_injection",
                                               inv_[0] + "_dissipation", inv_[1] + "_injection",
                                               inv_[1] + "_dissipation", inv_[0] + "_budget_residual",
                                               inv_[1] + "_budget_residual", "max_velocity", "cfl", "halvings"};
    std::optional<h5_series> h5;
    if (csv.get() && is_hdf5_path(settings.output))
        h5.emplace(csv.temporary(), "HDF5 output '" + settings.output + "'",
                   std::vector<h5_series::group>{{"diagnostics", diagnostics.size(), diagnostics}},
                   std::vector<h5_series::attribute>{
                       {"model", name_}, {"method", method}, {"dt", dt}, {"N", std::int64_t(p.n)}});
    std::FILE* out = h5 ? nullptr : csv.get();
    if (out)
        std::fputs(("step,t," + inv_[0] + "," + inv_[1] + ",palinstrophy," + inv_[0] + "_injection," + inv_[0] +
                    "_dissipation," + inv_[1] + "_injection," + inv_[1] + "_dissipation," + inv_[0] +
                    "_budget_residual," + inv_[1] + "_budget_residual,max_velocity,cfl,halvings\n")
                       .c_str(),
                   out);
    // --plot (rank 0's): E and Z over time, and each one's change beyond its budget (what the injection and
    // dissipation account for), from the CSV's rows
    std::optional<run_plot> plot;
    if (picture.get())
        plot.emplace(settings.plot, std::vector<std::string>{inv_[0], inv_[1]}, 2,
                     std::vector<std::string>{inv_[0], inv_[1]},
                     "eci run " + name_ + " (N = " + std::to_string(p.n) + "): " + method + ", dt " + title_number(dt),
                     inv_[0] + ", " + inv_[1], true, "(invariant - its budget - initial) / |initial|");
    // (the same on every process; `out` and the plot are rank 0's)
    const bool rows_wanted = !settings.output.empty() || !settings.plot.empty();
    std::uint64_t last_row = first, last_snapshot = first;  // the steps of the last CSV row and snapshot made
    // The pictures a stop left undrawn (the plotting program is stopped with the run, and a picture not begun is not
    // drawn: the snapshot keeps its data, not those pictures), by name: those of the last snapshot, and of the one
    // before it where the stop came at the first snapshot (the step after it is taken before the stop is seen).
    std::vector<std::string> cut_pictures;
    auto row = [&](std::uint64_t i, double t, double e, double z) {  // (e, z: E and Z of w at time t)
        last_row = i;
        const double u = model.max_velocity(w);
        const double pal = model.palinstrophy(w);
        const ns2d_budget& b = run.budget;
        if (plot) {
            const double ez[2] = {e, z};
            const double kept[2] = {e - (b.energy_injection - b.energy_dissipation),
                                    z - (b.enstrophy_injection - b.enstrophy_dissipation)};
            plot->add(t, ez, kept);
        }
        if (h5) {
            const double v[13] = {double(i), e, z, pal, b.energy_injection, b.energy_dissipation,
                                  b.enstrophy_injection, b.enstrophy_dissipation,
                                  e - run.energy0 - (b.energy_injection - b.energy_dissipation),
                                  z - run.enstrophy0 - (b.enstrophy_injection - b.enstrophy_dissipation), u,
                                  u * dt / dx, double(run.halvings)};
            const std::span<const double> row[1] = {v};
            h5->add(t, row);
        }
        if (!out) return;
        std::fprintf(out, "%llu,%s,%s,%s,%s,%s,%s,%s,%s,%s,%s,%s,%s,%llu\n", (unsigned long long)i,
                     num(t).c_str(), num(e).c_str(), num(z).c_str(), num(pal).c_str(),
                     num(b.energy_injection).c_str(), num(b.energy_dissipation).c_str(),
                     num(b.enstrophy_injection).c_str(), num(b.enstrophy_dissipation).c_str(),
                     num(e - run.energy0 - (b.energy_injection - b.energy_dissipation)).c_str(),
                     num(z - run.enstrophy0 - (b.enstrophy_injection - b.enstrophy_dissipation)).c_str(),
                     num(u).c_str(), num(u * dt / dx).c_str(), (unsigned long long)run.halvings);
    };
    // A failure of a file in the staging directory, named where the file was to go (rank 0's).
    const auto in_final_dir = [&](const run_error& e, const std::string& base) {
        std::string m = e.what();
        const std::string final_dir =
            snapshot_dir_.empty() || snapshot_dir_.back() == '/' ? snapshot_dir_ : snapshot_dir_ + "/";
        if (!base.empty())
            for (std::size_t at; (at = m.find(base)) != std::string::npos;) m.replace(at, base.size(), final_dir);
        return run_error(m);
    };
    // Whether the snapshots have pictures (rank 0's plotting program; spread over processes, only then is the field
    // gathered on rank 0 for them), asked at the first snapshot.
    [[maybe_unused]] std::optional<bool> pictures;
    auto snapshot = [&](std::uint64_t i, double t) {
        last_snapshot = i;
        char stem[32];
        std::snprintf(stem, sizeof stem, "%08llu", (unsigned long long)i);
        // the field (on one process), spectra and fluxes on every process (collective), the files as below
        const std::vector<double> field = mpi.on ? std::vector<double>() : model.to_physical(w);
        const spectral::flow_fluxes pi = model.fluxes(w);
        const std::vector<double> es = model.energy_spectrum(w), zs = model.enstrophy_spectrum(w);
        const std::string base = staged_snapshots ? staged_snapshots->path() + "/" : std::string();  // (rank 0's)
        const std::string h5 = base + stem_ + "_" + stem + ".h5", png = base + stem_ + "_" + stem + ".png";
        const auto no_pictures = [&] {
            if (!warned_ && !interrupt_requested()) {
                const std::string why = plotting_failure();
                std::fprintf(stderr, "eci: warning: %s\n",
                             why.empty() ? "gnuplot not available, no PNG figures"
                                         : (why + "; no more PNG figures").c_str());
                warned_ = true;
            }
        };
        try {
            if (!mpi.on) {
                write_snapshot_h5(h5, model, field, t, i, method, dt);
                if (!plot_vorticity_png(png, p.n, field, t, field_, std::string(eq_.symbol)))
                    no_pictures();
            } else {
#ifdef ECI_MPI
                // every process writes its rows of the field into the file; the picture is drawn from the field
                // gathered on rank 0 alone
                write_snapshot_h5(h5, model, model.to_physical_rows(w), t, i, method, dt,
                                  MPI_COMM_WORLD);
                if (!pictures) {
                    int yes = mpi.rank == 0 && plotting_available() ? 1 : 0;
                    MPI_Bcast(&yes, 1, MPI_INT, 0, MPI_COMM_WORLD);
                    pictures = yes != 0;
                }
                const std::vector<double> whole = *pictures ? model.to_physical(w, 0) : std::vector<double>();
                on_root_agreed([&] {
                    if (!*pictures || !plot_vorticity_png(png, p.n, whole, t, field_,
                                                          std::string(eq_.symbol)))
                        no_pictures();
                });
#endif
            }
            on_root_agreed([&] {
                write_spectrum(base + "spectrum_" + stem + ".csv", base + "spectrum_" + stem + ".png",
                               {es, zs, pi.energy, pi.enstrophy}, t);
                if (!interrupt_requested() || !plotting_available()) return;
                std::error_code ec;
                for (const std::string& picture :
                     {stem_ + "_" + stem + ".png", "spectrum_" + std::string(stem) + ".png"})
                    if (!fs::exists(base + picture, ec)) cut_pictures.push_back(picture);
            });
        } catch (const run_error& e) {
            throw in_final_dir(e, base);
        }
    };
    // A restart draws the pictures its earlier part's snapshots lack: those a stop left undrawn (it says which), or
    // all of them where that part had no plotting program. From each snapshot's field and time and its spectrum CSV,
    // into the staging directory, committed with the run's own snapshots (rank 0's: it alone draws). A picture that
    // cannot be drawn ends the drawing, as in a run, and the run goes on (its own snapshots say why, once).
    if (restart && snapshot_every_ > 0)
        on_root_agreed([&] {
            if (!staged_snapshots || !plotting_available()) return;
            const std::string dir = snapshot_dir_.empty() ? std::string(".") : snapshot_dir_;
            const std::string base = staged_snapshots->path() + "/";
            std::set<std::pair<std::uint64_t, std::string>> earlier;  // step, its digits in the names
            std::error_code ec;
            for (const auto& entry : fs::directory_iterator(dir, ec)) {
                const std::string file = entry.path().filename().string();
                const auto step = snapshot_step(file, stem_);
                if (step && *step <= first && file.rfind(stem_ + "_", 0) == 0 && entry.path().extension() == ".h5")
                    earlier.emplace(*step, file.substr(stem_.size() + 1, file.size() - stem_.size() - 4));
            }
            const auto missing = [&](const std::string& name) {
                std::error_code e;
                return !fs::exists(fs::symlink_status(fs::path(dir) / name, e));
            };
            try {
                for (const auto& [step, digits] : earlier) {
                    const std::string h5 = (fs::path(dir) / (stem_ + "_" + digits + ".h5")).string();
                    const std::string png = stem_ + "_" + digits + ".png", spectrum = "spectrum_" + digits;
                    const bool field_missing = missing(png),
                               spectrum_missing = !missing(spectrum + ".csv") && missing(spectrum + ".png");
                    if (!field_missing && !spectrum_missing) continue;
                    double t = 0.0;
                    std::vector<double> field;
                    try {
                        t = read_snapshot_time(h5);
                        if (field_missing) field = read_vorticity(h5, p.n, true, stem_).second;
                    } catch (const std::exception&) {
                        continue;  // (not a snapshot of this run's: nothing to draw from)
                    }
                    if (field_missing &&
                        !plot_vorticity_png(base + png, p.n, field, t, field_, std::string(eq_.symbol)))
                        return;
                    if (spectrum_missing &&
                        !redraw_spectrum_png((fs::path(dir) / (spectrum + ".csv")).string(), base + spectrum + ".png",
                                             t))
                        return;
                }
            } catch (const run_error& e) {
                throw in_final_dir(e, base);
            }
        });
    // Ctrl-C finishes the step under way and writes the checkpoint. On a large grid one step takes longer than the
    // signal handler's default allowance (0.3 s of CPU), so the run tells it how long a step and a checkpoint
    // take: estimated from one right-hand side's transforms before the first step, measured after.
    const auto cpu_now = [] {
        timespec ts{};
        ::clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
        return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
    };
    const auto wall_now = [] { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); };
    double step_cpu = 0.0, step_wall = 0.0, save_cpu = 0.0, save_wall = 0.0;
    const auto update_grace = [&] {
        set_interrupt_grace(0.3 + 2.0 * (step_cpu + save_cpu), 1.0 + 2.0 * (step_wall + save_wall));
    };
    {
        const double c0 = cpu_now(), w0 = wall_now();
        model.execute_transforms();
        // at most 13 stages (f78) plus the diagnostics; the checkpoint about two transforms' worth
        step_cpu = 16.0 * (cpu_now() - c0), step_wall = 16.0 * (wall_now() - w0);
        save_cpu = step_cpu / 8.0, save_wall = step_wall / 8.0;
        update_grace();
    }
    // The checkpoint of step i: the field ws and the generator's state rng there, with c's statistics (the run's
    // own, or a copy of them as they stood at step i).
    auto save_of = [&](ns2d_checkpoint& c, std::uint64_t i, const state& ws, std::uint64_t rng) {
        const double c0 = cpu_now(), w0 = wall_now();
        c.step = i;
        c.rng_state = rng;
        if (!mpi.on) {
            c.state = model.to_half_plane(ws);
            write_checkpoint(checkpoint_, c);
        } else {
#ifdef ECI_MPI
            // every process writes its columns of the half plane into the file
            c.state = model.to_half_plane_columns(ws);
            write_checkpoint(checkpoint_, c, MPI_COMM_WORLD, model.grid().first_column(),
                             model.grid().local_columns());
#endif
        }
        c.state = state();  // (held only while it is written)
        save_cpu = std::max(save_cpu, cpu_now() - c0), save_wall = std::max(save_wall, wall_now() - w0);
        update_grace();
    };
    auto save = [&](std::uint64_t i) { save_of(run, i, w, model.rng_state()); };

    progress_bar progress(last - first, 1);  // steps take milliseconds or more: look at the clock every step
    const auto start = std::chrono::steady_clock::now();
    std::uint64_t good_checkpoint = restart ? first : std::numeric_limits<std::uint64_t>::max();
    std::string good_file = restart_;  // the file that holds it: the restart file until this run writes one
    const auto last_good = [&] {
        return good_checkpoint != std::numeric_limits<std::uint64_t>::max()
                   ? "; last good checkpoint: " + good_file + " (step " + std::to_string(good_checkpoint) + ")"
                   : std::string();
    };
    // (a restart's dt is its checkpoint's: a smaller step is a new run, from the checkpoint's field)
    const std::string smaller_step = restart ? "a smaller step needs a new run (--ic " + restart_ +
                                                   " takes its field, with a smaller --dt or --cfl)"
                                             : "reduce --dt or --cfl";
    // The run is the library's (eci::solve: the flow's step hooks draw the forcing and integrate the budget); this
    // sink formats it. Per step it adds the step's budget and counts, checks for a blow-up and measures the step;
    // between steps it writes snapshots and checkpoints and answers Ctrl-C. A Ctrl-C between the halvings of a
    // step (eci::interrupted) goes back to the last whole step, w_prev.
    // a linear damping too stiff for dt: the cause a failure or blow-up names (the default step keeps within it)
    const std::string stiffness = model.stiffness_hint(dt);
    // w_prev is copied only where it can be needed, not at every step (a state's copy per step was ~1 % of an N =
    // 1024 step, and a state of memory): at a step's first failed attempt, where the library asks whether to stop
    // and x is still the step's start (a failed attempt leaves it), and before a shortened last step.
    state w_prev;
    bool w_prev_current = false;  // whether w_prev holds the start of the step being taken
    const auto keep_step_start = [&] {
        if (!w_prev_current) w_prev = w, w_prev_current = true;
    };
    std::uint64_t rng_prev = model.rng_state(), done = first;
    double e_prev = model.energy(w), z_prev = model.enstrophy(w);  // E and Z at the start of the step
    const std::uint64_t halvings0 = run.halvings, rhs_evals0 = run.rhs_evals;
    double c0 = 0.0, w0 = 0.0;  // the clocks at the start of the step
    // A shortened last step (short_end): the statistics as they stood before it, for the checkpoint of the end,
    // which keeps the step before it on the grid (w_prev, step `done`).
    ns2d_checkpoint before_end;
    // The checkpoint after step i (in on_progress, where w_prev is still the state before it): step i itself, or at
    // the end of a shortened last step the step before it. Returns the step kept.
    auto save_step = [&](std::uint64_t i) {
        if (i == last && short_end) {
            save_of(before_end, done, w_prev, rng_prev);
            good_file = checkpoint_;
            return done;
        }
        save(i);
        good_file = checkpoint_;
        return i;
    };
    auto interrupted_at = [&](std::uint64_t i) {
        return interrupted("interrupted at step " + std::to_string(i) + ", t = " + num(double(i) * dt) +
                           (keep_on_stop ? "; checkpoint written to " + checkpoint_ + " (continue with --restart " +
                                               checkpoint_ + ")"
                                         : "; no checkpoint written (" + no_checkpoint_why + ")"));
    };
    // The checkpoint of a stop after step i (where it may keep one): the step it kept, or the step reached.
    auto stop_at = [&](std::uint64_t i) { return keep_on_stop ? save_step(i) : i == last && short_end ? done : i; };
    std::uint64_t done_outputs = first;  // the step an interrupt in on_progress stopped at
    // The statistics of the run at its last whole step (after_step's), for the summary of an interrupted run.
    run_stats stats_so_far{};
    // (a restart's rows begin after its checkpoint's step: that row is the first part's last, and the parts join
    // without a repeated row)
    auto on_output = [&](const state&, const output_point& pt) {
        if (rows_wanted && !(restart && pt.index == first)) row(pt.index, pt.t, pt.invariants[0], pt.invariants[1]);
    };
    auto on_step = [&](const state&, const output_point& pt) {
        const std::uint64_t i = pt.index;
        if (i == first + 1) step_cpu = step_wall = 0.0;  // measured from now on, not estimated
        step_cpu = std::max(step_cpu, cpu_now() - c0), step_wall = std::max(step_wall, wall_now() - w0);
        update_grace();
        if (i == last && short_end) before_end = run;  // (the statistics before the shortened step)
        stats_so_far = *pt.stats;
        run.halvings = halvings0 + pt.stats->step_reductions;
        run.rhs_evals = rhs_evals0 + pt.stats->rhs_evals;
        const ns2d_budget& b = model.step_budget();
        run.budget.energy_injection += b.energy_injection;
        run.budget.energy_dissipation += b.energy_dissipation;
        run.budget.enstrophy_injection += b.enstrophy_injection;
        run.budget.enstrophy_dissipation += b.enstrophy_dissipation;
        const double e1 = pt.invariants[0], z1 = pt.invariants[1];
        // A blow-up (the library's rule and sentence, as Python's), with the remedy in this tool's options.
        try {
            model.check_blow_up(w, pt.invariants, run.energy0, run.budget.energy_injection, i, pt.t, dt);
        } catch (const eci::spectral::flow_blow_up& e) {
            progress.finish();
            throw run_error(std::string(e.what()) + "; " + (stiffness.empty() ? smaller_step : stiffness));
        }
        // the library's rule, as Python's (relative to the invariant, at least to the floor of subnormal terms)
        run.max_energy_residual =
            std::max(run.max_energy_residual,
                     model.budget_residual(e_prev, e1, b.energy_injection, b.energy_dissipation));
        run.max_enstrophy_residual =
            std::max(run.max_enstrophy_residual,
                     model.budget_residual(z_prev, z1, b.enstrophy_injection, b.enstrophy_dissipation));
        // (kept in the checkpoint's record across a restart, by the library's rule)
        run.max_energy_drift = eci::invariant_record::widened_drift(run.max_energy_drift, run.energy0, e1);
        run.max_enstrophy_drift = eci::invariant_record::widened_drift(run.max_enstrophy_drift, run.enstrophy0, z1);
        e_prev = e1, z_prev = z1;
    };
    auto on_progress = [&](double t, std::uint64_t i) {
        if (i == first) {
            if (snapshot_every_ > 0 && !restart) snapshot(first, t);
        } else {
            if (snapshot_every_ > 0 && (i % snapshot_every_ == 0 || i == last)) snapshot(i, t);
            // a checkpoint asked for (a restart's included: its file, continued in place) is at the run's end too
            if ((checkpoint_every_ > 0 && i % checkpoint_every_ == 0) || (checkpoint_asked && i == last))
                good_checkpoint = save_step(i);
            progress.update(i - first, t, [&] {
                // drift from the exact budget (pure drift when nothing is forced or dissipated)
                const ns2d_budget& b = run.budget;
                char line[160];
                // (max |u| is collective on MPI, and the bar is drawn on rank 0's clock: no CFL there)
                std::snprintf(line, sizeof line, " step %llu  CFL %.3g  %s drift %.2g  %s drift %.2g ",
                              (unsigned long long)i, mpi.on ? std::nan("") : model.cfl(w, dt), inv_[0].c_str(),
                              (e_prev - run.energy0 - (b.energy_injection - b.energy_dissipation)) /
                                  std::max(e_prev, model.invariant_floor()),
                              inv_[1].c_str(),
                              (z_prev - run.enstrophy0 - (b.enstrophy_injection - b.enstrophy_dissipation)) /
                                  std::max(z_prev, model.invariant_floor()));
                return std::string(line);
            });
            if (stop_requested()) {
                progress.finish();
                done_outputs = i;  // (its row and snapshot made above)
                throw interrupted_at(stop_at(i));
            }
        }
        w_prev_current = false;  // the next step starts here (w_prev copied if it is needed)
        if (i + 1 == last && short_end) keep_step_start();  // (the checkpoint of the end keeps this step)
        rng_prev = model.rng_state();
        done = i;
        c0 = cpu_now(), w0 = wall_now();
    };
    cfg.max_halvings = 40;
    cfg.max_substeps = run_options{}.max_substeps;  // as every model: a far too long dt fails, not halves for hours
    cfg.update = update == "paper" ? update_kind::paper : update_kind::conditioned;  // --update (default: conditioned)
    cfg.update_chosen = !settings.update.empty();
    cfg.stop_on_invariant_overflow = false;  // a blow-up is the sink's, with its own message
    cfg.stop_between_attempts = [&] {  // (collective on MPI)
        keep_step_start();  // (the step is then halved: x goes part-way through it)
        return stop_requested();
    };
    // A signal during the set-up: no step was made, so there is nothing for a checkpoint to keep.
    if (stop_requested()) {
        throw_if_interrupted("before the first step");  // (names the signal)
        throw interrupted("interrupted before the first step");  // (another process's)
    }
    // The summary of the run up to step `reached` (its end, or where an interrupt stopped it), with `stats` its
    // counts (after --restart, of the steps it took: steps, halvings, evaluations, the remedy's steps and elements
    // alike; halvings_per_step is over the whole run, the checkpoint's counts included). Collective on MPI.
    auto summary_of = [&](const run_stats& stats, std::uint64_t reached) {
        run_summary s;
        s.model = info_.name;
        s.method = method;
        s.order = find_method(method) ? find_method(method)->order : 0;
        s.conservative = method.rfind("c-", 0) == 0;
        s.dt = dt;
        s.t_end = std::isnan(t_end) ? double(last) * dt : t_end;
        s.t_start = double(first) * dt;  // (a restart's)
        s.stats = stats;
        s.stats.steps = reached - first;
        s.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        s.invariants.push_back({inv_[0], run.energy0, model.energy(w), run.max_energy_drift});
        s.invariants.push_back({inv_[1], run.enstrophy0, model.enstrophy(w), run.max_enstrophy_drift});
        // (final_cfl at the run's step; a span shorter than it was one step of the span: --cfl 1e308 gave dt 6e307)
        const double last_dt = reached == last && last > first ? std::min(dt, s.t_end - double(first) * dt) : dt;
        s.figures = {{"palinstrophy", model.palinstrophy(w)},
                     {inv_[0] + "_injection", run.budget.energy_injection},
                     {inv_[0] + "_dissipation", run.budget.energy_dissipation},
                     {inv_[1] + "_injection", run.budget.enstrophy_injection},
                     {inv_[1] + "_dissipation", run.budget.enstrophy_dissipation},
                     {"max_" + inv_[0] + "_budget_residual_per_step", run.max_energy_residual},
                     {"max_" + inv_[1] + "_budget_residual_per_step", run.max_enstrophy_residual},
                     {"halvings_per_step", double(run.halvings) / double(std::max<std::uint64_t>(reached, 1))},
                     {"advective_form_retries", double(model.form_retries())},
                     {"final_cfl", model.cfl(w, last_dt)}};
        // forced or damped: the drift columns are the physics' change; how well each was kept is its budget's
        const ns2d_budget& b = run.budget;
        if (b.energy_injection != 0.0 || b.energy_dissipation != 0.0 || b.enstrophy_injection != 0.0 ||
            b.enstrophy_dissipation != 0.0) {
            char kept[160];
            std::snprintf(kept, sizeof kept, " within %.2g and %.2g relative per step",
                          run.max_energy_residual, run.max_enstrophy_residual);
            s.invariants_note = inv_[0] + " and " + inv_[1] +
                                " change by forcing and dissipation (the drifts above); they kept to their budgets" +
                                kept;
        }
        return s;
    };
    // Ctrl-C (SIGINT, SIGTERM, SIGHUP, SIGQUIT) at step `reached`, the checkpoint written: the outputs up to that
    // step are kept, committed as for a finished run (the snapshots taken, the CSV's rows, a summary of the run so
    // far), and the message says what was kept. A run stopped before its first step, or by SIGPIPE (an output that
    // failed), keeps nothing but its checkpoint.
    auto keep_interrupted = [&](const std::string& stop, std::uint64_t reached) {
        if (!agreed_keeps_outputs() || reached == first) throw interrupted(stop);
        run_summary s = summary_of(stats_so_far, reached);
        s.interrupted = true;
        s.t_stopped = reached == last && short_end ? t_end : double(reached) * dt;
        std::string kept;
        const auto add = [&](const std::string& what) { kept += (kept.empty() ? "; kept: " : ", ") + what; };
        if (staged_snapshots) {
            // the pictures the stop left undrawn, each named, and how to draw them (a restart draws the pictures of
            // its earlier part's snapshots that are missing)
            std::string without;
            for (std::size_t j = 0; j < cut_pictures.size(); ++j)
                without += (j == 0 ? "" : j + 1 == cut_pictures.size() ? " and " : ", ") + cut_pictures[j];
            if (!without.empty())
                without = " (without " + without + ": the stop came before " +
                          (cut_pictures.size() == 1 ? "it was" : "they were") + " drawn" +
                          (keep_on_stop ? "; --restart " + checkpoint_ + " --snapshot-every " +
                                              std::to_string(snapshot_every_) + " --snapshot-dir '" + snapshot_dir_ +
                                              "' draws " + (cut_pictures.size() == 1 ? "it" : "them")
                                        : std::string()) +
                          ")";
            add("the snapshots in '" + snapshot_dir_ + "' to step " + std::to_string(last_snapshot) + without);
        }
        if (csv.replaces())
            add(std::string(h5 ? "HDF5" : "CSV") + " output '" + settings.output + "' (rows to step " +
                std::to_string(last_row) + ")");
        if (json.replaces()) add("summary JSON '" + settings.summary_json + "'");
        try {
            on_root_agreed([&] {
                if (std::FILE* j = json.get()) write_summary_json(j, s);
                if (h5) h5->close();
                commit_outputs({&csv, &json}, staged_snapshots ? &*staged_snapshots : nullptr, true);
                if (created_snapshot_dir) created_snapshot_dir->keep();
            });
        } catch (const std::exception& e) {
            throw interrupted(stop + "; " + e.what());
        }
        throw interrupted(stop + kept + (plot ? "; no plot (it is drawn for a finished run)" : ""));
    };
    // A failure of the sink's (an output that cannot be written, a blow-up): the checkpoint it leaves, named
    const auto with_checkpoint = [&](const run_error& e) { return run_error(std::string(e.what()) + last_good()); };
    solve_report report;
    std::string stop;  // an interrupt's message (the checkpoint written)
    std::uint64_t stopped_at = 0;  // the last step whose state and outputs the run has made
    try {
        report = solve<navier_stokes_2d>(model, w, method, cfg, callback_sink{on_output, on_step, on_progress}, {},
                                         "model " + name_);
    } catch (const run_error& e) {
        progress.finish();
        throw with_checkpoint(e);
    } catch (const eci::interrupted&) {  // (between the halvings of a step: back to the last whole step)
        progress.finish();
        w = w_prev;
        model.set_rng_state(rng_prev);
        if (keep_on_stop) save(done);
        stop = interrupted_at(done).what();
        stopped_at = done;
    } catch (const interrupted& e) {  // (between steps, in on_progress: step `done`, its outputs made)
        stop = e.what();
        stopped_at = done_outputs;
    }
    progress.finish();
    if (!stop.empty()) keep_interrupted(stop, stopped_at);
    if (report.failure) {
        const std::string stiff = stiffness.empty() ? std::string() : "; " + stiffness;
        if (report.failure->kind != run_failure_kind::step_failed)
            throw run_error(report.failure->message + stiff + last_good());
        // the library's cause, without its component (an index into the spectral state, not something to act on)
        const run_failure& f = *report.failure;
        const std::string decay = model.decay_hint(w);  // (collective: every process fails alike)
        const std::string cause = f.non_finite_rate_value
                                      ? "a rate is " + num(*f.non_finite_rate_value)
                                      : std::string(report.method.family == method_family::conservative
                                                        ? "a negative radicand or a non-finite state"
                                                        : "a non-finite state") +
                                            (!stiffness.empty() ? stiff
                                             : !decay.empty() ? "; " + decay
                                             : restart     ? "; " + smaller_step
                                                           : "; a smaller --dt or --cfl may pass");
        throw run_error("step " + std::to_string(done + 1) + " failed at t = " + num(f.t) +
                        " even with the step halved 40 times (down to dt = " + num(f.dt) + "): " + cause + last_good());
    }

    const run_summary s = summary_of(report.stats, last);
    // --plot: the field the run ended with, at the picture's right (gathered on rank 0: collective, every process)
    if (!settings.plot.empty()) {
        std::vector<double> field = model.to_physical(w, 0);
        if (plot) plot->set_field(p.n, std::move(field), s.t_end, std::string(model.eq().field),
                                  std::string(model.eq().symbol));
    }
    // The run's outputs are committed together: the snapshots first, the CSV and JSON that describe the run last, and
    // a failure takes back what was moved in (a failed run keeps its checkpoint, not a partial time series).
    try {
        on_root([&] {
            if (std::FILE* j = json.get()) write_summary_json(j, s);
            if (h5) h5->close();
            // a picture that could not be drawn loses nothing else: the other outputs are committed, the run fails
            const bool drawn = !plot || plot->draw(picture), others = csv.get() || json.get() || staged_snapshots;
            // Ctrl-C after the last step, while the picture was drawn (which stops the plotting program) or after: the
            // finished run's outputs are whole and kept, as a stopped run's are (the commit's own rule discarded them)
            const bool late_stop = interrupt_requested() && interrupt_keeps_outputs();
            if (drawn)
                commit_outputs({&csv, &json, &picture}, staged_snapshots ? &*staged_snapshots : nullptr, late_stop);
            else
                commit_outputs({&csv, &json}, staged_snapshots ? &*staged_snapshots : nullptr, late_stop);
            if (created_snapshot_dir) created_snapshot_dir->keep();
            print_summary(stderr, s);
            if (late_stop)
                throw interrupted(interrupt_message(drawn ? "after the run had finished"
                                                          : "while the plot was drawn, after the run had finished") +
                                  "; its outputs were kept" + (drawn ? "" : "; no plot"));
            if (!drawn)
                throw run_error("the plot '" + settings.plot + "' could not be drawn by " + plotting_program() +
                                (plot->failure().empty() ? "" : " (" + plot->failure() + ")") +
                                (others ? "; the other outputs were written" : ""));
        });
    } catch (const run_error& e) {
        throw with_checkpoint(e);
    }
    return 0;
}

}  // namespace

/// One command per spectral equation, in the order of eci::spectral::equations().
void append_spectral_commands(std::vector<std::unique_ptr<model_command>>& models) {
    for (const spectral::equation* e : spectral::equations()) models.push_back(std::make_unique<spectral_command>(*e));
}

}  // namespace eci::cli
