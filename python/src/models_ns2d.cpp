// eci.models.NavierStokes2D: the pseudo-spectral 2-D vorticity equation of eci::spectral (FFTW), stepped by
// ns2d_step as `eci run navier-stokes-2d` steps it, with its diagnostics (E, Z, P, spectrum, fields) from Python.
#include <cmath>
#include <complex>
#include <mutex>
#include <numbers>

#include <eci/models/navier_stokes_2d.hpp>
#include <eci/registry.hpp>

#include "models.hpp"
#include "module.hpp"

namespace eci::python {

namespace {

using state = navier_stokes_2d::state_type;
using cplx = std::complex<double>;

// Ctrl-C between the halvings of a failed step: ns2d_step's stop() is a plain function, so the flag is per thread.
thread_local bool gil_released_in_run = false;
thread_local bool interrupt_pending = false;
bool python_interrupt_requested() {
    auto check = [] { return PyErr_CheckSignals() != 0; };
    if (!gil_released_in_run) return interrupt_pending = check();
    py::gil_scoped_acquire gil;
    return interrupt_pending = check();
}

/// The model object: one navier_stokes_2d (its FFT plans and scratch) used by one call at a time.
class ns2d_object final : public model_base {
   public:
    ns2d_object(const ns2d_params& p) : model_(make(p)) {
        y0_ = model_->random_field(8.0, 0.5, 1);  // the CLI's default initial condition
        default_dt_ = cfl_step(y0_, 0.5);
    }

    navier_stokes_2d& model() const { return *model_; }
    /// The model for this call alone; a RuntimeError (not a wait, which could deadlock on the GIL) when another
    /// thread is using it.
    std::unique_lock<std::mutex> lock() const {
        std::unique_lock<std::mutex> l(*mutex_, std::try_to_lock);
        if (!l.owns_lock()) throw std::runtime_error("this NavierStokes2D is in use by another thread's call");
        return l;
    }

    std::string name() const override { return "navier-stokes-2d"; }
    std::vector<std::string> methods() const override { return eci::ns2d_methods(); }
    py::dict method_families() const override {
        py::dict d;
        for (const std::string& m : eci::ns2d_methods()) d[py::str(m)] = std::string(family_name(find_method(m)->family));
        return d;
    }
    double default_dt() const override { return default_dt_; }
    double default_t_end() const override { return 10.0; }
    py::array default_y0() const override { return to_numpy(y0_); }
    std::vector<std::string> invariant_names() const override { return {"energy", "enstrophy"}; }

    py::array call(double t, const py::object& y) const override {
        const state x = to_state(y);
        state d(x.size());
        const auto lock_ = lock();
        (*model_)(x, d, t);
        return to_numpy(d);
    }

    py::dict invariants(const py::object& y) const override {
        const py::array a = py::array::ensure(y);
        py::dict d;
        if (a && a.ndim() == 2) {  // n x m, SciPy's layout: one value per column
            const std::size_t n = model_->size(), m = static_cast<std::size_t>(a.shape(1));
            const auto c = py::array_t<cplx, py::array::f_style | py::array::forcecast>::ensure(a);
            if (!c || static_cast<std::size_t>(c.shape(0)) != n)
                throw py::value_error("y must have shape (" + std::to_string(n) + ", m), got " + shape_text(a));
            py::array_t<double> e(static_cast<py::ssize_t>(m)), z(static_cast<py::ssize_t>(m));
            for (std::size_t j = 0; j < m; ++j) {
                const state x(c.data() + j * n, c.data() + (j + 1) * n);
                e.mutable_data()[j] = model_->energy(x);
                z.mutable_data()[j] = model_->enstrophy(x);
            }
            d["energy"] = e, d["enstrophy"] = z;
            return d;
        }
        const state x = to_state(y);
        d["energy"] = model_->energy(x), d["enstrophy"] = model_->enstrophy(x);
        return d;
    }

