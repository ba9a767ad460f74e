// `eci run three-wave`: the three-wave model of eq. (1), its parameters K, P, Q, M and initial condition as
// options, with the paper's values (Figs. 1-5) as defaults.
#include <cmath>

#include <eci/models/three_wave.hpp>

#include "models.hpp"
#include "run.hpp"

namespace eci::cli {

namespace {

class three_wave_command final : public model_command {
   public:
    const model_info& info() const override { return info_; }

    void add_options(CLI::App& app) override {
        app.add_option("--K", model_.K, "wavenumber magnitude K (default sqrt 3)");
        app.add_option("--P", model_.P, "wavenumber magnitude P (default 3)");
        app.add_option("--Q", model_.Q, "wavenumber magnitude Q (default sqrt 6)");
        app.add_option("--M", coupling_, "coupling coefficients M_K,M_P,M_Q, obeying eqs. (2)-(3) (default 1,1,-2)")
            ->expected(3)
            ->delimiter(',')
            ->allow_extra_args(false);
        app.add_option("--psi", psi_, "initial condition psi_K,psi_P,psi_Q (default sqrt 1.5,0,sqrt 1.5)")
            ->expected(3)
            ->delimiter(',')
            ->allow_extra_args(false);
    }

    int run(const run_settings& settings) override {
        if (coupling_.size() != 3) throw bad_input("--M takes three values M_K,M_P,M_Q");
        if (psi_.size() != 3) throw bad_input("--psi takes three values psi_K,psi_P,psi_Q");
        model_.M = {coupling_[0], coupling_[1], coupling_[2]};
        const three_wave::state_type psi0{psi_[0], psi_[1], psi_[2]};
        const std::vector<std::string> columns(three_wave::component_names.begin(),
                                               three_wave::component_names.end());
        return run_model(info_, model_, psi0, columns, settings);
    }

   private:
    model_info info_{"three-wave",
                     "three real modes of the truncated Euler equations, eq. (1); invariants energy, enstrophy",
                     registry_methods_for<three_wave::state_type>(),
                     "c-pc",
                     0.01,
                     10.0};
    three_wave model_{};
    std::vector<double> coupling_{1.0, 1.0, -2.0};
    std::vector<double> psi_{std::sqrt(1.5), 0.0, std::sqrt(1.5)};
};

}  // namespace

/// The three-wave adapter.
std::unique_ptr<model_command> make_three_wave_command() { return std::make_unique<three_wave_command>(); }

}  // namespace eci::cli
