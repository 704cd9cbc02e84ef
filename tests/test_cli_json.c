/* The tools' one JSON writer (tools/pgem/cli_json.c): numbers at the precision each output
 * uses, null for what JSON cannot hold, strings escaped so that any bytes make valid JSON; and
 * the escaping of names for log lines (pgem_io_escape) beside it. */
#define _POSIX_C_SOURCE 200809L
#include <stdio.h>
#include <stdlib.h>

#include "cli.h"
#include "test_util.h"

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
    assert_string_equal(pgem_io_escape(out, sizeof out, "fe\nrejected (x): forged"),
                        "fe\\x0arejected (x): forged");
    assert_string_equal(pgem_io_escape(out, sizeof out, "\x1b[2J\\"), "\\x1b[2J\\\\");
    assert_string_equal(pgem_io_escape(out, sizeof out, "caf\xc3\xa9 \xc2\x85 \xe2\x80\xae"),
                        "caf\xc3\xa9 \\xc2\\x85 \\xe2\\x80\\xae");
    char small[8];
    assert_string_equal(pgem_io_escape(small, sizeof small, "ab\xff\xff"), "ab\\xff"); /* cut */
    size_t bad = 0;
    assert_true(pgem_io_text_printable("robot \xe6\x9c\xba", &bad));
    assert_int_equal(bad, 9);
    assert_false(pgem_io_text_printable("ok\x7f", &bad));
    assert_int_equal(bad, 2);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_numbers),
        cmocka_unit_test(test_strings),
        cmocka_unit_test(test_log_escaping),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
