/* Decimal text to float64, correctly rounded, accepting what Python's float() accepts.
 *
 * A token is checked against Python's grammar first ([+-], digits with an
 * optional point, an optional exponent; or inf, infinity, nan in any case;
 * underscores are refused), so nothing float() refuses is read (no hex, no
 * "nan(...)").  Tokens of at most 19 significant digits whose value and
 * power of ten are exact doubles take Clinger's fast path: one correctly
 * rounded multiplication or division of exact operands.  The rest go to
 * glibc's strtod_l in the "C" locale, which rounds correctly.
 */
#define _GNU_SOURCE
#include "core.h"

#include <locale.h>
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

int parse_double(const char *start, const char *end, double *value)
{
    const char *p = start;
    int negative = 0, digits = 0, significant = 0, exponent_sign = 1;
    int64_t exponent = 0, dropped = 0;
    uint64_t mantissa = 0;
    if (p < end && (*p == '+' || *p == '-'))
        negative = *p++ == '-';
    if (p < end && !is_digit(*p) && *p != '.') {
        if (special_value(p, (size_t)(end - p), value) != 0)
            return -1;
        if (negative)
            *value = -*value;
        return 0;
    }
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
    if (p != end)
        return -1;
    exponent = exponent_sign * exponent + dropped;
    /* More than 19 significant digits (some were not accumulated) never take the fast path. */
    if (significant <= 19 && mantissa <= ((uint64_t)1 << 53) && exponent >= -22 && exponent <= 22) {
        double m = (double)mantissa;                 /* exact: at most 2**53 */
        *value = exponent >= 0 ? m * powers_of_ten[exponent] : m / powers_of_ten[-exponent];
        if (negative)
            *value = -*value;
        return 0;
    }
    *value = slow_path(start, (size_t)(end - start));
    return 0;
}
