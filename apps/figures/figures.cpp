// `eci figures`: runs the nine figure producers, writes their CSV files and gnuplot scripts, draws PNG and SVG
// with gnuplot (the program named by $ECI_GNUPLOT, default `gnuplot`) and prints the table of key numbers.
#include "figures.hpp"

#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <charconv>
#include <chrono>
#include <csignal>
#include <cstring>
#include <cstdio>
#include <cstdlib>
#include <fcntl.h>
#include <fstream>
#include <functional>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <system_error>
#include <vector>

#include "common.hpp"
#include "output.hpp"

namespace eci::figures {

using cli::bad_input;
using cli::interrupt_requested;
using cli::program_timed_out;
using cli::run_program;
using cli::gnuplot_number;
using cli::plotting_time_limit;
using cli::plotting_program;
using cli::run_error;
using cli::staging_dir;
using cli::throw_if_interrupted;

void csv_table::add(std::vector<double> row) {
    if (row.size() != columns.size()) throw std::logic_error("csv_table: row size does not match the columns");
    rows.push_back(std::move(row));
}

void csv_table::write(const std::filesystem::path& file) const {
    throw_if_interrupted();
    std::ofstream out(file);
    if (!out) throw std::runtime_error("cannot write " + file.string());
    for (std::size_t i = 0; i < columns.size(); ++i) out << (i ? "," : "") << columns[i];
    out << '\n';
    char buffer[32];
    for (const auto& row : rows) {
        for (std::size_t i = 0; i < row.size(); ++i) {
            // %.17g round-trips every double, so the tests read back exactly what was computed.
            std::snprintf(buffer, sizeof buffer, "%.17g", row[i]);
            out << (i ? "," : "") << buffer;
        }
        out << '\n';
    }
    out.close();  // a full disk shows up at the last flush
    if (!out) throw run_error("cannot write " + file.string() + ": " + std::strerror(errno));
}

std::string fill(std::string text, const std::vector<std::pair<std::string, std::string>>& values) {
    for (const auto& [name, value] : values) {
        const std::string marker = "@" + name + "@";
        for (std::size_t at = text.find(marker); at != std::string::npos; at = text.find(marker, at + value.size()))
            text.replace(at, marker.size(), value);
    }
    return text;
}

std::string format_number(double v, int digits) {
    char buffer[64];
    std::snprintf(buffer, sizeof buffer, "%.*g", digits, v);
    return buffer;
}

std::string gnuplot_script(int n, const std::string& what, const std::string& body, int width, int height) {
    const std::string name = "fig" + std::to_string(n);
    return fill(R"gp(# Figure @N@ of Shadwick, Bowman & Morrison, "Exactly conservative integrators": @WHAT@.
# Written by `eci figures`; re-plot with `gnuplot @NAME@.gp` from any directory (it reads the CSV files beside it).
set encoding utf8
script = ARG0; cut = strlen(script)
while (cut > 0 && script[cut:cut] ne "/") { cut = cut - 1 }
if (cut > 0) { cd script[1:cut] }
do for [format in "png svg"] {
  if (format eq "png") {
    set terminal pngcairo size @W@,@H@ enhanced font "Sans,12" linewidth 1
  } else {
    set terminal svg size @W@,@H@ enhanced font "Sans,12" linewidth 1 background "white"
  }
  set output "@NAME@.".format
  reset
@BODY@
  set output
}
)gp",
                {{"N", std::to_string(n)},
                 {"WHAT", what},
                 {"NAME", name},
                 {"W", std::to_string(width)},
                 {"H", std::to_string(height)},
                 {"BODY", body}});
}

namespace {

/// Throws run_error unless `file` exists and is not empty (a full disk can leave gnuplot's output empty
/// with exit status 0).
void require_nonempty(const std::filesystem::path& file, const std::string& made_by) {
    std::error_code ec;
    const auto size = std::filesystem::file_size(file, ec);
    if (ec || size == 0)
        throw run_error(made_by + " left " + file.filename().string() + (ec ? " missing" : " empty") +
                          " (disk full?)");
}

/// The figure producers, by number.
const std::vector<std::function<figure_result()>>& producers() {
    static const std::vector<std::function<figure_result()>> all{
        make_figure_1, make_figure_2, make_figure_3,
        make_figure_4, make_figure_5, make_figure_6,
        make_figure_7, make_figure_8, make_figure_9};
    return all;
}

std::string quoted(const std::string& s) {
    std::string q = "\"";
    for (char c : s) q += c == '"' ? std::string("\"\"") : std::string(1, c);
    return q + "\"";
}

constexpr const char* summary_header = "figure,key,value,description,paper";

// The rows of an existing summary.csv (its header first) of figures other than `only`, each under its figure
// number: what `eci figures --only N` keeps of the other figures' numbers. Nothing if there is no such file or it is
// not a summary.
std::vector<std::pair<int, std::string>> rows_of_other_figures(const std::filesystem::path& file, int only) {
    std::vector<std::pair<int, std::string>> rows;
    std::ifstream in(file);
    std::string line;
    if (!in || !std::getline(in, line) || line != summary_header) return {};
    while (std::getline(in, line)) {
        const std::size_t comma = line.find(',');
        int figure = 0;
        if (comma == std::string::npos || comma == 0) return {};
        const auto [end, error] = std::from_chars(line.data(), line.data() + comma, figure);
        if (error != std::errc() || end != line.data() + comma || figure < 1 || figure > 9) return {};
        if (figure != only) rows.emplace_back(figure, line);
    }
    return rows;
}

// summary.csv: the key numbers of the figures made, and (with --only) the other figures' rows of the summary
// already in the output directory, in figure order.
void write_summary(const std::filesystem::path& file, const std::vector<figure_result>& results,
                   const std::vector<std::pair<int, std::string>>& kept = {}) {
    std::ofstream out(file);
    if (!out) throw run_error("cannot write " + file.string() + ": " + std::strerror(errno));
    out << summary_header << '\n';
    char buffer[32];
    std::size_t next = 0;  // the next kept row
    for (const auto& r : results) {
        for (; next < kept.size() && kept[next].first < r.number; ++next) out << kept[next].second << '\n';
        for (const auto& k : r.numbers) {
            std::snprintf(buffer, sizeof buffer, "%.17g", k.value);
            out << r.number << ',' << k.key << ',' << buffer << ',' << quoted(k.description) << ','
                << quoted(k.paper) << '\n';
        }
    }
    for (; next < kept.size(); ++next) out << kept[next].second << '\n';
    out.close();
    if (!out) throw run_error("cannot write " + file.string() + ": " + std::strerror(errno));
}

void print_summary(const std::vector<figure_result>& results) {
    std::cout << "\nKey numbers (eci measures | paper says):\n";
    std::cout << "fig  " << std::left << std::setw(58) << "quantity" << std::setw(14) << "eci" << "paper\n";
    for (const auto& r : results)
        for (const auto& k : r.numbers) {
            std::cout << std::left << std::setw(5) << r.number << std::setw(58) << k.description << std::setw(14)
                      << format_number(k.value, 4) << k.paper << '\n';
        }
}

}  // namespace

