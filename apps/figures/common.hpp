// Shared pieces of `eci figures`: the CSV table, the key numbers, the gnuplot script template and the
// per-figure producers (figures_three_wave.cpp, figures_lv_kepler.cpp). Internal to the CLI.
#pragma once

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace eci::figures {

/// A table of numbers with named columns, written as CSV with full (round-trip) precision.
struct csv_table {
    std::vector<std::string> columns;     ///< column names, in order
    std::vector<std::vector<double>> rows;  ///< one vector per row, columns.size() values each

    /// Appends a row (its size must match the columns).
    void add(std::vector<double> row);
    /// Writes the table to `file`; throws std::runtime_error if the file cannot be written.
    void write(const std::filesystem::path& file) const;
};

/// One key number of a figure: what eci measures, next to what the paper reports.
struct key_number {
    std::string key;          ///< stable machine name (summary.csv column `key`)
    std::string description;  ///< what it is, for the printed table
    double value = 0.0;       ///< what eci measures
    std::string paper;        ///< what the paper says, or "-" if it gives no number
};

/// What a figure producer returns: its data files, its gnuplot script and its key numbers.
struct figure_result {
    int number = 0;                                       ///< 1..9
    bool available = true;                                ///< false if the models it needs are not built in
    std::string unavailable_reason;                       ///< why, when not available
    std::vector<std::pair<std::string, csv_table>> csvs;  ///< file name (e.g. "fig1.csv") and contents
    std::string script;                                   ///< gnuplot script body (see gnuplot_script)
    std::vector<key_number> numbers;                      ///< key numbers for the summary
};

/// The complete gnuplot script of figure n: the header comment, the lines that make the script find its CSV
/// next to itself, the loop over the PNG and SVG terminals (size w x h) and `body` inside it.
std::string gnuplot_script(int n, const std::string& what, const std::string& body, int width = 1000,
                           int height = 750);

/// Replaces every "@NAME@" in `text` by its value.
std::string fill(std::string text, const std::vector<std::pair<std::string, std::string>>& values);

/// A number in short scientific or fixed notation for titles and labels (`digits` significant digits).
std::string format_number(double v, int digits = 3);

/// Figures 1-6 (three-wave model).
figure_result make_figure_1();
figure_result make_figure_2();
figure_result make_figure_3();
figure_result make_figure_4();
figure_result make_figure_5();
figure_result make_figure_6();
/// Figure 7 (Lotka-Volterra) and Figures 8, 9 (Kepler).
figure_result make_figure_7();
figure_result make_figure_8();
figure_result make_figure_9();

}  // namespace eci::figures
