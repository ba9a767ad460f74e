// `eci run n-wave` and `eci run n-wave-complex`: the n-wave model of §III.C with real or complex modes, a
// random system and initial condition drawn from --seed.
#include <complex>
#include <limits>

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
