// C-PC's finishing pass, and the common case of the conditioned update's, written with x86 SIMD intrinsics (SSE2, and AVX2 picked at run time), so that it is
// vectorized whatever flags the user compiles with: compilers vectorize std::sqrt only under -fno-math-errno.
#pragma once

#include <cmath>
#include <cstddef>
#include <limits>

#include "state_ops.hpp"

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>
#define ECI_DETAIL_X86_SIMD 1
#else
#define ECI_DETAIL_X86_SIMD 0
#endif

namespace eci::detail {

#if ECI_DETAIL_X86_SIMD
/// Whether the processor runs AVX2 (asked once).
inline bool cpu_has_avx2() {
    static const bool avx2 = [] {
        __builtin_cpu_init();
        return __builtin_cpu_supports("avx2") != 0;
    }();
    return avx2;
}
#endif

/// C-PC's finishing pass, eq. (30b) factorised: o holds psi~ and becomes sgn(psi~) sqrt(psi~ (x + dt S~)).
/// Returns the counts of negative (or NaN) and of infinite radicands. The reference loop: the vector versions
/// below perform the same IEEE operations in the same order (no FMA), so every version gives the same bits.
inline radicand_counts c_pc_finish_inline(double* o, const double* x, const double* k1, double dt, std::size_t n) {
    constexpr double most = std::numeric_limits<double>::max();
    radicand_counts c;
    for (std::size_t i = 0; i < n; ++i) {
        const double rad = o[i] * (x[i] + dt * k1[i]);
        c.negative += rad >= 0.0 ? 0.0 : 1.0;
        c.infinite += rad > most ? 1.0 : 0.0;
        o[i] = std::copysign(std::sqrt(rad), o[i]);
    }
    return c;
}

#if ECI_DETAIL_X86_SIMD
/// Two lanes (SSE2, every x86-64 processor).
inline radicand_counts c_pc_finish_sse2(double* o, const double* x, const double* k1, double dt, std::size_t n) {
    const __m128d step = _mm_set1_pd(dt), zero = _mm_setzero_pd(), sign = _mm_set1_pd(-0.0);
    const __m128d most = _mm_set1_pd(std::numeric_limits<double>::max());
    std::size_t bad = 0, inf = 0;
    std::size_t i = 0;
    for (; i + 2 <= n; i += 2) {
        const __m128d p = _mm_loadu_pd(o + i);
        const __m128d rad = _mm_mul_pd(p, _mm_add_pd(_mm_loadu_pd(x + i), _mm_mul_pd(step, _mm_loadu_pd(k1 + i))));
        bad += std::size_t(__builtin_popcount(unsigned(_mm_movemask_pd(_mm_cmpnge_pd(rad, zero)))));  // NaN: bad
        inf += std::size_t(__builtin_popcount(unsigned(_mm_movemask_pd(_mm_cmpgt_pd(rad, most)))));  // +inf
        const __m128d root = _mm_sqrt_pd(rad);
        _mm_storeu_pd(o + i, _mm_or_pd(_mm_andnot_pd(sign, root), _mm_and_pd(sign, p)));  // copysign(root, p)
    }
    radicand_counts c{double(bad), double(inf)};
    return c += c_pc_finish_inline(o + i, x + i, k1 + i, dt, n - i);
}

/// Four lanes (AVX2 without FMA, so it rounds like the others).
__attribute__((target("avx2"))) inline radicand_counts c_pc_finish_avx2(double* o, const double* x,
                                                                        const double* k1, double dt, std::size_t n) {
    const __m256d step = _mm256_set1_pd(dt), zero = _mm256_setzero_pd(), sign = _mm256_set1_pd(-0.0);
    const __m256d most = _mm256_set1_pd(std::numeric_limits<double>::max());
    std::size_t bad = 0, inf = 0;
    std::size_t i = 0;
    for (; i + 4 <= n; i += 4) {
        const __m256d p = _mm256_loadu_pd(o + i);
        const __m256d rad =
            _mm256_mul_pd(p, _mm256_add_pd(_mm256_loadu_pd(x + i), _mm256_mul_pd(step, _mm256_loadu_pd(k1 + i))));
        bad += std::size_t(__builtin_popcount(unsigned(_mm256_movemask_pd(_mm256_cmp_pd(rad, zero, _CMP_NGE_UQ)))));
        inf += std::size_t(__builtin_popcount(unsigned(_mm256_movemask_pd(_mm256_cmp_pd(rad, most, _CMP_GT_OQ)))));
        const __m256d root = _mm256_sqrt_pd(rad);
        _mm256_storeu_pd(o + i, _mm256_or_pd(_mm256_andnot_pd(sign, root), _mm256_and_pd(sign, p)));
    }
    radicand_counts c{double(bad), double(inf)};
    return c += c_pc_finish_inline(o + i, x + i, k1 + i, dt, n - i);
}
#endif

/// The same pass, vectorized for the processor it runs on (worth a call only for more than a few modes).
inline radicand_counts c_pc_finish(double* o, const double* x, const double* k1, double dt, std::size_t n) {
#if ECI_DETAIL_X86_SIMD
    return cpu_has_avx2() ? c_pc_finish_avx2(o, x, k1, dt, n) : c_pc_finish_sse2(o, x, k1, dt, n);
#else
    return c_pc_finish_inline(o, x, k1, dt, n);
#endif
}

/// The common case of the conditioned update's finishing pass for complex modes (radicand_remedy's
/// condition_block, Per = 2), over nb elements: x and c hold nb modes as (re, im) pairs (the state, the conventional
/// update), c2 = |c|^2 and xi one value per mode. For each mode it writes x2 = |x|^2, the ratio xi / |xi - x2|, the
/// kind (0: the conservative value, 1: that value and filed as ill-conditioned, 2: special, left to the caller: a
/// negative xi, no phase, or moduli within 2^-46), the conservative value c sqrt(xi) / |c| into o (garbage for
/// kind 2) and its |o|^2 into q. The reference loop; the vector versions below perform the same IEEE operations in
/// the same order (no FMA), so every version gives the same bits.
inline void condition_moduli_inline(double* o, double* q, double* x2v, double* ratio, unsigned char* kind,
                                    const double* x, const double* c, const double* c2, const double* xi,
                                    double kappa, std::size_t nb) {
    for (std::size_t b = 0; b < nb; ++b) {
        const double x2 = x[2 * b] * x[2 * b] + x[2 * b + 1] * x[2 * b + 1];
        const double v = xi[b], change = std::abs(v - x2);
        const bool plain = v >= 0.0 && c2[b] > 0.0 && !(std::abs(v - c2[b]) <= 0x1p-46 * v);
        const bool filed = v < kappa * change && std::abs(c2[b] - v) > 0x1p-40 * (c2[b] < v ? v : c2[b]);
        kind[b] = plain ? (filed ? 1 : 0) : 2;
        ratio[b] = v / change;
        x2v[b] = x2;
        const double root = std::sqrt(v), r = std::sqrt(c2[b]);
        const double o0 = root * (c[2 * b] / r), o1 = root * (c[2 * b + 1] / r);
        o[2 * b] = o0, o[2 * b + 1] = o1;
        q[b] = o0 * o0 + o1 * o1;
    }
}

#if ECI_DETAIL_X86_SIMD
/// Two modes at a time (SSE2).
inline void condition_moduli_sse2(double* o, double* q, double* x2v, double* ratio, unsigned char* kind,
                                  const double* x, const double* c, const double* c2, const double* xi, double kappa,
                                  std::size_t nb) {
    const __m128d zero = _mm_setzero_pd(), absmask = _mm_castsi128_pd(_mm_set1_epi64x(0x7fffffffffffffffLL));
    const __m128d k46 = _mm_set1_pd(0x1p-46), k40 = _mm_set1_pd(0x1p-40), kap = _mm_set1_pd(kappa);
    std::size_t b = 0;
    for (; b + 2 <= nb; b += 2) {
        const __m128d xa = _mm_loadu_pd(x + 2 * b), xb = _mm_loadu_pd(x + 2 * b + 2);
        const __m128d sa = _mm_mul_pd(xa, xa), sb = _mm_mul_pd(xb, xb);
        const __m128d x2 = _mm_add_pd(_mm_unpacklo_pd(sa, sb), _mm_unpackhi_pd(sa, sb));
        const __m128d v = _mm_loadu_pd(xi + b), cc = _mm_loadu_pd(c2 + b);
        const __m128d change = _mm_and_pd(_mm_sub_pd(v, x2), absmask);
        const __m128d plain = _mm_and_pd(_mm_and_pd(_mm_cmpge_pd(v, zero), _mm_cmpgt_pd(cc, zero)),
                                         _mm_cmpnle_pd(_mm_and_pd(_mm_sub_pd(v, cc), absmask), _mm_mul_pd(k46, v)));
        const __m128d mx = _mm_max_pd(cc, v);  // (cc > v ? cc : v: c2 < v ? v : c2 where neither is NaN)
        const __m128d filed = _mm_and_pd(_mm_cmplt_pd(v, _mm_mul_pd(kap, change)),
                                         _mm_cmpgt_pd(_mm_and_pd(_mm_sub_pd(cc, v), absmask), _mm_mul_pd(k40, mx)));
        const int pm = _mm_movemask_pd(plain), fm = _mm_movemask_pd(filed);
        for (int l = 0; l < 2; ++l)
            kind[b + std::size_t(l)] = (pm >> l & 1) ? ((fm >> l & 1) ? 1 : 0) : 2;
        _mm_storeu_pd(ratio + b, _mm_div_pd(v, change));
        _mm_storeu_pd(x2v + b, x2);
        const __m128d root = _mm_sqrt_pd(v), r = _mm_sqrt_pd(cc);
        const __m128d ca = _mm_loadu_pd(c + 2 * b), cb = _mm_loadu_pd(c + 2 * b + 2);
        const __m128d oa = _mm_mul_pd(_mm_unpacklo_pd(root, root), _mm_div_pd(ca, _mm_unpacklo_pd(r, r)));
        const __m128d ob = _mm_mul_pd(_mm_unpackhi_pd(root, root), _mm_div_pd(cb, _mm_unpackhi_pd(r, r)));
        _mm_storeu_pd(o + 2 * b, oa), _mm_storeu_pd(o + 2 * b + 2, ob);
        const __m128d qa = _mm_mul_pd(oa, oa), qb = _mm_mul_pd(ob, ob);
        _mm_storeu_pd(q + b, _mm_add_pd(_mm_unpacklo_pd(qa, qb), _mm_unpackhi_pd(qa, qb)));
    }
    condition_moduli_inline(o + 2 * b, q + b, x2v + b, ratio + b, kind + b, x + 2 * b, c + 2 * b, c2 + b, xi + b, kappa,
                            nb - b);
}

/// Four modes at a time (AVX2 without FMA, so it rounds like the others).
__attribute__((target("avx2"))) inline void condition_moduli_avx2(double* o, double* q, double* x2v, double* ratio,
                                                                  unsigned char* kind, const double* x,
                                                                  const double* c, const double* c2, const double* xi,
                                                                  double kappa, std::size_t nb) {
    const __m256d zero = _mm256_setzero_pd(),
                  absmask = _mm256_castsi256_pd(_mm256_set1_epi64x(0x7fffffffffffffffLL));
    const __m256d k46 = _mm256_set1_pd(0x1p-46), k40 = _mm256_set1_pd(0x1p-40), kap = _mm256_set1_pd(kappa);
    std::size_t b = 0;
    for (; b + 4 <= nb; b += 4) {
        // modes (0, 1) and (2, 3) as (re, im) pairs; hadd gives the pairs' sums in the order (0, 2, 1, 3)
        const __m256d xa = _mm256_loadu_pd(x + 2 * b), xb = _mm256_loadu_pd(x + 2 * b + 4);
        const __m256d x2 =
            _mm256_permute4x64_pd(_mm256_hadd_pd(_mm256_mul_pd(xa, xa), _mm256_mul_pd(xb, xb)), 0xD8);
        const __m256d v = _mm256_loadu_pd(xi + b), cc = _mm256_loadu_pd(c2 + b);
        const __m256d change = _mm256_and_pd(_mm256_sub_pd(v, x2), absmask);
        const __m256d plain = _mm256_and_pd(
            _mm256_and_pd(_mm256_cmp_pd(v, zero, _CMP_GE_OQ), _mm256_cmp_pd(cc, zero, _CMP_GT_OQ)),
            _mm256_cmp_pd(_mm256_and_pd(_mm256_sub_pd(v, cc), absmask), _mm256_mul_pd(k46, v), _CMP_NLE_UQ));
        const __m256d mx = _mm256_max_pd(cc, v);
        const __m256d filed = _mm256_and_pd(
            _mm256_cmp_pd(v, _mm256_mul_pd(kap, change), _CMP_LT_OQ),
            _mm256_cmp_pd(_mm256_and_pd(_mm256_sub_pd(cc, v), absmask), _mm256_mul_pd(k40, mx), _CMP_GT_OQ));
        const int pm = _mm256_movemask_pd(plain), fm = _mm256_movemask_pd(filed);
        for (int l = 0; l < 4; ++l)
            kind[b + std::size_t(l)] = (pm >> l & 1) ? ((fm >> l & 1) ? 1 : 0) : 2;
        _mm256_storeu_pd(ratio + b, _mm256_div_pd(v, change));
        _mm256_storeu_pd(x2v + b, x2);
        const __m256d root = _mm256_sqrt_pd(v), r = _mm256_sqrt_pd(cc);
        const __m256d ca = _mm256_loadu_pd(c + 2 * b), cb = _mm256_loadu_pd(c + 2 * b + 4);
        const __m256d oa = _mm256_mul_pd(_mm256_permute4x64_pd(root, 0x50),
                                         _mm256_div_pd(ca, _mm256_permute4x64_pd(r, 0x50)));  // (0, 0, 1, 1)
        const __m256d ob = _mm256_mul_pd(_mm256_permute4x64_pd(root, 0xFA),
                                         _mm256_div_pd(cb, _mm256_permute4x64_pd(r, 0xFA)));  // (2, 2, 3, 3)
        _mm256_storeu_pd(o + 2 * b, oa), _mm256_storeu_pd(o + 2 * b + 4, ob);
        _mm256_storeu_pd(q + b, _mm256_permute4x64_pd(
                                    _mm256_hadd_pd(_mm256_mul_pd(oa, oa), _mm256_mul_pd(ob, ob)), 0xD8));
    }
    condition_moduli_sse2(o + 2 * b, q + b, x2v + b, ratio + b, kind + b, x + 2 * b, c + 2 * b, c2 + b, xi + b, kappa,
                          nb - b);
}
#endif

/// The same, vectorized for the processor it runs on.
inline void condition_moduli(double* o, double* q, double* x2v, double* ratio, unsigned char* kind, const double* x,
                             const double* c, const double* c2, const double* xi, double kappa, std::size_t nb) {
#if ECI_DETAIL_X86_SIMD
    if (cpu_has_avx2())
        condition_moduli_avx2(o, q, x2v, ratio, kind, x, c, c2, xi, kappa, nb);
    else
        condition_moduli_sse2(o, q, x2v, ratio, kind, x, c, c2, xi, kappa, nb);
#else
    condition_moduli_inline(o, q, x2v, ratio, kind, x, c, c2, xi, kappa, nb);
#endif
}

}  // namespace eci::detail
