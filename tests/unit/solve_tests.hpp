// What the tests of eci::solve share (test_solve.cpp, test_solve_settings.cpp): the paper's three-wave state and a
// sink that keeps every output.
#pragma once

#include <cmath>
#include <limits>
#include <vector>

#include <eci/eci.hpp>
#include <eci/models/three_wave.hpp>

namespace solve_tests {

using tw_state = eci::three_wave::state_type;
inline const tw_state fig5{std::sqrt(1.5), 1.0, std::sqrt(1.5)};

/// Keeps every output.
template <class S>
struct keep_all {
    std::vector<double> t;
    std::vector<S> x;
    std::vector<std::vector<double>> invariants;
    void output(const S& s, const eci::output_point& p) {
        t.push_back(p.t);
        x.push_back(s);
        invariants.emplace_back(p.invariants.begin(), p.invariants.end());
    }
};

using vec = std::vector<double>;

}  // namespace solve_tests
