// Per-step cost of every eci stepper and of Boost.Odeint's RK4 and Heun on identical work: the three-wave model
// and random n-wave systems (in cache and memory bound, cheap and realistic right-hand sides). run.sh turns the
// medians into ratios. Own flags: --eci_big=N (modes of the large systems), --eci_min_time=S (per repetition),
// --eci_big_realistic_reps=R (repetitions of the large system with 20 triads per mode, seconds per step).
#include <benchmark/benchmark.h>

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include <eci/eci.hpp>
#include <eci/models/n_wave.hpp>
#include <eci/models/three_wave.hpp>
#include <eci/steppers/compensated_c_pc.hpp>

#include "bench_common.hpp"

namespace {

using namespace eci::bench;

// Small enough that a negative radicand (a mode crossing zero within O(dt^2) of the predictor) is rare even
// among 3e6 modes; failed steps are retried as two half steps like the driver does, and counted.
constexpr double dt = 1e-5;

template <class Model>
struct problem {
    Model model;
    typename Model::state_type x0;
};

// Both harnesses are flattened: everything they call is inlined into the timed loop, so neither library's step
// depends on the compiler's inlining heuristics (which otherwise outlined odeint's step once it had two callers).
template <class Model, class Stepper>
[[gnu::flatten]] void run_eci(benchmark::State& bs, const problem<Model>* pb) {
    Stepper stepper;
    auto x = pb->x0;
    rhs<Model> f{&pb->model};
    eci::run_stats stats;
    double t = 0.0;
    // One untimed step first: it sizes (and page-faults in) the stepper's buffers, which a large system's
    // few timed iterations would otherwise pay for.
    eci::detail::advance_with_reduction(stepper, f, x, t, dt, 40, stats);
    t += dt;
    stats = {};
    for (auto _ : bs) {
        eci::detail::advance_with_reduction(stepper, f, x, t, dt, 40, stats);
        t += dt;
        benchmark::DoNotOptimize(x.data());
        benchmark::ClobberMemory();
    }
    bs.counters["reductions"] = double(stats.step_reductions);
    bs.counters["buffers"] = double(Stepper::buffer_count());
}

template <class Model, class Stepper, class Make>
[[gnu::flatten]] void run_odeint(benchmark::State& bs, const problem<Model>* pb, Make make) {
    Stepper stepper = make();
    auto x = pb->x0;
    rhs<Model> f{&pb->model};
    double t = 0.0;
    stepper.do_step(f, x, t, dt);  // untimed, as for eci: odeint's resizer allocates on the first step
    t += dt;
    for (auto _ : bs) {
        stepper.do_step(f, x, t, dt);
        t += dt;
        benchmark::DoNotOptimize(x.data());
        benchmark::ClobberMemory();
    }
}

// `reps` > 0 overrides --benchmark_repetitions (the large realistic system takes seconds per step); `all` = false
// leaves out the informational C-Euler and compensated C-PC there.
template <class Model>
void register_problem(const std::string& name, const problem<Model>* pb, double min_time, int reps = 0,
                      bool all = true) {
    using S = typename Model::state_type;
    auto add = [&](const std::string& method, auto fn) {
        auto* b = benchmark::RegisterBenchmark((name + "/" + method).c_str(), fn, pb)->MinTime(min_time);
        if (reps > 0) b->Repetitions(reps);
    };
    add("euler", run_eci<Model, eci::euler<S>>);
    if (all) add("c_euler", run_eci<Model, eci::c_euler<S>>);
    add("pc", run_eci<Model, eci::pc<S>>);
    add("c_pc", run_eci<Model, eci::c_pc<S>>);
    if (all) add("c_pc_compensated", run_eci<Model, eci::compensated_c_pc<S>>);
    add("rk4", run_eci<Model, eci::rk4<S>>);
    add("c_rk4", run_eci<Model, eci::c_rk4<S>>);
    add("odeint_rk4", [](benchmark::State& bs, const problem<Model>* p) {
        run_odeint<Model, odeint_rk4<S>>(bs, p, [] { return odeint_rk4<S>(); });
    });
    add("odeint_heun", [](benchmark::State& bs, const problem<Model>* p) {
        run_odeint<Model, odeint_heun<S>>(bs, p, [] { return make_odeint_heun<S>(); });
    });
}

std::unique_ptr<problem<eci::n_wave<double>>> make_n_wave(std::size_t modes, std::size_t per_mode) {
    auto pb = std::make_unique<problem<eci::n_wave<double>>>();
    pb->model = eci::n_wave<double>::random(modes, per_mode, 12345);
    pb->x0 = pb->model.random_state(678);
    return pb;
}

}  // namespace

int main(int argc, char** argv) {
    benchmark::Initialize(&argc, argv);
    std::size_t big = 3000000;
    double min_time = 0.2;
    int big_realistic_reps = 0;
    for (int i = 1; i < argc; ++i) {
        if (std::strncmp(argv[i], "--eci_big=", 10) == 0) {
            big = std::strtoull(argv[i] + 10, nullptr, 10);
        } else if (std::strncmp(argv[i], "--eci_big_realistic_reps=", 25) == 0) {
            big_realistic_reps = std::atoi(argv[i] + 25);
        } else if (std::strncmp(argv[i], "--eci_min_time=", 15) == 0) {
            min_time = std::strtod(argv[i] + 15, nullptr);
        } else {
            std::fprintf(stderr, "eci_bench_step: unknown argument %s\n", argv[i]);
            return 2;
        }
    }
    if (big < 3 || big % 3 != 0 || !(min_time > 0.0)) {
        std::fprintf(stderr, "eci_bench_step: --eci_big must be a multiple of 3, --eci_min_time positive\n");
        return 2;
    }
    problem<eci::three_wave> three{eci::three_wave{}, {1.0, 0.5, -0.25}};
    register_problem("three_wave", &three, min_time);
    std::vector<std::unique_ptr<problem<eci::n_wave<double>>>> keep;
    for (std::size_t modes : {std::size_t{3000}, big}) {
        if (modes == 3000 && big == 3000) continue;
        for (std::size_t per_mode : {std::size_t{1}, std::size_t{20}}) {
            const bool slow = modes == big && per_mode == 20;
            keep.push_back(make_n_wave(modes, per_mode));
            register_problem("nwave_" + std::to_string(modes) + "_t" + std::to_string(per_mode), keep.back().get(),
                             min_time, slow ? big_realistic_reps : 0, !slow);
        }
    }
    benchmark::RunSpecifiedBenchmarks();
    benchmark::Shutdown();
    return 0;
}
