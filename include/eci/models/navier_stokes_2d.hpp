// The 2-D incompressible vorticity equation on [0, 2pi)^2, pseudo-spectral with FFTW3 and dealiased by the 2/3
// rule, so every triad conserves E and Z exactly (§III's truncated Euler equations). Link eci::spectral.
#pragma once

#include <array>
#include <complex>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "../concepts.hpp"
#include "../integrate.hpp"
#include "../steppers/conservative_rk.hpp"
#include "../steppers/explicit_rk.hpp"
#include "invariant.hpp"

namespace eci {

/// Which forcing drives the flow.
enum class ns2d_forcing { none, deterministic, stochastic };

/// The parameters of navier_stokes_2d: grid, dissipation, forcing and the FFT setup.
struct ns2d_params {
    int n = 256;                       ///< grid points per side: even, at least 8
    double nu = 0.0;                   ///< viscosity: -nu |k|^2 omega
    double hyper_nu = 0.0;             ///< hyperviscosity: -hyper_nu |k|^(2p) omega
    int hyper_p = 2;                   ///< the hyperviscosity's power p, at least 1
    double drag = 0.0;                 ///< linear (Ekman) drag: -drag omega
    ns2d_forcing forcing = ns2d_forcing::none;
    double forcing_k = 4.0;            ///< centre k_f of the forced band k_f - 1/2 <= |k| < k_f + 1/2
    double forcing_amplitude = 1.0;    ///< deterministic forcing: rms of the forcing field (random fixed phases)
    double injection_rate = 1.0;       ///< stochastic forcing: mean energy injection rate epsilon
    std::uint64_t forcing_seed = 1;    ///< seed of the deterministic phases and of the stochastic generator
    int threads = 1;                   ///< FFTW and OpenMP threads
    bool measure = true;               ///< FFTW_MEASURE plans (FFTW_ESTIMATE when false)
    std::string wisdom_file;           ///< FFTW wisdom read before planning and written after; empty: none
    std::string wisdom;                ///< FFTW wisdom text imported before planning (a checkpoint's, so that a
                                       ///< restart plans the same transforms and continues bit for bit)

    /// Throws std::invalid_argument naming the first bad parameter.
    void validate() const;
};

/// What the linear terms and the forcing did to E and Z at one right-hand-side evaluation (rates, per unit time).
struct ns2d_rates {
    double energy_injection = 0.0;      ///< sum_k w_k Re(conj(omega_k) F_k) / |k|^2
    double energy_dissipation = 0.0;    ///< -sum_k w_k Re(conj(omega_k) L_k) / |k|^2
    double enstrophy_injection = 0.0;   ///< sum_k w_k Re(conj(omega_k) F_k)
    double enstrophy_dissipation = 0.0; ///< -sum_k w_k Re(conj(omega_k) L_k)
    double energy_transfer = 0.0;       ///< sum_k w_k Re(conj(omega_k) N_k) / |k|^2: zero up to round-off
    double enstrophy_transfer = 0.0;    ///< sum_k w_k Re(conj(omega_k) N_k): zero up to round-off
};

/// The budget of E and Z over steps: injection and dissipation integrated with the steps' own stages and weights.
struct ns2d_budget {
    double energy_injection = 0.0;       ///< dt sum_j b_j (energy_injection rate at stage j)
    double energy_dissipation = 0.0;     ///< dt sum_j b_j (energy_dissipation rate at stage j)
    double enstrophy_injection = 0.0;    ///< the same for Z
    double enstrophy_dissipation = 0.0;  ///< the same for Z
};

/// The 2-D vorticity equation d omega/dt = -u . grad omega - (nu |k|^2 + nu_h |k|^2p + drag) omega + F.
/// The state is FFTW's real-to-complex half plane of omega: n rows (k_y = 0, 1, ..., -1) of n/2 + 1 columns
/// (k_x = 0 ... n/2), normalised so that omega(x) = sum_k omega_k exp(i k.x). Modes outside the retained square
/// |k_x|, |k_y| <= kmax = (n - 1) / 3 and the mean k = 0 are zero and stay zero.
class navier_stokes_2d {
   public:
    using state_type = std::vector<std::complex<double>>;

    /// Plans the FFTs (once) and tabulates the wavenumbers. Throws std::invalid_argument for bad parameters.
    explicit navier_stokes_2d(const ns2d_params& p);
    ~navier_stokes_2d();
    navier_stokes_2d(navier_stokes_2d&&) noexcept;
    navier_stokes_2d& operator=(navier_stokes_2d&&) noexcept;
    navier_stokes_2d(const navier_stokes_2d&) = delete;
    navier_stokes_2d& operator=(const navier_stokes_2d&) = delete;