    std::vector<std::string> adaptive_methods() const override { return {}; }
    /// Fixed steps t0 + i dt (the last one shortened to land on t1), each by ns2d_step as the CLI takes them.
    py::dict solve(double t0, double t1, const py::object& y0, const std::string& method, double dt,
                   const py::dict& settings, std::vector<py::object> invariants,
                   const std::vector<std::string>& invariant_names) const override {
        if (!settings["adaptive"].is_none())
            throw std::invalid_argument("method " + method + " has no error estimate for rtol/atol; navier-stokes-2d "
                                        "runs fixed steps (give dt, or none for the CFL 0.5 step)");
        std::optional<std::vector<double>> t_eval;
        if (!settings["t_eval"].is_none()) t_eval = settings["t_eval"].cast<std::vector<double>>();
        const int max_halvings = settings["max_halvings"].cast<int>();
        state x = y0.is_none() ? y0_ : to_state(y0);
        for (const cplx& v : x)
            if (!std::isfinite(v.real()) || !std::isfinite(v.imag()))
                throw std::invalid_argument("initial condition is not finite");
        const method_info info = resolve_named_method(method, eci::ns2d_methods(), "model navier-stokes-2d");
        const std::uint64_t n = steps_to_reach(t0, t1, dt);
        const double last = n ? t1 - (t0 + double(n - 1) * dt) : 0.0;
        const bool full_last = std::abs(last - dt) <= 1e-12 * dt;  // as integrate_to decides
        auto grid_time = [&](std::uint64_t i) { return i == n ? t1 : t0 + double(i) * dt; };
        if (t_eval)
            for (double te : *t_eval) {
                const double k = std::round((te - t0) / dt);
                if (te != t1 && (k < 0 || double(k) > double(n) || grid_time(std::uint64_t(k)) != te))
                    throw std::invalid_argument("t_eval time " + full_text(te) + " is not on the step grid t0 + i dt "
                                                "(navier-stokes-2d outputs whole steps)");
            }
        std::vector<drift_record> drift{{"energy"}, {"enstrophy"}};
        for (const std::string& nm : invariant_names) drift.push_back({nm});
        const python_invariants<cplx> user{std::move(invariants)};
        const bool release = user.functions.empty();
        recorded_output<state> out;
        step_counts report;
        ns2d_budget budget;
        const auto lock_ = lock();
        navier_stokes_2d& m = *model_;
        auto measure = [&](const state& s, bool first) {
            drift[0].update(m.energy(s), first);
            drift[1].update(m.enstrophy(s), first);
            if (!release) user.measure(s, drift, 2, first);
        };
        std::size_t k = 0;
        auto emit = [&](double t, const state& s) {
            if (!t_eval) return out.record(t, s);
            for (; k < t_eval->size() && (*t_eval)[k] == t; ++k) out.record(t, s);
        };
        std::optional<underflow_error> failure;
        {
            std::optional<py::gil_scoped_release> unlocked;
            if (release) unlocked.emplace();
            gil_released_in_run = release;
            interrupt_pending = false;
            interrupt_check interrupt(!release);
            measure(x, true);
            emit(t0, x);
            with_ns2d_method(method, [&](auto stepper) {
                for (std::uint64_t i = 1; i <= n; ++i) {
                    interrupt();
                    const double start = t0 + double(i - 1) * dt;
                    const double h = (i < n || full_last) ? dt : last;
                    try {
                        ns2d_step(stepper, m, x, start, h, budget, report.stats, max_halvings,
                                  &python_interrupt_requested);
                    } catch (const step_interrupted&) {
                        if (!release) throw py::error_already_set();
                        break;  // the KeyboardInterrupt is raised below, with the GIL
                    } catch (const step_size_underflow& e) {
                        report.rejected.step_failed = report.stats.step_reductions;
                        const std::string c = "mode " + std::to_string(e.component);
                        failure.emplace("step failed at t = " + full_text(e.time) + " in component " + c +
                                            " even with the step halved " + std::to_string(max_halvings) +
                                            " times (dt = " + full_text(e.dt) + "): negative radicand or "
                                            "non-finite state",
                                        e.time, e.component, c, e.dt, false, report);
                        break;
                    }
                    measure(x, false);
                    emit(grid_time(i), x);
                }
            });
            gil_released_in_run = false;
        }
        if (interrupt_pending) throw py::error_already_set();
        if (failure) throw *failure;
        report.rejected.step_failed = report.stats.step_reductions;
        py::dict d = result_dict(out, m.size(), report, drift, info);
        py::dict b;
        b["energy_injection"] = budget.energy_injection;
        b["energy_dissipation"] = budget.energy_dissipation;
        b["enstrophy_injection"] = budget.enstrophy_injection;
        b["enstrophy_dissipation"] = budget.enstrophy_dissipation;
        d["budget"] = b;
        return d;
    }

