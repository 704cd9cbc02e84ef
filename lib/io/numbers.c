/* pgem I/O numbers: decimal text to double and double to the shortest text that reads back to
 * the same bits, both exact and several times faster than strtod and printf("%.17g").
 *
 * Reading (io_strtod) takes plain decimals of at most 19 significant digits whose value is
 * w x 10^q with |q| <= 27: w and 5^|q| are integers of at most 64 bits, so the value is an
 * exact rational that 128-bit integer arithmetic rounds once, to nearest even, as strtod does
 * (and with w <= 2^53, |q| <= 22, one double multiplication or division does the same).
 * Everything else (more digits, other exponents, hexadecimal, inf, nan, bad text) goes to
 * strtod itself, so the result, the end pointer and errno are strtod's for every input.
 *
 * Writing (io_format_double) finds the shortest decimal inside the interval of reals that
 * read back to the double (Ryu's digit removal, Ulf Adams 2018, over exact scaled bounds
 * computed with the same 128-bit arithmetic instead of Ryu's tables), for doubles from about
 * 1e-9 to 1e45, and integers below 2^53 by their own digits (half the numbers of a g2o file:
 * the information matrices); the others are written with "%.17g", which also reads back
 * exactly. The text
 * is laid out as %.17g lays out its digits (fixed for decimal exponents -4 .. 16, else d.ddde+XX).
 * Without a 128-bit integer type (32-bit hosts) both fall back to the C library throughout. */
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "io_internal.h"

#if defined(__SIZEOF_INT128__)
#define IO_EXACT 1
typedef unsigned __int128 io_u128;
#else
#define IO_EXACT 0
#endif

#define IO_POW5_MAX 27 /* 5^27 < 2^63 */

/* Double operations round once only where the compiler evaluates in double precision. */
#if defined(FLT_EVAL_METHOD) && FLT_EVAL_METHOD == 0
#define IO_CLINGER 1
#else
#define IO_CLINGER 0
#endif

#if IO_EXACT
/* The powers of ten a double holds exactly. */
static const double io_exact_pow10[23] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,
                                          1e8,  1e9,  1e10, 1e11, 1e12, 1e13, 1e14, 1e15,
                                          1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};
#endif

#if IO_EXACT

/* 5^k for k = 0 .. IO_POW5_MAX. */
static uint64_t io_pow5(int k)
{
    static const uint64_t table[IO_POW5_MAX + 1] = {
        1u, 5u, 25u, 125u, 625u, 3125u, 15625u, 78125u, 390625u, 1953125u, 9765625u,
        48828125u, 244140625u, 1220703125u, UINT64_C(6103515625), UINT64_C(30517578125),
        UINT64_C(152587890625), UINT64_C(762939453125), UINT64_C(3814697265625),
        UINT64_C(19073486328125), UINT64_C(95367431640625), UINT64_C(476837158203125),
        UINT64_C(2384185791015625), UINT64_C(11920928955078125), UINT64_C(59604644775390625),
        UINT64_C(298023223876953125), UINT64_C(1490116119384765625),
        UINT64_C(7450580596923828125)};
    return table[k];
}

/* Bits of x (0 for 0): at most 128. */
static int io_bits128(io_u128 x)
{
    const uint64_t high = (uint64_t)(x >> 64), low = (uint64_t)x;
    if (high != 0) {
        return 128 - __builtin_clzll(high);
    }
    return low != 0 ? 64 - __builtin_clzll(low) : 0;
}

/* The double nearest (ties to even) to x * 2^exponent, x > 0, sticky: whether nonzero bits
 * were already dropped below x. The result is a normal double in the range io_strtod uses. */
static double io_round(io_u128 x, int exponent, int sticky)
{
    const int bits = io_bits128(x);
    uint64_t mantissa;
    if (bits > 53) {
        const int drop = bits - 53;
        const io_u128 rest = x & (((io_u128)1 << drop) - 1u);
        const io_u128 half = (io_u128)1 << (drop - 1);
        mantissa = (uint64_t)(x >> drop);
        exponent += drop;
        if (rest > half || (rest == half && (sticky || (mantissa & 1u) != 0))) {
            mantissa++;
            if (mantissa >> 53 != 0) {
                mantissa >>= 1;
                exponent++;
            }
        }
    } else {
        mantissa = (uint64_t)x; /* exact (sticky cannot be set: the callers scale first) */
    }
    return ldexp((double)mantissa, exponent);
}

