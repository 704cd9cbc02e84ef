/* UTF-8 and escaping (lib/support, private): text from outside (an LCM message, a file) checked
 * before it is kept, and escaped before it is logged. The bridge keeps only printable names; the
 * tools print names escaped; the JSON writer (json.h) decodes with pgem_utf8_next. */
#ifndef PGEM_SUPPORT_UTF8_H
#define PGEM_SUPPORT_UTF8_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* The length in bytes (1 to 4) of the UTF-8 character at text, of at most `length` bytes, with
 * its code point in *codepoint; 0 when the bytes there are not one (a stray or missing
 * continuation byte, an overlong form, a surrogate, past U+10FFFF), *codepoint then the first
 * byte. */
size_t pgem_utf8_next(const char *text, size_t length, uint32_t *codepoint);

/* 1 when a code point shows as text on a line: not a control character (C0, DEL, C1), a line or
 * paragraph separator (U+2028, U+2029), a bidirectional embedding, override or isolate
 * (U+202A-U+202E, U+2066-U+2069) that could disguise a log line, or U+FEFF. */
int pgem_utf8_printable(uint32_t codepoint);

/* 1 when every character of text is valid UTF-8 and printable (the rule the LCM bridge applies
 * to the names it keeps); *bad (may be NULL) receives the offset of the first byte that is not,
 * else the length. */
int pgem_utf8_text_printable(const char *text, size_t *bad);

/* Copies text into out (out_size > 0 bytes, always NUL-terminated, never cut inside an escape):
 * printable UTF-8 as it is, a backslash as `\\`, every other byte as `\xNN`. A name from the
 * network printed this way cannot forge a log line or a terminal's state. Returns out. */
char *pgem_utf8_escape(char *out, size_t out_size, const char *text);

#ifdef __cplusplus
}
#endif

#endif /* PGEM_SUPPORT_UTF8_H */
