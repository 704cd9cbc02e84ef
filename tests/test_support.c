/* The private support library (lib/support): the one JSON writer (json.c): numbers at the
 * precision each output uses, null for what JSON cannot hold, strings escaped so that any bytes
 * make valid JSON; the escaping of names for log lines (utf8.c); the union-find (union_find.c). */
#define _POSIX_C_SOURCE 200809L
#include <stdio.h>
#include <stdlib.h>

#include "json.h"
#include "test_util.h"
#include "union_find.h"
#include "utf8.h"

/* What a writer call printed, into a caller's buffer. */
#define CAPTURE(buffer, call)                                                                      \
    do {                                                                                           \
        char *capture_text = NULL;                                                                 \
        size_t capture_size = 0;                                                                   \
        FILE *out = open_memstream(&capture_text, &capture_size);                                  \
        assert_non_null(out);                                                                      \
        call;                                                                                      \
        assert_int_equal(fclose(out), 0);                                                          \
        snprintf(buffer, sizeof buffer, "%s", capture_text);                                       \
        free(capture_text);                                                                        \
    } while (0)

static void test_numbers(void **state)
{
    (void)state;
    char text[128];
    CAPTURE(text, pgem_json_number(out, 137.91295093603975, 10));
    assert_string_equal(text, "137.9129509");
    CAPTURE(text, pgem_json_number(out, 137.91295093603975, 17));
    assert_string_equal(text, "137.91295093603975");
    CAPTURE(text, pgem_json_fixed(out, 0.0123456789, 6));
    assert_string_equal(text, "0.012346");
    CAPTURE(text, pgem_json_number(out, 1e300 * 1e10, 10));
    assert_string_equal(text, "null");
    CAPTURE(text, pgem_json_number(out, -(double)INFINITY, 17));
    assert_string_equal(text, "null");
    CAPTURE(text, pgem_json_fixed(out, (double)NAN, 6));
    assert_string_equal(text, "null");
}

/* Issue 17: a source name with byte 0xff went into pgem-lcm-dump's JSON as it was, and the
 * file no longer parsed. */
static void test_strings(void **state)
{
    (void)state;
    char text[256];
    CAPTURE(text, pgem_json_string(out, "a \"b\" \\c\n\t\x01"));
    assert_string_equal(text, "\"a \\\"b\\\" \\\\c\\u000a\\u0009\\u0001\"");
    CAPTURE(text, pgem_json_string(out, "M\xc3\xbcnchen \xe6\x9c\xba \xf0\x9f\xa4\x96"));
    assert_string_equal(text, "\"M\xc3\xbcnchen \xe6\x9c\xba \xf0\x9f\xa4\x96\"");
    /* a stray byte, a cut sequence, an overlong '/', a surrogate, past U+10FFFF */
    CAPTURE(text, pgem_json_string(out, "fe\xff|\xc3|\xc0\xaf|\xed\xa0\x80|\xf4\x90\x80\x80"));
    assert_string_equal(text, "\"fe\\ufffd|\\ufffd|\\ufffd\\ufffd|\\ufffd\\ufffd\\ufffd|"
                              "\\ufffd\\ufffd\\ufffd\\ufffd\"");
    CAPTURE(text, pgem_json_string(out, ""));
    assert_string_equal(text, "\"\"");
}

/* Names in log lines: printable UTF-8 kept, anything else as \xNN, so a newline cannot start
 * a forged line and an escape sequence cannot reach a terminal. */
static void test_log_escaping(void **state)
{
    (void)state;
    char out[64];
    assert_string_equal(pgem_utf8_escape(out, sizeof out, "fe\nrejected (x): forged"),
                        "fe\\x0arejected (x): forged");
    assert_string_equal(pgem_utf8_escape(out, sizeof out, "\x1b[2J\\"), "\\x1b[2J\\\\");
    assert_string_equal(pgem_utf8_escape(out, sizeof out, "caf\xc3\xa9 \xc2\x85 \xe2\x80\xae"),
                        "caf\xc3\xa9 \\xc2\\x85 \\xe2\\x80\\xae");
    char small[8];
    assert_string_equal(pgem_utf8_escape(small, sizeof small, "ab\xff\xff"), "ab\\xff"); /* cut */
    size_t bad = 0;
    assert_true(pgem_utf8_text_printable("robot \xe6\x9c\xba", &bad));
    assert_int_equal(bad, 9);
    assert_false(pgem_utf8_text_printable("ok\x7f", &bad));
    assert_int_equal(bad, 2);
}

/* The union-find the core, the tools and the bridge share: a part's root is its smallest
 * index, whatever order the joins come in. */
static void test_parts(void **state)
{
    (void)state;
    uint32_t parent[8];
    for (uint32_t k = 0; k < 8u; k++) {
        parent[k] = k;
    }
    assert_int_equal(pgem_part_join(parent, 6, 4), 4);
    assert_int_equal(pgem_part_join(parent, 7, 6), 4);
    assert_int_equal(pgem_part_join(parent, 3, 1), 1);
    assert_int_equal(pgem_part_join(parent, 7, 3), 1);
    assert_int_equal(pgem_part_join(parent, 4, 1), 1); /* already one part */
    const uint32_t expected[8] = {0, 1, 2, 1, 1, 5, 1, 1};
    for (uint32_t k = 0; k < 8u; k++) {
        assert_int_equal(pgem_part_root(parent, k), expected[k]);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_numbers),
        cmocka_unit_test(test_strings),
        cmocka_unit_test(test_log_escaping),
        cmocka_unit_test(test_parts),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
