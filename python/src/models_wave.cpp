// eci.models.ThreeWave, NWave and NWaveComplex: the wave models of eqs. (1)-(5) and §III.C, with the CLI's
// parameters, defaults and messages; every registry method that runs on any state.
#include <cmath>
#include <complex>

#include <eci/models/n_wave.hpp>
#include <eci/models/three_wave.hpp>

#include "models.hpp"
#include "module.hpp"

namespace eci::python {

namespace {

using three_wave_object = model_object<three_wave>;

template <class T>
using n_wave_object = model_object<n_wave<T>>;

template <class T>
void bind_n_wave(py::module_& m, const char* name, const char* cli_name) {
    using object = n_wave_object<T>;
    constexpr bool complex = n_wave<T>::is_complex;
    bind_model<n_wave<T>>(
        m, name,
        complex ? "n complex modes coupled by random triads obeying eqs. (2)-(3) (section III.C); invariants "
                  "energy, enstrophy. The system and its default initial condition are drawn from seed."
                : "n real modes coupled by random triads obeying eqs. (2)-(3) (section III.C); invariants energy, "
                  "enstrophy. The system and its default initial condition are drawn from seed.")
        .def(py::init([cli_name](long long modes_in, long long triads_in, long long seed_in) {
                 // the CLI's checks of its whole-number options, then the generator's own
                 auto whole = [](long long v, long long min, const char* what) {
                     if (v < min)
                         throw std::invalid_argument(std::string(what) + " must be a whole number >= " +
                                                     std::to_string(min) + ", not " + std::to_string(v));
                     return static_cast<std::uint64_t>(v);
                 };
                 const std::size_t modes = whole(modes_in, 1, "modes");
                 const std::size_t triads_per_mode = whole(triads_in, 1, "triads_per_mode");
                 const std::uint64_t seed = whole(seed_in, 0, "seed");
                 n_wave<T> model;
                 try {
                     model = n_wave<T>::random(modes, triads_per_mode, seed);
                 } catch (const std::invalid_argument& e) {
                     throw std::invalid_argument(std::string(cli_name) + ": " + e.what());
                 }
                 auto y0 = model.random_state(seed);
                 auto meta = describe<n_wave<T>, typename object::meta>(indexed_columns("psi_", modes, complex));
                 return object(std::move(model), std::move(meta), std::move(y0));
             }),
             py::arg("modes") = 30, py::arg("triads_per_mode") = 20, py::arg("seed") = 1)
        .def_property_readonly("modes", [](const object& o) { return o.model().size(); })
        .def_property_readonly("triads_per_mode",
                               [](const object& o) { return 3 * o.model().triads.size() / o.model().size(); })
        .def_property_readonly("wavenumber",
                               [](const object& o) { return to_numpy(o.model().wavenumber); },
                               "|k| of each mode (the enstrophy weights' square roots)")
        .def_property_readonly(
            "triads",
            [](const object& o) {
                std::vector<std::array<double, 6>> rows;
                for (const triad& t : o.model().triads) rows.push_back({double(t.k), double(t.p), double(t.q), t.Mk, t.Mp, t.Mq});
                return rows;
            },
            "each triad as (k, p, q, M_k, M_p, M_q)")
        .def("__repr__", [name](const object& o) {
            return std::string(name) + "(modes=" + std::to_string(o.model().size()) + ", " +
                   std::to_string(o.model().triads.size()) + " triads)";
        });
}

}  // namespace

void init_wave_models(py::module_& m) {
    bind_model<three_wave>(
        m, "ThreeWave",
        "Three real modes of the truncated Euler equations, eq. (1); invariants energy (4) and enstrophy (5). "
        "Defaults are the paper's (Figs. 1-5); M must obey eqs. (2)-(3).")
        .def(py::init([](double K, double P, double Q, std::array<double, 3> M) {
                 three_wave model;
                 model.K = K, model.P = P, model.Q = Q, model.M = M;
                 return three_wave_object(model, describe<three_wave, three_wave_object::meta>(component_columns<three_wave>()),
                                          three_wave::presets()[0].x0);
             }),
             py::arg("K") = std::sqrt(3.0), py::arg("P") = 3.0, py::arg("Q") = std::sqrt(6.0),
             py::arg("M") = std::array<double, 3>{1.0, 1.0, -2.0})
        .def_property_readonly("K", [](const three_wave_object& o) { return o.model().K; })
        .def_property_readonly("P", [](const three_wave_object& o) { return o.model().P; })
        .def_property_readonly("Q", [](const three_wave_object& o) { return o.model().Q; })
        .def_property_readonly("M", [](const three_wave_object& o) { return o.model().M; })
        .def("__repr__", [](const three_wave_object& o) {
            const three_wave& w = o.model();
            return "ThreeWave(K=" + shortest_text(w.K) + ", P=" + shortest_text(w.P) + ", Q=" + shortest_text(w.Q) +
                   ", M=(" + shortest_text(w.M[0]) + ", " + shortest_text(w.M[1]) + ", " + shortest_text(w.M[2]) +
                   "))";
        });
    bind_n_wave<double>(m, "NWave", "n-wave");
    bind_n_wave<std::complex<double>>(m, "NWaveComplex", "n-wave-complex");
    add_presets<three_wave>(m, "ThreeWave", [](const three_wave&) { return component_columns<three_wave>(); });
    add_presets<n_wave<double>>(
        m, "NWave", [](const n_wave<double>& w) { return indexed_columns("psi_", w.size(), false); });
    add_presets<n_wave<std::complex<double>>>(m, "NWaveComplex", [](const n_wave<std::complex<double>>& w) {
        return indexed_columns("psi_", w.size(), true);
    });
}

}  // namespace eci::python
