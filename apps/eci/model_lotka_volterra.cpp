// `eci run lotka-volterra`: the predator-prey system (36) with mu and (x, y) as options and the paper's run
// (Fig. 7: mu = 1.5, (1, 0.4), 8e5 steps of 0.02) as defaults; conservative methods go through transform (39).
#include <string_view>

#include <eci/models/lotka_volterra.hpp>
#include <eci/steppers/kahan.hpp>
#include <eci/steppers/transformed_rk.hpp>

#include "models.hpp"
#include "run.hpp"

namespace eci::cli {

namespace {

using lv_state = lotka_volterra::state_type;
using lv_transform = lotka_volterra::transform;

// The conservative methods are the transform mechanism over their tableaux; kahan is the model's own; the
// conventional ones come from the registry.
struct lotka_volterra_dispatch {
    lotka_volterra model;

    template <class Fn>
    bool operator()(std::string_view name, Fn&& fn) const {
        const lv_transform tr = model.linearizing_transform();
        if (name == "c-pc") return fn(transformed_pc<lv_transform>{tr}), true;
        if (name == "c-rk2") return fn(transformed_rk2<lv_transform>{tr}), true;
        if (name == "c-rk4") return fn(transformed_rk4<lv_transform>{tr}), true;
        if (name == "kahan") return fn(kahan<lotka_volterra>{model}), true;
        return registry_dispatch<lv_state>{}(name, fn);
    }
};

class lotka_volterra_command final : public model_command {
   public:
    const model_info& info() const override { return info_; }

    void add_options(CLI::App& app) override {
        app.add_option("--mu", model_.mu, "the parameter mu of eq. (36) (default 1.5)");
        app.add_option("--x", x_, "initial x, > 0 (default 1)");
        app.add_option("--y", y_, "initial y, > 0 (default 0.4)");
    }

    int run(const run_settings& settings) override {
        const lv_state x0{x_, y_};
        const std::vector<std::string> columns(lotka_volterra::component_names.begin(),
                                               lotka_volterra::component_names.end());
        return run_model(info_, model_, x0, columns, settings, lotka_volterra_dispatch{model_});
    }

   private:
    model_info info_{"lotka-volterra",
                     "predator-prey equations (36); invariant the Hamiltonian (37); c-pc is eq. (42)",
                     {"euler", "pc", "rk2", "rk4", "c-pc", "c-rk2", "c-rk4", "kahan"},
                     "c-pc",
                     0.02,
                     16000.0};
    lotka_volterra model_{};
    double x_ = 1.0, y_ = 0.4;
};

}  // namespace

/// The Lotka-Volterra adapter.
std::unique_ptr<model_command> make_lotka_volterra_command() { return std::make_unique<lotka_volterra_command>(); }

}  // namespace eci::cli
