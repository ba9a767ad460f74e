// eci.models.NavierStokes2D, CharneyHasegawaMima, SurfaceQG: the spectral equations of eci::spectral (FFTW), stepped
// by eci::solve as `eci run EQUATION` steps them, with their diagnostics (E, Z, P, spectra, fluxes, fields).
#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdint>
#include <limits>
#include <mutex>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>

#include <eci/format.hpp>
#include <eci/spectral/step.hpp>
#include <eci/registry.hpp>
#include <eci/solve.hpp>

#include "models.hpp"
#include "module.hpp"

// the CLI's checkpoint files (apps/eci, linked through apps/eci/files.cmake): one format, written and read by one code
#include "ns2d_output.hpp"
#include "output.hpp"

namespace eci::python {

namespace {

using state = navier_stokes_2d::state_type;
using cplx = std::complex<double>;
using eci::cli::ns2d_checkpoint;

// A file problem (a checkpoint that cannot be written or read) as Python's OSError, the GIL held.
[[noreturn]] void raise_os_error(const std::string& what) {
    PyErr_SetString(PyExc_OSError, what.c_str());
    throw py::error_already_set();
}

// Ctrl-C between the halvings of a failed step (run_config::stop_between_attempts): the flag is per thread.
thread_local bool gil_released_in_run = false;
thread_local bool interrupt_pending = false;
bool python_interrupt_requested() {
    auto check = [] { return PyErr_CheckSignals() != 0; };
    if (!gil_released_in_run) return interrupt_pending = check();
    py::gil_scoped_acquire gil;
    return interrupt_pending = check();
}

/// A sink of eci::solve made of three callables: output, after_step, progress.
template <class Output, class AfterStep, class Progress>
struct flow_sink {
    Output on_output;
    AfterStep on_step;
    Progress on_progress;
    void output(const state& x, const output_point& p) { on_output(x, p); }
    void after_step(const state& x, const output_point& p) { on_step(x, p); }
    void progress(double t, std::uint64_t i) { on_progress(t, i); }
};

/// The model object: one spectral flow (its FFT plans and scratch) used by one call at a time.
class ns2d_object : public model_base {
   public:
    ns2d_object(const ns2d_params& p) : model_(make(p)), names_(model_->invariant_names()) {
        y0_ = model_->random_field(8.0, 0.5, 1);  // the CLI's default initial condition
        default_dt_ = cfl_step(y0_, 0.5);
    }

    navier_stokes_2d& model() const { return *model_; }
    /// The model for this call alone; a RuntimeError (not a wait, which could deadlock on the GIL) when another
    /// thread is using it.
    std::unique_lock<std::mutex> lock() const {
        std::unique_lock<std::mutex> l(*mutex_, std::try_to_lock);
        if (!l.owns_lock()) throw std::runtime_error("this " + name() + " model is in use by another thread's call");
        return l;
    }

    std::string name() const override { return model_->params().equation; }
    std::vector<std::string> methods() const override { return eci::ns2d_methods(); }
    py::dict method_families() const override {
        py::dict d;
        for (const std::string& m : eci::ns2d_methods()) d[py::str(m)] = std::string(family_name(find_method(m)->family));
        return d;
    }
    double default_dt() const override { return default_dt_; }
    double default_t_end() const override { return 10.0; }
    py::array default_y0() const override { return to_numpy(y0_); }
    std::vector<std::string> invariant_names() const override { return {names_[0], names_[1]}; }

    // A white-in-time forcing is drawn by each step of eci.solve (begin_step) and held over it: a right-hand side
    // asked for outside those steps has no forcing of its own to add. It added F = 0 before the first solve and the
    // last step's draw after one, so SciPy's solve_ivp(model, ...) ran unforced (or one draw held for the whole
    // run) without a word; refused, as a setting that cannot act is refused.
    py::array call(double t, const py::object& y) const override {
        if (model_->params().forcing == ns2d_forcing::stochastic)
            throw std::invalid_argument(
                std::string(model_->eq().python_class) +
                "(t, y): the stochastic forcing is white in time, drawn once per step by eci.solve(model, ...) (as "
                "eci run draws it) and held over that step, so a right-hand side asked for outside those steps "
                "(SciPy's solve_ivp, a Python function) has no forcing to add; integrate it with eci.solve, or make "
                "the model with forcing='deterministic' or 'none' for fun(t, y) (model.forcing_term is the forcing of "
                "the last step taken)");
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
            d[py::str(names_[0])] = e, d[py::str(names_[1])] = z;
            return d;
        }
        const state x = to_state(y);
        d[py::str(names_[0])] = model_->energy(x), d[py::str(names_[1])] = model_->enstrophy(x);
        return d;
    }