    /// The step of CFL number `cfl` at w: cfl dx / max|u|, dx = 2 pi / n (the CLI's --cfl).
    double cfl_step(const state& w, double cfl) const {
        const double u = model_->max_velocity(w);
        if (!(u > 0.0)) throw std::invalid_argument("the initial velocity is zero: give dt");
        return cfl * 2.0 * std::numbers::pi / model_->n() / u;
    }

    state to_state(const py::object& y) const {
        const auto a = as_vector<cplx>(y, model_->size(), "y", false, "the navier-stokes-2d state (n (n/2 + 1) modes)");
        return {a.data(), a.data() + a.shape(0)};
    }

   private:
    static std::unique_ptr<navier_stokes_2d> make(const ns2d_params& p) {
        try {
            return std::make_unique<navier_stokes_2d>(p);
        } catch (const std::invalid_argument& e) {
            throw std::invalid_argument(std::string("invalid navier-stokes-2d model: ") + e.what());
        }
    }

    std::unique_ptr<navier_stokes_2d> model_;
    std::unique_ptr<std::mutex> mutex_ = std::make_unique<std::mutex>();
    state y0_;
    double default_dt_ = 0.0;
};

ns2d_forcing forcing_named(const std::string& s) {
    if (s == "none") return ns2d_forcing::none;
    if (s == "deterministic") return ns2d_forcing::deterministic;
    if (s == "stochastic") return ns2d_forcing::stochastic;
    throw std::invalid_argument("forcing must be none, deterministic or stochastic, not '" + s + "'");
}

}  // namespace

void init_ns2d(py::module_& m) {
    using o = ns2d_object;
    py::class_<o, model_base>(
        m, "NavierStokes2D",
        "The 2-D incompressible vorticity equation on [0, 2pi)^2, pseudo-spectral (FFTW), dealiased by the 2/3 rule "
        "so that every triad keeps energy and enstrophy (the paper's section III at scale); the state is FFTW's "
        "half plane of omega_k, n rows of n/2 + 1 complex modes. Invariants energy, enstrophy (inviscid, unforced).")
        .def(py::init([](long long n, double nu, double hyper_nu, long long hyper_p, double drag,
                         const std::string& forcing, double forcing_k, double forcing_amplitude, double injection_rate,
                         long long forcing_seed, long long threads, bool fftw_measure) {
                 if (n < 0 || hyper_p < 0 || forcing_seed < 0 || threads < 1)
                     throw std::invalid_argument(
                         "n, hyper_p and forcing_seed must be whole numbers >= 0, threads >= 1");
                 ns2d_params p;
                 p.n = int(n), p.nu = nu, p.hyper_nu = hyper_nu, p.hyper_p = int(hyper_p), p.drag = drag;
                 p.forcing = forcing_named(forcing), p.forcing_k = forcing_k, p.forcing_amplitude = forcing_amplitude;
                 p.injection_rate = injection_rate, p.forcing_seed = std::uint64_t(forcing_seed);
                 p.threads = int(threads), p.measure = fftw_measure;
                 return std::make_unique<o>(p);
             }),
             py::arg("n") = 256, py::arg("nu") = 0.0, py::arg("hyper_nu") = 0.0, py::arg("hyper_p") = 2,
             py::arg("drag") = 0.0, py::arg("forcing") = "none", py::arg("forcing_k") = 4.0,
             py::arg("forcing_amplitude") = 1.0, py::arg("injection_rate") = 1.0, py::arg("forcing_seed") = 1,
             py::arg("threads") = 1, py::arg("fftw_measure") = false)
        .def_property_readonly("n", [](const o& s) { return s.model().n(); }, "grid points per side")
        .def_property_readonly("kmax", [](const o& s) { return s.model().kmax(); }, "largest retained |k_x|, |k_y|")
        .def_property_readonly("size", [](const o& s) { return s.model().size(); }, "stored complex modes")
        .def_property_readonly(
            "kx",
            [](const o& s) {
                std::vector<double> k(s.model().size());
                for (std::size_t i = 0; i < k.size(); ++i) k[i] = s.model().kx(i);
                return to_numpy(k);
            },
            "k_x of each stored mode")
        .def_property_readonly(
            "ky",
            [](const o& s) {
                std::vector<double> k(s.model().size());
                for (std::size_t i = 0; i < k.size(); ++i) k[i] = s.model().ky(i);
                return to_numpy(k);
            },
            "k_y of each stored mode")
        .def("energy", [](const o& s, const py::object& w) { return s.model().energy(s.to_state(w)); },
             py::arg("w"), "E = 1/2 <|u|^2>")
        .def("enstrophy", [](const o& s, const py::object& w) { return s.model().enstrophy(s.to_state(w)); },
             py::arg("w"), "Z = 1/2 <omega^2>")
        .def("palinstrophy", [](const o& s, const py::object& w) { return s.model().palinstrophy(s.to_state(w)); },
             py::arg("w"), "P = 1/2 <|grad omega|^2>")
        .def("energy_spectrum",
             [](const o& s, const py::object& w) { return to_numpy(s.model().energy_spectrum(s.to_state(w))); },
             py::arg("w"), "shell-averaged E(k), k = 0, 1, ...")
        .def("max_velocity",
             [](const o& s, const py::object& w) {
                 const state x = s.to_state(w);
                 const auto lock = s.lock();
                 return s.model().max_velocity(x);
             },
             py::arg("w"), "max over the grid of |u|")
        .def("cfl_step",
             [](const o& s, const py::object& w, double cfl) {
                 const state x = s.to_state(w);
                 const auto lock = s.lock();
                 return s.cfl_step(x, cfl);
             },
             py::arg("w"), py::arg("cfl") = 0.5, "the step cfl dx / max|u| at w (eci.solve's default dt)")
        .def("to_physical",
             [](const o& s, const py::object& w) {
                 const state x = s.to_state(w);
                 const auto lock = s.lock();
                 py::array_t<double> a = to_numpy(s.model().to_physical(x));
                 return a.reshape({s.model().n(), s.model().n()});
             },
             py::arg("w"), "the vorticity on the n x n grid (rows: y)")
        .def("from_physical",
             [](const o& s, const py::object& field) {
                 const std::size_t n = std::size_t(s.model().n());
                 const auto f = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(field);
                 if (!f || f.size() != py::ssize_t(n * n))
                     throw py::value_error("field must have n x n = " + std::to_string(n * n) + " values");
                 const auto lock = s.lock();
                 return to_numpy(s.model().from_physical({f.data(), n * n}));
             },
             py::arg("field"), "the state of a vorticity field on the n x n grid (truncated, mean removed)")
        .def("random_field",
             [](const o& s, double k_peak, double energy, long long seed) {
                 if (seed < 0) throw std::invalid_argument("seed must be a whole number >= 0");
                 const auto lock = s.lock();
                 return to_numpy(s.model().random_field(k_peak, energy, std::uint64_t(seed)));
             },
             py::arg("k_peak") = 8.0, py::arg("energy") = 0.5, py::arg("seed") = 1,
             "random phases, E(k) ~ q^4 / (1 + q^2)^4 with q = k / k_peak, scaled to `energy` (the default y0)")
        .def("vortex_pair",
             [](const o& s, double radius, double separation, double peak) {
                 const auto lock = s.lock();
                 return to_numpy(s.model().vortex_pair(radius, separation, peak));
             },
             py::arg("radius") = 0.25, py::arg("separation") = 0.7, py::arg("peak") = 10.0,
             "two co-rotating Gaussian vortices (the merger problem)")
        .def("taylor_green",
             [](const o& s, double velocity) {
                 const auto lock = s.lock();
                 return to_numpy(s.model().taylor_green(velocity));
             },
             py::arg("velocity") = 1.0, "omega = 2 U sin x sin y, steady for Euler, damped as exp(-2 nu t)")
        .def("__repr__", [](const o& s) {
            const ns2d_params& p = s.model().params();
            return "NavierStokes2D(n=" + std::to_string(p.n) + ", nu=" + shortest_text(p.nu) + ")";
        });
}

}  // namespace eci::python
