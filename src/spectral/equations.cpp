// The list of spectral equations: one line per module of equations/.
#include "eci/spectral/equation.hpp"
#include "eci/spectral/flow.hpp"

#include <stdexcept>
#include <string>

namespace eci::spectral {

const std::vector<const equation*>& equations() {
    static const std::vector<const equation*> all{&navier_stokes_2d_equation, &charney_hasegawa_mima_equation,
                                                  &surface_qg_equation};
    return all;
}

const equation& find_equation(std::string_view name) {
    std::string names;
    for (const equation* e : equations()) {
        if (e->name == name) return *e;
        names += (names.empty() ? "" : ", ") + std::string(e->name);
    }
    throw std::invalid_argument("no spectral equation '" + std::string(name) + "' (one of " + names + ")");
}

void refuse_wave_parameters(const flow_params& p, std::string_view equation) {
    if (p.beta != 0.0 || p.deformation != 0.0)
        throw std::invalid_argument(std::string(equation) + " has no beta or deformation (charney-hasegawa-mima has)");
}

}  // namespace eci::spectral
