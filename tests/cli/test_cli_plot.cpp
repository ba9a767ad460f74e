// `eci run MODEL --plot FILE`: the picture of a run. What is drawn is checked through a stand-in plotting program
// ($ECI_GNUPLOT) that keeps the script and the data it was given; the real gnuplot (when installed) must produce
// a whole PNG, SVG and PDF. Bad requests are refused before the run, and a picture that cannot be drawn loses
// nothing else.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include "cli/support.hpp"

using namespace eci::test_cli;

namespace {

bool gnuplot_installed() { return std::system("gnuplot --version >/dev/null 2>&1") == 0; }

class cli_plot : public ::testing::Test {
   protected:
    run_result eci(const std::vector<std::string>& args, const std::string& wrapper = "") const {
        return dir_.run(args, wrapper);
    }
    std::set<std::string> work_files() const { return dir_.files(); }
    fs::path work(const std::string& name) const { return dir_.file(name); }
    /// A stand-in plotting program in the scratch tree: answers --version, copies the script it is given and the
    /// data file the script plots to kept.gp and kept.dat beside it, and writes a tiny "PNG" (its IEND chunk) where
    /// the script sets the output; with `fail`, it draws nothing and exits 1; `before_version` and `before_drawing`
    /// are shell commands it runs first (a sleep). Returns "ECI_GNUPLOT=<it>".
    std::string fake_plotter(bool fail = false, const std::string& before_version = "",
                             const std::string& before_drawing = "", const std::string& after_drawing = "") const {
        const fs::path tool = dir_.capture() / "plot-tool";
        std::ofstream(tool) << "#!/bin/sh\n"
                            << "[ \"$1\" = --version ] && { " << before_version << " exit 0; }\n"
                            << before_drawing << (fail ? "exit 1\n" : "")
                            << "here=$(dirname \"$0\")\n"
                               "cp \"$1\" \"$here/kept.gp\"\n"
                               "data=$(sed -n \"s/^plot '\\([^']*\\)'.*/\\1/p\" \"$1\" | head -n 1)\n"
                               "cp \"$data\" \"$here/kept.dat\"\n"
                               // a field's binary data (a snapshot's picture, a spectral run's field panel), each
                               // kept in the order drawn: kept-0.bin, kept-1.bin, ...
                               "for b in $(sed -n \"s/^plot '\\([^']*\\)' binary.*/\\1/p\" \"$1\"); do\n"
                               "  k=$(ls \"$here\" | grep -c '^kept-.*\\.bin$'); cp \"$b\" \"$here/kept-$k.bin\"\n"
                               "done\n"
                               "out=$(sed -n \"s/^set output '\\([^']*\\)'.*/\\1/p\" \"$1\")\n"
                               "printf '\\211PNG\\000\\000\\000\\000IEND\\256\\102\\140\\202' > \"$out\"\n"
                            << after_drawing;
        fs::permissions(tool, fs::perms::owner_all);
        return "ECI_GNUPLOT=" + shell_quote(tool.string());
    }
    /// Whether this build has the spectral equations (eci::spectral).
    bool has_spectral() const { return dir_.run({"run", "navier-stokes-2d", "--help"}).status == 0; }
    std::string kept_script() const { return read_text(dir_.capture() / "kept.gp"); }
    /// The k-th field's values the plotting program was given (doubles), in the order drawn.
    std::vector<double> kept_field(int k) const {
        const std::string bytes = read_text(dir_.capture() / ("kept-" + std::to_string(k) + ".bin"));
        std::vector<double> v(bytes.size() / sizeof(double));
        std::memcpy(v.data(), bytes.data(), v.size() * sizeof(double));
        return v;
    }
    /// The rows of numbers the plotting program was given.
    std::vector<std::vector<double>> kept_data() const {
        std::vector<std::vector<double>> rows;
        for (const std::string& line : lines_of(read_text(dir_.capture() / "kept.dat"))) {
            std::vector<double> row;
            for (const std::string& cell : split(line, ' '))
                row.push_back(cell == "NaN" ? std::numeric_limits<double>::quiet_NaN() : std::stod(cell));
            rows.push_back(row);
        }
        return rows;
    }

