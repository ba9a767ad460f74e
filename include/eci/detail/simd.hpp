// C-PC's finishing pass written with x86 SIMD intrinsics (SSE2, and AVX2 picked at run time), so that it is
// vectorized whatever flags the user compiles with: compilers vectorize std::sqrt only under -fno-math-errno.
#pragma once

#include <cmath>
#include <cstddef>

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>
#define ECI_DETAIL_X86_SIMD 1
#else
#define ECI_DETAIL_X86_SIMD 0
#endif

namespace eci::detail {

/// C-PC's finishing pass, eq. (30b) factorised: o holds psi~ and becomes sgn(psi~) sqrt(psi~ (x + dt S~)).
/// Returns the number of negative (or NaN) radicands, as a double. The reference loop: the vector versions
/// below perform the same IEEE operations in the same order (no FMA), so every version gives the same bits.
inline double c_pc_finish_inline(double* o, const double* x, const double* k1, double dt, std::size_t n) {
    double bad = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
        const double rad = o[i] * (x[i] + dt * k1[i]);
        bad += rad >= 0.0 ? 0.0 : 1.0;
        o[i] = std::copysign(std::sqrt(rad), o[i]);
    }
    return bad;
}

#if ECI_DETAIL_X86_SIMD
/// Two lanes (SSE2, every x86-64 processor).
inline double c_pc_finish_sse2(double* o, const double* x, const double* k1, double dt, std::size_t n) {
    const __m128d step = _mm_set1_pd(dt), zero = _mm_setzero_pd(), sign = _mm_set1_pd(-0.0);
    int bad = 0;
    std::size_t i = 0;
    for (; i + 2 <= n; i += 2) {
        const __m128d p = _mm_loadu_pd(o + i);
        const __m128d rad = _mm_mul_pd(p, _mm_add_pd(_mm_loadu_pd(x + i), _mm_mul_pd(step, _mm_loadu_pd(k1 + i))));
        bad += __builtin_popcount(unsigned(_mm_movemask_pd(_mm_cmpnge_pd(rad, zero))));  // NaN counts as bad
        const __m128d root = _mm_sqrt_pd(rad);
        _mm_storeu_pd(o + i, _mm_or_pd(_mm_andnot_pd(sign, root), _mm_and_pd(sign, p)));  // copysign(root, p)
    }
    return double(bad) + c_pc_finish_inline(o + i, x + i, k1 + i, dt, n - i);
}

/// Four lanes (AVX2 without FMA, so it rounds like the others).
__attribute__((target("avx2"))) inline double c_pc_finish_avx2(double* o, const double* x, const double* k1,
                                                               double dt, std::size_t n) {
    const __m256d step = _mm256_set1_pd(dt), zero = _mm256_setzero_pd(), sign = _mm256_set1_pd(-0.0);
    int bad = 0;
    std::size_t i = 0;
    for (; i + 4 <= n; i += 4) {
        const __m256d p = _mm256_loadu_pd(o + i);
        const __m256d rad =
            _mm256_mul_pd(p, _mm256_add_pd(_mm256_loadu_pd(x + i), _mm256_mul_pd(step, _mm256_loadu_pd(k1 + i))));
        bad += __builtin_popcount(unsigned(_mm256_movemask_pd(_mm256_cmp_pd(rad, zero, _CMP_NGE_UQ))));
        const __m256d root = _mm256_sqrt_pd(rad);
        _mm256_storeu_pd(o + i, _mm256_or_pd(_mm256_andnot_pd(sign, root), _mm256_and_pd(sign, p)));
    }
    return double(bad) + c_pc_finish_inline(o + i, x + i, k1 + i, dt, n - i);
}
#endif

/// The same pass, vectorized for the processor it runs on (worth a call only for more than a few modes).
inline double c_pc_finish(double* o, const double* x, const double* k1, double dt, std::size_t n) {
#if ECI_DETAIL_X86_SIMD
    static const bool avx2 = [] {
        __builtin_cpu_init();
        return __builtin_cpu_supports("avx2") != 0;
    }();
    return avx2 ? c_pc_finish_avx2(o, x, k1, dt, n) : c_pc_finish_sse2(o, x, k1, dt, n);
#else
    return c_pc_finish_inline(o, x, k1, dt, n);
#endif
}

}  // namespace eci::detail
