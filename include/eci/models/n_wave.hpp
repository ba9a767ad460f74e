// The n-wave generalization (paper §III.C): modes coupled by triads (k, p, q), each triad obeying eqs. (2)-(3),
// so that energy and enstrophy are conserved; real or complex amplitudes; a seeded random generator of any size,
// described (its settings, a default set-up) like the other models' parameters.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "../concepts.hpp"
#include "../memory.hpp"
#include "description.hpp"

namespace eci {

/// One triad: dpsi_k/dt += M_k psi_p psi_q and cyclically (for complex modes, the conjugate of the product).
struct triad {
    std::uint32_t k, p, q;
    double Mk, Mp, Mq;
};

/// A truncated spectral model of n real (T = double) or complex (T = std::complex<double>) modes.
template <scalar T>
struct n_wave {
    using state_type = std::vector<T>;
    static constexpr bool is_complex = std::same_as<T, std::complex<double>>;

    std::vector<double> wavenumber;  ///< |k| of each mode, the enstrophy weight's square root
    std::vector<triad> triads;

    /// `eci run n-wave` or `eci run n-wave-complex`.
    static constexpr std::string_view name = is_complex ? "n-wave-complex" : "n-wave";
    static constexpr std::string_view description =
        is_complex ? "n complex modes coupled by random triads obeying eqs. (2)-(3), section III.C; invariants "
                     "energy, enstrophy"
                   : "n real modes coupled by random triads obeying eqs. (2)-(3), section III.C; invariants energy, "
                     "enstrophy";

    /// What random() and random_state() draw from: the model's settings, in place of parameters.
    struct recipe {
        std::uint64_t modes = 30;
        std::uint64_t triads_per_mode = 20;
        std::uint64_t seed = 1;
    };
    /// The recipe's settings, with the smallest value random() accepts for each.
    static constexpr auto recipe_parameters() {
        return std::array<count_parameter<recipe>, 3>{{
            {"modes", "number of modes", 1, &recipe::modes},
            {"triads-per-mode", "triads each mode takes part in, about; 1 gives independent triads", 1,
             &recipe::triads_per_mode},
            {"seed", "seed of the random system and initial condition", 0, &recipe::seed},
        }};
    }
    /// About how many bytes a run of this recipe holds: the triads, the wavenumbers and eight states (the state,
    /// a stepper's buffers, checks); 0 for a recipe random() rejects anyway. Throws std::invalid_argument if the
    /// triad count overflows.
    static double bytes_needed(const recipe& r) {
        if (r.modes < 3 || (r.triads_per_mode == 1 && r.modes % 3 != 0)) return 0.0;
        const double triads = double(triad_count(r.modes, r.triads_per_mode));
        return triads * double(sizeof(triad)) + double(r.modes) * (double(sizeof(double)) + 8.0 * double(sizeof(T)));
    }
    /// The system and initial state a recipe draws; throws std::invalid_argument as random() does, and, before
    /// drawing anything, "the system needs about X GiB of memory, more than this machine's Y GiB" for a recipe
    /// whose bytes_needed exceed this machine's memory (every front end's refusal: check_fits_in_memory).
    static std::pair<n_wave, state_type> generate(const recipe& r) {
        check_fits_in_memory(bytes_needed(r), "the system");
        n_wave w = random(r.modes, r.triads_per_mode, r.seed);
        state_type x = w.random_state(r.seed);
        return {std::move(w), std::move(x)};
    }
    /// The default set-up (`eci run n-wave`): the default recipe, C-PC with dt 0.01 to t = 10.
    static std::array<preset<n_wave>, 1> presets() {
        auto [w, x] = generate(recipe{});
        return {{{"standard", "30 modes in about 20 triads each (seed 1), C-PC with dt 0.01 to t = 10", std::move(w),
                  std::move(x), "c-pc", 0.01, 10.0}}};
    }

    std::size_t size() const { return wavenumber.size(); }

    /// Throws std::invalid_argument unless the state has one element per mode (the right-hand side indexes it by
    /// the triads' modes: a shorter state was read and written past its end).
    void validate_state(const state_type& x) const {
        if (x.size() != size())
            throw std::invalid_argument("the state has " + std::to_string(x.size()) + " elements and the n-wave model " +
                                        std::to_string(size()) + " modes");
    }

