// What the tests of eci::solve share (test_solve.cpp, test_solve_settings.cpp, test_first_step.cpp; the numeric
// tests' runs of listed models use its sinks): the paper's three-wave state and sinks. The three-wave runs go through eci::solve_model<eci::three_wave>, compiled once in
// eci_model_runs (linked into the unit tests) and run by the CLI and Python as well.
#pragma once

#include <cmath>
#include <limits>
#include <vector>

#include <eci/dynamic_sink.hpp>
#include <eci/eci.hpp>
#include <eci/models/three_wave.hpp>

namespace solve_tests {

using tw_state = eci::three_wave::state_type;
inline const tw_state fig5{std::sqrt(1.5), 1.0, std::sqrt(1.5)};

/// Keeps every output. A dynamic sink, so that the runs of the listed models are the compiled ones the front ends
/// run (eci::solve_model, src/models) and the tests compile none of them again.
template <class S>
struct keep_all final : eci::dynamic_sink<S> {
    std::vector<double> t;
    std::vector<S> x;
    std::vector<std::vector<double>> invariants;
    void output(const S& s, const eci::output_point& p) override {
        t.push_back(p.t);
        x.push_back(s);
        invariants.emplace_back(p.invariants.begin(), p.invariants.end());
    }
};

/// Keeps nothing (eci::no_sink as a dynamic sink).
template <class S>
struct discard final : eci::dynamic_sink<S> {
    void output(const S&, const eci::output_point&) override {}
};

using vec = std::vector<double>;

}  // namespace solve_tests
