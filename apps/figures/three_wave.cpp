// Figures 1-6 of the paper: the three-wave model, eq. (1), integrated by Euler, C-Euler, PC and C-PC and
// compared with the exact solution. Only runs the library's steppers and writes what they produce.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include <eci/eci.hpp>
#include <eci/models/three_wave.hpp>
#include <eci/models/three_wave_exact.hpp>

#include "common.hpp"

namespace eci::figures {
namespace {

using state = three_wave::state_type;

// The paper's set-ups, from the model's presets: t in [0, 10] (the paper does not state the span of Figs. 1-4
// and 6; it shows about three periods), dt 0.02 for Fig. 1 and 0.2 for Figs. 2-4 and 6, and Fig. 5's psi(0).
const preset<three_wave> fig1 = find_preset<three_wave>("fig1");
const preset<three_wave> fig2 = find_preset<three_wave>("fig2");  // Figs. 2-4, 6
const preset<three_wave> fig5 = find_preset<three_wave>("fig5");
const double t_end = fig2.t_end;
const double dt_pc = fig2.dt;

const std::vector<std::string> mode_suffix{"K", "P", "Q"};

/// Every step of a fixed-step run, its statistics and its invariants' record (energy, enstrophy).
struct trajectory {
    std::vector<double> t;
    std::vector<state> x;
    std::vector<std::uint64_t> halvings_so_far;  ///< the run's step halvings up to x[i] (0 at x[0])
    run_stats stats;
    std::vector<invariant_record> invariants;