    /// Throws std::invalid_argument for an out-of-range index or a triad violating eq. (2) or (3).
    void validate() const {
        const std::size_t n = size();
        for (double k : wavenumber) {
            detail::require_normal(k, "wavenumber");
            detail::require_representable(k * k, "a wavenumber's square", k != 0.0);
        }
        for (std::size_t i = 0; i < triads.size(); ++i) {
            const triad& t = triads[i];
            const auto name = [i] { return "triad " + std::to_string(i); };  // built only for a message
            if (t.k >= n || t.p >= n || t.q >= n) throw std::invalid_argument(name() + " refers to a missing mode");
            if (t.k == t.p || t.p == t.q || t.q == t.k) throw std::invalid_argument(name() + " repeats a mode");
            for (double m : {t.Mk, t.Mp, t.Mq}) detail::require_normal(m, [&] { return name() + " coefficient"; });
            detail::require_cancellation(t.Mk + t.Mp + t.Mq, std::abs(t.Mk) + std::abs(t.Mp) + std::abs(t.Mq),
                                         [&] { return name() + ": M_k + M_p + M_q (eq. 2)"; });
            const double k2 = sq(wavenumber[t.k]), p2 = sq(wavenumber[t.p]), q2 = sq(wavenumber[t.q]);
            for (double prod : {k2 * t.Mk, p2 * t.Mp, q2 * t.Mq})
                detail::require_representable(prod, [&] { return name() + ": a product k^2 M_k"; }, false);
            detail::require_cancellation(k2 * t.Mk + p2 * t.Mp + q2 * t.Mq,
                                         std::abs(k2 * t.Mk) + std::abs(p2 * t.Mp) + std::abs(q2 * t.Mq),
                                         [&] { return name() + ": k^2 M_k + p^2 M_p + q^2 M_q (eq. 3)"; });
        }
    }

    void operator()(const state_type& x, state_type& dxdt, double /*t*/) const {
        std::fill(dxdt.begin(), dxdt.end(), T{});
        for (const triad& t : triads) {
            if constexpr (is_complex) {
                // conj(a b), written out so that no library call handles infinities per element
                auto cprod = [](const T& a, const T& b) {
                    return T(a.real() * b.real() - a.imag() * b.imag(), -(a.real() * b.imag() + a.imag() * b.real()));
                };
                dxdt[t.k] += t.Mk * cprod(x[t.p], x[t.q]);
                dxdt[t.p] += t.Mp * cprod(x[t.q], x[t.k]);
                dxdt[t.q] += t.Mq * cprod(x[t.k], x[t.p]);
            } else {
                dxdt[t.k] += t.Mk * x[t.p] * x[t.q];
                dxdt[t.p] += t.Mp * x[t.q] * x[t.k];
                dxdt[t.q] += t.Mq * x[t.k] * x[t.p];
            }
        }
    }

    /// E = 1/2 sum |psi_k|^2, eqs. (4), (33).
    double energy(const state_type& x) const {
        double e = 0.0;
        for (const T& v : x) e += std::norm(v);
        return 0.5 * e;
    }
    /// Z = 1/2 sum k^2 |psi_k|^2, eqs. (5), (34).
    double enstrophy(const state_type& x) const {
        double z = 0.0;
        for (std::size_t i = 0; i < x.size(); ++i) z += sq(wavenumber[i]) * std::norm(x[i]);
        return 0.5 * z;
    }

    /// Energy and enstrophy as quadratic invariants sum_k w_jk |psi_k|^2, j in the order of invariants(): w_0k = 1/2
    /// and w_1k = k^2 / 2. Relaxation and projection, and the conservative steppers' remedy for negative radicands,
    /// take them from here.
    double quadratic_invariant_weight(std::size_t j, std::size_t k) const {
        return j == 0 ? 0.5 : 0.5 * sq(wavenumber[k]);
    }

    static constexpr auto invariants() {
        return std::array<named_invariant<n_wave>, 2>{
            {{"energy", &n_wave::energy}, {"enstrophy", &n_wave::enstrophy}}};
    }

