/* Decimal text to float64, correctly rounded, accepting what Python's float() accepts.
 *
 * A token is checked against Python's grammar first ([+-], digits with an
 * optional point, an optional exponent; or inf, infinity, nan in any case;
 * underscores are refused), so nothing float() refuses is read (no hex, no
 * "nan(...)").  Tokens of at most 19 significant digits whose value and
 * power of ten are exact doubles take Clinger's fast path: one correctly
 * rounded multiplication or division of exact operands.  Up to 19 digits
 * with a power of ten up to 10**19 (the "%.17g" a mesh exporter writes) are
 * rounded exactly in 128-bit integers: M · 10**k, or M · 2**s / 10**k with its
 * remainder as a sticky bit.  The rest go to glibc's strtod_l in the "C"
 * locale, which rounds correctly.
 */
#define _GNU_SOURCE
#include "core.h"

#include <locale.h>
#if defined(__APPLE__)
#include <xlocale.h>                         /* strtod_l, newlocale */
#endif
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

static locale_t c_locale;

void numbers_init(void)
{
    if (!c_locale)
        c_locale = newlocale(LC_ALL_MASK, "C", (locale_t)0);
}

static const double powers_of_ten[23] = {
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
    1e17, 1e18, 1e19, 1e20, 1e21, 1e22};

static int is_digit(char c) { return c >= '0' && c <= '9'; }

#if defined(__SIZEOF_INT128__)
typedef unsigned __int128 u128;

static const uint64_t exact_powers[20] = {
    1ULL, 10ULL, 100ULL, 1000ULL, 10000ULL, 100000ULL, 1000000ULL, 10000000ULL, 100000000ULL, 1000000000ULL,
    10000000000ULL, 100000000000ULL, 1000000000000ULL, 10000000000000ULL, 100000000000000ULL,
    1000000000000000ULL, 10000000000000000ULL, 100000000000000000ULL, 1000000000000000000ULL,
    10000000000000000000ULL};

static int bit_length(u128 x)
{
    uint64_t high = (uint64_t)(x >> 64);
    return high ? 128 - __builtin_clzll(high) : (uint64_t)x ? 64 - __builtin_clzll((uint64_t)x) : 0;
}

/* x · 2**scale rounded to nearest (ties to even), `sticky` meaning x is a little above its value;
 * -1 if the result could be subnormal or out of range (then the caller takes the slow path). */
static int round_scaled(u128 x, int scale, int sticky, double *value)
{
    int bits = bit_length(x), shift = bits > 53 ? bits - 53 : 0;
    uint64_t kept = (uint64_t)(x >> shift);
    if (shift > 0) {
        u128 rest = x & (((u128)1 << shift) - 1), half = (u128)1 << (shift - 1);
        if (rest > half || (rest == half && (sticky || (kept & 1))))
            kept++;                                  /* 2**53 after a carry is still exact */
    } else if (sticky) {
        return -1;                                   /* cannot happen: x has at least 63 bits then */
    }
    if (bits + scale > 1000 || shift + scale < -1000)
        return -1;                                   /* near the ends of the range: strtod_l decides */
    {
        /* 2**(shift + scale) built from its bits: exact, and the product below is exact too
         * (kept has at most 54 bits, the result is a normal double) */
        uint64_t power_bits = (uint64_t)(1023 + shift + scale) << 52;
        double power;
        memcpy(&power, &power_bits, sizeof power);
        *value = (double)kept * power;
    }
    return 0;
}

/* mantissa · 10**exponent correctly rounded, for |exponent| <= 19; -1 if out of that range. */
static int exact_decimal(uint64_t mantissa, int64_t exponent, double *value)
{
    if (mantissa == 0) {
        *value = 0.0;
        return 0;
    }
    if (exponent >= 0 && exponent <= 19)
        return round_scaled((u128)mantissa * exact_powers[exponent], 0, 0, value);
    if (exponent < 0 && exponent >= -19) {
        uint64_t divisor = exact_powers[-exponent], quotient, remainder;
        /* shift so that the quotient has 63 or 64 bits: enough for 53, a rounding bit and more */
        int shift = 63 + bit_length(divisor) - bit_length(mantissa);
        u128 numerator = (u128)mantissa << shift;
#if defined(__x86_64__) && defined(__GNUC__)
        /* one 128-by-64-bit division: the quotient fits in 64 bits by the choice of shift */
        uint64_t high = (uint64_t)(numerator >> 64), low = (uint64_t)numerator;
        __asm__("divq %4" : "=a"(quotient), "=d"(remainder) : "a"(low), "d"(high), "rm"(divisor) : "cc");
#else
        quotient = (uint64_t)(numerator / divisor);
        remainder = (uint64_t)(numerator - (u128)quotient * divisor);
#endif
        return round_scaled(quotient, -shift, remainder != 0, value);
    }
    return -1;
}
#endif