    /// FFTW's accumulated wisdom as text (holds this model's plans).
    static std::string fftw_wisdom();
    /// The parameters it was built with.
    const ns2d_params& params() const;
    /// Grid points per side.
    int n() const { return n_; }
    /// Stored columns, n/2 + 1.
    int columns() const { return n_ / 2 + 1; }
    /// Stored complex modes, n (n/2 + 1).
    std::size_t size() const { return std::size_t(n_) * std::size_t(columns()); }
    /// The largest retained |k_x| and |k_y|: the 2/3 rule, 3 kmax < n, so no product aliases onto a kept mode.
    int kmax() const { return (n_ - 1) / 3; }
    /// k_x of stored mode i.
    int kx(std::size_t i) const { return int(i % std::size_t(columns())); }
    /// k_y of stored mode i.
    int ky(std::size_t i) const {
        const int row = int(i / std::size_t(columns()));
        return row <= n_ / 2 ? row : row - n_;
    }
    /// Whether mode i is evolved (inside the 2/3 square and not k = 0).
    bool retained(std::size_t i) const { return weights_[i] != 0.0; }
    /// How often stored mode i appears in the full plane: 2 (itself and its conjugate -k, which is not stored),
    /// 1 on the k_x = 0 and Nyquist columns (where -k is stored too), 0 for a truncated mode or k = 0.
    const std::vector<double>& weights() const { return weights_; }
    /// E and Z as quadratic invariants sum_k q_k |omega_k|^2 over the stored modes, in the order of invariants():
    /// q = w_k / (2 |k|^2) and w_k / 2 (what the conservative steppers' remedy for negative radicands needs).
    std::vector<std::vector<double>> quadratic_invariant_weights() const;

    /// The right-hand side. Records the rates of the linear terms and forcing when recording is on.
    void operator()(const state_type& w, state_type& dwdt, double t);
    /// Executes the transforms of one right-hand-side evaluation (4 inverse, 1 forward) on the scratch arrays and
    /// nothing else: the FFT floor of a step, for benchmarks.
    void execute_transforms();
    /// The nonlinear term alone, -u . grad omega, dealiased (zero outside the retained modes).
    void nonlinear(const state_type& w, state_type& out);
    /// The rates of one state (with the current forcing).
    ns2d_rates rates(const state_type& w);

    /// E = 1/2 sum |omega_k|^2 / |k|^2 (full plane) = 1/2 <|u|^2>.
    double energy(const state_type& w) const;
    /// Z = 1/2 sum |omega_k|^2 = 1/2 <omega^2>.
    double enstrophy(const state_type& w) const;
    /// P = 1/2 sum |k|^2 |omega_k|^2 = 1/2 <|grad omega|^2>.
    double palinstrophy(const state_type& w) const;
    /// The invariants the conservative methods keep in the inviscid, unforced limit.
    static constexpr auto invariants() {
        return std::array<named_invariant<navier_stokes_2d>, 2>{
            {{"energy", &navier_stokes_2d::energy}, {"enstrophy", &navier_stokes_2d::enstrophy}}};
    }
    /// max over the grid of |u|.
    double max_velocity(const state_type& w);
    /// The CFL number max|u| dt / dx with dx = 2 pi / n.
    double cfl(const state_type& w, double dt);
    /// The shell-averaged energy spectrum: E(k) for k = 0, 1, ..., the sum over modes with round(|k|) = k.
    std::vector<double> energy_spectrum(const state_type& w) const;

    /// The state of a real field sampled on the n x n grid (row-major, y rows): transformed, truncated, mean removed.
    state_type from_physical(std::span<const double> field);
    /// The field on the grid (row-major, y rows).
    std::vector<double> to_physical(const state_type& w);
    /// A random field with energy spectrum E(k) ~ q^4 / (1 + q^2)^4, q = k / k_peak (peak at k_peak, tail k^-4),
    /// random phases, scaled to energy `energy`.
    state_type random_field(double k_peak, double energy, std::uint64_t seed);
    /// Two co-rotating Gaussian vortices of radius `radius`, peak vorticity `peak`, `separation` apart near the
    /// centre (the merger problem).
    state_type vortex_pair(double radius, double separation, double peak);
    /// The Taylor-Green vortex omega = 2 U sin x sin y, a steady Euler flow that viscosity damps as exp(-2 nu t).
    state_type taylor_green(double velocity);

    /// Draws the stochastic forcing for the next step of size dt (held constant over the step); a no-op otherwise.
    void draw_forcing(double dt);
    /// The stochastic generator's state (part of a checkpoint).
    std::uint64_t rng_state() const { return rng_; }
    /// Restores it.
    void set_rng_state(std::uint64_t s) { rng_ = s; }
    /// The forcing F_k held now.
    const state_type& forcing() const;

    /// Starts recording the rates of each right-hand-side evaluation (cleared on each call).
    void start_recording();
    /// Stops recording.
    void stop_recording() { recording_ = false; }
    /// The rates recorded since start_recording, one per evaluation.
    std::span<const ns2d_rates> recorded() const { return {recorded_.data(), recorded_count_}; }