    /// Steps of the grid that needed at least one halving (a negative radicand somewhere in them): how often the
    /// step has to be reduced, which is what Sec. III.D's "approximately 10% of the time" counts. A step of the
    /// grid may need several halvings (its half steps can fail again), so stats.step_reductions counts more.
    std::uint64_t reduced_steps() const {
        std::uint64_t n = 0;
        for (std::size_t i = 1; i < halvings_so_far.size(); ++i) n += halvings_so_far[i] > halvings_so_far[i - 1];
        return n;
    }
};

constexpr std::size_t energy = 0, enstrophy = 1;  // in three_wave::invariants()

/// The paper's procedure for a negative radicand: halve the step (C-PC; C-Euler takes its implicit step), never
/// the remedy of radicand_remedy.hpp (which on three modes would not apply anyway: one mode is not isolated).
template <class Stepper>
void use_papers_procedure(Stepper& stepper) {
    if constexpr (requires { stepper.remedy.policy; }) stepper.remedy.policy = radicand_policy::halve;
}

template <class Stepper>
trajectory run(const preset<three_wave>& p) {
    Stepper stepper;
    use_papers_procedure(stepper);
    trajectory out;
    state x = p.x0;
    // eci::run's run (every step an output, an overflowing invariant recorded, not stopping it), through a sink
    // that also keeps the run's statistics at every step of the grid.
    struct keep_every_step {
        trajectory& out;
        void output(const state& s, const output_point& point) {
            out.t.push_back(point.t);
            out.x.push_back(s);
            out.halvings_so_far.push_back(point.stats ? point.stats->step_reductions : 0);
        }
    };
    run_config cfg;
    cfg.dt = p.dt;
    cfg.steps = p.steps();
    cfg.stop_on_invariant_overflow = false;
    const solve_report r = solve_with(stepper, p.model, x, cfg, keep_every_step{out});
    if (r.failure) throw std::runtime_error(r.failure->message);
    out.stats = r.stats;
    out.invariants = r.invariants;
    return out;
}

std::vector<std::string> mode_columns(const std::string& method) {
    std::vector<std::string> c;
    for (const auto& m : mode_suffix) c.push_back(method + "_" + m);
    return c;
}

void append(std::vector<std::string>& a, const std::vector<std::string>& b) { a.insert(a.end(), b.begin(), b.end()); }

/// (I(end) - I(0)) / I(0) for an invariant I.
double relative_change_at_end(const invariant_record& r) { return (r.final - r.initial) / r.initial; }

/// The two methods of a comparison figure, run on one preset, and the exact solution on their grid.
struct comparison {
    three_wave model;
    state psi0;
    trajectory conventional, conservative;
    std::vector<state> exact;  // at the conventional run's times (both runs share the grid)
};

template <class Conventional, class Conservative>
comparison compare(const preset<three_wave>& p) {
    comparison c;
    c.model = p.model;
    c.psi0 = p.x0;
    c.conventional = run<Conventional>(p);
    c.conservative = run<Conservative>(p);
    const three_wave_exact exact(c.model, c.psi0);
    for (double t : c.conventional.t) c.exact.push_back(exact(t));
    return c;
}

/// Columns t, <a>_K.., <b>_K.., exact_K.., <a>_E, <a>_Z, <b>_E, <b>_Z.
csv_table solution_table(const comparison& c, const std::string& a, const std::string& b) {
    csv_table table;
    table.columns = {"t"};
    append(table.columns, mode_columns(a));
    append(table.columns, mode_columns(b));
    append(table.columns, mode_columns("exact"));
    append(table.columns, {a + "_E", a + "_Z", b + "_E", b + "_Z"});
    for (std::size_t i = 0; i < c.conventional.t.size(); ++i) {
        const state& u = c.conventional.x[i];
        const state& v = c.conservative.x[i];
        const state& e = c.exact[i];
        table.add({c.conventional.t[i], u[0], u[1], u[2], v[0], v[1], v[2], e[0], e[1], e[2], c.model.energy(u),
                   c.model.enstrophy(u), c.model.energy(v), c.model.enstrophy(v)});
    }
    return table;
}

/// The exact solution sampled finely, for smooth reference curves.
csv_table exact_table(const three_wave& model, const state& psi0, double t_final, double dt) {
    const three_wave_exact exact(model, psi0);
    csv_table table;
    table.columns = {"t", "exact_K", "exact_P", "exact_Q"};
    const auto n = static_cast<int>(std::llround(t_final / dt));
    for (int i = 0; i <= n; ++i) {
        const double t = dt * i;
        const state e = exact(t);
        table.add({t, e[0], e[1], e[2]});
    }
    return table;
}

double max_abs_error(const trajectory& tr, const std::vector<state>& exact) {
    double worst = 0.0;
    for (std::size_t i = 0; i < tr.x.size(); ++i)
        for (int k = 0; k < 3; ++k) worst = std::max(worst, std::abs(tr.x[i][k] - exact[i][k]));
    return worst;
}

// Three stacked panels psi_K, psi_P, psi_Q: exact (thick grey), conventional (red dashed), conservative (blue).
const char* const modes_body = R"gp(
set datafile separator comma
set key outside right top vertical box opaque
set grid lc rgb "#dddddd"
set xrange [0:@TEND@]
set multiplot layout 3,1 title "@TITLE@" font ",14"
set lmargin 12
set rmargin 18
do for [k = 1:3] {
  mode = word("K P Q", k)
  set ylabel sprintf("{/Symbol y}_%s", mode)
  if (k == 3) { set xlabel "t" } else { unset xlabel }
  if (k > 1) { unset key }
  plot "@EXACT@" using "t":(column("exact_".mode)) with lines lw 5 lc rgb "#b0b0b0" title "Exact", \
       "@CSV@" using "t":(column("@A@_".mode)) with @ASTYLE@ lw 2 dt 2 lc rgb "#d62728" title "@ANAME@", \
       "@CSV@" using "t":(column("@B@_".mode)) with @BSTYLE@ lw 2 dt 1 lc rgb "#1f5fbf" title "@BNAME@"
}
unset multiplot
)gp";

/// One method's curves in modes_body: its CSV column prefix, its name in the key, its gnuplot style.
struct curve {
    std::string column, name, style;
};

/// modes_body filled in: the exact solution from `exact_csv`, methods a (dashed) and b from `csv`.
std::string mode_panels(const std::string& title, const std::string& exact_csv, const std::string& csv,
                        const curve& a, const curve& b) {
    return fill(modes_body, {{"TEND", format_number(t_end)},
                             {"TITLE", title},
                             {"EXACT", exact_csv},
                             {"CSV", csv},
                             {"A", a.column},
                             {"ANAME", a.name},
                             {"ASTYLE", a.style},
                             {"B", b.column},
                             {"BNAME", b.name},
                             {"BSTYLE", b.style}});
}

}  // namespace

