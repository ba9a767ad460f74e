// `eci run n-wave` and `eci run n-wave-complex`: the n-wave model of §III.C with real or complex modes, a
// random system and initial condition drawn from --seed.
#include <complex>
#include <cstdio>
#include <limits>

#include <unistd.h>

#include <eci/models/n_wave.hpp>

#include "models.hpp"
#include "run.hpp"

namespace eci::cli {

namespace {

template <class T>
class n_wave_command final : public model_command {
    static constexpr bool is_complex = n_wave<T>::is_complex;

   public:
    const model_info& info() const override { return info_; }

    void add_options(CLI::App& app) override {
        app.add_option("--modes", modes_, "number of modes (default 30)")->check(whole_number(1));
        app.add_option("--triads-per-mode", triads_per_mode_,
                       "triads each mode takes part in, about (default 20; 1 gives independent triads)")
            ->check(whole_number(1));
        app.add_option("--seed", seed_, "seed of the random system and initial condition (default 1)")
            ->check(whole_number(0));
    }

    int run(const run_settings& settings) override {
        check_memory();
        n_wave<T> model;
        try {
            model = n_wave<T>::random(modes_, triads_per_mode_, seed_);
        } catch (const std::invalid_argument& e) {
            throw bad_input(info_.name + ": " + e.what());
        }
        return run_model(info_, model, model.random_state(seed_), indexed_columns("psi_", modes_, is_complex),
                         settings);
    }

   private:
    // A huge request says what it costs before it starts, and one beyond this machine's memory is refused:
    // the triads, the wavenumbers and about eight states (the state, the stepper's buffers, the checks').
    void check_memory() const {
        if (modes_ < 3 || (triads_per_mode_ == 1 && modes_ % 3 != 0)) return;  // random() explains
        std::size_t triads = 0;
        try {
            triads = n_wave<T>::triad_count(modes_, triads_per_mode_);
        } catch (const std::invalid_argument& e) {
            throw bad_input(info_.name + ": " + e.what());
        }
        const double bytes = double(triads) * double(sizeof(triad)) + double(modes_) * double(sizeof(double)) +
                             8.0 * double(modes_) * double(sizeof(T));
        const double gib = bytes / double(1ull << 30);
        const double physical = double(::sysconf(_SC_PHYS_PAGES)) * double(::sysconf(_SC_PAGESIZE));
        char size[32];
        std::snprintf(size, sizeof size, "%.3g GiB", gib);
        if (physical > 0 && bytes > physical) {
            char have[32];
            std::snprintf(have, sizeof have, "%.3g GiB", physical / double(1ull << 30));
            throw bad_input(info_.name + " with " + std::to_string(modes_) + " modes and " + std::to_string(triads) +
                            " triads needs about " + size + " of memory, more than this machine's " + have);
        }
        if (bytes > double(256ull << 20))
            std::fprintf(stderr, "eci: note: %s with %zu modes and %zu triads needs about %s of memory\n",
                         info_.name.c_str(), modes_, triads, size);
    }

    model_info info_{is_complex ? "n-wave-complex" : "n-wave",
                     is_complex ? "n complex modes coupled by random triads obeying eqs. (2)-(3), section III.C; "
                                  "invariants energy, enstrophy"
                                : "n real modes coupled by random triads obeying eqs. (2)-(3), section III.C; "
                                  "invariants energy, enstrophy",
                     registry_methods_for<typename n_wave<T>::state_type>(),
                     "c-pc",
                     0.01,
                     10.0};
    std::size_t modes_ = 30;
    std::size_t triads_per_mode_ = 20;
    std::uint64_t seed_ = 1;
};

}  // namespace

/// The n-wave adapter, real modes.
std::unique_ptr<model_command> make_n_wave_command() { return std::make_unique<n_wave_command<double>>(); }

/// The n-wave adapter, complex modes.
std::unique_ptr<model_command> make_n_wave_complex_command() {
    return std::make_unique<n_wave_command<std::complex<double>>>();
}

}  // namespace eci::cli