   private:
    work_dir dir_{"cli-plot"};
};

std::vector<std::vector<double>> csv_rows(const std::string& text) {
    std::vector<std::vector<double>> rows;
    const auto lines = lines_of(text);
    for (std::size_t i = 1; i < lines.size(); ++i) {
        std::vector<double> row;
        for (const std::string& cell : split(lines[i])) row.push_back(std::stod(cell));
        rows.push_back(row);
    }
    return rows;
}

// The data drawn are the CSV's rows: t, the state, and each invariant's change relative to its first value.
TEST_F(cli_plot, draws_the_state_and_each_invariants_relative_change_from_the_csv_rows) {
    const run_result r = eci({"run", "three-wave", "--method", "pc", "--dt", "0.1", "--t-end", "5", "--output",
                              "out.csv", "--plot", "out.png"},
                             fake_plotter());
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(work_files(), (std::set<std::string>{"out.csv", "out.png"}));
    const auto csv = csv_rows(read_text(work("out.csv")));  // t, psi_K, psi_P, psi_Q, energy, enstrophy
    const auto drawn = kept_data();
    ASSERT_EQ(drawn.size(), csv.size());
    for (std::size_t i = 0; i < csv.size(); ++i) {
        ASSERT_EQ(drawn[i].size(), 8u);  // ... and the phase plane's psi_P, psi_Q (three_wave::plot_plane)
        for (std::size_t c = 0; c < 4; ++c) EXPECT_EQ(drawn[i][c], csv[i][c]) << "row " << i << " column " << c;
        for (std::size_t k = 0; k < 2; ++k) {
            const double first = csv[0][4 + k];
            EXPECT_EQ(drawn[i][4 + k], (csv[i][4 + k] - first) / std::abs(first)) << "row " << i;
        }
        EXPECT_EQ(drawn[i][6], csv[i][2]) << "row " << i;
        EXPECT_EQ(drawn[i][7], csv[i][3]) << "row " << i;
    }
    // PC drifts: the last relative change of the energy is what the summary reports, far from round-off
    EXPECT_GT(std::abs(drawn.back()[4]), 1e-3);
    const std::string gp = kept_script();
    EXPECT_NE(gp.find("set terminal pngcairo"), std::string::npos) << gp;
    for (const char* title : {"'psi_K'", "'psi_P'", "'psi_Q'", "'energy'", "'enstrophy'", "three-wave: pc, dt 0.1"})
        EXPECT_NE(gp.find(title), std::string::npos) << title << "\n" << gp;
}

// The phase-plane panel (the model's plot_plane) draws the CSV's columns of its two names, a state component or a
// derived column (Kepler's orbit x = r cos theta, y = r sin theta), coloured by time; an orbit on one scale on both
// axes: the ranges set have the panel's shape, so that a circle is drawn round.
TEST_F(cli_plot, the_phase_plane_draws_the_models_two_columns_and_an_orbit_on_one_scale) {
    struct expected {
        const char* model;
        std::size_t x, y;  // the CSV's columns (t is column 0)
        std::size_t width;  // of a drawn row: t, components, invariants, the two phase coordinates
        bool equal_axes;
    };
    // kepler: t, r, v_r, theta, x, y, hamiltonian, runge_lenz_x, runge_lenz_y; lotka-volterra: t, x, y, hamiltonian
    for (const expected& e : {expected{"kepler", 4, 5, 1 + 3 + 3 + 2, true},
                              expected{"lotka-volterra", 1, 2, 1 + 2 + 1 + 2, false}}) {
        SCOPED_TRACE(e.model);
        const run_result r = eci({"run", e.model, "--method", "pc", "--steps", "300", "--output", "out.csv", "--plot",
                                  "out.png"},
                                 fake_plotter());
        ASSERT_EQ(r.status, 0) << r.err;
        const auto csv = csv_rows(read_text(work("out.csv")));
        const auto drawn = kept_data();
        ASSERT_EQ(drawn.size(), csv.size());
        for (std::size_t i = 0; i < csv.size(); ++i) {
            ASSERT_EQ(drawn[i].size(), e.width);
            EXPECT_EQ(drawn[i][e.width - 2], csv[i][e.x]) << "row " << i;
            EXPECT_EQ(drawn[i][e.width - 1], csv[i][e.y]) << "row " << i;
        }
        const std::string gp = kept_script();
        const std::string x = std::to_string(e.width - 1), y = std::to_string(e.width);  // gnuplot counts from 1
        EXPECT_NE(gp.find("using " + x + ":" + y + ":1 with lines linewidth 1.5 lc palette"), std::string::npos)
            << gp;
        EXPECT_NE(gp.find("every ::0::0 using " + x + ":" + y), std::string::npos) << gp;  // the start marked
        const auto range = [&](const std::string& axis) {
            const std::size_t at = gp.find("set " + axis + "range [");
            if (at == std::string::npos) return std::pair<double, double>{NAN, NAN};
            const std::size_t open = gp.find('[', at), colon = gp.find(':', open), close = gp.find(']', colon);
            return std::pair<double, double>{std::stod(gp.substr(open + 1, colon - open - 1)),
                                             std::stod(gp.substr(colon + 1, close - colon - 1))};
        };
        const auto [x0, x1] = range("x");
        const auto [y0, y1] = range("y");
        if (!e.equal_axes) {
            EXPECT_TRUE(std::isnan(x0) && std::isnan(y0)) << "each axis fitted to its data\n" << gp;
            continue;
        }
        // the panel's margins (screen fractions) and the canvas in pixels, from the script
        const auto margin = [&](const std::string& side) {
            const std::size_t at = gp.rfind("set " + side + "margin at screen ");
            return std::stod(gp.substr(at + std::string("set " + side + "margin at screen ").size()));
        };
        const std::size_t size = gp.find("size ");
        const double w_px = std::stod(gp.substr(size + 5)), h_px = std::stod(gp.substr(gp.find(',', size) + 1));
        const double panel_w = (margin("r") - margin("l")) * w_px, panel_h = (margin("t") - margin("b")) * h_px;
        // units per pixel alike on both axes, to the rounding of the script's numbers (gnuplot_number's 17 digits)
        EXPECT_NEAR((x1 - x0) / panel_w, (y1 - y0) / panel_h, 1e-12 * (x1 - x0) / panel_w) << gp;
        for (const auto& row : drawn) {  // and every point inside them
            EXPECT_GE(row[e.width - 2], x0);
            EXPECT_LE(row[e.width - 2], x1);
            EXPECT_GE(row[e.width - 1], y0);
            EXPECT_LE(row[e.width - 1], y1);
        }
    }
}

// A large state draws its first components only, and says how many there are; the format follows the name.
TEST_F(cli_plot, a_large_state_draws_its_first_components_and_the_name_picks_the_format) {
    const run_result r = eci({"run", "n-wave", "--modes", "30", "--steps", "10", "--plot", "out.svg"}, fake_plotter());
    ASSERT_EQ(r.status, 0) << r.err;
    const auto drawn = kept_data();
    ASSERT_EQ(drawn.size(), 11u);
    EXPECT_EQ(drawn.front().size(), 1u + 6u + 2u);  // t, 6 of 30 components, energy, enstrophy
    EXPECT_NE(kept_script().find("first 6 of 30 components"), std::string::npos) << kept_script();
    EXPECT_EQ(kept_script().find("palette"), std::string::npos) << "n-wave declares no phase plane";
    EXPECT_NE(kept_script().find("set terminal svg"), std::string::npos);
}

// A run of many outputs is thinned evenly as it goes (memory bounded), its first and last outputs always drawn.
TEST_F(cli_plot, a_long_run_is_thinned_evenly_with_its_first_and_last_outputs) {
    const run_result r = eci({"run", "three-wave", "--steps", "20001", "--plot", "out.png"}, fake_plotter());
    ASSERT_EQ(r.status, 0) << r.err;
    const auto drawn = kept_data();
    EXPECT_LE(drawn.size(), 2u * 4096u + 1u);
    EXPECT_GE(drawn.size(), 4096u);
    EXPECT_EQ(drawn.front()[0], 0.0);
    EXPECT_NEAR(drawn.back()[0], 200.01, 1e-9);
    for (std::size_t i = 1; i + 1 < drawn.size(); ++i) {  // evenly spaced: every 4th step (20001 outputs > 16384)
        ASSERT_GT(drawn[i][0], drawn[i - 1][0]);
        EXPECT_NEAR(drawn[i][0] - drawn[i - 1][0], 0.04, 1e-9) << "row " << i;
    }
    // the phase plane of thinned outputs as points: a line between outputs 0.04 apart would cut across the curve
    const std::string gp = kept_script();
    EXPECT_NE(gp.find("with points pointtype 7 pointsize 0.3 lc palette"), std::string::npos) << gp;
    EXPECT_EQ(gp.find("with lines linewidth 1.5 lc palette"), std::string::npos) << gp;
}

// The budget panel of a spectral run: E and Z minus what forcing and dissipation account for, which the
// conservative method keeps to round-off (relative change k eps sqrt(steps), k = 8).
TEST_F(cli_plot, a_spectral_run_draws_its_invariants_beyond_their_budget_to_round_off) {
    if (!has_spectral()) GTEST_SKIP() << "built without the spectral equations";
    const run_result r = eci({"run", "navier-stokes-2d", "--N", "32", "--nu", "0.01", "--forcing", "stochastic",
                              "--steps", "50", "--plot", "flow.png", "--fftw-estimate"},
                             fake_plotter());
    ASSERT_EQ(r.status, 0) << r.err;
    const auto drawn = kept_data();
    ASSERT_EQ(drawn.size(), 51u);
    const double bound = 8.0 * std::numeric_limits<double>::epsilon() * std::sqrt(50.0);
    for (const auto& row : drawn) {
        ASSERT_EQ(row.size(), 5u);  // t, E, Z, and the two budget residuals relative to E(0) and Z(0)
        EXPECT_GT(row[1], 0.0);
        EXPECT_LE(std::abs(row[3]), bound) << "t = " << row[0];
        EXPECT_LE(std::abs(row[4]), bound) << "t = " << row[0];
    }
    EXPECT_GT(std::abs(drawn.back()[1] - drawn.front()[1]), 1e-6);  // forced and viscous: E itself changes
    EXPECT_NE(kept_script().find("set logscale y"), std::string::npos);
}

// Beside them, the field the run ended with: the same values as its last snapshot's (a separate path, the
// snapshot's own picture), on a colour range symmetric about 0, titled by the equation's field.
TEST_F(cli_plot, a_spectral_run_draws_the_field_it_ended_with) {
    if (!has_spectral()) GTEST_SKIP() << "built without the spectral equations";
    const run_result r = eci({"run", "navier-stokes-2d", "--N", "16", "--nu", "0.01", "--steps", "3",
                              "--snapshot-every", "3", "--snapshot-dir", "snaps", "--plot", "flow.png",
                              "--fftw-estimate", "--fftw-wisdom", "none"},
                             fake_plotter());
    ASSERT_EQ(r.status, 0) << r.err;
    // drawn in order: the snapshots' fields at steps 0 and 3 (their spectra have no field), then the run's picture
    const std::vector<double> first = kept_field(0), last = kept_field(1), drawn = kept_field(2);
    ASSERT_EQ(drawn.size(), 16u * 16u);
    EXPECT_EQ(drawn, last);    // bit for bit
    EXPECT_NE(drawn, first);   // (the field moved in 3 steps)
    double big = 0.0;
    for (double v : drawn) big = std::max(big, std::abs(v));
    const std::string gp = kept_script();
    EXPECT_NE(gp.find("with image"), std::string::npos) << gp;
    char range[96];  // (gnuplot_number's %.17g: the maximum read back exactly)
    std::snprintf(range, sizeof range, "set cbrange [%.17g:%.17g]", -big, big);
    EXPECT_NE(gp.find(range), std::string::npos) << range << "\n" << gp;
    EXPECT_NE(gp.find("set title 'vorticity at t = "), std::string::npos) << gp;
    EXPECT_NE(gp.find("set cblabel 'omega'"), std::string::npos) << gp;
}

void expect_refused(const run_result& r, const std::string& words) {
    EXPECT_EQ(r.status, 2) << r.err;
    const auto lines = lines_of(r.err);
    ASSERT_EQ(lines.size(), 1u) << r.err;
    EXPECT_NE(lines[0].find(words), std::string::npos) << r.err;
}

// Refused before the run, nothing written: an unknown format, no plotting program, the same file as another output,
// a directory that does not exist.
TEST_F(cli_plot, a_plot_that_cannot_be_drawn_is_refused_before_the_run_and_nothing_is_written) {
    const std::vector<std::string> run{"run", "three-wave", "--output", "out.csv", "--summary-json", "out.json"};
    auto with = [&](std::vector<std::string> more) {
        std::vector<std::string> a = run;
        a.insert(a.end(), more.begin(), more.end());
        return a;
    };
    expect_refused(eci(with({"--plot", "out.jpg"})), "must end in .png, .svg or .pdf");
    expect_refused(eci(with({"--plot", "out.png"}), "ECI_GNUPLOT=/nonexistent/gnuplot"), "--plot needs gnuplot");
    expect_refused(eci(with({"--plot", "./out.json"})), "name the same file");
    expect_refused(eci(with({"--plot", "missing/out.png"})), "missing/out.png");
    if (has_spectral())
        expect_refused(eci({"run", "navier-stokes-2d", "--N", "16", "--steps", "1", "--plot", "a.gif"}),
                       "must end in .png, .svg or .pdf");
    EXPECT_TRUE(work_files().empty());
}

// A plotting program that fails at the end: the other outputs are kept, the run says so and exits 1.
TEST_F(cli_plot, a_picture_that_fails_at_the_end_loses_no_other_output) {
    std::ofstream(work("out.png")) << "old picture";
    const run_result r =
        eci({"run", "three-wave", "--steps", "10", "--output", "out.csv", "--plot", "out.png"}, fake_plotter(true));
    EXPECT_EQ(r.status, 1);
    EXPECT_NE(r.err.find("the plot 'out.png' could not be drawn"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("the other outputs were written"), std::string::npos) << r.err;
    EXPECT_EQ(csv_rows(read_text(work("out.csv"))).size(), 11u);
    EXPECT_EQ(read_text(work("out.png")), "old picture");
}

// A plotting program that hangs is stopped after $ECI_PLOT_TIMEOUT seconds (the stand-in would sleep for a minute,
// then draw): over the picture, the run fails in one line that says so and keeps its other outputs; over --version,
// --plot is refused before the run.
TEST_F(cli_plot, a_plotting_program_that_hangs_is_stopped) {
    const run_result r = eci({"run", "three-wave", "--steps", "10", "--output", "out.csv", "--plot", "out.png"},
                             "ECI_PLOT_TIMEOUT=0.5 " + fake_plotter(false, "", "sleep 60;"));
    EXPECT_EQ(r.status, 1) << r.err;
    EXPECT_NE(r.err.find("the plot 'out.png' could not be drawn by "), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("did not finish a picture within 0.5 s ($ECI_PLOT_TIMEOUT)"), std::string::npos) << r.err;
    EXPECT_EQ(csv_rows(read_text(work("out.csv"))).size(), 11u);
    EXPECT_FALSE(fs::exists(work("out.png")));
    const run_result v = eci({"run", "three-wave", "--steps", "10", "--output", "v.csv", "--plot", "v.png"},
                             "ECI_PLOT_TIMEOUT=0.5 " + fake_plotter(false, "sleep 60;"));
    EXPECT_EQ(v.status, 2) << v.err;
    EXPECT_NE(v.err.find("did not answer --version within 0.5 s"), std::string::npos) << v.err;
    EXPECT_FALSE(fs::exists(work("v.csv")));
}

// Ctrl-C while the picture is drawn at the end of a finished run: the plotting program is stopped, the run's other
// outputs are kept whole (they were all lost), exit 130. Ctrl-C while the plotting program is probed before the run:
// an interrupt (130), not "gnuplot does not run" (2).
TEST_F(cli_plot, an_interrupt_while_drawing_keeps_the_finished_runs_other_outputs) {
    const run_result r = eci({"run", "three-wave", "--steps", "100", "--output", "o.csv", "--summary-json", "s.json",
                              "--plot", "p.png"},
                             fake_plotter(false, "", "sleep 5;") + " timeout -s INT --preserve-status 1.5");
    EXPECT_EQ(r.status, 130) << r.err;
    EXPECT_NE(r.err.find("interrupted by SIGINT while the plot was drawn"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("kept: CSV output 'o.csv', summary JSON 's.json'; no plot"), std::string::npos) << r.err;
    EXPECT_EQ(work_files(), (std::set<std::string>{"o.csv", "s.json"}));
    EXPECT_EQ(csv_rows(read_text(work("o.csv"))).size(), 101u);
    const run_result probe = eci({"run", "three-wave", "--steps", "100", "--output", "o2.csv", "--plot", "p.png"},
                                 fake_plotter(false, "sleep 5;") + " timeout -s INT --preserve-status 1");
    EXPECT_EQ(probe.status, 130) << probe.err;
    EXPECT_NE(probe.err.find("interrupted by SIGINT before the run"), std::string::npos) << probe.err;
    EXPECT_EQ(work_files(), (std::set<std::string>{"o.csv", "s.json"}));
}

// Ctrl-C once the run has finished and its picture is drawn (the stand-in interrupts eci as it exits): the outputs are
// whole and kept, exit 130 (the commit's rule discarded all of them). Whether the picture is kept depends on whether
// eci saw the plotting program end before the signal: either way it is whole or absent.
TEST_F(cli_plot, an_interrupt_after_the_run_has_finished_keeps_its_outputs) {
    const run_result r = eci({"run", "three-wave", "--steps", "100", "--output", "o.csv", "--summary-json", "s.json",
                              "--plot", "p.png"},
                             fake_plotter(false, "", "", "kill -INT $PPID\n"));
    EXPECT_EQ(r.status, 130) << r.err;
    EXPECT_NE(r.err.find("interrupted by SIGINT"), std::string::npos) << r.err;
    EXPECT_EQ(csv_rows(read_text(work("o.csv"))).size(), 101u);
    EXPECT_NE(read_text(work("s.json")).find("\"steps\": 100"), std::string::npos);
    const auto files = work_files();
    EXPECT_TRUE(files == (std::set<std::string>{"o.csv", "s.json"}) ||
                files == (std::set<std::string>{"o.csv", "s.json", "p.png"}));
    if (files.count("p.png")) {
        EXPECT_EQ(read_text(work("p.png")).substr(1, 3), "PNG");
    }
}

// With gnuplot itself: whole pictures in each format.
TEST_F(cli_plot, gnuplot_draws_whole_png_svg_and_pdf_files) {
    if (!gnuplot_installed()) GTEST_SKIP() << "gnuplot is not installed";
    const run_result r = eci({"run", "kepler", "--t-end", "5", "--plot", "k.png"});
    ASSERT_EQ(r.status, 0) << r.err;
    const std::string png = read_text(work("k.png"));
    ASSERT_GT(png.size(), 1000u);
    EXPECT_EQ(png.substr(1, 3), "PNG");
    EXPECT_EQ(png.substr(png.size() - 8, 4), "IEND");
    ASSERT_EQ(eci({"run", "lotka-volterra", "--plot", "lv.svg"}).status, 0);
    EXPECT_NE(read_text(work("lv.svg")).find("</svg>"), std::string::npos);
    ASSERT_EQ(eci({"run", "rigid-body", "--plot", "rb.pdf"}).status, 0);
    EXPECT_EQ(read_text(work("rb.pdf")).substr(0, 4), "%PDF");
    EXPECT_EQ(work_files(), (std::set<std::string>{"k.png", "lv.svg", "rb.pdf"}));
    // one output alone (no step): its phase plane a point, its colour range about its one time (gnuplot refuses an
    // empty one)
    const run_result one = eci({"run", "kepler", "--steps", "0", "--plot", "one.png"});
    ASSERT_EQ(one.status, 0) << one.err;
    EXPECT_EQ(one.err.find("could not be drawn"), std::string::npos) << one.err;
    EXPECT_EQ(read_text(work("one.png")).substr(1, 3), "PNG");
}

}  // namespace
