/* The I/O layer's number text (lib/io/numbers.c): every double written reads back to its bits,
 * with the fewest digits that do (within the range the exact path covers), laid out as %.17g
 * lays out its digits; the reader gives strtod's value, end and errno for every input. */
#include <errno.h>
#include <float.h>

#include "test_util.h"

#include "io_internal.h"

/* Significant digits of a number's text: from its first to its last nonzero digit (the
 * exponent left out). */
static int significant_digits(const char *text)
{
    int first = -1, last = -1, at = 0;
    for (const char *c = text; *c != '\0' && *c != 'e'; c++) {
        if (*c >= '0' && *c <= '9') {
            if (*c != '0') {
                first = first < 0 ? at : first;
                last = at;
            }
            at++;
        }
    }
    return first < 0 ? 0 : last - first + 1;
}

/* The fewest significant digits that read back to x (%.*e tried from 1 up). */
static int fewest_digits(double x)
{
    char text[64];
    for (int p = 1; p < 17; p++) {
        snprintf(text, sizeof text, "%.*e", p - 1, x);
        if (strtod(text, NULL) == x) {
            return p;
        }
    }
    return 17;
}

/* The shortest text comes from 128-bit integer arithmetic (lib/io/numbers.c); hosts without
 * it (32-bit x86) write %.17g, exact but not shortest. */
#ifdef __SIZEOF_INT128__
#define SHORTEST_TEXT 1
#else
#define SHORTEST_TEXT 0
#endif

static void check_double(double x, int shortest)
{
    char text[IO_NUMBER_TEXT];
    const size_t length = io_format_double(x, text);
    assert_int_equal(length, strlen(text));
    const double back = strtod(text, NULL);
    if (memcmp(&back, &x, sizeof x) != 0) {
        fail_msg("%.17g was written '%s', which reads back as %.17g", x, text, back);
    }
    if (SHORTEST_TEXT && shortest && x != 0.0 && significant_digits(text) > fewest_digits(x)) {
        fail_msg("%.17g was written '%s': %d digits where %d read back", x, text,
                 significant_digits(text), fewest_digits(x));
    }
}

static void test_written_numbers_read_back_exactly(void **state)
{
    (void)state;
    test_rng_t rng = {7};
    const int count = getenv("PGEM_TEST_VALGRIND") != NULL ? 20000 : 400000;
    for (int k = 0; k < count; k++) {
        const uint64_t bits = test_next(&rng);
        double x;
        if (k % 3 == 0) {
            memcpy(&x, &bits, sizeof x); /* any double at all */
        } else if (k % 3 == 1) {
            x = test_uniform_in(&rng, -1.0, 1.0) * pow(10.0, (double)(int)(bits % 40u) - 8.0);
        } else {
            x = (double)(int64_t)(bits % 2000001u) / 1000.0 - 1000.0; /* short decimals */
        }
        if (isfinite(x)) {
            /* shortest where the exact path applies: magnitudes 1e-8 .. 1e30 */
            check_double(x, fabs(x) > 1e-8 && fabs(x) < 1e30);
        }
    }
    const double edges[] = {0.0, -0.0, 1.0, -1.0, 0.1, 0.3, 2.0 / 3.0, 1e-5, 1e-4, 1e16, 1e17,
                            123456789012345678.0, 5e-324, 2.2250738585072014e-308, DBL_MAX,
                            -DBL_MAX, 9007199254740993.0, 0.5, 4.35, 1e23, 8.41e21, 5e-10};
    for (size_t k = 0; k < sizeof edges / sizeof edges[0]; k++) {
        check_double(edges[k], 0);
    }
}

static void test_layout_as_percent_17g(void **state)
{
    (void)state;
    const struct {
        double value;
        const char *text;
    } cases[] = {{0.5, "0.5"},       {-1.0, "-1"},          {0.25, "0.25"},     {11.0, "11"},
                 {0.0, "0"},         {-0.0, "-0"},          {1e-5, "1e-05"},
                 {0.0001, "0.0001"}, {0.1, "0.1"},          {1e16, "10000000000000000"},
                 {1e17, "1e+17"},    {123.456, "123.456"},  {-0.001234, "-0.001234"},
                 {3e20, "3e+20"},  {1.5e-7, "1.5e-07"}};
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        char text[IO_NUMBER_TEXT], expected[IO_NUMBER_TEXT];
        io_format_double(cases[k].value, text);
        if (SHORTEST_TEXT) {
            assert_string_equal(text, cases[k].text);
        } else { /* without 128-bit integers the writer is %.17g itself */
            snprintf(expected, sizeof expected, "%.17g", cases[k].value);
            assert_string_equal(text, expected);
        }
    }
}

/* io_strtod and strtod agree on value, end and errno. */
static void check_parse(const char *text)
{
    char *end_fast = NULL, *end_libc = NULL;
    errno = 0;
    const double fast = io_strtod(text, &end_fast);
    const int errno_fast = errno;
    errno = 0;
    const double libc = strtod(text, &end_libc);
    const int errno_libc = errno;
    if (memcmp(&fast, &libc, sizeof fast) != 0 && !(isnan(fast) && isnan(libc))) {
        fail_msg("'%s': %.17g, strtod %.17g", text, fast, libc);
    }
    assert_ptr_equal(end_fast, end_libc);
    assert_int_equal(errno_fast, errno_libc);
}

static void test_reader_agrees_with_strtod(void **state)
{
    (void)state;
    const char *texts[] = {"0", "-0", "+1.5", ".5", "5.", "1e5", "1E-5", "1e+300", "1e-30",
                           "12345678901234567890", "1234567890123456789", "0.1", "-2.5e-3",
                           "0x1p3", "inf", "-Infinity", "nan", "1e", "1e+", "", "-", ".",
                           "1.2.3", "1e5x", "00000000000000000000001", "4.9e-324", "1e-400",
                           "1.7976931348623157e308", "1.8e308", "9007199254740993",
                           "0.30000000000000004", "3.141592653589793238462643383279",
                           "1000000000000000000000000000", "1e27", "1e-27", "1e28", " 1"};
    for (size_t k = 0; k < sizeof texts / sizeof texts[0]; k++) {
        check_parse(texts[k]);
    }
    test_rng_t rng = {11};
    char text[64];
    const int count = getenv("PGEM_TEST_VALGRIND") != NULL ? 20000 : 300000;
    for (int k = 0; k < count; k++) {
        const uint64_t bits = test_next(&rng);
        double x;
        memcpy(&x, &bits, sizeof x);
        if (k % 2 == 0) {
            x = test_uniform_in(&rng, -100.0, 100.0) * pow(10.0, (double)(int)(bits % 30u) - 15.0);
        }
        /* 6 to 21 significant digits: every path of the reader */
        snprintf(text, sizeof text, "%.*g", 6 + (int)(bits % 16u), x);
        check_parse(text);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_written_numbers_read_back_exactly),
        cmocka_unit_test(test_layout_as_percent_17g),
        cmocka_unit_test(test_reader_agrees_with_strtod),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
