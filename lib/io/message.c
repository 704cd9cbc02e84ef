/* pgem I/O messages: "FILE:LINE: what is wrong" into the caller's buffer. */
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "io_internal.h"

static void io_vmessage(char *message, size_t size, const char *format, va_list args)
{
    if (message == NULL || size == 0) {
        return;
    }
    vsnprintf(message, size, format, args);
}

void io_message(char *message, size_t size, const char *format, ...)
{
    va_list args;
    va_start(args, format);
    io_vmessage(message, size, format, args);
    va_end(args);
}

void io_vmessage_at(char *message, size_t size, const char *name, unsigned long line,
                    const char *format, va_list args)
{
    char detail[512];
    vsnprintf(detail, sizeof detail, format, args);
    if (line > 0) {
        io_message(message, size, "%s:%lu: %s", name, line, detail);
    } else {
        io_message(message, size, "%s: %s", name, detail);
    }
}

int io_fail(const io_reader_t *reader, unsigned long line, int code, const char *format, ...)
{
    va_list args;
    va_start(args, format);
    io_vmessage_at(reader->message, reader->message_size, reader->name, line, format, args);
    va_end(args);
    return code;
}

void io_copy_printable(char *out, size_t size, const char *text)
{
    size_t i = 0;
    if (size == 0) {
        return;
    }
    for (; i + 1 < size && text[i] != '\0'; ++i) {
        unsigned char c = (unsigned char)text[i];
        out[i] = text[i];
        if (c < 0x20 || c >= 0x7f) {
            out[i] = '?';
        }
    }
    out[i] = '\0';
}
