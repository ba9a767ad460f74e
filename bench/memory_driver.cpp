// Peak resident memory of one stepper on a large n-wave system (independent triads), measured in its own process
// so that run.sh can compare C-PC with PC: `eci_bench_memory_driver <stepper> <modes> <steps>`.
#include <sys/resource.h>

#include <cstdio>
#include <cstdlib>
#include <string>

#include <eci/eci.hpp>
#include <eci/models/n_wave.hpp>

#include "bench_common.hpp"

namespace {

using state = std::vector<double>;
using model = eci::n_wave<double>;

long peak_rss_kib() {
    rusage u{};
    getrusage(RUSAGE_SELF, &u);
    return u.ru_maxrss;  // KiB on Linux
}

template <class Stepper>
void run(const model& m, state& x, unsigned long steps) {
    Stepper stepper;
    eci::bench::rhs<model> f{&m};
    eci::run_stats stats;
    for (unsigned long i = 0; i < steps; ++i) eci::step_with_reduction(stepper, f, x, double(i) * 1e-5, 1e-5, stats);
    std::printf("%zu", Stepper::buffer_count());
}

}  // namespace

int main(int argc, char** argv) {
    if (argc != 4) {
        std::fprintf(stderr, "usage: eci_bench_memory_driver <none|METHOD> <modes> <steps> (METHOD: a "
                             "method of `eci list` with '-' written '_', e.g. c_pc)\n");
        return 2;
    }
    const std::string name = argv[1];
    const unsigned long modes = std::strtoul(argv[2], nullptr, 10), steps = std::strtoul(argv[3], nullptr, 10);
    if (modes < 3 || modes % 3 != 0) {
        std::fprintf(stderr, "eci_bench_memory_driver: modes must be a positive multiple of 3\n");
        return 2;
    }
    // The stepper by its bench label, the registry's name with '-' written '_' (eci::identifier).
    std::string method;
    for (const eci::method_info& i : eci::methods)
        if (eci::identifier(i.name) == name) method = i.name;
    const model m = model::random(modes, 1, 1);
    state x = m.random_state(2);
    std::printf("%s buffers=", name.c_str());
    if (name == "none")
        std::printf("0");
    else if (!eci::with_stepper<state>(method, [&](auto stepper) { run<decltype(stepper)>(m, x, steps); })) {
        std::fprintf(stderr, "\neci_bench_memory_driver: unknown stepper %s\n", name.c_str());
        return 2;
    }
    double check = 0.0;  // keeps the state alive and the run honest
    for (double v : x) check += v * v;
    std::printf(" peak_rss_kib=%ld energy=%.17g\n", peak_rss_kib(), 0.5 * check);
    return 0;
}
