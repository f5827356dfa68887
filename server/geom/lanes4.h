/* Four lanes of doubles (GCC's vector extension): one AVX register, or two SSE ones. Code
 * written on them compiles once for the baseline and once more under
 * __attribute__((target("avx2"))), the same operations in the same order either way, so
 * each lane rounds as the scalar expression it mirrors does. */
#ifndef TRIOCT_LANES4_H
#define TRIOCT_LANES4_H

#include <stdint.h>
#include <string.h>

typedef double lanes4 __attribute__((vector_size(32)));
typedef long long mask4 __attribute__((vector_size(32)));
typedef int32_t ints4 __attribute__((vector_size(16)));
typedef uint8_t bytes16 __attribute__((vector_size(16)));

#define LOAD4(p) (__extension__({ lanes4 v_; memcpy(&v_, (p), sizeof v_); v_; }))
#define STORE4(p, v) (__extension__({ lanes4 w_ = (v); memcpy((p), &w_, sizeof w_); }))
/* m ? a : b lane by lane, by bits: the chosen value itself, unrounded. */
#define PICK4(m, a, b) ((lanes4)(((m) & (mask4)(a)) | (~(m) & (mask4)(b))))
#define ABS4(x) ((lanes4)((mask4)(x) & (mask4){INT64_MAX, INT64_MAX, INT64_MAX, INT64_MAX}))
/* Four bytes as doubles, exactly: each byte spread to the low end of a 32-bit lane (one
 * byte shuffle under AVX2), then converted. A macro, since a function returning a vector
 * would take a different calling convention in each target. */
/* __builtin_shufflevector (GCC 12 and clang alike): index 16 is the first byte of the zero
 * vector. */
#define LANES4_SPREAD_BYTES 0, 16, 16, 16, 1, 16, 16, 16, 2, 16, 16, 16, 3, 16, 16, 16
#define BYTES4(p)                                                                                            \
    (__extension__({                                                                                         \
        uint32_t w_;                                                                                         \
        memcpy(&w_, (p), sizeof w_);                                                                         \
        ints4 packed_ = {(int32_t)w_, 0, 0, 0};                                                              \
        __builtin_convertvector((ints4)__builtin_shufflevector((bytes16)packed_, (bytes16){0}, LANES4_SPREAD_BYTES), \
                                lanes4);                                                                     \
    }))

/* Bit k set where lane k of the mask is. */
#define BITS4(m) ((unsigned)(((m)[0] & 1) | ((m)[1] & 2) | ((m)[2] & 4) | ((m)[3] & 8)))

#endif