int run_figures(const options& options) {
    if (options.only && (*options.only < 1 || *options.only > 9))
        throw bad_input("--only must be a figure number from 1 to 9, got " + std::to_string(*options.only));
    const std::filesystem::path& dir = options.out;
    if (dir.empty()) throw bad_input("--out must not be empty");
    // Everything is written into a temporary directory and moved into `dir` at the end: a failure or an
    // interrupt leaves `dir` as it was.
    staging_dir staging(dir.string());
    const std::filesystem::path work = staging.path();

    const std::string gnuplot = plotting_program();
    const bool have_gnuplot = run_program(gnuplot, {"--version"}, true, plotting_time_limit()) == 0;

    const auto start = std::chrono::steady_clock::now();
    std::vector<figure_result> results;
    std::vector<int> missing;
    std::ostringstream report;  // printed once everything is committed
    for (int n = 1; n <= 9; ++n) {
        if (options.only && *options.only != n) continue;
        throw_if_interrupted();
        figure_result r = producers()[n - 1]();
        if (!r.available) {
            if (options.only) throw bad_input("figure " + std::to_string(n) + " is not available: " + r.unavailable_reason);
            report << "fig" << n << ": NOT AVAILABLE: " << r.unavailable_reason << '\n';
            missing.push_back(n);
            continue;
        }
        for (const auto& [name, table] : r.csvs) table.write(work / name);
        const std::string stem = "fig" + std::to_string(n);
        const std::filesystem::path script = work / (stem + ".gp");
        {
            std::ofstream out(script);
            out << r.script;
            out.close();
            if (!out) throw run_error("cannot write " + script.string() + ": " + std::strerror(errno));
        }
        std::string files;
        for (const auto& [name, table] : r.csvs) files += " " + name;
        if (have_gnuplot) {
            const int status = run_program(gnuplot, {script.string()}, false, plotting_time_limit());
            if (status == -1) throw_if_interrupted("while gnuplot was drawing");
            if (status == program_timed_out)
                throw run_error(gnuplot + " did not finish " + stem + ".gp within " +
                                gnuplot_number(plotting_time_limit()) + " s ($ECI_PLOT_TIMEOUT) and was stopped");
            if (status != 0)
                throw run_error(gnuplot + " failed on " + stem + ".gp (exit status " + std::to_string(status) + ")");
            require_nonempty(work / (stem + ".png"), gnuplot);
            require_nonempty(work / (stem + ".svg"), gnuplot);
            report << stem << ": " << (dir / stem).string() << ".png .svg," << files << ", " << stem << ".gp\n";
        } else {
            report << stem << ":" << files << ", " << stem << ".gp (no picture, see below)\n";
        }
        results.push_back(std::move(r));
    }
    // --only N replaces figure N's rows of an existing summary.csv and keeps the others'
    write_summary(work / "summary.csv", results,
                  options.only ? rows_of_other_figures(dir / "summary.csv", *options.only)
                               : std::vector<std::pair<int, std::string>>{});
    staging.commit();
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

    std::cout << report.str();
    print_summary(results);
    std::cout << "\nwrote " << (dir / "summary.csv").string() << " in " << std::fixed << std::setprecision(1)
              << seconds << " s\n";
    std::cout.unsetf(std::ios::fixed);
    if (!missing.empty()) {
        std::cout << "not available in this build:";
        for (int n : missing) std::cout << " fig" << n;
        std::cout << '\n';
    }
    if (!have_gnuplot) {
        std::cerr << "eci figures: warning: the plotting program '" << gnuplot
                  << "' was not found, so no PNG/SVG pictures were drawn; the CSV data and gnuplot scripts are in "
                  << dir.string() << ". To draw them: apt-get install gnuplot-nox, then run gnuplot "
                  << (dir / "figN.gp").string()
                  << " for each figure N (or set ECI_GNUPLOT to the gnuplot program).\n";
    }
    std::cout.flush();
    if (!std::cout) throw run_error("cannot write the report to standard output");
    return 0;
}

}  // namespace eci::figures
