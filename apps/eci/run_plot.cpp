// The picture of `eci run MODEL --plot FILE.png` (run_plot.hpp), drawn by the plotting program.
#include "run_plot.hpp"

#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <utility>

namespace eci::cli {

namespace {

// A file name in the temporary directory no other run uses.
std::string temporary_name(const std::string& suffix) {
    static int count = 0;
    std::error_code ec;
    std::filesystem::path dir = std::filesystem::temp_directory_path(ec);
    if (ec) dir = "/tmp";
    return (dir / ("eci-plot-" + std::to_string(::getpid()) + "-" + std::to_string(count++) + suffix)).string();
}

}  // namespace

std::string title_number(double v) {
    char b[32];
    std::snprintf(b, sizeof b, "%.6g", v);
    return b;
}

std::string plot_format(std::string_view path) {
    const std::string ext = extension_of(path);
    if (ext == "png" || ext == "svg" || ext == "pdf") return ext;
    return names_a_stream(std::string(path)) ? "png" : std::string();  // a stream: PNG
}

void check_plot_request(const std::string& path) {
    if (path.empty()) return;
    if (plot_format(path).empty())
        throw bad_input("--plot '" + path + "': the picture's name must end in .png, .svg or .pdf");
    if (!plotting_available()) {
        throw_if_interrupted("before the run");  // (the probe of the plotting program was stopped, not refused)
        const std::string why = plotting_failure();
        throw bad_input("--plot needs gnuplot (Debian package gnuplot-nox), and '" + plotting_program() + "' " +
                        (why.empty() ? "does not run" : "did not answer --version within " +
                                                            gnuplot_number(plotting_time_limit()) +
                                                            " s ($ECI_PLOT_TIMEOUT)"));
    }
}

run_plot::run_plot(std::string path, std::vector<std::string> components, std::size_t component_count,
                   std::vector<std::string> invariants, std::string title, std::string top_label, bool log_top,
                   std::string bottom_label)
    : path_(std::move(path)),
      names_(std::move(components)),
      invariants_(std::move(invariants)),
      component_count_(component_count),
      title_(std::move(title)),
      top_label_(std::move(top_label)),
      bottom_label_(std::move(bottom_label)),
      log_top_(log_top) {
    if (names_.size() > max_components) names_.resize(max_components);
}

void run_plot::set_phase_plane(std::string x, std::string y, bool equal_axes) {
    phase_ = true;
    phase_x_ = std::move(x);
    phase_y_ = std::move(y);
    equal_axes_ = equal_axes;
}

void run_plot::set_field(int n, std::vector<double> field, double t, std::string name, std::string symbol) {
    field_n_ = n;
    field_ = std::move(field);
    field_t_ = t;
    field_name_ = std::move(name);
    field_symbol_ = std::move(symbol);
}

void run_plot::add(double t, std::span<const double> components, std::span<const double> invariants) {
    const std::array<double, 2> none{std::nan(""), std::nan("")};
    add(t, components, invariants, none);
}

void run_plot::add(double t, std::span<const double> components, std::span<const double> invariants,
                   std::span<const double, 2> phase) {
    last_.assign(width(), std::nan(""));
    last_[0] = t;
    for (std::size_t i = 0; i < names_.size() && i < components.size(); ++i) last_[1 + i] = components[i];
    for (std::size_t k = 0; k < invariants_.size() && k < invariants.size(); ++k)
        last_[1 + names_.size() + k] = invariants[k];
    if (phase_) std::copy(phase.begin(), phase.end(), last_.end() - 2);
    has_last_ = true;
    if (seen_++ % stride_ != 0) return;
    data_.insert(data_.end(), last_.begin(), last_.end());
    if (++rows_ < 2 * max_rows) return;
    // full: keep every other row (the first among them) and from now on every other output
    const std::size_t w = width();
    for (std::size_t r = 0; 2 * r < rows_; ++r)
        std::copy_n(data_.begin() + std::ptrdiff_t(2 * r * w), w, data_.begin() + std::ptrdiff_t(r * w));
    rows_ = (rows_ + 1) / 2;
    data_.resize(rows_ * w);
    stride_ *= 2;
}

bool run_plot::draw(output_file& png) const {
    try {
        return draw_into(png);
    } catch (const std::exception& e) {
        failure_ = e.what();
        return false;
    }
}

std::string run_plot::phase_panel(const std::vector<double>& rows, std::size_t count, const std::string& placement,
                                  double panel_width, double panel_height, int width_px, int height_px,
                                  const std::string& file) const {
    const std::size_t w = width(), nc = names_.size(), ni = invariants_.size();
    const std::string x = std::to_string(2 + nc + ni), y = std::to_string(3 + nc + ni);
    std::string s = placement + "unset key\nset xlabel " + gnuplot_quoted(phase_x_) + "\nset ylabel " +
                    gnuplot_quoted(phase_y_) + "\nset autoscale xy\n";
    if (!equal_axes_) s += "set offsets graph 0.04, graph 0.04, graph 0.04, graph 0.04\n";  // (the curve off the frame)
    if (equal_axes_) {
        // one scale on both axes: the data's ranges widened to the panel's shape (gnuplot's `size ratio` does not
        // act on a panel whose margins are fixed)
        double lo[2] = {HUGE_VAL, HUGE_VAL}, hi[2] = {-HUGE_VAL, -HUGE_VAL};
        for (std::size_t r = 0; r < count; ++r)
            for (int a = 0; a < 2; ++a) {
                const double v = rows[r * w + w - 2 + std::size_t(a)];
                if (std::isfinite(v)) lo[a] = std::min(lo[a], v), hi[a] = std::max(hi[a], v);
            }
        const double px[2] = {panel_width * width_px, panel_height * height_px};
        double scale = 0.0;  // data units per pixel
        for (int a = 0; a < 2; ++a)
            if (lo[a] <= hi[a]) scale = std::max(scale, 1.1 * (hi[a] - lo[a]) / px[a]);
        if (scale > 0.0 && std::isfinite(scale)) {
            for (int a = 0; a < 2; ++a) {
                const double mid = 0.5 * (lo[a] + hi[a]), half = 0.5 * scale * px[a];
                s += std::string(a == 0 ? "set xrange [" : "set yrange [") + gnuplot_number(mid - half) + ":" +
                     gnuplot_number(mid + half) + "]\n";
            }
        }
    }
    // coloured by time, dark to light (a method that drifts leaves a band or a spiral of colours); a line through
    // every output, or points where a long run's outputs were thinned (a line would cut across the orbit)
    s += "set palette defined (0 '#30123b', 1 '#4686fb', 2 '#1ae4b6', 3 '#a2fc3c', 4 '#fabb39', 5 '#e4460a', "
         "6 '#7a0403')\nset cblabel 't'\nset colorbox\n";
    // the colours span the run's times (backward in time too); one output alone gets a range about its time, which
    // gnuplot needs to be not empty
    const double t0 = std::min(rows.front(), rows[(count - 1) * w]), t1 = std::max(rows.front(), rows[(count - 1) * w]);
    const double pad = t0 < t1 ? 0.0 : std::max(1.0, std::abs(t0));
    s += "set cbrange [" + gnuplot_number(t0 - pad) + ":" + gnuplot_number(t1 + pad) + "]\n";
    const std::string style = count == 1          ? " with points pointtype 7 pointsize 1 lc palette"
                              : stride_ == 1 ? " with lines linewidth 1.5 lc palette"
                                                  : " with points pointtype 7 pointsize 0.3 lc palette";
    s += "plot " + file + " using " + x + ":" + y + ":1" + style + ", " + file + " every ::0::0 using " + x + ":" +
         y + " with points pointtype 6 pointsize 1.8 lc rgb 'black'\n";
    return s;
}

bool run_plot::draw_into(output_file& png) const {
    if (empty() || !png.get()) return false;
    const std::size_t w = width(), nc = names_.size(), ni = invariants_.size();
    // the rows drawn: those kept, and the last output if it was not
    std::vector<double> rows = data_;
    if (rows.size() < w || !std::equal(last_.begin(), last_.end(), rows.end() - std::ptrdiff_t(w)))
        rows.insert(rows.end(), last_.begin(), last_.end());
    const std::size_t count = rows.size() / w;
    // each invariant's change from its first value, relative to it (absolute where it is 0 or not finite)
    std::vector<bool> relative(ni);
    for (std::size_t k = 0; k < ni; ++k) {
        const double first = rows[1 + nc + k];
        relative[k] = std::isfinite(first) && first != 0.0;
    }
    const scoped_temporary data(temporary_name(".dat"));
    write_new_file(data.path(), "plot data", [&](std::FILE* f) {
        for (std::size_t r = 0; r < count; ++r) {
            const double* row = rows.data() + r * w;
            std::string line = gnuplot_number(row[0]);
            for (std::size_t i = 0; i < nc; ++i) line += ' ' + gnuplot_number(row[1 + i]);
            for (std::size_t k = 0; k < ni; ++k) {
                const double first = rows[1 + nc + k], v = row[1 + nc + k];
                line += ' ' + gnuplot_number(relative[k] ? (v - first) / std::abs(first) : v - first);
            }
            if (phase_) line += ' ' + gnuplot_number(row[w - 2]) + ' ' + gnuplot_number(row[w - 1]);
            line += '\n';
            if (std::fputs(line.c_str(), f) < 0) return;  // (write_new_file checks the stream's error state)
        }
    });
    const std::string format = plot_format(path_);
    // with a phase plane, a wider canvas: the state (left) and the phase plane (right) above, the invariants below;
    // with a field, the time panels at the left and the field, square, at the right
    const bool field = field_n_ > 0 && field_.size() == std::size_t(field_n_) * std::size_t(field_n_);
    const int width_px = field ? 1500 : phase_ ? 1240 : 1000, height_px = 760;
    const std::string size = std::to_string(width_px) + "," + std::to_string(height_px);
    std::string s = format == "svg"   ? "set terminal svg size " + size + " font ',10' noenhanced\n"
                    : format == "pdf" ? "set terminal pdfcairo size " + gnuplot_number(width_px / 100.0) +
                                            "in,7.6in font ',10' noenhanced\n"
                                      : "set terminal pngcairo size " + size + " font ',10' noenhanced\n";
    const scoped_temporary picture(temporary_name("." + format));
    s += "set output " + gnuplot_quoted(picture.path()) + "\n";
    // Each panel's place on the canvas (screen fractions): the time axes share their left edge, the keys are right
    // of their panels.
    struct box {
        double left, right, bottom, top;
    };
    const bool two_rows = nc > 0 && ni > 0;
    const box state_box = field    ? box{0.07, 0.40, two_rows ? 0.55 : 0.1, 0.93}
                          : phase_ ? box{0.08, 0.45, 0.55, 0.93}
                                   : box{0.11, 0.74, two_rows ? 0.55 : 0.1, 0.93};
    const box invariant_box = field ? box{0.07, 0.40, 0.08, nc > 0 ? 0.45 : 0.93}
                                    : box{phase_ ? 0.08 : 0.11, phase_ ? 0.8 : 0.74, 0.08, nc > 0 || phase_ ? 0.45 : 0.93};
    const box phase_box{0.61, 0.87, 0.55, 0.93};
    // square in pixels: 0.8 of the height, as wide
    const double field_width = 0.8 * height_px / width_px;
    const box field_box{0.53, 0.53 + field_width, 0.1, 0.9};
    // (beside a panel at the right, a key between the panels: "outside right" is the canvas' right edge)
    const auto key_beside = [](const box& b) {
        return "set key at screen " + gnuplot_number(b.right + 0.085) + "," + gnuplot_number(b.top) + " right top\n";
    };
    const auto place = [](const box& b) {
        return "set lmargin at screen " + gnuplot_number(b.left) + "\nset rmargin at screen " +
               gnuplot_number(b.right) + "\nset bmargin at screen " + gnuplot_number(b.bottom) +
               "\nset tmargin at screen " + gnuplot_number(b.top) + "\n";
    };
    s += "set multiplot title " + gnuplot_quoted(title_) + "\n";
    // the panels' axes ending at the data (not the next tic), the keys right of them; a single output as a point (a
    // line of one point is not drawn)
    s += "set grid\nset key outside right top\nset xlabel 't'\nset autoscale xfix\n";
    const std::string style = count > 1 ? " with lines" : " with points pointtype 7";
    const std::string file = gnuplot_quoted(data.path());
    if (nc > 0) {
        const std::string label = !top_label_.empty()      ? top_label_
                                  : component_count_ > nc ? "state (first " + std::to_string(nc) + " of " +
                                                                std::to_string(component_count_) + " components)"
                                                          : std::string("state");
        // (beside a phase plane, the key between the two panels: "outside right" is the canvas' right edge)
        s += place(state_box) + "set ylabel " + gnuplot_quoted(label) + "\n";
        if (log_top_) s += "set logscale y\n";
        if (phase_ || field) s += key_beside(state_box);
        s += "plot ";
        for (std::size_t i = 0; i < nc; ++i)
            s += (i ? ", " : "") + file + " using 1:" + std::to_string(2 + i) + style + " title " +
                 gnuplot_quoted(names_[i]);
        s += "\n";
        if (log_top_) s += "unset logscale y\n";
    }
    if (ni > 0) {
        // relative to the initial value, or where that is 0 (or not finite) absolute, said in the key
        const bool any_absolute = !std::ranges::all_of(relative, [](bool r) { return r; });
        const std::string label = bottom_label_.empty() ? "(invariant - initial) / |initial|" : bottom_label_;
        s += place(invariant_box) + (field ? key_beside(invariant_box) : std::string("set key outside right top\n")) +
             "set ylabel " +
             gnuplot_quoted(label + (any_absolute ? "; (abs.): - initial" : "")) + "\nset format y '%.1e'\nplot ";
        for (std::size_t k = 0; k < ni; ++k)
            s += (k ? ", " : "") + file + " using 1:" + std::to_string(2 + nc + k) + style + " title " +
                 gnuplot_quoted(invariants_[k] + (relative[k] ? "" : " (abs.)"));
        s += "\nset format y '% h'\n";
    }
    if (phase_) s += phase_panel(rows, count, place(phase_box), phase_box.right - phase_box.left,
                                 phase_box.top - phase_box.bottom, width_px, height_px, file);
    std::optional<scoped_temporary> field_data;
    if (field) {
        // as the snapshots' pictures (field_image), beside the others
        field_data.emplace(temporary_name(".bin"));
        s += place(field_box) + "unset key\nunset grid\nset colorbox user origin screen " +
             gnuplot_number(field_box.right + 0.012) + ",0.2 size screen 0.012,0.6\nset title " +
             gnuplot_quoted(field_name_ + " at t = " + title_number(field_t_)) + "\n" +
             field_image(field_data->path(), field_n_, field_, field_symbol_);
    }
    s += "unset multiplot\nset output\n";
    if (!draw_picture(s, picture.path())) {
        failure_ = plotting_failure();
        return false;
    }
    // the picture into the output's stream (a temporary of its own until commit_outputs, or a device)
    std::FILE* in = std::fopen(picture.path().c_str(), "rb");
    if (!in) return false;
    char buffer[1 << 16];
    // (a failed write sets the stream's error flag, which output_file::finish reports with the reason)
    for (std::size_t got; (got = std::fread(buffer, 1, sizeof buffer, in)) > 0;)
        if (std::fwrite(buffer, 1, got, png.get()) != got) break;
    const bool read = !std::ferror(in);
    std::fclose(in);
    if (!read) throw run_error("cannot read the plot drawn at '" + picture.path() + "'");
    return true;
}

}  // namespace eci::cli