    std::vector<std::string> adaptive_methods() const override { return {}; }
    std::string default_method(bool adaptive) const override {
        return default_method_for<navier_stokes_2d>(eci::ns2d_methods().front(), adaptive, "model " + name());
    }
    /// Fixed steps t0 + i dt (the last one shortened to land on t1), by eci::solve as the CLI takes them.
    py::dict solve(double t0, double t1, const py::object& y0, const std::string& method, double dt,
                   const py::dict& settings, std::vector<py::object> invariants,
                   const std::vector<std::string>& invariant_names) const override {
        if (!settings["adaptive"].is_none())
            throw std::invalid_argument("method " + method + " has no error estimate for rtol/atol; " + name() +
                                        " runs fixed steps (give dt, or none for the CFL 0.5 step)");
        std::optional<std::vector<double>> t_eval;
        if (!settings["t_eval"].is_none()) t_eval = settings["t_eval"].cast<std::vector<double>>();
        const int max_halvings = settings["max_halvings"].cast<int>();
        // checkpoint=: the CLI's checkpoint file (every checkpoint_every steps, at the end, on Ctrl-C between steps);
        // restart: the checkpoint a run continues (eci.restart), its step and its statistics so far
        const auto setting = [&](const char* k) { return settings.contains(k) ? py::object(settings[k]) : py::none(); };
        const std::string ck_path = setting("checkpoint").is_none() ? "" : setting("checkpoint").cast<std::string>();
        const std::uint64_t ck_every =
            setting("checkpoint_every").is_none() ? 0 : setting("checkpoint_every").cast<std::uint64_t>();
        const ns2d_checkpoint* from =
            setting("restart").is_none() ? nullptr : setting("restart").cast<const ns2d_checkpoint*>();
        const std::uint64_t first = from ? from->step : 0;
        if (!ck_path.empty()) {
            if (t0 != 0.0 && !from)
                throw std::invalid_argument("checkpoint= keeps the run at step i of the grid t = i dt from t = 0, as "
                                            "eci run's checkpoints: give t_span from 0 (a run from t0 = " +
                                            eci::detail::shortest_text(t0) + " has none)");
            try {
                eci::cli::check_output_path(ck_path, "checkpoint");
            } catch (const std::exception& e) {
                raise_os_error(e.what());
            }
        }
        state x = y0.is_none() ? y0_ : to_state(y0);
        const method_info info = resolve_named_method(method, eci::ns2d_methods(), "model " + name());
        {
            const auto lock_ = lock();
            model_->check_initial_state(x);  // the library's check and sentences, as the CLI's
            model_->make_hermitian(x);       // (a real field's state to round-off, made exact: as the CLI's fields)
            model_->check_initial_rates(x);  // (a field whose nonlinear term overflows: refused, as the CLI's)
        }
        const std::uint64_t n = steps_to_reach(t0, t1, dt);
        auto grid_time = [&](std::uint64_t i) { return i == n ? t1 : t0 + double(i) * dt; };
        if (t_eval)
            for (double te : *t_eval) {
                const double k = std::round((te - t0) / dt);
                if (te != t1 && (k < double(first) || double(k) > double(n) || grid_time(std::uint64_t(k)) != te)) {
                    // (a step the user never chose is named as such: the remedy is then to choose one)
                    const bool dt_given = !settings.contains("dt_given") || settings["dt_given"].cast<bool>();
                    throw std::invalid_argument(
                        "t_eval time " + eci::detail::shortest_text(te) +
                        " is not on the step grid t0 + i dt of dt = " + eci::detail::shortest_text(dt) +
                        (dt_given ? "" : " (the CFL 0.5 step of y0: no dt was given)") + "; " +
                        name() + " outputs whole steps: give output_dt= for evenly spaced outputs (the step is " +
                        "then shortened to divide it), or a dt of which every t_eval time is a whole multiple " +
                        "after t0");
                }
            }
        std::vector<invariant_record> drift{{names_[0]}, {names_[1]}};
        for (const std::string& nm : invariant_names) drift.push_back({nm});
        const python_invariants<cplx> user{std::move(invariants)};
        const bool release = user.functions.empty();
        recorded_output<state> out;
        step_counts report;
        ns2d_budget budget;
        const auto lock_ = lock();
        navier_stokes_2d& m = *model_;
        // The run is the library's (eci::solve, the flow's step hooks); this sink fills the arrays, the drifts
        // and the budget, and polls Ctrl-C between steps.
        run_config cfg;
        cfg.t0 = t0;
        cfg.t_end = t1;
        cfg.dt = dt;
        cfg.first_step = first;
        if (t_eval) cfg.times = *t_eval;
        if (settings.contains("output_dt") && !settings["output_dt"].is_none()) {
            // every k = output_dt / dt steps: the library's rule and sentences, as `eci run navier-stokes-2d`'s
            cfg.output_dt = settings["output_dt"].cast<double>();
            resolve_output_dt(cfg, {.tolerances = ""});
        }
        cfg.max_halvings = max_halvings;
        cfg.max_substeps = run_options{}.max_substeps;  // as every model: a far too long dt fails, not halves for hours
        if (settings.contains("update") && !settings["update"].is_none()) {  // (None: not chosen)
            cfg.update = settings["update"].cast<std::string>() == "paper" ? update_kind::paper
                                                                           : update_kind::conditioned;
            cfg.update_chosen = true;
        }
        cfg.stop_on_invariant_overflow = false;
        // (set below: a stop between the halvings of a failed step keeps that step's start in the checkpoint)
        const bool no_outputs = t_eval && t_eval->empty();
        // the arrays keep every output (the state, its time, each invariant's value and the two budget residuals
        // there): a run whose outputs cannot fit is refused before it starts
        cfg.output_bytes = no_outputs ? 0 : m.size() * sizeof(cplx) + (1 + drift.size() + 2) * sizeof(double);
        // A run that stops early returns what it reached with result.failure (status -1), as every model's run does:
        // the library's report (failure_dict, once the GIL is held again), or the library's blow-up stop.
        std::optional<solve_report> failed;
        std::optional<eci::spectral::flow_blow_up> blew_up;
        const double energy0 = m.energy(x);
        std::array<double, 2> before{energy0, m.enstrophy(x)}, residual{0.0, 0.0};
        // The checkpoint of step i at state s: the run's settings, the generator where it stands, and the
        // statistics since step 0 (a restart's checkpoint's and this run's), as the CLI's checkpoints hold them.
        ns2d_checkpoint base = from ? *from : ns2d_checkpoint{};
        if (!from) base.energy0 = energy0, base.enstrophy0 = before[1];
        base.params = m.params();
        base.method = method;
        base.update = cfg.update == update_kind::paper ? "paper" : "conditioned";
        base.dt = dt;
        base.total_steps = n;
        base.t_end = t1;
        base.checksum.reset();
        std::array<double, 2> max_drift{base.max_energy_drift, base.max_enstrophy_drift};
        ns2d_budget total_budget = base.budget;  // since step 0, summed step by step as the CLI's (the same bits)
        std::uint64_t written = std::numeric_limits<std::uint64_t>::max();  // the step of the last checkpoint written
        const auto save = [&](std::uint64_t i, const state& s, std::uint64_t rng) {
            ns2d_checkpoint c = base;
            c.step = i;
            c.rng_state = rng;
            c.halvings += report.stats.step_reductions;
            c.rhs_evals += report.stats.rhs_evals;
            c.budget = total_budget;
            c.max_energy_drift = max_drift[0], c.max_enstrophy_drift = max_drift[1];
            c.max_energy_residual = std::max(c.max_energy_residual, residual[0]);
            c.max_enstrophy_residual = std::max(c.max_enstrophy_residual, residual[1]);
            c.state = m.to_half_plane(s);
            eci::cli::write_checkpoint(ck_path, c);
            written = i;
        };
        // A write that fails (eci::cli::run_error, the only error a checkpoint's write throws) ends the run: Python's
        // OSError, raised with the GIL held (as_os_error; during the run, by the catch after it).
        const auto as_os_error = [](auto&& write) {
            try {
                write();
            } catch (const eci::cli::run_error& e) {
                raise_os_error(e.what());
            }
        };
        // a run whose last step is shortened to land on t1 keeps the step before it (the grid's last state, as the
        // CLI's: a restart to the same end repeats that step, to a later one goes on along the grid)
        // (by the CLI's rule, last_step_to_reach: a last step within 1e-12 dt of dt is a whole one)
        const bool shortened_end = n > 0 && last_step_to_reach(t0, t1, dt, n) != dt;
        std::uint64_t done = first;  // the step of the state x holds between steps
        bool stopped_between_steps = false;
        // A step that fails is halved, and Ctrl-C is looked for between its attempts, where x may be part-way
        // through it: the step's start (x at its first failed attempt, which leaves x as it was) and the generator
        // before the step's draw are what a checkpoint then keeps, as the CLI's stop does.
        state x_start;
        std::uint64_t start_of = std::numeric_limits<std::uint64_t>::max(), rng_before = m.rng_state();
        cfg.stop_between_attempts = [&] {
            if (!ck_path.empty() && start_of != done) x_start = x, start_of = done;
            return python_interrupt_requested();
        };
        // The checkpoint of a run stopped by Ctrl-C (the GIL held; a failed write raised as OSError instead).
        // (a failed write is the OSError instead of the KeyboardInterrupt: the run was not kept)
        const auto keep_on_stop = [&] {
            if (ck_path.empty() || written == done) return;
            as_os_error([&] {
                if (stopped_between_steps)
                    save(done, x, m.rng_state());
                else if (interrupt_pending && start_of == done)
                    save(done, x_start, rng_before);
            });
        };
        std::array<std::vector<double>, 2> residual_at_output;
        // eci.solve's progress= line (its position set at every step, drawn when the GIL is taken for Ctrl-C; erased
        // when destroyed, the GIL held again, however the run ends)
        std::optional<progress_display> progress;
        if (settings.contains("progress") && settings["progress"].cast<bool>())
            progress.emplace(t0 + double(first) * dt, t1);
        try {
            std::optional<py::gil_scoped_release> unlocked;
            if (release) unlocked.emplace();
            gil_released_in_run = release;
            interrupt_pending = false;
            interrupt_check interrupt(!release, progress ? &*progress : nullptr);
            drift[0].record(energy0, true);
            drift[1].record(before[1], true);
            if (!release) user.measure(x, drift, 2, true);
            // per output: E and Z (measured there anyway), the user's invariants (their last measurement, at this
            // state), and each one's largest budget residual over the steps since the previous output
            std::vector<double> at_output(drift.size());
            std::array<double, 2> residual_since{0.0, 0.0};
            auto on_output = [&](const state& s, const output_point& pt) {
                if (no_outputs) return;
                out.record(pt.t, s);
                at_output[0] = pt.invariants[0];
                at_output[1] = pt.invariants[1];
                for (std::size_t j = 2; j < drift.size(); ++j) at_output[j] = drift[j].final;
                out.record_invariants(at_output);
                residual_at_output[0].push_back(residual_since[0]);
                residual_at_output[1].push_back(residual_since[1]);
                residual_since = {0.0, 0.0};
            };
            auto on_step = [&](const state& s, const output_point& pt) {
                report.stats = *pt.stats;  // (the counts up to here, for a run the blow-up stop ends)
                const ns2d_budget& b = m.step_budget();
                // each step's budget residual, the library's rule (eci run's max_*_budget_residual_per_step)
                residual_since[0] = std::max(residual_since[0], m.budget_residual(before[0], pt.invariants[0],
                                                                                  b.energy_injection,
                                                                                  b.energy_dissipation));
                residual_since[1] = std::max(residual_since[1], m.budget_residual(before[1], pt.invariants[1],
                                                                                  b.enstrophy_injection,
                                                                                  b.enstrophy_dissipation));
                residual[0] = std::max(residual[0], residual_since[0]);
                residual[1] = std::max(residual[1], residual_since[1]);
                before = {pt.invariants[0], pt.invariants[1]};
                budget.energy_injection += b.energy_injection;
                budget.energy_dissipation += b.energy_dissipation;
                budget.enstrophy_injection += b.enstrophy_injection;
                budget.enstrophy_dissipation += b.enstrophy_dissipation;
                total_budget.energy_injection += b.energy_injection;
                total_budget.energy_dissipation += b.energy_dissipation;
                total_budget.enstrophy_injection += b.enstrophy_injection;
                total_budget.enstrophy_dissipation += b.enstrophy_dissipation;
                m.check_blow_up(s, pt.invariants, energy0, budget.energy_injection, pt.index, pt.t, cfg.dt);
                max_drift[0] = invariant_record::widened_drift(max_drift[0], base.energy0, pt.invariants[0]);
                max_drift[1] = invariant_record::widened_drift(max_drift[1], base.enstrophy0, pt.invariants[1]);
                // (the end's: the step before a shortened last step here, a whole last step after the run)
                if (!ck_path.empty() && ((ck_every && pt.index % ck_every == 0) || (shortened_end && pt.index + 1 == n)))
                    save(pt.index, s, m.rng_state());
                drift[0].record(pt.invariants[0], false);
                drift[1].record(pt.invariants[1], false);
                if (!release) user.measure(s, drift, 2, false);
            };
            auto on_progress = [&](double t, std::uint64_t i) {
                done = i;
                rng_before = m.rng_state();  // (the next step's forcing is drawn after this)
                if (i < n) {  // before every step
                    try {
                        interrupt(t);
                    } catch (...) {
                        stopped_between_steps = true;  // (x is step i's state: a checkpoint can keep it)
                        throw;
                    }
                }
            };
            // the end's checkpoint where the state before a shortened last step is the start (no step ends there)
            if (!ck_path.empty() && shortened_end && n - 1 == first) save(first, x, m.rng_state());
            try {
                const solve_report r = eci::solve<navier_stokes_2d>(
                    m, x, method, cfg, flow_sink{on_output, on_step, on_progress}, {}, "model " + name());
                report.stats = r.stats;  // (steps, halvings, evaluations, the remedy's counts)
                if (r.failure) failed = r;
            } catch (const eci::spectral::flow_blow_up& e) {
                blew_up = e;
            } catch (const eci::interrupted&) {  // between the halvings of a step
                if (!release) throw py::error_already_set();
                // the KeyboardInterrupt is raised below, with the GIL
            }
            gil_released_in_run = false;
        } catch (const py::error_already_set&) {
            // Ctrl-C keeps the run in its checkpoint (keep_on_stop: the step reached), as eci run's stop does
            gil_released_in_run = false;
            keep_on_stop();
            throw;
        } catch (const eci::cli::run_error& e) {  // (a checkpoint's write, the GIL held again)
            gil_released_in_run = false;
            raise_os_error(e.what());
        } catch (...) {
            gil_released_in_run = false;
            throw;
        }
        if (interrupt_pending) {
            keep_on_stop();
            throw py::error_already_set();
        }
        // a finished run's checkpoint at its end, on the grid (a run that failed keeps the last one written)
        if (!ck_path.empty() && !shortened_end && !failed && !blew_up && written != n)
            as_os_error([&] { save(n, x, m.rng_state()); });
        report.rejected.step_failed = report.stats.step_reductions;
        py::dict d = result_dict(out, m.size(), report, drift, info);
        d["invariant_values"] = invariant_values_dict(out, record_names(drift));
        py::dict per_output;
        for (std::size_t k = 0; k < 2; ++k)
            per_output[py::str(names_[k])] = py::array_t<double>(static_cast<py::ssize_t>(residual_at_output[k].size()),
                                                                 residual_at_output[k].data());
        d["budget_residual_values"] = per_output;
        d["failure"] = failed    ? py::object(failure_of(*failed, max_halvings, cfg.dt, m.decay_hint(x)))
                       : blew_up ? py::object(failure_of(*blew_up, cfg.dt))
                                 : py::object(py::none());
        d["stopped_at"] = py::none();
        py::dict b;
        b[py::str(names_[0] + "_injection")] = budget.energy_injection;
        b[py::str(names_[0] + "_dissipation")] = budget.energy_dissipation;
        b[py::str(names_[1] + "_injection")] = budget.enstrophy_injection;
        b[py::str(names_[1] + "_dissipation")] = budget.enstrophy_dissipation;
        b[py::str("max_" + names_[0] + "_budget_residual_per_step")] = residual[0];
        b[py::str("max_" + names_[1] + "_budget_residual_per_step")] = residual[1];
        d["budget"] = b;
        return d;
    }

