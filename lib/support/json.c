/* The JSON writer of pgem, the LCM tools and the benchmark driver: the one writer of numbers
 * and strings, so every --json output stays valid JSON whatever the values (non-finite numbers,
 * names from the network that are not UTF-8). */
#include <math.h>
#include <stdio.h>
#include <stdint.h>
#include <string.h>

#include "json.h"
#include "utf8.h"

/* A finite value in a printf format taking a precision, or null. */
static void pgem_json_formatted(FILE *out, const char *format, int precision, double value)
{
    if (isfinite(value)) {
        fprintf(out, format, precision, value);
    } else {
        fputs("null", out);
    }
}

void pgem_json_number(FILE *out, double value, int digits)
{
    pgem_json_formatted(out, "%.*g", digits, value);
}

void pgem_json_fixed(FILE *out, double value, int decimals)
{
    pgem_json_formatted(out, "%.*f", decimals, value);
}

void pgem_json_string(FILE *out, const char *text)
{
    size_t length = strlen(text);
    size_t at = 0;
    fputc('"', out);
    while (at < length) {
        const unsigned char c = (unsigned char)text[at];
        uint32_t codepoint;
        size_t size = pgem_utf8_next(text + at, length - at, &codepoint);
        if (size == 0) {
            fputs("\\ufffd", out); /* a byte that is not UTF-8: JSON cannot carry it */
            at++;
        } else if (c == '"' || c == '\\') {
            fprintf(out, "\\%c", c);
            at++;
        } else if (c < 0x20u) {
            fprintf(out, "\\u%04x", (unsigned)c);
            at++;
        } else {
            fwrite(text + at, 1, size, out);
            at += size;
        }
    }
    fputc('"', out);
}