figure_result make_figure_1() {
    const auto c = compare<euler<state>, c_euler<state>>(fig1);
    figure_result r;
    r.number = 1;
    r.csvs.emplace_back("fig1.csv", solution_table(c, "euler", "c_euler"));
    const double gain = relative_change_at_end(c.conventional.invariants[energy]);
    r.script = gnuplot_script(
        1, "three-wave psi_k(t): Euler, C-Euler and exact, dt = 0.02",
        mode_panels("Fig. 1: three-wave model, {/Symbol t} = 0.02, Euler gains " + format_number(100.0 * gain) +
                        "% energy by t = " + format_number(t_end),
                    "fig1.csv", "fig1.csv", {"euler", "Euler", "lines"}, {"c_euler", "C-Euler", "lines"}));
    r.numbers = {
        {"euler_energy_gain_rel", "Euler: E(t_end)/E(0) - 1 (dt 0.02, t_end 10)", gain, "growth shown, no number"},
        {"c_euler_max_drift_E_rel", "C-Euler: max |E(t)-E(0)|/E(0)",
         c.conservative.invariants[energy].max_rel_drift(), "0 (exact)"},
        {"c_euler_max_drift_Z_rel", "C-Euler: max |Z(t)-Z(0)|/Z(0)",
         c.conservative.invariants[enstrophy].max_rel_drift(), "0 (exact)"},
        {"c_euler_implicit_steps", "C-Euler: implicit midpoint steps near psi_k = 0",
         double(c.conservative.stats.solver.solves), "-"},
        {"euler_max_abs_error", "Euler: max |psi_k - exact|", max_abs_error(c.conventional, c.exact), "-"},
        {"c_euler_max_abs_error", "C-Euler: max |psi_k - exact|", max_abs_error(c.conservative, c.exact), "-"},
    };
    return r;
}

figure_result make_figure_2() {
    const auto c = compare<pc<state>, c_pc<state>>(fig2);
    figure_result r;
    r.number = 2;
    r.csvs.emplace_back("fig2.csv", solution_table(c, "pc", "c_pc"));
    r.csvs.emplace_back("fig2_exact.csv", exact_table(c.model, c.psi0, t_end, 0.01));
    r.script = gnuplot_script(
        2, "three-wave psi_k(t): PC, C-PC and exact, dt = 0.2",
        mode_panels("Fig. 2: three-wave model, predictor-corrector, {/Symbol t} = 0.2", "fig2_exact.csv", "fig2.csv",
                    {"pc", "PC", "linespoints pt 8 ps 0.9"}, {"c_pc", "C-PC", "linespoints pt 7 ps 0.6"}));
    const double steps = double(c.conservative.stats.steps);
    if (c.conservative.halvings_so_far.back() != c.conservative.stats.step_reductions)
        throw std::logic_error("figure 2: the per-step record of halvings disagrees with the run's statistics");
    const double reduced = double(c.conservative.reduced_steps());
    r.numbers = {
        {"c_pc_steps", "C-PC: steps of 0.2 to t = 10", steps, "-"},
        {"c_pc_step_reductions", "C-PC: step halvings (negative radicand) at dt 0.2",
         double(c.conservative.stats.step_reductions), "-"},
        {"c_pc_reduced_steps", "C-PC: steps of 0.2 that needed a halving", reduced, "-"},
        {"c_pc_reduced_steps_fraction", "C-PC: fraction of the steps that needed a halving", reduced / steps,
         "~0.1 (\"approximately 10% of the time\")"},
    };
    return r;
}

