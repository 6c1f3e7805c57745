/* Decimal text to float64, correctly rounded, accepting what Python's float() accepts.
 *
 * A token is checked against Python's grammar first ([+-], digits with an
 * optional point, an optional exponent; or inf, infinity, nan in any case;
 * underscores are refused), so nothing float() refuses is read (no hex, no
 * "nan(...)").  Tokens of at most 19 significant digits whose value and
 * power of ten are exact doubles take Clinger's fast path: one correctly
 * rounded multiplication or division of exact operands.  Up to 19 digits
 * with a power of ten from 10**-64 to 10**64 (the "%.17g" a mesh exporter
 * writes) take Eisel-Lemire: a 128-bit product with a table of powers of
 * five, which rounds correctly or says it cannot.  Then, up to 19 digits
 * with a power of ten up to 10**19 are rounded exactly in 128-bit
 * integers: M · 10**k, or M · 2**s / 10**k with its remainder as a sticky
 * bit.  The rest go to glibc's strtod_l in the "C"
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
/* ---- Eisel-Lemire ------------------------------------------------------------------------------
 *
 * mantissa · 10**q for |q| <= 64 from one (rarely two) 64 x 128-bit products with 5**q, normalised
 * and truncated to 128 bits (rounded up for q < 0): the product fixes the correctly rounded double
 * unless it lies too close to a halfway point, which is detected and left to the exact paths
 * (Lemire, "Number parsing at a gigabyte per second", 2021; the tables of fast_float). */
#define LEMIRE_MIN (-64)
#define LEMIRE_MAX 64

