// `eci run MODEL --output FILE.h5`: the run's outputs (the CSV's rows) as HDF5 datasets instead of text, written
// into the output's temporary by name and committed with the run's other files. Implemented beside the snapshots'
// HDF5 (ns2d_output.cpp) in a build with HDF5; without it, asking for HDF5 is refused (h5_series_none.cpp).
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <variant>

#include "output.hpp"
#include <vector>

namespace eci::cli {

/// Whether an --output path asks for HDF5 (it ends in .h5 or .hdf5, in any case).
inline bool is_hdf5_path(std::string_view path) {
    const std::string ext = extension_of(path);
    return ext == "h5" || ext == "hdf5";
}

/// The rows of a run as HDF5: a dataset `t` of the output times and, per group of columns (the state's real
/// unknowns, the invariants, ...), a 2-D dataset of rows x columns with the columns' names in its attribute
/// `columns` (when there are at most max_named of them). The file's root attributes say what made it (format
/// "eci run series", version 1, and the caller's: model, method, ...). Rows are buffered and appended in chunks;
/// close() writes the rest and closes the file, checking every write (a full disk is run_error with the reason).
class h5_series {
   public:
    struct group {
        std::string name;                  ///< the dataset's name
        std::size_t width = 0;             ///< columns
        std::vector<std::string> columns;  ///< their names (may be empty: unnamed)
    };
    static constexpr std::size_t max_named = 100000;
    /// A root attribute: text, a real or a whole number.
    struct attribute {
        std::string name;
        std::variant<std::string, double, std::int64_t> value;
    };
    /// Creates `file` (the output's temporary) for the output `what` names in messages ("HDF5 output 'run.h5'");
    /// throws run_error, or bad_input in a build without HDF5.
    h5_series(const std::string& file, std::string_view what, std::vector<group> groups,
              std::vector<attribute> attributes);
    ~h5_series();
    h5_series(const h5_series&) = delete;
    h5_series& operator=(const h5_series&) = delete;

    /// One row: its time and one span of values per group, in the groups' order, each of the group's width.
    void add(double t, std::span<const std::span<const double>> values);
    /// Writes the buffered rows and closes the file; throws run_error on a failed write.
    void close();

   private:
    struct impl;
    std::unique_ptr<impl> d_;
};

/// Refuses (bad_input) an HDF5 --output this build cannot write: one without HDF5, or standard output, a device, a
/// FIFO or a socket (HDF5 writes a file it can seek). Nothing for any other path.
void check_hdf5_request(const std::string& path);

}  // namespace eci::cli