    /// result.failure of a run the library's report ended (failure_dict's kind, cause and numbers), with the CLI's
    /// sentence for a failed step (its step number, the radicand named only for the conservative methods) and
    /// the stiffness of the damping where that is the cause to act on, else a field decayed below double precision's
    /// normal range (`decay`: flow2d::decay_hint of the last good state), as the CLI says them.
    py::dict failure_of(const solve_report& r, int max_halvings, double dt, const std::string& decay) const {
        const run_failure& e = *r.failure;
        py::dict f = failure_dict(r, component_namer{});
        f["component_name"] = "mode " + std::to_string(e.component);
        std::string hint = model_->stiffness_hint(dt);
        if (hint.empty()) hint = decay;
        const std::string stiff = hint.empty() ? std::string() : "; " + hint;
        if (e.kind == run_failure_kind::step_failed)
            f["message"] = "step " + std::to_string(r.stats.steps + 1) + " failed at t = " + full_text(e.t) +
                           " even with the step halved " + std::to_string(max_halvings) + " times (down to dt = " +
                           full_text(e.dt) + "): " +
                           (e.non_finite_rate_value ? "a rate is " + full_text(*e.non_finite_rate_value)
                            : r.method.family == method_family::conservative
                                ? "a negative radicand or a non-finite state"
                                : "a non-finite state") +
                           stiff;
        else
            f["message"] = f["message"].cast<std::string>() + stiff;
        return f;
    }
    /// result.failure of a run the library's blow-up stop ended (flow2d::check_blow_up): NonFiniteSolution,
    /// cause "blow_up" (energy grown a thousandfold beyond E0 and its injection) or "invariant_overflow".
    py::dict failure_of(const eci::spectral::flow_blow_up& e, double dt) const {
        const std::string hint = model_->stiffness_hint(dt);
        py::dict f;
        f["kind"] = "NonFiniteSolution";
        f["message"] = std::string(e.what()) + "; " + (hint.empty() ? "reduce dt" : hint);
        f["cause"] = e.finite ? "blow_up" : "invariant_overflow";
        f["t"] = e.t, f["dt"] = dt, f["component"] = e.invariant;
        f["component_name"] = names_[e.invariant];
        return f;
    }