static const uint64_t powers_of_five[LEMIRE_MAX - LEMIRE_MIN + 1][2] = {
    {0xa87fea27a539e9a5ULL, 0x3f2398d747b36224ULL}, /* 5**-64 */
    {0xd29fe4b18e88640eULL, 0x8eec7f0d19a03aadULL}, /* 5**-63 */
    {0x83a3eeeef9153e89ULL, 0x1953cf68300424acULL}, /* 5**-62 */
    {0xa48ceaaab75a8e2bULL, 0x5fa8c3423c052dd7ULL}, /* 5**-61 */
    {0xcdb02555653131b6ULL, 0x3792f412cb06794dULL}, /* 5**-60 */
    {0x808e17555f3ebf11ULL, 0xe2bbd88bbee40bd0ULL}, /* 5**-59 */
    {0xa0b19d2ab70e6ed6ULL, 0x5b6aceaeae9d0ec4ULL}, /* 5**-58 */
    {0xc8de047564d20a8bULL, 0xf245825a5a445275ULL}, /* 5**-57 */
    {0xfb158592be068d2eULL, 0xeed6e2f0f0d56712ULL}, /* 5**-56 */
    {0x9ced737bb6c4183dULL, 0x55464dd69685606bULL}, /* 5**-55 */
    {0xc428d05aa4751e4cULL, 0xaa97e14c3c26b886ULL}, /* 5**-54 */
    {0xf53304714d9265dfULL, 0xd53dd99f4b3066a8ULL}, /* 5**-53 */
    {0x993fe2c6d07b7fabULL, 0xe546a8038efe4029ULL}, /* 5**-52 */
    {0xbf8fdb78849a5f96ULL, 0xde98520472bdd033ULL}, /* 5**-51 */
    {0xef73d256a5c0f77cULL, 0x963e66858f6d4440ULL}, /* 5**-50 */
    {0x95a8637627989aadULL, 0xdde7001379a44aa8ULL}, /* 5**-49 */
    {0xbb127c53b17ec159ULL, 0x5560c018580d5d52ULL}, /* 5**-48 */
    {0xe9d71b689dde71afULL, 0xaab8f01e6e10b4a6ULL}, /* 5**-47 */
    {0x9226712162ab070dULL, 0xcab3961304ca70e8ULL}, /* 5**-46 */
    {0xb6b00d69bb55c8d1ULL, 0x3d607b97c5fd0d22ULL}, /* 5**-45 */
    {0xe45c10c42a2b3b05ULL, 0x8cb89a7db77c506aULL}, /* 5**-44 */
    {0x8eb98a7a9a5b04e3ULL, 0x77f3608e92adb242ULL}, /* 5**-43 */
    {0xb267ed1940f1c61cULL, 0x55f038b237591ed3ULL}, /* 5**-42 */
    {0xdf01e85f912e37a3ULL, 0x6b6c46dec52f6688ULL}, /* 5**-41 */
    {0x8b61313bbabce2c6ULL, 0x2323ac4b3b3da015ULL}, /* 5**-40 */
    {0xae397d8aa96c1b77ULL, 0xabec975e0a0d081aULL}, /* 5**-39 */
    {0xd9c7dced53c72255ULL, 0x96e7bd358c904a21ULL}, /* 5**-38 */
    {0x881cea14545c7575ULL, 0x7e50d64177da2e54ULL}, /* 5**-37 */
    {0xaa242499697392d2ULL, 0xdde50bd1d5d0b9e9ULL}, /* 5**-36 */
    {0xd4ad2dbfc3d07787ULL, 0x955e4ec64b44e864ULL}, /* 5**-35 */
    {0x84ec3c97da624ab4ULL, 0xbd5af13bef0b113eULL}, /* 5**-34 */
    {0xa6274bbdd0fadd61ULL, 0xecb1ad8aeacdd58eULL}, /* 5**-33 */
    {0xcfb11ead453994baULL, 0x67de18eda5814af2ULL}, /* 5**-32 */
    {0x81ceb32c4b43fcf4ULL, 0x80eacf948770ced7ULL}, /* 5**-31 */
    {0xa2425ff75e14fc31ULL, 0xa1258379a94d028dULL}, /* 5**-30 */
    {0xcad2f7f5359a3b3eULL, 0x096ee45813a04330ULL}, /* 5**-29 */
    {0xfd87b5f28300ca0dULL, 0x8bca9d6e188853fcULL}, /* 5**-28 */
    {0x9e74d1b791e07e48ULL, 0x775ea264cf55347eULL}, /* 5**-27 */
    {0xc612062576589ddaULL, 0x95364afe032a819eULL}, /* 5**-26 */
    {0xf79687aed3eec551ULL, 0x3a83ddbd83f52205ULL}, /* 5**-25 */
    {0x9abe14cd44753b52ULL, 0xc4926a9672793543ULL}, /* 5**-24 */
    {0xc16d9a0095928a27ULL, 0x75b7053c0f178294ULL}, /* 5**-23 */
    {0xf1c90080baf72cb1ULL, 0x5324c68b12dd6339ULL}, /* 5**-22 */
    {0x971da05074da7beeULL, 0xd3f6fc16ebca5e04ULL}, /* 5**-21 */
    {0xbce5086492111aeaULL, 0x88f4bb1ca6bcf585ULL}, /* 5**-20 */
    {0xec1e4a7db69561a5ULL, 0x2b31e9e3d06c32e6ULL}, /* 5**-19 */
    {0x9392ee8e921d5d07ULL, 0x3aff322e62439fd0ULL}, /* 5**-18 */
    {0xb877aa3236a4b449ULL, 0x09befeb9fad487c3ULL}, /* 5**-17 */
    {0xe69594bec44de15bULL, 0x4c2ebe687989a9b4ULL}, /* 5**-16 */
    {0x901d7cf73ab0acd9ULL, 0x0f9d37014bf60a11ULL}, /* 5**-15 */
    {0xb424dc35095cd80fULL, 0x538484c19ef38c95ULL}, /* 5**-14 */
    {0xe12e13424bb40e13ULL, 0x2865a5f206b06fbaULL}, /* 5**-13 */
    {0x8cbccc096f5088cbULL, 0xf93f87b7442e45d4ULL}, /* 5**-12 */
    {0xafebff0bcb24aafeULL, 0xf78f69a51539d749ULL}, /* 5**-11 */
    {0xdbe6fecebdedd5beULL, 0xb573440e5a884d1cULL}, /* 5**-10 */
    {0x89705f4136b4a597ULL, 0x31680a88f8953031ULL}, /* 5**-9 */
    {0xabcc77118461cefcULL, 0xfdc20d2b36ba7c3eULL}, /* 5**-8 */
    {0xd6bf94d5e57a42bcULL, 0x3d32907604691b4dULL}, /* 5**-7 */
    {0x8637bd05af6c69b5ULL, 0xa63f9a49c2c1b110ULL}, /* 5**-6 */
    {0xa7c5ac471b478423ULL, 0x0fcf80dc33721d54ULL}, /* 5**-5 */
    {0xd1b71758e219652bULL, 0xd3c36113404ea4a9ULL}, /* 5**-4 */
    {0x83126e978d4fdf3bULL, 0x645a1cac083126eaULL}, /* 5**-3 */
    {0xa3d70a3d70a3d70aULL, 0x3d70a3d70a3d70a4ULL}, /* 5**-2 */
    {0xccccccccccccccccULL, 0xcccccccccccccccdULL}, /* 5**-1 */
    {0x8000000000000000ULL, 0x0000000000000000ULL}, /* 5**0 */
    {0xa000000000000000ULL, 0x0000000000000000ULL}, /* 5**1 */
    {0xc800000000000000ULL, 0x0000000000000000ULL}, /* 5**2 */
    {0xfa00000000000000ULL, 0x0000000000000000ULL}, /* 5**3 */
    {0x9c40000000000000ULL, 0x0000000000000000ULL}, /* 5**4 */
    {0xc350000000000000ULL, 0x0000000000000000ULL}, /* 5**5 */
    {0xf424000000000000ULL, 0x0000000000000000ULL}, /* 5**6 */
    {0x9896800000000000ULL, 0x0000000000000000ULL}, /* 5**7 */
    {0xbebc200000000000ULL, 0x0000000000000000ULL}, /* 5**8 */
    {0xee6b280000000000ULL, 0x0000000000000000ULL}, /* 5**9 */
    {0x9502f90000000000ULL, 0x0000000000000000ULL}, /* 5**10 */
    {0xba43b74000000000ULL, 0x0000000000000000ULL}, /* 5**11 */
    {0xe8d4a51000000000ULL, 0x0000000000000000ULL}, /* 5**12 */
    {0x9184e72a00000000ULL, 0x0000000000000000ULL}, /* 5**13 */
    {0xb5e620f480000000ULL, 0x0000000000000000ULL}, /* 5**14 */
    {0xe35fa931a0000000ULL, 0x0000000000000000ULL}, /* 5**15 */
    {0x8e1bc9bf04000000ULL, 0x0000000000000000ULL}, /* 5**16 */
    {0xb1a2bc2ec5000000ULL, 0x0000000000000000ULL}, /* 5**17 */
    {0xde0b6b3a76400000ULL, 0x0000000000000000ULL}, /* 5**18 */
    {0x8ac7230489e80000ULL, 0x0000000000000000ULL}, /* 5**19 */
    {0xad78ebc5ac620000ULL, 0x0000000000000000ULL}, /* 5**20 */
    {0xd8d726b7177a8000ULL, 0x0000000000000000ULL}, /* 5**21 */
    {0x878678326eac9000ULL, 0x0000000000000000ULL}, /* 5**22 */
    {0xa968163f0a57b400ULL, 0x0000000000000000ULL}, /* 5**23 */
    {0xd3c21bcecceda100ULL, 0x0000000000000000ULL}, /* 5**24 */
    {0x84595161401484a0ULL, 0x0000000000000000ULL}, /* 5**25 */
    {0xa56fa5b99019a5c8ULL, 0x0000000000000000ULL}, /* 5**26 */
    {0xcecb8f27f4200f3aULL, 0x0000000000000000ULL}, /* 5**27 */
    {0x813f3978f8940984ULL, 0x4000000000000000ULL}, /* 5**28 */
    {0xa18f07d736b90be5ULL, 0x5000000000000000ULL}, /* 5**29 */
    {0xc9f2c9cd04674edeULL, 0xa400000000000000ULL}, /* 5**30 */
    {0xfc6f7c4045812296ULL, 0x4d00000000000000ULL}, /* 5**31 */
    {0x9dc5ada82b70b59dULL, 0xf020000000000000ULL}, /* 5**32 */
    {0xc5371912364ce305ULL, 0x6c28000000000000ULL}, /* 5**33 */
    {0xf684df56c3e01bc6ULL, 0xc732000000000000ULL}, /* 5**34 */
    {0x9a130b963a6c115cULL, 0x3c7f400000000000ULL}, /* 5**35 */
    {0xc097ce7bc90715b3ULL, 0x4b9f100000000000ULL}, /* 5**36 */
    {0xf0bdc21abb48db20ULL, 0x1e86d40000000000ULL}, /* 5**37 */
    {0x96769950b50d88f4ULL, 0x1314448000000000ULL}, /* 5**38 */
    {0xbc143fa4e250eb31ULL, 0x17d955a000000000ULL}, /* 5**39 */
    {0xeb194f8e1ae525fdULL, 0x5dcfab0800000000ULL}, /* 5**40 */
    {0x92efd1b8d0cf37beULL, 0x5aa1cae500000000ULL}, /* 5**41 */
    {0xb7abc627050305adULL, 0xf14a3d9e40000000ULL}, /* 5**42 */
    {0xe596b7b0c643c719ULL, 0x6d9ccd05d0000000ULL}, /* 5**43 */
    {0x8f7e32ce7bea5c6fULL, 0xe4820023a2000000ULL}, /* 5**44 */
    {0xb35dbf821ae4f38bULL, 0xdda2802c8a800000ULL}, /* 5**45 */
    {0xe0352f62a19e306eULL, 0xd50b2037ad200000ULL}, /* 5**46 */
    {0x8c213d9da502de45ULL, 0x4526f422cc340000ULL}, /* 5**47 */
    {0xaf298d050e4395d6ULL, 0x9670b12b7f410000ULL}, /* 5**48 */
    {0xdaf3f04651d47b4cULL, 0x3c0cdd765f114000ULL}, /* 5**49 */
    {0x88d8762bf324cd0fULL, 0xa5880a69fb6ac800ULL}, /* 5**50 */
    {0xab0e93b6efee0053ULL, 0x8eea0d047a457a00ULL}, /* 5**51 */
    {0xd5d238a4abe98068ULL, 0x72a4904598d6d880ULL}, /* 5**52 */
    {0x85a36366eb71f041ULL, 0x47a6da2b7f864750ULL}, /* 5**53 */
    {0xa70c3c40a64e6c51ULL, 0x999090b65f67d924ULL}, /* 5**54 */
    {0xd0cf4b50cfe20765ULL, 0xfff4b4e3f741cf6dULL}, /* 5**55 */
    {0x82818f1281ed449fULL, 0xbff8f10e7a8921a4ULL}, /* 5**56 */
    {0xa321f2d7226895c7ULL, 0xaff72d52192b6a0dULL}, /* 5**57 */
    {0xcbea6f8ceb02bb39ULL, 0x9bf4f8a69f764490ULL}, /* 5**58 */
    {0xfee50b7025c36a08ULL, 0x02f236d04753d5b4ULL}, /* 5**59 */
    {0x9f4f2726179a2245ULL, 0x01d762422c946590ULL}, /* 5**60 */
    {0xc722f0ef9d80aad6ULL, 0x424d3ad2b7b97ef5ULL}, /* 5**61 */
    {0xf8ebad2b84e0d58bULL, 0xd2e0898765a7deb2ULL}, /* 5**62 */
    {0x9b934c3b330c8577ULL, 0x63cc55f49f88eb2fULL}, /* 5**63 */
    {0xc2781f49ffcfa6d5ULL, 0x3cbf6b71c76b25fbULL}, /* 5**64 */
};