/* The exact value of a plain decimal w x 10^q, |q| <= IO_POW5_MAX, w > 0. */
static double io_decimal_value(uint64_t w, int q)
{
    if (q >= 0) { /* w 5^q 2^q: an integer of at most 127 bits */
        return io_round((io_u128)w * io_pow5(q), q, 0);
    }
    /* w / 5^p / 2^p: w shifted to the top of 128 bits, divided, the remainder sticky */
    const int p = -q;
    int shift = 64;
    uint64_t top = w;
    while ((top >> 63) == 0) {
        top <<= 1;
        shift++;
    }
    const io_u128 numerator = (io_u128)top << 64;
    const io_u128 quotient = numerator / io_pow5(p);
    const int sticky = numerator % io_pow5(p) != 0;
    return io_round(quotient, -(shift + p), sticky);
}

#endif

#if IO_EXACT

/* Parses [+-]digits[.digits][(e|E)[+-]digits] into w, q; 0 if the text is anything else or
 * needs more than 19 significant digits. */
static int io_plain_decimal(const char *text, int *negative, uint64_t *w, int *q)
{
    const char *p = text;
    *negative = *p == '-';
    if (*p == '-' || *p == '+') {
        p++;
    }
    uint64_t value = 0;
    int digits = 0, significant = 0, exponent = 0;
    for (; *p >= '0' && *p <= '9'; p++, digits++) {
        if (significant < 19) {
            value = value * 10u + (uint64_t)(*p - '0');
            significant += value != 0;
        } else if (*p != '0') {
            return 0;
        } else {
            exponent++;
        }
    }
    if (*p == '.') {
        for (p++; *p >= '0' && *p <= '9'; p++, digits++) {
            if (significant < 19) {
                value = value * 10u + (uint64_t)(*p - '0');
                significant += value != 0;
                exponent--;
            } else if (*p != '0') {
                return 0;
            }
        }
    }
    if (digits == 0) {
        return 0;
    }
    if (*p == 'e' || *p == 'E') {
        p++;
        const int minus = *p == '-';
        if (*p == '-' || *p == '+') {
            p++;
        }
        if (*p < '0' || *p > '9') {
            return 0;
        }
        int e = 0;
        for (; *p >= '0' && *p <= '9'; p++) {
            if (e > 10000) {
                return 0;
            }
            e = e * 10 + (*p - '0');
        }
        exponent += minus ? -e : e;
    }
    if (*p != '\0') {
        return 0;
    }
    *w = value;
    *q = exponent;
    return 1;
}

#endif

double io_strtod(const char *text, char **end)
{
#if IO_EXACT
    int negative, q;
    uint64_t w;
    if (io_plain_decimal(text, &negative, &w, &q)) {
        double value;
        if (w == 0) {
            value = 0.0;
        } else if (IO_CLINGER && w <= (UINT64_C(1) << 53) && q >= -22 && q <= 22) {
            /* w and 10^|q| are exact doubles: one correctly rounded operation (Clinger) */
            value = q >= 0 ? (double)w * io_exact_pow10[q] : (double)w / io_exact_pow10[-q];
        } else if (q >= -IO_POW5_MAX && q <= IO_POW5_MAX) {
            value = io_decimal_value(w, q);
        } else {
            return strtod(text, end);
        }
        if (end != NULL) {
            *end = strchr(text, '\0'); /* strtod's type: the end of the text */
        }
        return negative ? -value : value;
    }
#endif
    return strtod(text, end);
}

#if IO_EXACT

/* floor(e log10(2)) for |e| <= 1650. */
static int io_log10_pow2(int e)
{
    return (int)(((int64_t)e * 78913) >> 18);
}

/* floor(x 2^e2 10^-q) and (in *exact) whether that was exact, for the q io_shortest chooses
 * (|q| <= IO_POW5_MAX, x < 2^55; the result fits 64 bits). */