    /// The step of CFL number `cfl` at w: cfl dx / max|u|, dx = 2 pi / n (the CLI's --cfl), w checked first: the
    /// library's rule and sentences (flow2d::initial_cfl_step), the CLI's default step.
    double cfl_step(const state& w, double cfl) const { return model_->initial_cfl_step(w, cfl, "dt", "cfl"); }

    state to_state(const py::object& y) const {
        const auto a = as_vector<cplx>(y, model_->size(), "y", false, "the " + name() + " state ((2 kmax + 1) (kmax + 1) modes)");
        return {a.data(), a.data() + a.shape(0)};
    }

   private:
    static std::unique_ptr<navier_stokes_2d> make(const ns2d_params& p) {
        try {
            return std::make_unique<navier_stokes_2d>(p);
        } catch (const std::invalid_argument& e) {
            throw std::invalid_argument(p.equation + ": " + e.what());  // as `eci run EQUATION`
        }
    }

    std::unique_ptr<navier_stokes_2d> model_;
    std::array<std::string, 2> names_;
    std::unique_ptr<std::mutex> mutex_ = std::make_unique<std::mutex>();
    state y0_;
    double default_dt_ = 0.0;
};


// A constructor keyword of the spectral classes (after n): its value in a flow's parameters, whether it differs from
// the constructor's default (repr leaves those out), and its help. beta and deformation: equations with waves only.
struct flow_keyword {
    const char* name;
    py::object (*get)(const ns2d_params&);
    bool (*given)(const ns2d_params&);
    const char* doc;
    bool waves = false;
};

const std::vector<flow_keyword>& flow_keywords() {
    static const ns2d_params d;  // (the library's defaults; Python's differ only in fftw_measure)
    static const std::vector<flow_keyword> k = {
        {"beta", [](const ns2d_params& p) -> py::object { return py::float_(p.beta); },
         [](const ns2d_params& p) { return p.beta != 0.0; }, "the planetary vorticity gradient (Rossby waves)", true},
        {"deformation", [](const ns2d_params& p) -> py::object { return py::float_(p.deformation); },
         [](const ns2d_params& p) { return p.deformation != 0.0; }, "F = 1 / L_d^2 in q = lap psi - F psi", true},
        {"nu", [](const ns2d_params& p) -> py::object { return py::float_(p.nu); },
         [](const ns2d_params& p) { return p.nu != 0.0; }, "viscosity: -nu |k|^2 q"},
        {"hyper_nu", [](const ns2d_params& p) -> py::object { return py::float_(p.hyper_nu); },
         [](const ns2d_params& p) { return p.hyper_nu != 0.0; }, "hyperviscosity: -hyper_nu |k|^(2 hyper_p) q"},
        {"hyper_p", [](const ns2d_params& p) -> py::object { return py::int_(p.hyper_p); },
         [](const ns2d_params& p) { return p.hyper_p != d.hyper_p; }, "the hyperviscosity's power"},
        {"hypo_nu", [](const ns2d_params& p) -> py::object { return py::float_(p.hypo_nu); },
         [](const ns2d_params& p) { return p.hypo_nu != 0.0; }, "hypoviscosity: -hypo_nu |k|^(-2 hypo_p) q"},
        {"hypo_p", [](const ns2d_params& p) -> py::object { return py::int_(p.hypo_p); },
         [](const ns2d_params& p) { return p.hypo_p != d.hypo_p; }, "the hypoviscosity's power"},
        {"drag", [](const ns2d_params& p) -> py::object { return py::float_(p.drag); },
         [](const ns2d_params& p) { return p.drag != 0.0; }, "linear (Ekman) drag: -drag q"},
        {"forcing",
         [](const ns2d_params& p) -> py::object {
             return py::str(std::string(ns2d_params::forcing_name(p.forcing)));
         },
         [](const ns2d_params& p) { return p.forcing != ns2d_forcing::none; }, "none, deterministic or stochastic"},
        {"forcing_k", [](const ns2d_params& p) -> py::object { return py::float_(p.forcing_k); },
         [](const ns2d_params& p) { return p.forcing != ns2d_forcing::none && p.forcing_k != d.forcing_k; },
         "centre k_f of the forced band k_f - 1/2 <= |k| < k_f + 1/2"},
        {"forcing_amplitude", [](const ns2d_params& p) -> py::object { return py::float_(p.forcing_amplitude); },
         [](const ns2d_params& p) {
             return p.forcing == ns2d_forcing::deterministic && p.forcing_amplitude != d.forcing_amplitude;
         },
         "deterministic forcing: rms of the forcing field"},
        {"injection_rate", [](const ns2d_params& p) -> py::object { return py::float_(p.injection_rate); },
         [](const ns2d_params& p) {
             return p.forcing == ns2d_forcing::stochastic && p.injection_rate != d.injection_rate;
         },
         "stochastic forcing: mean energy injection rate epsilon"},
        {"forcing_seed", [](const ns2d_params& p) -> py::object { return py::int_(p.forcing_seed); },
         [](const ns2d_params& p) { return p.forcing != ns2d_forcing::none && p.forcing_seed != d.forcing_seed; },
         "seed of the forcing's phases and generator"},
        {"threads", [](const ns2d_params& p) -> py::object { return py::int_(p.threads); },
         [](const ns2d_params& p) { return p.threads != 1; }, "FFTW and OpenMP threads"},
        {"fftw_measure", [](const ns2d_params& p) -> py::object { return py::bool_(p.measure); },
         [](const ns2d_params& p) { return p.measure; }, "FFTW_MEASURE plans (else FFTW_ESTIMATE)"},
        {"full_transforms", [](const ns2d_params& p) -> py::object { return py::bool_(!p.pruned_transforms); },
         [](const ns2d_params& p) { return !p.pruned_transforms; }, "FFTW's 2-D plans (the CLI's --full-transforms)"},
    };
    return k;
}

// The flow as the constructor call that makes it again: its class, n, and every keyword that is not the default.
// The keywords of that call, in order: n, then each keyword its equation takes that is not the default (repr's, and
// the model eci.load_checkpoint makes from a checkpoint's parameters).
py::dict constructor_keywords(const ns2d_params& p) {
    const spectral::equation& e = spectral::find_equation(p.equation);
    py::dict kw;
    kw["n"] = p.n;
    for (const flow_keyword& k : flow_keywords())
        if ((!k.waves || e.dispersion) && k.given(p)) kw[k.name] = k.get(p);
    return kw;
}
std::string flow_repr(const ns2d_params& p) {
    std::string r = std::string(spectral::find_equation(p.equation).python_class) + "(";
    const char* sep = "";
    for (const auto& [k, v] : constructor_keywords(p)) {
        r += sep + k.cast<std::string>() + "=" + py::repr(v).cast<std::string>();
        sep = ", ";
    }
    return r + ")";
}

// The methods and properties every spectral equation's class has.
template <class Class>
void add_flow_methods(Class& c) {
    using o = typename Class::type;
    using field = eci::spectral::flow2d::field_defaults;  // the initial fields' defaults, as eci run's
    c
        .def_property_readonly("n", [](const o& s) { return s.model().n(); }, "grid points per side")
        .def_property(
            "_rng_state", [](const o& s) { return s.model().rng_state(); },
            [](const o& s, std::uint64_t v) {
                const auto l = s.lock();
                s.model().set_rng_state(v);
            },
            "where the stochastic forcing's generator stands (each solve continues it; a copy carries it)")
        .def_property_readonly(
            "forcing_term",
            [](const o& s) {
                const auto lock = s.lock();
                const state& f = s.model().forcing();
                return to_numpy(f.empty() ? state(s.model().size()) : f);
            },
            "the forcing F_k the right-hand side adds, in the state's layout: the deterministic band's, or the "
            "stochastic forcing of the last step eci.solve took (sigma g / sqrt(dt); zero before the first); zero "
            "unforced")
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
             py::arg("w"), "E = 1/2 sum |a_k| |q_k|^2 (psi_k = a_k q_k; for Navier-Stokes 1/2 <|u|^2>)")
        .def("enstrophy", [](const o& s, const py::object& w) { return s.model().enstrophy(s.to_state(w)); },
             py::arg("w"), "Z = 1/2 sum |q_k|^2 (enstrophy; surface QG calls it variance)")
        .def("palinstrophy", [](const o& s, const py::object& w) { return s.model().palinstrophy(s.to_state(w)); },
             py::arg("w"), "P = 1/2 <|grad q|^2> of the evolved field q (vorticity, potential vorticity or buoyancy)")
        .def("energy_spectrum",
             [](const o& s, const py::object& w) { return to_numpy(s.model().energy_spectrum(s.to_state(w))); },
             py::arg("w"), "shell-summed E(k), k = round(|k|) = 0, 1, ... (sum over k is E, not a shell average)")
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
             py::arg("w"), py::arg("cfl") = eci::spectral::flow2d::default_cfl,
             "the step cfl dx / max|u| at w (eci.solve's default dt)")
        .def("to_physical",
             [](const o& s, const py::object& w) {
                 const state x = s.to_state(w);
                 const auto lock = s.lock();
                 py::array_t<double> a = to_numpy(s.model().to_physical(x));
                 return a.reshape({s.model().n(), s.model().n()});
             },
             py::arg("w"), "the evolved field q (vorticity, potential vorticity or buoyancy) on the n x n grid "
             "(rows: y)")
        .def("from_physical",
             [](const o& s, const py::object& field) {
                 const std::size_t n = std::size_t(s.model().n());
                 // (a complex field was cast to its real part, with numpy's warning at most)
                 if (const py::array a = py::array::ensure(field); a && a.dtype().kind() == 'c')
                     throw py::type_error("field must be real (a field on the n x n grid), not " +
                                          py::str(a.dtype()).cast<std::string>());
                 const auto f = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(field);
                 if (!f || f.size() != py::ssize_t(n * n))
                     throw py::value_error("field must have n x n = " + std::to_string(n * n) + " values");
                 const auto lock = s.lock();
                 return to_numpy(s.model().from_physical({f.data(), n * n}));
             },
             py::arg("field"),
             "the state of a field q (vorticity, potential vorticity or buoyancy) on the n x n grid (truncated, mean "
             "removed)")
        .def("random_field",
             [](const o& s, std::optional<double> k_peak, double energy, long long seed) {
                 if (seed < 0) throw std::invalid_argument("seed must be a whole number >= 0");
                 // a peak asked for beyond the retained modes is refused (eci run's --k-peak); the default 8 is
                 // kept on a small grid
                 const auto lock = s.lock();
                 if (const std::string why = s.model().grid().beyond_retained(k_peak.value_or(field::k_peak));
                     k_peak && !why.empty())
                     throw std::invalid_argument("k_peak " + eci::shortest_text(*k_peak) + " " + why);
                 return to_numpy(s.model().random_field(k_peak.value_or(field::k_peak), energy, std::uint64_t(seed)));
             },
             py::arg("k_peak") = py::none(), py::arg("energy") = field::energy, py::arg("seed") = field::seed,
             "random phases, E(k) ~ q^4 / (1 + q^2)^4 with q = k / k_peak (default 8; at most the grid's kmax), "
             "scaled to `energy` (the default y0)")
        .def("vortex_pair",
             [](const o& s, double radius, double separation, double peak) {
                 const auto lock = s.lock();
                 return to_numpy(s.model().vortex_pair(radius, separation, peak));
             },
             py::arg("radius") = field::vortex_radius, py::arg("separation") = field::vortex_separation,
             py::arg("peak") = field::vortex_peak,
             "two co-rotating Gaussian vortices (the merger problem)")
        .def("taylor_green",
             [](const o& s, double velocity) {
                 const auto lock = s.lock();
                 return to_numpy(s.model().taylor_green(velocity));
             },
             py::arg("velocity") = field::taylor_green_velocity,
             "q = 2 U sin x sin y (one |k| = sqrt 2; U is the peak velocity for Navier-Stokes, 2U/(2 + F) is it "
             "for Charney-Hasegawa-Mima and sqrt(2) U for surface QG): steady without beta, forcing or dissipation, "
             "damped at the linear "
             "terms' rate at k^2 = 2 (exp(-2 nu t) with viscosity); with beta (charney-hasegawa-mima) it travels "
             "west rigidly, q = 2 U sin(x + beta t / (2 + F)) sin y")
        .def("enstrophy_spectrum",
             [](const o& s, const py::object& w) { return to_numpy(s.model().enstrophy_spectrum(s.to_state(w))); },
             py::arg("w"), "shell-summed Z(k) (the second invariant's spectrum), k = 0, 1, ...")
        .def("fluxes",
             [](const o& s, const py::object& w) {
                 const state x = s.to_state(w);
                 const auto lock = s.lock();
                 const auto f = s.model().fluxes(x);
                 return py::make_tuple(to_numpy(f.energy), to_numpy(f.enstrophy));
             },
             py::arg("w"), "(Pi_E(k), Pi_Z(k)): the nonlinear term's flux of E and Z out of the shells <= k")
        .def_property_readonly("equation", [](const o& s) { return s.model().params().equation; },
                               "the equation's name (as `eci run` calls it)")
        .def_property_readonly("field", [](const o& s) { return std::string(s.model().eq().field); },
                               "the evolved field's name, e.g. 'vorticity' (the snapshots', the pictures')")
        .def_property_readonly("symbol", [](const o& s) { return std::string(s.model().eq().symbol); },
                               "the evolved field's symbol, e.g. 'omega' (a checkpoint's dataset omega_hat)")
        .def("__repr__", [](const o& s) { return flow_repr(s.model().params()); });
}