/* 0 and the correctly rounded mantissa · 10**q (mantissa != 0, at most 19 digits), or -1 when the
 * product cannot decide it (then an exact path does). */
static int lemire(uint64_t mantissa, int64_t q, double *value)
{
    const uint64_t *power;
    int lz, upper;
    int64_t power2;
    uint64_t high, low, bits;
    u128 product;
    if (q < LEMIRE_MIN || q > LEMIRE_MAX || mantissa == 0)
        return -1;
    power = powers_of_five[q - LEMIRE_MIN];
    lz = __builtin_clzll(mantissa);
    mantissa <<= lz;
    product = (u128)mantissa * power[0];
    high = (uint64_t)(product >> 64);
    low = (uint64_t)product;
    if ((high & 0x1FF) == 0x1FF) {               /* the truncated low part could carry into the bits kept */
        u128 second = (u128)mantissa * power[1];
        uint64_t second_high = (uint64_t)(second >> 64);
        low += second_high;
        if (second_high > low)
            high++;
    }
    if (low == 0xFFFFFFFFFFFFFFFFULL)
        return -1;                               /* still undecided: the exact paths decide */
    upper = (int)(high >> 63);
    mantissa = high >> (upper + 64 - 52 - 3);
    power2 = (((152170 + 65536) * q) >> 16) + 63 + upper - lz + 1023;
    if (power2 <= 0 || power2 >= 0x7FF - 1)
        return -1;                               /* subnormal or near overflow: strtod_l decides */
    /* a product exactly halfway between two doubles (only possible for small |q|): ties to even */
    if (low <= 1 && q >= -4 && q <= 23 && (mantissa & 3) == 1 && (mantissa << (upper + 64 - 52 - 3)) == high)
        mantissa &= ~(uint64_t)1;
    mantissa += mantissa & 1;
    mantissa >>= 1;
    if (mantissa >= ((uint64_t)2 << 52)) {
        mantissa = (uint64_t)1 << 52;
        power2++;
    }
    mantissa &= ~((uint64_t)1 << 52);
    if (power2 >= 0x7FF)
        return -1;
    bits = mantissa | (uint64_t)power2 << 52;
    memcpy(value, &bits, sizeof bits);
    return 0;
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
    *value = eight_digits_value(v - 0x3030303030303030ULL);
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

/* The double nearest mantissa * 10**exponent (negated when `negative`), the decimal being
 * [start, end) with `significant` significant digits (mantissa holds the first 19 of them). */
static inline double finish_decimal(uint64_t mantissa, int64_t exponent, int significant, int negative,
                                    const char *start, const char *end)
{
    double value;
    /* More than 19 significant digits (some were not accumulated) never take the fast path. */
    if (significant <= 19 && mantissa <= ((uint64_t)1 << 53) && exponent >= -22 && exponent <= 22) {
        double m = (double)mantissa;                 /* exact: at most 2**53 */
        value = exponent >= 0 ? m * powers_of_ten[exponent] : m / powers_of_ten[-exponent];
        return negative ? -value : value;
    }
#if defined(__SIZEOF_INT128__)
    if (significant <= 19 && (lemire(mantissa, exponent, &value) == 0 || exact_decimal(mantissa, exponent, &value) == 0))
        return negative ? -value : value;
#endif
    return slow_path(start, (size_t)(end - start));
}

/* Any decimal (see parse_decimal). */
static __attribute__((noinline)) int general_decimal(const char *start, const char *end, const char **stop,
                                                      double *value)
{
    const char *p = start;
    int negative = 0, digits = 0, significant = 0, exponent_sign = 1;
    int64_t exponent = 0, dropped = 0;
    uint64_t mantissa = 0, eight;
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
    *value = finish_decimal(mantissa, exponent_sign * exponent + dropped, significant, negative, start, p);
    return 0;
}

int parse_decimal(const char *start, const char *end, const char **stop, double *value)
{
    /* The usual shapes first: "ddd.ddd" with a nonzero leading digit (the point optional) or "0.ddd", at
     * most 19 significant digits, no exponent (what "%.17g" and "%f" write), read with few registers; the
     * same mantissa and exponent as the general reading (general_decimal), which takes every other shape. */
    const char *q = start;
    int negative = 0, count = 0, fraction = 0, point;
    uint64_t mantissa = 0, eight;
    if (q < end && *q == '-') {
        negative = 1;
        q++;
    }
    if (end - q >= 2 && q[0] == '0' && q[1] == '.') {
        for (q += 2; q < end && *q == '0'; q++)      /* "0.00": leading zeros, not significant */
            fraction++;
        point = 1;
    } else if (q < end && *q >= '1' && *q <= '9') {
        for (; q < end && is_digit(*q) && count < 19; q++, count++)
            mantissa = 10 * mantissa + (uint64_t)(*q - '0');
        point = q < end && *q == '.';
        q += point;
    } else {
        return general_decimal(start, end, stop, value);
    }
    if (point) {
        for (; count <= 11 && end - q >= 8 && eight_digits(q, &eight); q += 8, count += 8, fraction += 8)
            mantissa = mantissa * 100000000ULL + eight;
        for (; q < end && is_digit(*q) && count < 19; q++, count++, fraction++)
            mantissa = 10 * mantissa + (uint64_t)(*q - '0');
    }
    if (q < end && (is_digit(*q) || *q == '.' || *q == 'e' || *q == 'E'))
        return general_decimal(start, end, stop, value);
    *stop = q;
    *value = finish_decimal(mantissa, -fraction, count, negative, start, q);
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