static uint64_t io_scale(uint64_t x, int e2, int q, int *exact)
{
    io_u128 n;
    if (q <= 0) {
        n = (io_u128)x * io_pow5(-q);
        const int shift = e2 - q;
        if (shift >= 0) {
            *exact = 1;
            return (uint64_t)(n << shift);
        }
        *exact = (n & (((io_u128)1 << -shift) - 1u)) == 0;
        return (uint64_t)(n >> -shift);
    }
    n = (io_u128)x << (e2 - q);
    *exact = n % io_pow5(q) == 0;
    return (uint64_t)(n / io_pow5(q));
}

/* One digit off the three scaled bounds, tracking the last digit removed from vr and whether
 * all removed before it were zeros. */
static void io_drop_digit(uint64_t *vr, uint64_t *vp, uint64_t *vm, int *last, int *vr_zeros)
{
    *vr_zeros &= *last == 0;
    *last = (int)(*vr % 10u);
    *vr /= 10u;
    *vp /= 10u;
    *vm /= 10u;
}

/* The shortest digits of a positive normal double: *digits x 10^*exponent. 0 if outside the
 * range the exact scaling covers. */
static int io_shortest(uint64_t mantissa_bits, int exponent_bits, uint64_t *digits, int *exponent)
{
    const uint64_t m2 = (UINT64_C(1) << 52) | mantissa_bits;
    const int e2 = exponent_bits - 1075 - 2;
    const int q = io_log10_pow2(e2 + 55) - 18;
    if (q < -IO_POW5_MAX || q > IO_POW5_MAX) {
        return 0;
    }
    const int accept_bounds = (m2 & 1u) == 0;
    const int mm_shift = mantissa_bits != 0 || exponent_bits <= 1;
    const uint64_t mv = 4u * m2, mp = 4u * m2 + 2u, mm = 4u * m2 - 1u - (uint64_t)mm_shift;
    int vr_exact, vp_exact, vm_exact;
    uint64_t vr = io_scale(mv, e2, q, &vr_exact);
    uint64_t vp = io_scale(mp, e2, q, &vp_exact);
    uint64_t vm = io_scale(mm, e2, q, &vm_exact);
    int vm_trailing_zeros = accept_bounds && vm_exact;
    int vr_trailing_zeros = vr_exact;
    if (!accept_bounds && vp_exact) {
        vp--; /* the upper bound itself reads back to the neighbour */
    }
    int removed = 0, last = 0;
    if (!vm_trailing_zeros && !vr_trailing_zeros) {
        /* the common case: no exactness to track, so only the last digit removed decides the
         * rounding: the digits go eight, four, two and one at a time while they can */
        int round_up = 0;
        while (vp / 100u > vm / 100u) {
            round_up = vr % 100u >= 50u;
            vr /= 100u;
            vp /= 100u;
            vm /= 100u;
            removed += 2;
        }
        while (vp / 10u > vm / 10u) {
            round_up = vr % 10u >= 5u;
            vr /= 10u;
            vp /= 10u;
            vm /= 10u;
            removed++;
        }
        *digits = vr + (vr == vm || round_up);
        *exponent = q + removed;
        return 1;
    }
    while (vp / 10u > vm / 10u) {
        vm_trailing_zeros &= vm % 10u == 0;
        io_drop_digit(&vr, &vp, &vm, &last, &vr_trailing_zeros);
        removed++;
    }
    if (vm_trailing_zeros) {
        while (vm != 0 && vm % 10u == 0) {
            io_drop_digit(&vr, &vp, &vm, &last, &vr_trailing_zeros);
            removed++;
        }
    }
    if (vr_trailing_zeros && last == 5 && vr % 2u == 0) {
        last = 4; /* exactly halfway: round to even */
    }
    *digits = vr + ((vr == vm && (!accept_bounds || !vm_trailing_zeros)) || last >= 5);
    *exponent = q + removed;
    return 1;
}

/* Decimal digits of v (1 .. 20). */
static int io_digit_count(uint64_t v)
{
    int count = 1;
    if (v >= UINT64_C(10000000000000000)) {
        v /= UINT64_C(10000000000000000);
        count += 16;
    }
    if (v >= 100000000u) {
        v /= 100000000u;
        count += 8;
    }
    if (v >= 10000u) {
        v /= 10000u;
        count += 4;
    }
    if (v >= 100u) {
        v /= 100u;
        count += 2;
    }
    return count + (v >= 10u);
}