// Figure 3's plot commands.
const char* const fig3_body = R"gp(
set datafile separator comma
set key outside right top vertical box opaque
set grid lc rgb "#dddddd"
set xrange [0:@TEND@]
set multiplot layout 3,1 title "Fig. 3: error {/Symbol y}_k - {/Symbol y}_k^{exact} of Fig. 2 ({/Symbol t} = 0.2); max |error|: PC @PCERR@, C-PC @CPCERR@" font ",14"
set lmargin 12
set rmargin 18
do for [k = 1:3] {
  mode = word("K P Q", k)
  set ylabel sprintf("error in {/Symbol y}_%s", mode)
  if (k == 3) { set xlabel "t" } else { unset xlabel }
  if (k > 1) { unset key }
  plot 0 with lines lc rgb "#b0b0b0" lw 1 notitle, \
       "fig3.csv" using "t":(column("pc_err_".mode)) with linespoints lw 2 dt 2 lc rgb "#d62728" pt 8 ps 0.9 title "PC", \
       "fig3.csv" using "t":(column("c_pc_err_".mode)) with linespoints lw 2 dt 1 lc rgb "#1f5fbf" pt 7 ps 0.6 title "C-PC"
}
unset multiplot
)gp";

figure_result make_figure_3() {
    const auto c = compare<pc<state>, c_pc<state>>(fig2);
    figure_result r;
    r.number = 3;
    csv_table table;
    table.columns = {"t"};
    append(table.columns, mode_columns("pc_err"));
    append(table.columns, mode_columns("c_pc_err"));
    for (std::size_t i = 0; i < c.exact.size(); ++i) {
        const state &u = c.conventional.x[i], &v = c.conservative.x[i], &e = c.exact[i];
        table.add({c.conventional.t[i], u[0] - e[0], u[1] - e[1], u[2] - e[2], v[0] - e[0], v[1] - e[1],
                   v[2] - e[2]});
    }
    r.csvs.emplace_back("fig3.csv", std::move(table));
    const double pc_err = max_abs_error(c.conventional, c.exact), c_pc_err = max_abs_error(c.conservative, c.exact);
    const std::vector<std::pair<std::string, std::string>> values{
        {"TEND", format_number(t_end)},
        {"PCERR", format_number(pc_err)},
        {"CPCERR", format_number(c_pc_err)},
    };
    r.script = gnuplot_script(3, "errors of Fig. 2's PC and C-PC solutions against the exact one",
                              fill(fig3_body, values));
    r.numbers = {
        {"pc_max_abs_error", "PC: max |psi_k - exact| for t <= 10 (dt 0.2)", pc_err, "C-PC more accurate"},
        {"c_pc_max_abs_error", "C-PC: max |psi_k - exact| for t <= 10 (dt 0.2)", c_pc_err, "C-PC more accurate"},
    };
    return r;
}

// Figure 4's plot commands.
const char* const fig4_body = R"gp(
set datafile separator comma
set key top left box opaque
set grid lc rgb "#dddddd"
set xrange [0:@TEND@]
set xlabel "t"
set multiplot layout 2,1 title "Fig. 4: change of the invariants, {/Symbol t} = 0.2 (E(0) = @E0@, Z(0) = @Z0@)" font ",14"
set ylabel "{/Symbol D}E = E(t) - E(0)"
plot "fig4.csv" using "t":"pc_dE" with linespoints lw 2 dt 2 lc rgb "#d62728" pt 8 ps 0.9 title "PC (gains @GAINE@% by t = @TEND@)", \
     "fig4.csv" using "t":"c_pc_dE" with linespoints lw 2 dt 1 lc rgb "#1f5fbf" pt 7 ps 0.6 title "C-PC (max |{/Symbol D}E|/E(0) = @DRIFTE@)"
set ylabel "{/Symbol D}Z = Z(t) - Z(0)"
plot "fig4.csv" using "t":"pc_dZ" with linespoints lw 2 dt 2 lc rgb "#d62728" pt 8 ps 0.9 title "PC (gains @GAINZ@% by t = @TEND@)", \
     "fig4.csv" using "t":"c_pc_dZ" with linespoints lw 2 dt 1 lc rgb "#1f5fbf" pt 7 ps 0.6 title "C-PC (max |{/Symbol D}Z|/Z(0) = @DRIFTZ@)"
unset multiplot
)gp";