// A setting's keyword: the library's name of it.
std::string keyword_name(std::string_view field) { return std::string(field); }

// The keywords that act only with another setting: None, "not given" (flow_params::unused_setting).
using given_int = std::optional<long long>;
using given_real = std::optional<double>;

ns2d_params flow_params_from(const std::string& equation, long long n, double nu, double hyper_nu, given_int hyper_p,
                             double hypo_nu, given_int hypo_p, double drag, const std::string& forcing,
                             given_real forcing_k, given_real forcing_amplitude, given_real injection_rate,
                             given_int forcing_seed, long long threads, bool fftw_measure, bool full_transforms) {
    // Python ints are unbounded: a value beyond int is refused with the library's sentence for the field (the
    // CLI's), not wrapped or truncated
    auto whole = [&](const char* field, long long v) {
        try {
            return ns2d_params::whole(field, v);
        } catch (const std::invalid_argument& e) {
            throw std::invalid_argument(equation + ": " + e.what());
        }
    };
    if (forcing_seed && *forcing_seed < 0)  // (the CLI's sentence for --forcing-seed -1)
        throw std::invalid_argument("forcing_seed: must be a whole number >= 0, not '" +
                                    std::to_string(*forcing_seed) + "'");
    ns2d_params p;
    p.equation = equation;
    p.n = whole("n", n), p.nu = nu, p.hyper_nu = hyper_nu, p.drag = drag, p.hypo_nu = hypo_nu;
    if (hyper_p) p.hyper_p = whole("hyper_p", *hyper_p);
    if (hypo_p) p.hypo_p = whole("hypo_p", *hypo_p);
    p.forcing = ns2d_params::forcing_named(forcing, keyword_name);
    if (forcing_k) p.forcing_k = *forcing_k;
    if (forcing_amplitude) p.forcing_amplitude = *forcing_amplitude;
    if (injection_rate) p.injection_rate = *injection_rate;
    if (forcing_seed) p.forcing_seed = std::uint64_t(*forcing_seed);
    p.threads = whole("threads", threads), p.measure = fftw_measure;
    p.pruned_transforms = !full_transforms;  // (the CLI's --full-transforms)
    // a setting given that cannot change the run is refused, as the CLI refuses its option (the library's rule)
    const std::pair<const char*, bool> given[] = {{"forcing_k", bool(forcing_k)}, {"forcing_seed", bool(forcing_seed)},
                                                  {"forcing_amplitude", bool(forcing_amplitude)},
                                                  {"injection_rate", bool(injection_rate)},
                                                  {"hyper_p", bool(hyper_p)}, {"hypo_p", bool(hypo_p)}};
    for (const auto& [field, is_given] : given)
        if (is_given)
            if (const std::string why = p.unused_setting(field, keyword_name); !why.empty())
                throw std::invalid_argument(why);
    return p;
}

