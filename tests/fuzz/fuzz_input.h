/* Reading a fuzz input as a program (bytes, ids, values) and writing seeds in the same
 * encoding; shared by fuzz_core_api and fuzz_bridge_ingest. Past the end every read gives 0,
 * so any prefix of an input is a valid input. */
#ifndef PGEM_FUZZ_INPUT_H
#define PGEM_FUZZ_INPUT_H

#include <float.h>
#include <math.h>
#include <stdint.h>
#include <string.h>

typedef struct fuzz_input {
    const uint8_t *data;
    size_t size;
    size_t at;
} fuzz_input_t;

static inline int fuzz_more(const fuzz_input_t *in)
{
    return in->at < in->size;
}

static inline uint8_t fuzz_byte(fuzz_input_t *in)
{
    return in->at < in->size ? in->data[in->at++] : 0;
}

static inline uint64_t fuzz_u64(fuzz_input_t *in)
{
    uint64_t value = 0;
    for (int i = 0; i < 8; ++i) {
        value |= (uint64_t)fuzz_byte(in) << (8 * i);
    }
    return value;
}

/* Bytes below FUZZ_VALUE_SPECIAL are numbers on a grid of 1/16 around 0 (FUZZ_GRID gives the
 * byte of a grid value); the next 16 are special values; the last 16 are followed by the 8
 * bytes of any double. */
#define FUZZ_VALUE_SPECIAL 0xE0u
#define FUZZ_VALUE_RAW 0xF0u
#define FUZZ_GRID(x) ((uint8_t)((x) * 16.0 + 112.0))

static inline double fuzz_value(fuzz_input_t *in)
{
    static const double special[16] = {
        0.0 /* NaN */, 0.0 /* +Inf */, 0.0 /* -Inf */, DBL_MAX, -DBL_MAX, 4.9406564584124654e-324,
        -0.0, 1e-300, 1e300, 1e8, 1e-8, 3.14159265358979323846, -3.14159265358979323846,
        1e15, 0.999, 1.001};
    uint8_t b = fuzz_byte(in);
    if (b < FUZZ_VALUE_SPECIAL) {
        return ((double)b - 112.0) / 16.0;
    }
    if (b < FUZZ_VALUE_RAW) {
        switch (b - FUZZ_VALUE_SPECIAL) {
        case 0: return (double)NAN;
        case 1: return (double)INFINITY;
        case 2: return -(double)INFINITY;
        default: return special[b - FUZZ_VALUE_SPECIAL];
        }
    }
    uint64_t bits = fuzz_u64(in);
    double value;
    memcpy(&value, &bits, sizeof value);
    return value;
}

/* An id: bytes below 0xF0 are small ids (0 .. small - 1, so ids collide often), the rest
 * are large ones (the extremes of 64 bits, or any 8 bytes). */
static inline uint64_t fuzz_id(fuzz_input_t *in, unsigned small)
{
    uint8_t b = fuzz_byte(in);
    if (b < 0xF0u) {
        return b % small;
    }
    switch (b) {
    case 0xF0: return UINT64_MAX;
    case 0xF1: return UINT64_MAX - 1u;
    case 0xF2: return UINT64_C(1) << 63;
    case 0xF3: return (UINT64_C(1) << 63) - 1u;
    case 0xF4: return UINT64_C(1) << 32;
    default: return fuzz_u64(in);
    }
}

/* ---- seeds in the same encoding ------------------------------------------------------------ */

typedef struct fuzz_output {
    uint8_t *data;
    size_t size;
    size_t capacity;
} fuzz_output_t;

static inline void fuzz_put(fuzz_output_t *out, uint8_t b)
{
    if (out->size < out->capacity) {
        out->data[out->size] = b;
    }
    out->size++;
}

/* A value: on the grid when it is one, else raw. */
static inline void fuzz_put_value(fuzz_output_t *out, double x)
{
    double scaled = x * 16.0 + 112.0;
    if (scaled >= 0.0 && scaled < (double)FUZZ_VALUE_SPECIAL && scaled == floor(scaled)) {
        fuzz_put(out, (uint8_t)scaled);
        return;
    }
    uint64_t bits;
    memcpy(&bits, &x, sizeof bits);
    fuzz_put(out, (uint8_t)FUZZ_VALUE_RAW);
    for (int i = 0; i < 8; ++i) {
        fuzz_put(out, (uint8_t)(bits >> (8 * i)));
    }
}

/* An id: small when it fits a byte below 0xF0, else raw. */
static inline void fuzz_put_id(fuzz_output_t *out, uint64_t id)
{
    if (id < 0xF0u) {
        fuzz_put(out, (uint8_t)id);
        return;
    }
    fuzz_put(out, 0xFFu);
    for (int i = 0; i < 8; ++i) {
        fuzz_put(out, (uint8_t)(id >> (8 * i)));
    }
}

#endif /* PGEM_FUZZ_INPUT_H */
