// `eci figures`: the paper's nine figures (PNG, SVG and the CSV behind each) and the key numbers, from one call.
// A library of its own (apps/figures), built on eci's public API; the CLI only parses its options.
#pragma once

#include <filesystem>
#include <optional>

namespace eci::figures {

/// Options of `eci figures`.
struct options {
    std::filesystem::path out = "figures";  ///< where the images, CSV files and gnuplot scripts go
    std::optional<int> only;                 ///< one figure (1-9), or all of them
};

/// Writes the figures; returns the process exit status (0, or 2 after a one-line error on stderr).
int run_figures(const options& options);

}  // namespace eci::figures