figure_result make_figure_4() {
    const auto c = compare<pc<state>, c_pc<state>>(fig2);
    figure_result r;
    r.number = 4;
    csv_table table;
    table.columns = {"t", "pc_dE", "pc_dZ", "c_pc_dE", "c_pc_dZ"};
    const double e0 = c.model.energy(c.psi0), z0 = c.model.enstrophy(c.psi0);
    for (std::size_t i = 0; i < c.exact.size(); ++i) {
        const state &u = c.conventional.x[i], &v = c.conservative.x[i];
        table.add({c.conventional.t[i], c.model.energy(u) - e0, c.model.enstrophy(u) - z0, c.model.energy(v) - e0,
                   c.model.enstrophy(v) - z0});
    }
    r.csvs.emplace_back("fig4.csv", std::move(table));
    const double gain_e = relative_change_at_end(c.conventional.invariants[energy]);
    const double gain_z = relative_change_at_end(c.conventional.invariants[enstrophy]);
    const double drift_e = c.conservative.invariants[energy].max_rel_drift();
    const double drift_z = c.conservative.invariants[enstrophy].max_rel_drift();
    const std::vector<std::pair<std::string, std::string>> values{
        {"TEND", format_number(t_end)},
        {"E0", format_number(e0)},
        {"Z0", format_number(z0)},
        {"GAINE", format_number(100 * gain_e)},
        {"GAINZ", format_number(100 * gain_z)},
        {"DRIFTE", format_number(drift_e, 2)},
        {"DRIFTZ", format_number(drift_z, 2)},
    };
    r.script = gnuplot_script(4, "energy and enstrophy change of PC and C-PC, dt = 0.2",
                              fill(fig4_body, values), 1000, 700);
    r.numbers = {
        {"pc_energy_gain_rel", "PC: E(10)/E(0) - 1 (dt 0.2)", gain_e, "always increasing"},
        {"pc_enstrophy_gain_rel", "PC: Z(10)/Z(0) - 1 (dt 0.2)", gain_z, "always increasing"},
        {"c_pc_max_drift_E_rel", "C-PC: max |E(t)-E(0)|/E(0)", drift_e, "0 (exact)"},
        {"c_pc_max_drift_Z_rel", "C-PC: max |Z(t)-Z(0)|/Z(0)", drift_z, "0 (exact)"},
    };
    return r;
}

namespace {

/// Least-squares line through (log tau, log err): err = A tau^n. Returns {A, n}.
std::pair<double, double> fit_power_law(const std::vector<double>& tau, const std::vector<double>& err) {
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    const double m = double(tau.size());
    for (std::size_t i = 0; i < tau.size(); ++i) {
        const double x = std::log(tau[i]), y = std::log(err[i]);
        sx += x;
        sy += y;
        sxx += x * x;
        sxy += x * y;
    }
    const double n = (m * sxy - sx * sy) / (m * sxx - sx * sx);
    return {std::exp((sy - n * sx) / m), n};
}

/// |psi_K after one step of tau - exact psi_K(tau)|, or NaN if the step fails (C-PC, negative radicand).
template <class Stepper>
double single_step_error(const three_wave& model, const three_wave_exact& exact, double tau) {
    Stepper stepper;
    use_papers_procedure(stepper);
    state x = fig5.x0;
    three_wave f = model;
    if (!stepper.step(f, x, 0.0, tau)) return std::numeric_limits<double>::quiet_NaN();
    return std::abs(x[0] - exact(tau)[0]);
}

}  // namespace