// The keywords every equation's constructor takes after its own.
#define ECI_FLOW_KEYWORDS                                                                                    \
    py::arg("n") = 256, py::arg("nu") = 0.0, py::arg("hyper_nu") = 0.0, py::arg("hyper_p") = py::none(),   \
        py::arg("hypo_nu") = 0.0, py::arg("hypo_p") = py::none(), py::arg("drag") = 0.0,                   \
        py::arg("forcing") = "none", py::arg("forcing_k") = py::none(),                                    \
        py::arg("forcing_amplitude") = py::none(), py::arg("injection_rate") = py::none(),                 \
        py::arg("forcing_seed") = py::none(), py::arg("threads") = 1, py::arg("fftw_measure") = false,     \
        py::arg("full_transforms") = false

// One C++ type per Python class (pybind11 registers a type once): equation I of spectral::equations() is bound as
// flow_object<I>, so that an equation added to the list is a Python class with no code here.
template <std::size_t I>
struct flow_object final : ns2d_object {
    using ns2d_object::ns2d_object;
};
constexpr std::size_t max_equations = 16;

// What every flow class's help says after its equation's summary.
constexpr const char* flow_help =
    " The state is FFTW's retained modes q_k: kmax + 1 columns (k_x = 0 .. kmax) of 2 kmax + 1 modes (k_y = 0 .. "
    "kmax, -kmax .. -1), kmax = (n - 1) // 3, stored by columns (by rows with full_transforms=True); the kx and "
    "ky properties give each mode's wavenumber. The keywords are `eci run "
    "NAME`'s options (--hyper-nu: hyper_nu); forcing settings and powers default to None, 'not given', and a "
    "setting that cannot change the run is refused as the CLI refuses it. See ";

