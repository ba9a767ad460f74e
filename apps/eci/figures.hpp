// `eci figures`: the paper's nine figures (PNG, SVG and the CSV behind each) and the key numbers, from one call.
#pragma once

#include <filesystem>
#include <optional>

namespace eci::cli {

/// Options of `eci figures`.
struct figures_options {
    std::filesystem::path out = "figures";  ///< where the images, CSV files and gnuplot scripts go
    std::optional<int> only;                 ///< one figure (1-9), or all of them
};

/// Writes the figures; returns the process exit status (0, or 2 after a one-line error on stderr).
int run_figures(const figures_options& options);

}  // namespace eci::cli