// Figure 5's plot commands.
const char* const fig5_body = R"gp(
set datafile separator comma
set logscale xy
set xrange [7e-4:0.15]
set format x "10^{%T}"
set format y "10^{%T}"
set grid lc rgb "#dddddd"
set key top left box opaque
set xlabel "time step {/Symbol t}"
set ylabel "single-step error |{/Symbol y}_K({/Symbol t}) - {/Symbol y}_K^{exact}({/Symbol t})|"
set title "Fig. 5: single-step error of mode K, {/Symbol y}(0) = (1.5^{1/2}, 1, 1.5^{1/2}), least-squares fit A{/Symbol t}^n" font ",14"
pc_A = @PCA@; pc_n = @PCN@; c_pc_A = @CPCA@; c_pc_n = @CPCN@
# The two fits nearly coincide: C-PC's is drawn wide and pale underneath, PC's dashed on top.
plot c_pc_A * x**c_pc_n with lines lw 6 dt 1 lc rgb "#8fb3e8" title sprintf("C-PC fit: A = %.3g, n = %.3f", c_pc_A, c_pc_n), \
     pc_A * x**pc_n with lines lw 2 dt 2 lc rgb "#d62728" title sprintf("PC fit: A = %.3g, n = %.3f", pc_A, pc_n), \
     "fig5.csv" using "tau":"c_pc_error_K" with points pt 7 ps 1.2 lc rgb "#1f5fbf" title "C-PC", \
     "fig5.csv" using "tau":"pc_error_K" with points pt 8 ps 1.8 lw 2 lc rgb "#d62728" title "PC"
)gp";

figure_result make_figure_5() {
    const three_wave model = fig5.model;
    const three_wave_exact exact(model, fig5.x0);
    // tau from 1e-3 to 1e-1, 5 points per decade: small enough to be in the asymptotic range, large enough that
    // the single-step error (~tau^3) stays far above round-off.
    constexpr int points = 11;
    std::vector<double> taus, pc_err, c_pc_err;
    csv_table table;
    table.columns = {"tau", "pc_error_K", "c_pc_error_K"};
    int failures = 0;
    for (int i = 0; i < points; ++i) {
        const double tau = std::pow(10.0, -3.0 + 2.0 * i / (points - 1));
        const double a = single_step_error<pc<state>>(model, exact, tau);
        const double b = single_step_error<c_pc<state>>(model, exact, tau);
        if (!(a > 0.0) || !(b > 0.0)) {  // a failed C-PC step (NaN) or an exact zero cannot enter a log-log fit
            ++failures;
            continue;
        }
        taus.push_back(tau);
        pc_err.push_back(a);
        c_pc_err.push_back(b);
        table.add({tau, a, b});
    }
    const auto [pc_a, pc_n] = fit_power_law(taus, pc_err);
    const auto [c_pc_a, c_pc_n] = fit_power_law(taus, c_pc_err);
    figure_result r;
    r.number = 5;
    r.csvs.emplace_back("fig5.csv", std::move(table));
    const std::vector<std::pair<std::string, std::string>> values{
        {"PCA", format_number(pc_a, 17)},
        {"PCN", format_number(pc_n, 17)},
        {"CPCA", format_number(c_pc_a, 17)},
        {"CPCN", format_number(c_pc_n, 17)},
    };
    r.script = gnuplot_script(5, "single-step error of mode K against tau, PC and C-PC, with fitted A tau^n",
                              fill(fig5_body, values), 900, 700);
    r.numbers = {
        {"pc_fit_A", "PC single-step error fit: A", pc_a, "shown on plot"},
        {"pc_fit_n", "PC single-step error fit: n (expect 3)", pc_n, "second order (n = 3)"},
        {"c_pc_fit_A", "C-PC single-step error fit: A", c_pc_a, "shown on plot"},
        {"c_pc_fit_n", "C-PC single-step error fit: n (expect 3)", c_pc_n, "second order (n = 3)"},
        {"fig5_failed_steps", "C-PC single steps that failed (not fitted)", double(failures), "-"},
    };
    return r;
}