template <std::size_t I>
void bind_equation(py::module_& m, py::list& classes) {
    const auto& all = spectral::equations();
    if (I >= all.size()) return;
    const spectral::equation& e = *all[I];
    using o = flow_object<I>;
    // (pybind11 keeps the class's name and help as the pointers it is given: strings that live as long as the module)
    static const std::string name(e.python_class), help = std::string(e.summary) + flow_help + std::string(e.docs) + ".";
    py::class_<o, model_base> c(m, name.c_str(), help.c_str());
    const std::string equation(e.name);
    const auto params = [equation](long long n, double nu, double hyper_nu, given_int hyper_p, double hypo_nu,
                                   given_int hypo_p, double drag, const std::string& forcing, given_real forcing_k,
                                   given_real forcing_amplitude, given_real injection_rate, given_int forcing_seed,
                                   long long threads, bool fftw_measure, bool full_transforms) {
        return flow_params_from(equation, n, nu, hyper_nu, hyper_p, hypo_nu, hypo_p, drag, forcing, forcing_k,
                                forcing_amplitude, injection_rate, forcing_seed, threads, fftw_measure, full_transforms);
    };
    if (e.dispersion) {  // an equation with waves takes beta and the deformation F first, as its CLI options come
        c.def(py::init([params](double beta, double deformation, long long n, double nu, double hyper_nu,
                                given_int hyper_p, double hypo_nu, given_int hypo_p, double drag,
                                const std::string& forcing, given_real forcing_k, given_real forcing_amplitude,
                                given_real injection_rate, given_int forcing_seed, long long threads, bool fftw_measure,
                                bool full_transforms) {
                  ns2d_params p = params(n, nu, hyper_nu, hyper_p, hypo_nu, hypo_p, drag, forcing, forcing_k,
                                         forcing_amplitude, injection_rate, forcing_seed, threads, fftw_measure,
                                         full_transforms);
                  p.beta = beta, p.deformation = deformation;
                  return std::make_unique<o>(p);
              }),
              py::arg("beta") = 0.0, py::arg("deformation") = 0.0, ECI_FLOW_KEYWORDS);
    } else {
        c.def(py::init([params](long long n, double nu, double hyper_nu, given_int hyper_p, double hypo_nu,
                                given_int hypo_p, double drag, const std::string& forcing, given_real forcing_k,
                                given_real forcing_amplitude, given_real injection_rate, given_int forcing_seed,
                                long long threads, bool fftw_measure, bool full_transforms) {
                  return std::make_unique<o>(params(n, nu, hyper_nu, hyper_p, hypo_nu, hypo_p, drag, forcing,
                                                    forcing_k, forcing_amplitude, injection_rate, forcing_seed,
                                                    threads, fftw_measure, full_transforms));
              }),
              ECI_FLOW_KEYWORDS);
    }
    add_flow_methods(c);
    // every constructor keyword of this equation is a read-only property (n above): the value the flow runs with
    for (const flow_keyword& k : flow_keywords())
        if (!k.waves || e.dispersion)
            c.def_property_readonly(k.name, [get = k.get](const o& s) { return get(s.model().params()); }, k.doc);
    classes.append(c);
}