/* Eight ASCII digits at p (which has eight bytes to read): 1 and their value, else 0.  Read as
 * one little-endian word (Lemire's fast_float): the same value the digit loop forms. */
static inline int eight_digits(const char *p, uint64_t *value)
{
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
    uint64_t v;
    memcpy(&v, p, sizeof v);
    if (((v & 0xF0F0F0F0F0F0F0F0ULL) | (((v + 0x0606060606060606ULL) & 0xF0F0F0F0F0F0F0F0ULL) >> 4))
            != 0x3333333333333333ULL)
        return 0;
    v -= 0x3030303030303030ULL;
    v = v * 10 + (v >> 8);
    *value = ((v & 0x000000FF000000FFULL) * (100 + (1000000ULL << 32))
              + ((v >> 16) & 0x000000FF000000FFULL) * (1 + (10000ULL << 32))) >> 32;
    return 1;
#else
    (void)p;
    (void)value;
    return 0;
#endif
}

static int special_value(const char *p, size_t length, double *value)
{
    if ((length == 3 && strncasecmp(p, "inf", 3) == 0) || (length == 8 && strncasecmp(p, "infinity", 8) == 0)) {
        *value = HUGE_VAL;
        return 0;
    }
    if (length == 3 && strncasecmp(p, "nan", 3) == 0) {
        *value = NAN;
        return 0;
    }
    return -1;
}

static double slow_path(const char *start, size_t length)
{
    char local[128], *copy = length < sizeof local ? local : malloc(length + 1);
    double value;
    if (!copy)
        return NAN;                                  /* unreachable in practice; never silently 0 */
    memcpy(copy, start, length);
    copy[length] = '\0';
    value = strtod_l(copy, NULL, c_locale);
    if (copy != local)
        free(copy);
    return value;
}

int parse_decimal(const char *start, const char *end, const char **stop, double *value)
{
    const char *p = start;
    int negative = 0, digits = 0, significant = 0, exponent_sign = 1;
    int64_t exponent = 0, dropped = 0;
    uint64_t mantissa = 0;
    if (p < end && (*p == '+' || *p == '-'))
        negative = *p++ == '-';
    for (; p < end && is_digit(*p); p++, digits++) {
        if (significant || *p != '0') {
            if (significant < 19)
                mantissa = 10 * mantissa + (uint64_t)(*p - '0');
            else
                dropped++;
            significant++;
        }
    }
    if (p < end && *p == '.') {
        for (p++; p < end && is_digit(*p); p++, digits++) {
            uint64_t eight;
            /* eight digits at once while all eight are accumulated (after the leading zeros, below 19) */
            while (significant > 0 && significant <= 11 && end - p >= 8 && eight_digits(p, &eight)) {
                mantissa = mantissa * 100000000ULL + eight;
                significant += 8;
                dropped -= 8;
                digits += 8;
                p += 8;
            }
            if (p >= end || !is_digit(*p))
                break;
            if (significant || *p != '0') {
                if (significant < 19) {
                    mantissa = 10 * mantissa + (uint64_t)(*p - '0');
                    dropped--;
                }
                significant++;
            } else {
                dropped--;
            }
        }
    }
    if (digits == 0)
        return -1;
    if (p < end && (*p == 'e' || *p == 'E')) {
        int exponent_digits = 0;
        p++;
        if (p < end && (*p == '+' || *p == '-'))
            exponent_sign = *p++ == '-' ? -1 : 1;
        for (; p < end && is_digit(*p); p++, exponent_digits++)
            if (exponent < 100000)
                exponent = 10 * exponent + (*p - '0');
        if (exponent_digits == 0)
            return -1;
    }
    *stop = p;
    end = p;
    exponent = exponent_sign * exponent + dropped;
    /* More than 19 significant digits (some were not accumulated) never take the fast path. */
    if (significant <= 19 && mantissa <= ((uint64_t)1 << 53) && exponent >= -22 && exponent <= 22) {
        double m = (double)mantissa;                 /* exact: at most 2**53 */
        *value = exponent >= 0 ? m * powers_of_ten[exponent] : m / powers_of_ten[-exponent];
        if (negative)
            *value = -*value;
        return 0;
    }
#if defined(__SIZEOF_INT128__)
    if (significant <= 19 && exact_decimal(mantissa, exponent, value) == 0) {
        if (negative)
            *value = -*value;
        return 0;
    }
#endif
    *value = slow_path(start, (size_t)(end - start));
    return 0;
}

int parse_double(const char *start, const char *end, double *value)
{
    const char *p = start, *stop;
    if (p < end && (*p == '+' || *p == '-'))
        p++;
    if (p < end && !is_digit(*p) && *p != '.') {
        if (special_value(p, (size_t)(end - p), value) != 0)
            return -1;
        if (*start == '-')
            *value = -*value;
        return 0;
    }
    return parse_decimal(start, end, &stop, value) == 0 && stop == end ? 0 : -1;
}
