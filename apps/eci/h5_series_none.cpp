// h5_series (h5_series.hpp) in a build without HDF5 (no spectral equations): an HDF5 --output is refused.
#include "h5_series.hpp"


#include "output.hpp"

namespace eci::cli {

void check_hdf5_request(const std::string& path) {
    if (is_hdf5_path(path))
        throw bad_input("--output '" + path + "': this eci was built without HDF5 (it comes with the spectral "
                        "equations: FFTW3 and libhdf5-dev); write a CSV instead");
}

struct h5_series::impl {};

h5_series::h5_series(const std::string&, std::string_view, std::vector<group>, std::vector<attribute>) {
    throw bad_input("this eci was built without HDF5");
}
h5_series::~h5_series() = default;
void h5_series::add(double, std::span<const std::span<const double>>) {}
void h5_series::close() {}

}  // namespace eci::cli