// Figure 6's plot commands.
const char* const fig6_body = R"gp(
set datafile separator comma
set grid lc rgb "#dddddd"
set multiplot layout 1,2 title "Fig. 6: three-wave orbit, {/Symbol t} = 0.2, t in [0, @TEND@]: PC gains @GAINP@% energy in one period (t = @PERIOD@)\nand @GAINE@% by t = @TEND@, so its orbit spirals off the exact one; C-PC stays on it" font ",14"
set key at screen 0.5, screen 0.12 center center horizontal box opaque
set xlabel "{/Symbol y}_K" offset 0,-0.5
set ylabel "{/Symbol y}_P" offset 0,-0.5
set zlabel "{/Symbol y}_Q" rotate parallel
set view 62, 38, 1.0, 1.0
set xyplane relative 0.05
set xtics 0.1
set title "in ({/Symbol y}_K, {/Symbol y}_P, {/Symbol y}_Q) space"
splot "fig6_exact.csv" using "exact_K":"exact_P":"exact_Q" with lines lw 6 lc rgb "#b0b0b0" title "exact orbit", \
      "fig6.csv" using "pc_K":"pc_P":"pc_Q" with linespoints lw 1.5 dt 2 lc rgb "#d62728" pt 8 ps 0.9 title "PC", \
      "fig6.csv" using "c_pc_K":"c_pc_P":"c_pc_Q" with points pt 7 ps 0.9 lc rgb "#1f5fbf" title "C-PC"
unset key
set title "projection on the ({/Symbol y}_P, {/Symbol y}_Q) plane"
set xlabel "{/Symbol y}_P" offset 0,0
set ylabel "{/Symbol y}_Q" offset 0,0
set xtics autofreq
set size ratio -1
plot "fig6_exact.csv" using "exact_P":"exact_Q" with lines lw 6 lc rgb "#b0b0b0" title "exact orbit", \
     "fig6.csv" using "pc_P":"pc_Q" with linespoints lw 1.5 dt 2 lc rgb "#d62728" pt 8 ps 0.9 title "PC", \
     "fig6.csv" using "c_pc_P":"c_pc_Q" with points pt 7 ps 0.9 lc rgb "#1f5fbf" title "C-PC"
unset multiplot
)gp";

figure_result make_figure_6() {
    const auto c = compare<pc<state>, c_pc<state>>(fig2);
    figure_result r;
    r.number = 6;
    csv_table table;
    table.columns = {"t"};
    append(table.columns, mode_columns("pc"));
    append(table.columns, mode_columns("c_pc"));
    append(table.columns, {"pc_E", "c_pc_E"});
    for (std::size_t i = 0; i < c.exact.size(); ++i) {
        const state &u = c.conventional.x[i], &v = c.conservative.x[i];
        table.add({c.conventional.t[i], u[0], u[1], u[2], v[0], v[1], v[2], c.model.energy(u), c.model.energy(v)});
    }
    r.csvs.emplace_back("fig6.csv", std::move(table));
    const three_wave_exact exact(c.model, c.psi0);
    const double period = exact.period();
    r.csvs.emplace_back("fig6_exact.csv", exact_table(c.model, c.psi0, period, period / 400));
    // PC's energy gain after one period of the exact motion, interpolated between the grid points around it.
    const double e0 = c.model.energy(c.psi0);
    const auto i = static_cast<std::size_t>(period / dt_pc);
    const double w = period / dt_pc - double(i);
    const double e_period =
        (1 - w) * c.model.energy(c.conventional.x[i]) + w * c.model.energy(c.conventional.x[i + 1]);
    const double gain_period = e_period / e0 - 1.0;
    const double gain_end = relative_change_at_end(c.conventional.invariants[energy]);
    const std::vector<std::pair<std::string, std::string>> values{
        {"TEND", format_number(t_end)},
        {"PERIOD", format_number(period)},
        {"GAINP", format_number(100 * gain_period)},
        {"GAINE", format_number(100 * gain_end)},
    };
    r.script = gnuplot_script(6, "three-wave orbit in (psi_K, psi_P, psi_Q), PC against C-PC, dt = 0.2",
                              fill(fig6_body, values), 1400, 760);
    r.numbers = {
        {"three_wave_period", "exact period of the three-wave orbit", period, "-"},
        {"pc_energy_gain_rel_one_period", "PC: E/E(0) - 1 after one period (dt 0.2)", gain_period,
         "0.04 (\"4% energy gain\")"},
        {"pc_energy_gain_rel_end", "PC: E/E(0) - 1 at t = 10 (dt 0.2)", gain_end, "-"},
    };
    return r;
}

}  // namespace eci::figures