/* v's count decimal digits into text, two at a time from the last. */
static void io_digits(uint64_t v, int count, char *text)
{
    static const char pairs[] = "00010203040506070809101112131415161718192021222324252627282930313233343536373839"
                                "40414243444546474849505152535455565758596061626364656667686970717273747576777879"
                                "8081828384858687888990919293949596979899";
    int at = count;
    while (at >= 2) {
        const unsigned pair = (unsigned)(v % 100u);
        v /= 100u;
        at -= 2;
        text[at] = pairs[(size_t)2u * pair];
        text[at + 1] = pairs[(size_t)2u * pair + 1u];
    }
    if (at == 1) {
        text[0] = (char)('0' + (int)v);
    }
}

/* Writes digits x 10^exponent as %.17g lays out 17 significant digits with trailing zeros
 * removed; returns the length. */
static size_t io_layout(char *out, uint64_t digits, int exponent)
{
    char text[24] = {0}; /* io_digits fills the first count */
    const int count = io_digit_count(digits);
    io_digits(digits, count, text);
    const int lead = exponent + count - 1; /* decimal exponent of the first digit */
    size_t at = 0;
    if (lead < -4 || lead >= 17) {
        out[at++] = text[0];
        if (count > 1) {
            out[at++] = '.';
            memcpy(out + at, text + 1, (size_t)count - 1u);
            at += (size_t)count - 1u;
        }
        const int magnitude = lead < 0 ? -lead : lead;
        out[at++] = 'e';
        out[at++] = lead < 0 ? '-' : '+';
        if (magnitude >= 100) {
            out[at++] = (char)('0' + magnitude / 100);
        }
        out[at++] = (char)('0' + magnitude / 10 % 10);
        out[at++] = (char)('0' + magnitude % 10);
    } else if (lead < 0) {
        memcpy(out, "0.0000", (size_t)(1 - lead));
        at = (size_t)(1 - lead);
        memcpy(out + at, text, (size_t)count);
        at += (size_t)count;
    } else if (count > lead + 1) {
        memcpy(out, text, (size_t)lead + 1u);
        out[lead + 1] = '.';
        memcpy(out + lead + 2, text + lead + 1, (size_t)(count - lead - 1));
        at = (size_t)count + 1u;
    } else {
        memcpy(out, text, (size_t)count);
        memset(out + count, '0', (size_t)(lead + 1 - count));
        at = (size_t)lead + 1u;
    }
    out[at] = '\0';
    return at;
}

#endif

size_t io_format_double(double value, char *out)
{
#if IO_EXACT
    uint64_t bits;
    memcpy(&bits, &value, sizeof bits);
    const int negative = (int)(bits >> 63);
    const int exponent_bits = (int)((bits >> 52) & 0x7ffu);
    const uint64_t mantissa_bits = bits & ((UINT64_C(1) << 52) - 1u);
    size_t at = 0;
    if (exponent_bits == 0 && mantissa_bits == 0) {
        return negative ? (memcpy(out, "-0", 3), 2u) : (memcpy(out, "0", 2), 1u);
    }
    uint64_t digits;
    int exponent;
    const double magnitude = negative ? -value : value;
    if (exponent_bits != 0x7ff && magnitude < 9007199254740992.0 &&
        magnitude == (double)(uint64_t)magnitude) {
        /* an integer below 2^53: its own digits are the shortest text (a shorter one would
         * be at least 1 away, and its neighbours are at most 1 away) */
        digits = (uint64_t)magnitude;
        const int count = io_digit_count(digits);
        if (negative) {
            out[at++] = '-';
        }
        io_digits(digits, count, out + at);
        out[at + (size_t)count] = '\0';
        return at + (size_t)count;
    }
    if (exponent_bits != 0 && exponent_bits != 0x7ff &&
        io_shortest(mantissa_bits, exponent_bits, &digits, &exponent)) {
        if (negative) {
            out[at++] = '-';
        }
        return at + io_layout(out + at, digits, exponent);
    }
#endif
    return (size_t)sprintf(out, "%.17g", value);
}
