// The tests' check that a conservative step is the conventional step rescaled (radicand_remedy::rescale_conventional):
// each element's s_e = |c_e|^2 / |r_e|^2 - 1 (c the conservative step, r the conventional one) must lie on one plane
// s_e = c_E w_E,e + c_Z w_Z,e in the two invariants' weights.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

namespace eci::test {

struct rescale_fit {
    double ce = 0.0, cz = 0.0;  // the fitted coefficients
    double worst = 0.0;         // the largest |s_e - (ce w_E,e + cz w_Z,e)|
    double smax = 0.0;          // the largest |s_e|: how large a rescale the fit saw
};

// s_e / w_Z,e = c_E (w_E,e / w_Z,e) + c_Z: a line in w_E,e / w_Z,e, fitted by least squares over the elements (each
// s_e carries a few roundings of the ratio, ~eps, against a rescale of 1e-7 ... 1e-4 in the tests). w_Z,e != 0.
inline rescale_fit fit_rescale(const std::vector<double>& s, const std::vector<double>& we,
                               const std::vector<double>& wz) {
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    const double n = double(s.size());
    for (std::size_t j = 0; j < s.size(); ++j) {
        const double x = we[j] / wz[j], y = s[j] / wz[j];
        sx += x, sy += y, sxx += x * x, sxy += x * y;
    }
    rescale_fit f;
    f.ce = (n * sxy - sx * sy) / (n * sxx - sx * sx), f.cz = (sy - f.ce * sx) / n;
    for (std::size_t j = 0; j < s.size(); ++j) {
        f.worst = std::max(f.worst, std::abs(s[j] - (f.ce * we[j] + f.cz * wz[j])));
        f.smax = std::max(f.smax, std::abs(s[j]));
    }
    return f;
}

}  // namespace eci::test