    /// A random system of `modes` modes, each in about `triads_per_mode` triads; triads_per_mode == 1 gives
    /// independent triads (modes 3i, 3i+1, 3i+2; `modes` must then be a multiple of 3). Wavenumbers are drawn
    /// from [1, 10], and each triad's coefficients are proportional to (p^2 - q^2, q^2 - k^2, k^2 - p^2),
    /// which satisfies eqs. (2) and (3).
    static n_wave random(std::size_t modes, std::size_t triads_per_mode, std::uint64_t seed) {
        if (modes < 3) throw std::invalid_argument("an n-wave system needs at least 3 modes");
        if (modes > (std::size_t{1} << 32)) throw std::invalid_argument("too many modes for 32-bit triad indices");
        if (triads_per_mode == 0) throw std::invalid_argument("triads per mode must be at least 1");
        if (triads_per_mode == 1 && modes % 3 != 0)
            throw std::invalid_argument("independent triads need a number of modes divisible by 3");
        const std::size_t count = triad_count(modes, triads_per_mode);
        splitmix rng{seed};
        n_wave w;
        w.wavenumber.resize(modes);
        for (double& k : w.wavenumber) k = 1.0 + 9.0 * rng.uniform();
        w.triads.reserve(count);
        for (std::size_t i = 0; i < count; ++i) {
            std::uint32_t k, p, q;
            if (triads_per_mode == 1) {
                k = std::uint32_t(3 * i), p = k + 1, q = k + 2;
            } else {
                k = rng.below(modes);
                do p = rng.below(modes); while (p == k);
                do q = rng.below(modes); while (q == k || q == p);
            }
            const double k2 = sq(w.wavenumber[k]), p2 = sq(w.wavenumber[p]), q2 = sq(w.wavenumber[q]);
            const double mk = p2 - q2, mp = q2 - k2, mq = k2 - p2;
            const double scale = (rng.uniform() < 0.5 ? -1.0 : 1.0) /
                                 std::max({std::abs(mk), std::abs(mp), std::abs(mq), 1e-300});
            w.triads.push_back({k, p, q, scale * mk, scale * mp, scale * mq});
        }
        return w;
    }

    /// The number of triads random(modes, triads_per_mode, seed) builds: modes * triads_per_mode / 3 (modes / 3
    /// for independent triads), computed without overflow; throws std::invalid_argument if it exceeds what a
    /// std::vector<triad> can hold.
    static std::size_t triad_count(std::size_t modes, std::size_t triads_per_mode) {
        if (triads_per_mode == 1) return modes / 3;
        // modes * tpm / 3 exactly: split modes = 3 q + r, then q tpm + r tpm / 3, each checked.
        const std::size_t q = modes / 3, r = modes % 3;
        std::size_t a = 0, count = 0;
        if (__builtin_mul_overflow(q, triads_per_mode, &a) ||
            __builtin_add_overflow(a, r * (triads_per_mode / 3) + (r * (triads_per_mode % 3)) / 3, &count) ||
            count > std::vector<triad>().max_size())
            throw std::invalid_argument(std::to_string(modes) + " modes with " + std::to_string(triads_per_mode) +
                                        " triads per mode is more triads than memory can hold");
        return count;
    }

    /// A random initial state, every real unknown uniform in [-1, 1].
    state_type random_state(std::uint64_t seed) const {
        splitmix rng{seed};
        state_type x(size());
        for (T& v : x) {
            if constexpr (is_complex)
                v = T(2.0 * rng.uniform() - 1.0, 2.0 * rng.uniform() - 1.0);
            else
                v = 2.0 * rng.uniform() - 1.0;
        }
        return x;
    }

   private:
    static double sq(double v) { return v * v; }

    // A small, portable generator (SplitMix64) so a seed means the same system on every platform.
    struct splitmix {
        std::uint64_t s;
        std::uint64_t next() {
            std::uint64_t z = (s += 0x9E3779B97F4A7C15ull);
            z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
            z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
            return z ^ (z >> 31);
        }
        double uniform() { return double(next() >> 11) * 0x1.0p-53; }
        std::uint32_t below(std::size_t n) { return std::uint32_t(next() % n); }
    };
};

}  // namespace eci
