// Every way to keep invariants, head to head: eci's transformation method, relaxation RK (RRK, IDT,
// multiple relaxation), orthogonal projection and symplectic splittings, with RK4 as the baseline, on the field's
// test problems. Usage: eci_bench_compare_methods <quick: 0|1> <csv file> <markdown file>.
// The CSV holds a work-precision sweep (steps doubling); the markdown one table per problem at its default step,
// CPU time as a ratio to the transformation method measured in the same run, repetitions interleaved.
#include <time.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <limits>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include <boost/numeric/odeint/stepper/symplectic_rkn_sb3a_mclachlan.hpp>

#include <eci/eci.hpp>
#include <eci/models/list.hpp>
#include <eci/models/kepler_exact.hpp>
#include <eci/models/rigid_body_exact.hpp>
#include <eci/models/three_wave_exact.hpp>
#include <eci/steppers/projection.hpp>
#include <eci/steppers/relaxation_rk.hpp>
#include <eci/steppers/symplectic.hpp>

namespace {

using vec = std::vector<double>;

double cpu_seconds() {
    timespec ts{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

/// What one run of one method did.
struct outcome {
    bool ok = true;
    vec end;                      // the final state, in the problem's variables
    double lag = 0.0;             // RRK's true time minus t_end
    std::uint64_t rhs = 0, iterations = 0, rejected = 0;
    vec invariant_errors;          // each invariant's largest relative change, observed every step
    double invariant_error() const {
        double w = 0.0;
        for (double e : invariant_errors) w = std::max(w, e);
        return w;
    }
    void observe(const vec& errs) {
        invariant_errors.resize(errs.size(), 0.0);
        for (std::size_t k = 0; k < errs.size(); ++k) invariant_errors[k] = std::max(invariant_errors[k], errs[k]);
    }
};

/// One method on one problem: family (for the docs), name, and a run at n steps (observing the invariants or not).
struct method {
    std::string family, name;
    std::function<outcome(std::uint64_t n, bool observe)> run;
};

/// A problem: the invariants' relative error of a state (problem variables), the exact solution, the methods.
struct problem {
    std::string name, title;
    double t_end;
    std::uint64_t table_steps;
    std::vector<std::uint64_t> sweep;
    std::function<vec(double)> exact;
    std::vector<method> methods;
    std::string reference;  // the transformation method's name: CPU ratios are to it
    std::string invariant_names;
};

template <class S>
vec to_vec(const S& s) {
    return vec(s.begin(), s.end());
}

/// Run a stepper (a fresh copy of `proto`) n steps of t_end / n on `model` from x0. `to_problem` maps a state to
/// the problem's variables, `inv_error` gives the invariants' relative error of such a state.
template <class St, class Model, class ToProblem>
outcome run_stepper(const St& proto, const Model& model, typename Model::state_type x0, double t_end, std::uint64_t n,
                    bool observe, ToProblem to_problem, const std::function<vec(const vec&)>& inv_error) {
    St st = proto;
    outcome o;
    auto x = x0;
    const double dt = t_end / double(n);
    try {
        eci::run_stats rs;
        if (observe)
            rs = eci::integrate_n_steps(st, model, x, 0.0, dt, n, [&](const auto& s, double, std::uint64_t) {
                o.observe(inv_error(to_problem(s)));
            });
        else
            rs = eci::integrate_n_steps(st, model, x, 0.0, dt, n);
        o.rhs = rs.rhs_evals;
        o.iterations = rs.solver.iterations;
        o.rejected = rs.step_reductions;
    } catch (const eci::step_size_underflow&) {
        o.ok = false;
    }
    if constexpr (requires { st.time_lag(); }) o.lag = st.time_lag();
    o.end = to_problem(x);
    return o;
}

/// Each invariant's relative error, from a list of invariants (functions of the problem's state).
std::function<vec(const vec&)> relative_errors(std::vector<std::function<double(const vec&)>> invs, const vec& x0) {
    vec v0;
    double scale = 0.0;
    for (auto& I : invs) {
        v0.push_back(I(x0));
        scale = std::max(scale, std::abs(v0.back()));
    }
    return [invs, v0, scale](const vec& x) {
        vec errs(invs.size());
        for (std::size_t k = 0; k < invs.size(); ++k) {
            const double r = std::abs(invs[k](x) - v0[k]) / (v0[k] != 0.0 ? std::abs(v0[k]) : scale);
            errs[k] = std::isnan(r) ? std::numeric_limits<double>::infinity() : r;
        }
        return errs;
    };
}

template <class Model>
auto identity() {
    return [](const typename Model::state_type& s) { return to_vec(s); };
}

/// Methods every problem gets on its own model: the RK4 baseline, relaxation on the first invariant (RRK, IDT),
/// multiple relaxation and projection on `all` (when given).
template <class Model, class One, class All>
void add_relaxation_and_projection(problem& p, const Model& model, typename Model::state_type x0, One one, All all,
                                   bool multiple, const std::function<vec(const vec&)>& err) {
    using S = typename Model::state_type;
    const double T = p.t_end;
    auto id = identity<Model>();
    p.methods.push_back({"baseline", "rk4", [=](std::uint64_t n, bool o) {
                             return run_stepper(eci::rk4<S>{}, model, x0, T, n, o, id, err);
                         }});
    p.methods.push_back({"relaxation", "rrk-rk4", [=](std::uint64_t n, bool o) {
                             return run_stepper(eci::rrk4<S, One>(one), model, x0, T, n, o, id, err);
                         }});
    p.methods.push_back({"relaxation", "idt-rk4", [=](std::uint64_t n, bool o) {
                             return run_stepper(eci::idt_rk4<S, One>(one), model, x0, T, n, o, id, err);
                         }});
    if (multiple) {
        p.methods.push_back({"relaxation", "mrrk-rk4", [=](std::uint64_t n, bool o) -> outcome {
                                 if (all.count() == 2)
                                     return run_stepper(eci::mrrk4_2<S, All>(all), model, x0, T, n, o, id, err);
                                 return run_stepper(eci::mrrk4_3<S, All>(all), model, x0, T, n, o, id, err);
                             }});
    }
    p.methods.push_back({"projection", "projected-rk4", [=](std::uint64_t n, bool o) {
                             return run_stepper(eci::orthogonal_projection<eci::rk4<S>, S, All>(all), model, x0, T, n,
                                                o, id, err);
                         }});
}

/// The fifth-order group (Dormand-Prince 5(4) underneath every method): DP54 itself, relaxation on its weights
/// (one invariant), multiple relaxation along b and b - bhat (two), projection after it, and the transformation
/// method on the same tableau, `Conservative` (the registry's c-dp54 on the model, or on `polar` for Kepler e = 0.5).
template <class Model, class One, class All, class Conservative>
void add_dp54_group(problem& p, const Model& model, typename Model::state_type x0, One one, All all, bool multiple,
                    const std::function<vec(const vec&)>& err, const std::string& transformation,
                    Conservative conservative) {
    using S = typename Model::state_type;
    const double T = p.t_end;
    auto id = identity<Model>();
    p.methods.push_back({"baseline", "dp54", [=](std::uint64_t n, bool o) {
                             return run_stepper(eci::explicit_rk<eci::tableaus::dormand_prince_54, S>{}, model, x0, T,
                                                n, o, id, err);
                         }});
    p.methods.push_back({"relaxation", "rrk-dp54", [=](std::uint64_t n, bool o) {
                             return run_stepper(eci::rrk_dp54<S, One>(one), model, x0, T, n, o, id, err);
                         }});
    if (multiple)
        p.methods.push_back({"relaxation", "mrrk-dp54", [=](std::uint64_t n, bool o) {
                                 return run_stepper(eci::mrrk_dp54<S, All>(all), model, x0, T, n, o, id, err);
                             }});
    p.methods.push_back({"projection", "projected-dp54", [=](std::uint64_t n, bool o) {
                             using base = eci::explicit_rk<eci::tableaus::dormand_prince_54, S>;
                             return run_stepper(eci::orthogonal_projection<base, S, All>(all), model, x0, T, n, o, id,
                                                err);
                         }});
    p.methods.push_back({"transformation", transformation, conservative});
}

/// The transformation method on DP54 for `model` itself, as the registry builds c-dp54 on it.
template <class Model>
auto c_dp54_on(const Model& model, typename Model::state_type x0, double T, const std::function<vec(const vec&)>& err) {
    return [=](std::uint64_t n, bool o) {
        return run_stepper(eci::stepper_for<eci::method_entries::c_dp54, Model>{}, model, x0, T, n, o,
                           identity<Model>(), err);
    };
}

// ---- the problems ----

problem rigid_body_problem() {
    using S = eci::rigid_body::state_type;
    const eci::rigid_body model;
    const S x0 = eci::rigid_body::initial_state();
    problem p{"rigid_body", "Rigid body (Biswas & Ketcheson), t = 100", 100.0, 1000, {250, 500, 1000, 2000, 4000, 8000},
              [](double t) { return to_vec(eci::rigid_body_exact(t)); }, {}, "c-rk4", "G1 / G2"};
    const auto err = relative_errors({[model](const vec& u) { return model.g1({u[0], u[1], u[2]}); },
                                      [model](const vec& u) { return model.g2({u[0], u[1], u[2]}); }},
                                     to_vec(x0));
    const auto inv = eci::invariants_of(model);
    add_relaxation_and_projection(p, model, x0, eci::pick_invariants(inv, {0}), inv, true, err);
    p.methods.push_back({"transformation", "c-rk4", [=](std::uint64_t n, bool o) {
                             return run_stepper(eci::c_rk4<S>{}, model, x0, 100.0, n, o, identity<eci::rigid_body>(),
                                                err);
                         }});
    add_dp54_group(p, model, x0, eci::pick_invariants(inv, {0}), inv, true, err, "c-dp54",
                   c_dp54_on(model, x0, 100.0, err));
    return p;
}

problem three_wave_problem() {
    using S = eci::three_wave::state_type;
    const eci::three_wave model;
    const S x0{std::sqrt(1.5), 1.0, std::sqrt(1.5)};
    const eci::three_wave_exact exact(model, x0);
    problem p{"three_wave", "Three-wave (paper, Fig. 5 initial state), t = 20", 20.0, 400,
              {100, 200, 400, 800, 1600, 3200},
              [exact](double t) { return to_vec(exact(t)); }, {}, "c-rk4", "energy / enstrophy"};
    const auto err = relative_errors({[model](const vec& u) { return model.energy({u[0], u[1], u[2]}); },
                                      [model](const vec& u) { return model.enstrophy({u[0], u[1], u[2]}); }},
                                     to_vec(x0));
    const auto inv = eci::invariants_of(model);
    add_relaxation_and_projection(p, model, x0, eci::pick_invariants(inv, {0}), inv, true, err);
    p.methods.push_back({"transformation", "c-rk4", [=](std::uint64_t n, bool o) {
                             return run_stepper(eci::c_rk4<S>{}, model, x0, 20.0, n, o, identity<eci::three_wave>(),
                                                err);
                         }});
    add_dp54_group(p, model, x0, eci::pick_invariants(inv, {0}), inv, true, err, "c-dp54",
                   c_dp54_on(model, x0, 20.0, err));
    return p;
}

problem oscillator_problem() {
    using S = eci::nonlinear_oscillator::state_type;
    const eci::nonlinear_oscillator model;
    const S x0 = eci::nonlinear_oscillator::initial_state();
    problem p{"nonlinear_oscillator", "Nonlinear oscillator (Ketcheson's \"Ranocha problem\"), t = 10", 10.0, 100,
              {25, 50, 100, 200, 400, 800}, [x0](double t) { return to_vec(eci::nonlinear_oscillator::exact(x0, t)); },
              {}, "c-rk4", "|u|^2"};
    const auto err = relative_errors({[model](const vec& u) { return model.norm2({u[0], u[1]}); }}, to_vec(x0));
    const auto inv = eci::invariants_of(model);
    add_relaxation_and_projection(p, model, x0, inv, inv, false, err);
    // |u|^2 = u1^2 + u2^2 with u1 u1' + u2 u2' = 0: the form C-RK4 keeps (errata item 9), no transform needed.
    p.methods.push_back({"transformation", "c-rk4", [=](std::uint64_t n, bool o) {
                             return run_stepper(eci::c_rk4<S>{}, model, x0, 10.0, n, o,
                                                identity<eci::nonlinear_oscillator>(), err);
                         }});
    add_dp54_group(p, model, x0, inv, inv, false, err, "c-dp54", c_dp54_on(model, x0, 10.0, err));
    return p;
}

problem entropy_problem() {
    using S = eci::exponential_entropy::state_type;
    const eci::exponential_entropy model;
    const S x0 = eci::exponential_entropy::initial_state();
    problem p{"exponential_entropy", "Conserved exponential entropy (ARKODE), t = 5", 5.0, 100,
              {25, 50, 100, 200, 400, 800},
              [x0](double t) { return to_vec(eci::exponential_entropy::exact(x0, t)); }, {}, "transformed-rk4",
              "e^u + e^v"};
    const auto err = relative_errors({[model](const vec& u) { return model.entropy({u[0], u[1]}); }}, to_vec(x0));
    const auto inv = eci::invariants_of(model);
    add_relaxation_and_projection(p, model, x0, inv, inv, false, err);
    p.methods.push_back({"transformation", "transformed-rk4", [=](std::uint64_t n, bool o) {
                             return run_stepper(eci::transformed_rk4<eci::exponential_entropy::transform>(), model, x0,
                                                5.0, n, o, identity<eci::exponential_entropy>(), err);
                         }});
    add_dp54_group(p, model, x0, inv, inv, false, err, "transformed-dp54", c_dp54_on(model, x0, 5.0, err));
    return p;
}

problem lotka_volterra_problem() {
    using S = eci::lotka_volterra::state_type;
    const eci::lotka_volterra model;
    const S x0{1.0, 0.4};
    // No closed form: RK4 with 2^20 steps (truncation ~1e-17, below its round-off).
    S ref = x0;
    eci::rk4<S> r;
    eci::integrate_n_steps(r, model, ref, 0.0, 20.0 / 1048576.0, 1048576);
    problem p{"lotka_volterra", "Lotka-Volterra (paper, Fig. 7 setup), t = 20", 20.0, 400,
              {100, 200, 400, 800, 1600, 3200},
              [ref](double) { return to_vec(ref); }, {}, "transformed-rk4", "H"};
    const auto err = relative_errors({[model](const vec& u) { return model.hamiltonian({u[0], u[1]}); }}, to_vec(x0));
    const auto inv = eci::invariants_of(model);
    add_relaxation_and_projection(p, model, x0, inv, inv, false, err);
    p.methods.push_back({"transformation", "transformed-rk4", [=](std::uint64_t n, bool o) {
                             return run_stepper(eci::transformed_rk4<eci::lotka_volterra::transform>{},
                                                model, x0, 20.0, n, o, identity<eci::lotka_volterra>(), err);
                         }});
    add_dp54_group(p, model, x0, inv, inv, false, err, "transformed-dp54", c_dp54_on(model, x0, 20.0, err));
    return p;
}

problem kepler_paper_problem() {
    using S = eci::kepler::state_type;
    const eci::kepler model;
    const S x0{1.0, 0.0, 0.0};
    const eci::kepler_exact exact(model, x0);
    problem p{"kepler_paper", "Kepler, polar variables (paper, Figs. 8-9: e = 1/3), t = 10", 10.0, 200,
              {50, 100, 200, 400, 800, 1600}, [exact](double t) { return to_vec(exact(t)); }, {}, "transformed-rk4",
              "H / A_x / A_y"};
    const auto err = relative_errors({[model](const vec& u) { return model.hamiltonian({u[0], u[1], u[2]}); },
                                      [model](const vec& u) { return model.runge_lenz_x({u[0], u[1], u[2]}); },
                                      [model](const vec& u) { return model.runge_lenz_y({u[0], u[1], u[2]}); }},
                                     to_vec(x0));
    // H with A_y (A_x is dependent on H where A_y = 0, as at this initial state).
    const auto inv = eci::pick_invariants(eci::invariants_of(model), {0, 2});
    add_relaxation_and_projection(p, model, x0, eci::pick_invariants(eci::invariants_of(model), {0}), inv, true, err);
    p.methods.push_back({"transformation", "transformed-rk4", [=](std::uint64_t n, bool o) {
                             return run_stepper(eci::transformed_rk4<eci::kepler::transform>{},
                                                model, x0, 10.0, n, o, identity<eci::kepler>(), err);
                         }});
    add_dp54_group(p, model, x0, eci::pick_invariants(eci::invariants_of(model), {0}), inv, true, err,
                   "transformed-dp54", c_dp54_on(model, x0, 10.0, err));
    return p;
}

problem kepler_05_problem(bool quick) {
    using S = eci::kepler_cartesian::state_type;
    const eci::kepler_cartesian model;
    const S x0 = eci::kepler_cartesian::initial_state(0.5);
    const eci::kepler_cartesian_exact exact(x0);
    const double T = quick ? 20.0 * std::numbers::pi : 300.0 * std::numbers::pi;
    const std::uint64_t base = quick ? 800 : 12000;
    problem p{"kepler_05",
              std::string("Kepler e = 0.5, Cartesian (Ranocha & Ketcheson), t = ") + (quick ? "20 pi" : "300 pi"), T,
              2 * base, {base / 2, base, 2 * base, 4 * base, 8 * base},
              [exact](double t) { return to_vec(exact(t)); }, {},
              "transformed-rk4", "H / L / A_x / A_y"};
    const auto err =
        relative_errors({[model](const vec& u) { return model.hamiltonian({u[0], u[1], u[2], u[3]}); },
                         [model](const vec& u) { return model.angular_momentum({u[0], u[1], u[2], u[3]}); },
                         [model](const vec& u) { return model.runge_lenz_x({u[0], u[1], u[2], u[3]}); },
                         [model](const vec& u) { return model.runge_lenz_y({u[0], u[1], u[2], u[3]}); }},
                        to_vec(x0));
    const auto all = eci::invariants_of(model);
    add_relaxation_and_projection(p, model, x0, eci::pick_invariants(all, {0}), eci::pick_invariants(all, {0, 1, 3}),
                                  true, err);
    auto id = identity<eci::kepler_cartesian>();
    p.methods.push_back({"symplectic", "stormer-verlet", [=](std::uint64_t n, bool o) {
                             using verlet = eci::symplectic_splitting<eci::splittings::stormer_verlet, S,
                                                                      eci::drift_rule::momentum>;
                             return run_stepper(verlet{}, model, x0, T, n, o, id, err);
                         }});
    p.methods.push_back({"symplectic", "sb3a", [=](std::uint64_t n, bool o) {
                             using sb3a = eci::symplectic_splitting<eci::splittings::mclachlan_sb3a, S,
                                                                    eci::drift_rule::momentum>;
                             return run_stepper(sb3a{}, model, x0, T, n, o, id, err);
                         }});
    // Boost.Odeint's SB3A, given the force only (its Nystrom form): the same coefficients, odeint's engine.
    p.methods.push_back({"symplectic", "odeint-sb3a", [=](std::uint64_t n, bool o) {
                             using coor = std::array<double, 2>;
                             boost::numeric::odeint::symplectic_rkn_sb3a_mclachlan<coor> st;
                             std::uint64_t calls = 0;
                             auto force = [&](const coor& q, coor& dpdt) {
                                 ++calls;
                                 const double r2 = q[0] * q[0] + q[1] * q[1], r3 = r2 * std::sqrt(r2);
                                 dpdt = {-q[0] / r3, -q[1] / r3};
                             };
                             coor q{x0[0], x0[1]}, pm{x0[2], x0[3]};
                             outcome out;
                             const double dt = T / double(n);
                             for (std::uint64_t i = 0; i < n; ++i) {
                                 st.do_step(force, std::make_pair(std::ref(q), std::ref(pm)), double(i) * dt, dt);
                                 if (o) out.observe(err({q[0], q[1], pm[0], pm[1]}));
                             }
                             out.end = {q[0], q[1], pm[0], pm[1]};
                             out.rhs = calls;
                             return out;
                         }});
    // eci's transformation method runs the same orbit in polar variables (H and A linear in xi, eq. (50)).
    const auto [pmodel, p0] = eci::kepler_cartesian::to_polar(x0);
    const eci::kepler polar = pmodel;
    const eci::kepler::state_type polar0 = p0;
    p.methods.push_back({"transformation", "transformed-rk4", [=](std::uint64_t n, bool o) {
                             return run_stepper(eci::transformed_rk4<eci::kepler::transform>{},
                                                polar, polar0, T, n, o,
                                                [ell = polar.ell](const eci::kepler::state_type& s) {
                                                    return to_vec(eci::kepler_cartesian::from_polar(s, ell));
                                                },
                                                err);
                         }});
    // Fifth order: multiple relaxation keeps H and L (two directions, b and b - bhat).
    add_dp54_group(p, model, x0, eci::pick_invariants(all, {0}), eci::pick_invariants(all, {0, 1}), true, err,
                   "transformed-dp54", [=](std::uint64_t n, bool o) {
                       return run_stepper(eci::stepper_for<eci::method_entries::c_dp54, eci::kepler>{}, polar, polar0,
                                          T, n, o,
                                          [ell = polar.ell](const eci::kepler::state_type& s) {
                                              return to_vec(eci::kepler_cartesian::from_polar(s, ell));
                                          },
                                          err);
                   });
    return p;
}

double end_error(const problem& p, const outcome& o) {
    if (!o.ok) return std::numeric_limits<double>::infinity();
    const vec e = p.exact(p.t_end + o.lag);
    double d = 0.0, r = 0.0;
    for (std::size_t i = 0; i < e.size(); ++i) {
        d += (o.end[i] - e[i]) * (o.end[i] - e[i]);
        r += e[i] * e[i];
    }
    return std::sqrt(d / r);
}

// CPU seconds of one run without observation: the fastest of `reps` repetitions, methods interleaved.
std::vector<double> cpu_times(const problem& p, std::uint64_t n, int reps, double min_seconds) {
    std::vector<double> best(p.methods.size(), std::numeric_limits<double>::infinity());
    for (int r = 0; r < reps; ++r)
        for (std::size_t m = 0; m < p.methods.size(); ++m) {
            int runs = 0;
            const double start = cpu_seconds();
            double elapsed = 0.0;
            do {
                p.methods[m].run(n, false);
                ++runs;
                elapsed = cpu_seconds() - start;
            } while (elapsed < min_seconds);
            best[m] = std::min(best[m], elapsed / runs);
        }
    return best;
}

void emit(const problem& p, bool quick, std::FILE* csv, std::FILE* md) {
    const int reps = quick ? 3 : 7;
    const double min_seconds = quick ? 0.005 : 0.05;
    // The sweep: errors and counts (observed), CPU time (unobserved) at each n.
    for (std::uint64_t n : p.sweep) {
        const std::vector<double> cpu = cpu_times(p, n, quick ? 1 : 3, min_seconds / 5);
        for (std::size_t m = 0; m < p.methods.size(); ++m) {
            const outcome o = p.methods[m].run(n, true);
            std::fprintf(csv, "%s,%s,%s,%llu,%.6e,%llu,%llu,%llu,%.6e,%.6e,%.6e\n", p.name.c_str(),
                         p.methods[m].name.c_str(), p.methods[m].family.c_str(), static_cast<unsigned long long>(n),
                         p.t_end / double(n), static_cast<unsigned long long>(o.rhs),
                         static_cast<unsigned long long>(o.iterations), static_cast<unsigned long long>(o.rejected),
                         o.ok ? o.invariant_error() : std::numeric_limits<double>::infinity(), end_error(p, o), cpu[m]);
        }
    }
    // The table at the default step.
    const std::uint64_t n = p.table_steps;
    const std::vector<double> cpu = cpu_times(p, n, reps, min_seconds);
    std::size_t ref = 0;
    for (std::size_t m = 0; m < p.methods.size(); ++m)
        if (p.methods[m].name == p.reference) ref = m;
    std::fprintf(md, "\n### %s\n\n%llu steps of %.4g; invariants (relative change, largest over the run): %s.\n\n",
                 p.title.c_str(), static_cast<unsigned long long>(n), p.t_end / double(n), p.invariant_names.c_str());
    std::fprintf(md,
                 "| method | family | steps | RHS evaluations | solver iterations | rejected steps | invariant errors "
                 "| end-time error | CPU time / %s |\n|---|---|---|---|---|---|---|---|---|\n",
                 p.reference.c_str());
    for (std::size_t m = 0; m < p.methods.size(); ++m) {
        const outcome o = p.methods[m].run(n, true);
        std::string errs;
        for (double e : o.invariant_errors) {
            char buf[32];
            std::snprintf(buf, sizeof buf, "%s%.1e", errs.empty() ? "" : " / ", e);
            errs += buf;
        }
        std::fprintf(md, "| %s | %s | %llu | %llu | %llu | %llu | %s | %.1e | %.2f |\n", p.methods[m].name.c_str(),
                     p.methods[m].family.c_str(), static_cast<unsigned long long>(n),
                     static_cast<unsigned long long>(o.rhs), static_cast<unsigned long long>(o.iterations),
                     static_cast<unsigned long long>(o.rejected), errs.c_str(), end_error(p, o), cpu[m] / cpu[ref]);
        std::printf("compare problem=%s method=%s rhs=%llu iterations=%llu rejected=%llu invariant_error=%.2e "
                    "end_error=%.2e cpu_ratio=%.2f\n",
                    p.name.c_str(), p.methods[m].name.c_str(), static_cast<unsigned long long>(o.rhs),
                    static_cast<unsigned long long>(o.iterations), static_cast<unsigned long long>(o.rejected),
                    o.invariant_error(), end_error(p, o), cpu[m] / cpu[ref]);
    }
    std::fflush(md);
    std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
    if (argc != 4 || (std::string(argv[1]) != "0" && std::string(argv[1]) != "1")) {
        std::fprintf(stderr, "usage: eci_bench_compare_methods <quick: 0|1> <csv file> <markdown file>\n");
        return 2;
    }
    const bool quick = argv[1][0] == '1';
    std::FILE* csv = std::fopen(argv[2], "w");
    std::FILE* md = csv ? std::fopen(argv[3], "w") : nullptr;
    if (!csv || !md) {
        std::fprintf(stderr, "eci_bench_compare_methods: cannot write %s\n", csv ? argv[3] : argv[2]);
        return 2;
    }
    std::fprintf(csv, "problem,method,family,steps,dt,rhs_evals,solver_iterations,rejected_steps,invariant_error,"
                      "end_error,cpu_seconds\n");
    std::fprintf(md, "<!-- written by bench/compare_methods.cpp (%s run); do not edit -->\n", quick ? "quick" : "full");
    for (const problem& p : {rigid_body_problem(), kepler_05_problem(quick), oscillator_problem(), entropy_problem(),
                             three_wave_problem(), lotka_volterra_problem(), kepler_paper_problem()})
        emit(p, quick, csv, md);
    std::fclose(md);
    std::fclose(csv);
    return 0;
}