   private:
    struct impl;
    int n_;
    std::vector<double> weights_;
    std::unique_ptr<impl> d_;
    std::uint64_t rng_ = 0;
    bool recording_ = false;
    std::array<ns2d_rates, 8> recorded_{};
    std::size_t recorded_count_ = 0;
};

/// A step abandoned between attempts because `stop()` said so; the state may be part-way through the step.
class step_interrupted : public std::runtime_error {
   public:
    using std::runtime_error::runtime_error;
};

namespace detail {

/// The Butcher tableau of a Runge-Kutta stepper (conventional or conservative): its weights weigh the budget.
template <class St> struct tableau_of;
template <const auto& T, state S> struct tableau_of<explicit_rk<T, S>> {
    static constexpr const auto& value = T;
};
template <const auto& T, state S, sign_rule R> struct tableau_of<conservative_rk<T, S, R>> {
    static constexpr const auto& value = T;
};

template <class St>
void ns2d_attempt(St& stepper, navier_stokes_2d& m, navier_stokes_2d::state_type& x, double t, double dt,
                  int halvings_left, ns2d_budget& b, run_stats& stats, bool (*stop)()) {
    constexpr const auto& T = tableau_of<St>::value;
    m.start_recording();
    const step_result r = stepper.step(m, x, t, dt);
    stats.rhs_evals += T.stages;
    if (r) {
        // Sum w xi changes by exactly dt sum_j b_j sum_k w_k 2 psi_k^(j) S_k^(j) (errata item 9): split S into
        // nonlinear (zero), linear and forcing parts, these are the discrete dissipation and injection.
        const auto rec = m.recorded();
        for (std::size_t j = 0; j < T.stages; ++j) {
            const double w = dt * T.b[j];
            b.energy_injection += w * rec[j].energy_injection;
            b.energy_dissipation += w * rec[j].energy_dissipation;
            b.enstrophy_injection += w * rec[j].enstrophy_injection;
            b.enstrophy_dissipation += w * rec[j].enstrophy_dissipation;
        }
        m.stop_recording();
        return;
    }
    m.stop_recording();
    if (halvings_left == 0) throw step_size_underflow(t, r.component, dt);
    // a cascade of halvings can take long: let the caller stop it (Ctrl-C)
    if (stop && stop()) throw step_interrupted("step interrupted while halving");
    ++stats.step_reductions;
    ns2d_attempt(stepper, m, x, t, 0.5 * dt, halvings_left - 1, b, stats, stop);
    ns2d_attempt(stepper, m, x, t + 0.5 * dt, 0.5 * dt, halvings_left - 1, b, stats, stop);
}

}  // namespace detail

/// One step of a Runge-Kutta stepper (conventional or conservative) on the vorticity equation: draws the step's
/// stochastic forcing, steps (halving on a failed step, the forcing held), and adds the step's injection and
/// dissipation, integrated with the stepper's own stage values and weights, to `budget`. Between halvings it
/// throws step_interrupted if `stop` (optional) returns true.
template <class St>
void ns2d_step(St& stepper, navier_stokes_2d& m, navier_stokes_2d::state_type& x, double t, double dt,
               ns2d_budget& budget, run_stats& stats, int max_halvings = 40, bool (*stop)() = nullptr) {
    // A conservative stepper remedies isolated negative radicands exactly when it knows the invariants' weights
    // (issue 9); hand it E's and Z's once.
    if constexpr (requires { stepper.set_quadratic_invariants(m.quadratic_invariant_weights()); }) {
        if (stepper.quadratic_invariants().empty() || stepper.quadratic_invariants().front().size() != m.size())
            stepper.set_quadratic_invariants(m.quadratic_invariant_weights());
    }
    m.draw_forcing(dt);
    detail::ns2d_attempt(stepper, m, x, t, dt, max_halvings, budget, stats, stop);
    ++stats.steps;
}

/// The methods ns2d_step can step the vorticity equation with (Runge-Kutta steppers, whose stages and weights the
/// budget is integrated with), default first: the CLI's and the Python module's one list.
inline const std::vector<std::string>& ns2d_methods() {
    static const std::vector<std::string> names{"c-rk4", "c-pc", "c-rk2", "rk4", "pc", "rk2", "euler"};
    return names;
}

/// Calls fn(stepper) with a default-constructed stepper of the method `name` (one of ns2d_methods()); false if it
/// is not one of them.
template <class Fn>
bool with_ns2d_method(const std::string& name, Fn&& fn) {
    using S = navier_stokes_2d::state_type;
    if (name == "c-pc") return fn(c_pc<S>{}), true;
    if (name == "c-rk2") return fn(c_rk2<S>{}), true;
    if (name == "c-rk4") return fn(c_rk4<S>{}), true;
    if (name == "pc") return fn(pc<S>{}), true;
    if (name == "rk2") return fn(rk2<S>{}), true;
    if (name == "rk4") return fn(rk4<S>{}), true;
    if (name == "euler") return fn(euler<S>{}), true;
    return false;
}

}  // namespace eci
