// `eci run MODEL --plot FILE.png` (or .svg, .pdf): a picture of a run drawn from its outputs (the CSV's rows, written or not): the
// state's first components over time above, beside them the model's phase plane (its orbit or cycle, coloured by
// time) where it declares one, each invariant's relative change below; a spectral run's last field at the right.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "output.hpp"

namespace eci::cli {

/// A number for a picture's title: 6 significant digits.
std::string title_number(double v);

/// The picture format --plot's file name asks for ("png", "svg" or "pdf", from its extension; "png" for standard
/// output and devices), or empty if it names none.
std::string plot_format(std::string_view path);

/// Refuses (bad_input), before a run, a --plot it could not draw: a name without .png, .svg or .pdf, or no plotting
/// program. Nothing for an empty path (no --plot).
void check_plot_request(const std::string& path);

/// The outputs a plot keeps and draws. A long run's outputs are thinned as they come: when 2 * max_rows are held,
/// every other one is dropped and from then on only every other output is kept, so that memory stays bounded and
/// the points stay evenly spread; the first and the last output are always drawn.
class run_plot {
   public:
    /// At most this many of the state's real components are drawn (the first ones; the key says how many there are).
    static constexpr std::size_t max_components = 6;
    static constexpr std::size_t max_rows = 4096;

    /// `path`: the --plot file (its extension picks the format), `components`: the names of the state's real unknowns (all of them: the plot draws the first
    /// max_components), `invariants` the invariants' names, `title` the picture's title (model, method, step),
    /// `top_label` the upper panel's axis ("state" if empty), `log_top` a logarithmic axis there, `bottom_label`
    /// the lower panel's ("(invariant - initial) / |initial|" if empty).
    run_plot(std::string path, std::vector<std::string> components, std::size_t component_count, std::vector<std::string> invariants,
             std::string title, std::string top_label = {}, bool log_top = false, std::string bottom_label = {});

    /// One output: its time, the state's first components (at most max_components are read) and the invariants.
    void add(double t, std::span<const double> components, std::span<const double> invariants);
    /// The same with the output's point in the phase plane (set_phase_plane), two values.
    void add(double t, std::span<const double> components, std::span<const double> invariants,
             std::span<const double, 2> phase);
    /// Draws a phase-plane panel beside the state's: the outputs' (x, y), labelled by the two columns' names, on one
    /// scale where `equal_axes`, coloured by time (a drift shows as a band or a spiral), the first output marked.
    /// Before the first add().
    void set_phase_plane(std::string x, std::string y, bool equal_axes);
    /// Draws a field panel to the right (a spectral run's last field, as its snapshots draw it): `field` n x n
    /// values (row-major, y rows) on [0, 2 pi)^2, colours symmetric about 0, titled "`name` at t = `t`", the colour
    /// bar labelled `symbol`.
    void set_field(int n, std::vector<double> field, double t, std::string name, std::string symbol);
    /// Whether any output was added.
    bool empty() const { return rows_ == 0 && !has_last_; }

    /// Draws the picture (PNG, SVG or PDF by the path's extension) into `png` (its stream: a temporary renamed by
    /// commit_outputs, or a device). False if it could not be drawn: the plotting program failed or was interrupted,
    /// or a temporary could not be written (failure() then says why); never throws, so that a run whose picture
    /// fails keeps its other outputs.
    bool draw(output_file& png) const;
    /// Why the last draw() failed, if it could tell ("" otherwise).
    const std::string& failure() const { return failure_; }

   private:
    bool draw_into(output_file& png) const;
    /// The phase-plane panel's script (after the others'): `rows` as drawn, `placement` its margins, its size as a
    /// fraction of the canvas and the canvas in pixels (one scale on both axes needs them), `file` the data.
    std::string phase_panel(const std::vector<double>& rows, std::size_t count, const std::string& placement,
                            double panel_width, double panel_height, int width_px, int height_px,
                            const std::string& file) const;
    std::size_t width() const { return 1 + names_.size() + invariants_.size() + (phase_ ? 2 : 0); }
    std::string path_;
    std::vector<std::string> names_, invariants_;
    std::size_t component_count_;
    std::string title_, top_label_, bottom_label_;
    bool log_top_;
    bool phase_ = false, equal_axes_ = false;
    std::string phase_x_, phase_y_;
    int field_n_ = 0;  // 0: no field panel
    std::vector<double> field_;
    double field_t_ = 0.0;
    std::string field_name_, field_symbol_;
    std::vector<double> data_;  // rows of width(): t, the components drawn, the invariants
    std::size_t rows_ = 0;
    std::uint64_t seen_ = 0, stride_ = 1;  // outputs seen; every stride_-th is kept
    std::vector<double> last_;             // the latest output, drawn last whether kept or not
    bool has_last_ = false;
    mutable std::string failure_;
};

}  // namespace eci::cli