// eci.load_checkpoint's part in C++: the checkpoint at `path` (eci run's or eci.solve's) as a model of its equation
// with its settings, plans (its FFTW wisdom) and generator, its state in the model's layout (checked against its
// checksum), and its header (the step, the run's settings and statistics). ValueError naming the problem.
py::tuple load_checkpoint(py::module_& module, const std::string& path) {
    ns2d_checkpoint ck;
    try {
        ck = eci::cli::read_checkpoint(path);
    } catch (const std::exception& e) {
        throw std::invalid_argument(std::string("cannot restart: ") + e.what());
    }
    const auto& all = spectral::equations();
    std::size_t index = all.size();
    for (std::size_t i = 0; i < all.size(); ++i)
        if (all[i]->name == ck.params.equation) index = i;
    if (index == all.size())
        throw std::invalid_argument("cannot restart: " + path + " is a checkpoint of " + ck.params.equation +
                                    ", an equation this eci does not have");
    const spectral::equation& e = *all[index];
    if (const std::uint64_t sum = eci::cli::state_checksum(ck.state.data(), ck.params.n, 0, ck.params.n / 2 + 1);
        ck.checksum && sum != *ck.checksum)
        throw std::invalid_argument("cannot restart: " + eci::cli::checksum_mismatch(path, std::string(e.name)));
    // the plans the run made (a checkpoint of FFTW_MEASURE plans repeats bit for bit only with them)
    if (!ck.params.wisdom.empty()) navier_stokes_2d::import_fftw_wisdom(ck.params.wisdom);
    const py::dict kwargs = constructor_keywords(ck.params);
    const std::vector<std::string> methods = eci::ns2d_methods();
    if (std::find(methods.begin(), methods.end(), ck.method) == methods.end())
        throw std::invalid_argument("cannot restart: " + path + ": method '" + ck.method + "' is not a method of " +
                                    std::string(e.name));
    py::object model;
    try {
        model = module.attr("_flow_models")[py::int_(index)](**kwargs);
    } catch (const py::error_already_set& err) {  // (settings the file holds that the model refuses)
        if (!err.matches(PyExc_ValueError)) throw;
        throw std::invalid_argument("cannot restart: " + path + ": " + py::str(err.value()).cast<std::string>());
    }
    auto& flow = dynamic_cast<ns2d_object&>(model.cast<model_base&>());
    state y;
    {
        const auto lock = flow.lock();
        flow.model().set_rng_state(ck.rng_state);
        y = flow.model().from_half_plane(ck.state);
    }
    ck.state = state();
    ck.params.wisdom.clear();
    return py::make_tuple(model, to_numpy(y), ck);
}

}  // namespace

void init_ns2d(py::module_& m) {
    if (spectral::equations().size() > max_equations)
        throw std::logic_error("python/src/models_ns2d.cpp binds at most " + std::to_string(max_equations) +
                               " spectral equations: raise max_equations");
    // every equation of spectral::equations(), in `eci list` order; eci._eci._flow_models holds the classes
    py::list classes;
    [&]<std::size_t... I>(std::index_sequence<I...>) { (bind_equation<I>(m, classes), ...); }(
        std::make_index_sequence<max_equations>{});
    m.attr("_flow_models") = py::tuple(classes);

    // A checkpoint's header (eci.Checkpoint's fields; the statistics a restart carries on)
    py::class_<ns2d_checkpoint>(m, "_CheckpointHeader")
        .def_readonly("method", &ns2d_checkpoint::method)
        .def_readonly("update", &ns2d_checkpoint::update)
        .def_readonly("dt", &ns2d_checkpoint::dt)
        .def_readonly("step", &ns2d_checkpoint::step)
        .def_readonly("total_steps", &ns2d_checkpoint::total_steps)
        .def_readonly("t_end", &ns2d_checkpoint::t_end)
        .def_readonly("rhs_evals", &ns2d_checkpoint::rhs_evals)
        .def_readonly("halvings", &ns2d_checkpoint::halvings)
        .def_readonly("rng_state", &ns2d_checkpoint::rng_state)
        .def_property_readonly("equation", [](const ns2d_checkpoint& c) { return c.params.equation; })
        .def_property_readonly("initial",
                               [](const ns2d_checkpoint& c) { return py::make_tuple(c.energy0, c.enstrophy0); })
        .def_property_readonly("max_drift", [](const ns2d_checkpoint& c) {
            return py::make_tuple(c.max_energy_drift, c.max_enstrophy_drift);
        })
        .def_property_readonly("max_budget_residual", [](const ns2d_checkpoint& c) {
            return py::make_tuple(c.max_energy_residual, c.max_enstrophy_residual);
        })
        .def_property_readonly("budget", [](const ns2d_checkpoint& c) {
            return py::make_tuple(c.budget.energy_injection, c.budget.energy_dissipation,
                                  c.budget.enstrophy_injection, c.budget.enstrophy_dissipation);
        });
    m.def("_load_checkpoint", [m](const std::string& path) mutable { return load_checkpoint(m, path); },
          py::arg("path"));
}

#undef ECI_FLOW_KEYWORDS

}  // namespace eci::python
