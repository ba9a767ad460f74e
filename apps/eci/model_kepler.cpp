// `eci run kepler`: the Kepler problem (45) in polar variables with m, K, ell and (r, v_r, theta) as options and
// the paper's C-PC run (Fig. 9: 1000 steps of 0.105) as defaults; conservative methods go through transform (50).
#include <string_view>

#include <eci/models/kepler.hpp>
#include <eci/steppers/transformed_rk.hpp>

#include "models.hpp"
#include "run.hpp"

namespace eci::cli {

namespace {

using kepler_state = kepler::state_type;
using kepler_transform = kepler::transform;

// The conservative methods are the transform mechanism over their tableaux; the conventional ones come from
// the registry.
struct kepler_dispatch {
    kepler model;

    template <class Fn>
    bool operator()(std::string_view name, Fn&& fn) const {
        const kepler_transform tr = model.linearizing_transform();
        if (name == "c-pc") return fn(transformed_pc<kepler_transform>{tr}), true;
        if (name == "c-rk2") return fn(transformed_rk2<kepler_transform>{tr}), true;
        if (name == "c-rk4") return fn(transformed_rk4<kepler_transform>{tr}), true;
        return registry_dispatch<kepler_state>{}(name, fn);
    }
};

class kepler_command final : public model_command {
   public:
    const model_info& info() const override { return info_; }

    void add_options(CLI::App& app) override {
        app.add_option("--m", model_.m, "mass, > 0 (default 1)");
        app.add_option("--K", model_.K, "strength of the potential -K/r, > 0 (default 1.5)");
        app.add_option("--ell", model_.ell, "angular momentum, nonzero (default 1)");
        app.add_option("--r", r_, "initial radius, > 0 (default 1)");
        app.add_option("--v-r", v_r_, "initial radial velocity (default 0)");
        app.add_option("--theta", theta_, "initial angle (default 0)");
    }

    int run(const run_settings& settings) override {
        const kepler_state x0{r_, v_r_, theta_};
        const std::vector<std::string> columns(kepler::component_names.begin(), kepler::component_names.end());
        return run_model(info_, model_, x0, columns, settings, kepler_dispatch{model_});
    }

   private:
    model_info info_{"kepler",
                     "Kepler problem (45) in polar variables (bound orbits); invariants H (46) and the Runge-Lenz "
                     "vector (47); c-pc is eqs. (49)-(54)",
                     {"euler", "pc", "rk2", "rk4", "c-pc", "c-rk2", "c-rk4"},
                     "c-pc",
                     0.105,
                     105.0};
    kepler model_{};
    double r_ = 1.0, v_r_ = 0.0, theta_ = 0.0;
};

}  // namespace

/// The Kepler adapter.
std::unique_ptr<model_command> make_kepler_command() { return std::make_unique<kepler_command>(); }

}  // namespace eci::cli
