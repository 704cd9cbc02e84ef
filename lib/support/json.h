/* The JSON writer (lib/support, private): the one writer of numbers and strings every --json
 * output of pgem, the LCM tools and the benchmark driver goes through, so each stays valid JSON
 * whatever the values (non-finite numbers, names from the network that are not UTF-8). */
#ifndef PGEM_SUPPORT_JSON_H
#define PGEM_SUPPORT_JSON_H

#include <stdio.h>

#ifdef __cplusplus
extern "C" {
#endif

/* A number with `digits` significant digits (%.*g: 10 for the CLI's summaries, 17 for values
 * that must read back exactly), or with `decimals` after the point (%.*f: seconds); null when it
 * is NaN or infinite, which JSON cannot hold. */
void pgem_json_number(FILE *out, double value, int digits);
void pgem_json_fixed(FILE *out, double value, int decimals);

/* A JSON string: quoted, '"', '\\' and control bytes escaped, and each byte that is not part of
 * valid UTF-8 as \ufffd (a name from the network cannot break the document). */
void pgem_json_string(FILE *out, const char *text);

#ifdef __cplusplus
}
#endif

#endif /* PGEM_SUPPORT_JSON_H */
