/* UTF-8 decoding, the printable rule and escaping, for names and paths that come from outside
 * (LCM messages, files) before they are kept, logged or written as JSON. */
#include <stdio.h>
#include <string.h>

#include "utf8.h"

/* Bytes of a UTF-8 sequence by its first byte (0: not a first byte), and the smallest code
 * point each length may encode (anything smaller is an overlong form). */
static size_t utf8_length(unsigned char first)
{
    if (first < 0x80u) {
        return 1;
    }
    if (first >= 0xC2u && first <= 0xDFu) {
        return 2;
    }
    if (first >= 0xE0u && first <= 0xEFu) {
        return 3;
    }
    if (first >= 0xF0u && first <= 0xF4u) {
        return 4;
    }
    return 0;
}

size_t pgem_utf8_next(const char *text, size_t length, uint32_t *codepoint)
{
    static const uint32_t smallest[5] = {0, 0, 0x80u, 0x800u, 0x10000u};
    const unsigned char *bytes = (const unsigned char *)text;
    size_t size = length > 0 ? utf8_length(bytes[0]) : 0;
    uint32_t value = length > 0 ? bytes[0] : 0u;
    size_t k;
    *codepoint = value;
    if (size == 0 || size > length) {
        return 0;
    }
    if (size == 1) {
        return 1;
    }
    value &= 0x3Fu >> (size - 1);
    for (k = 1; k < size; ++k) {
        if ((bytes[k] & 0xC0u) != 0x80u) {
            return 0;
        }
        value = value << 6 | (bytes[k] & 0x3Fu);
    }
    if (value < smallest[size] || value > 0x10FFFFu || (value >= 0xD800u && value <= 0xDFFFu)) {
        return 0;
    }
    *codepoint = value;
    return size;
}

int pgem_utf8_printable(uint32_t c)
{
    if (c < 0x20u || (c >= 0x7Fu && c <= 0x9Fu)) {
        return 0; /* C0, DEL, C1 */
    }
    if (c == 0x2028u || c == 0x2029u || (c >= 0x202Au && c <= 0x202Eu) ||
        (c >= 0x2066u && c <= 0x2069u) || c == 0xFEFFu) {
        return 0; /* line breaks and text direction a terminal would apply */
    }
    return 1;
}

int pgem_utf8_text_printable(const char *text, size_t *bad)
{
    size_t length = strlen(text);
    size_t at = 0;
    while (at < length) {
        uint32_t codepoint;
        size_t size = pgem_utf8_next(text + at, length - at, &codepoint);
        if (size == 0 || !pgem_utf8_printable(codepoint)) {
            break;
        }
        at += size;
    }
    if (bad != NULL) {
        *bad = at;
    }
    return at == length;
}

char *pgem_utf8_escape(char *out, size_t out_size, const char *text)
{
    size_t length = strlen(text);
    size_t at = 0;
    size_t used = 0;
    while (at < length) {
        char piece[8];
        uint32_t codepoint;
        size_t size = pgem_utf8_next(text + at, length - at, &codepoint);
        if (size > 0 && pgem_utf8_printable(codepoint) && codepoint != '\\') {
            memcpy(piece, text + at, size);
            piece[size] = '\0';
        } else if (size > 0 && codepoint == '\\') {
            strcpy(piece, "\\\\");
        } else {
            snprintf(piece, sizeof piece, "\\x%02x", (unsigned)(unsigned char)text[at]);
            size = 1; /* the next byte may start a good character */
        }
        size_t piece_length = strlen(piece);
        if (used + piece_length + 1 > out_size) {
            break;
        }
        memcpy(out + used, piece, piece_length);
        used += piece_length;
        at += size;
    }
    out[used] = '\0';
    return out;
}
