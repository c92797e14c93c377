/* The .npy reader (see npy.h): a small recursive-descent parser for the header's dict literal. */
#include "io/npy.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"

#define KEY_MAX 32

/* A cursor over the header text. */
struct cursor {
    const char *s, *end;
    const char *begin; /* the header's first character, for positions in messages */
    const char *name;
};

static void skip_space(struct cursor *c)
{
    while (c->s < c->end && (*c->s == ' ' || *c->s == '\t' || *c->s == '\n' || *c->s == '\r'))
        c->s++;
}

static int expect(struct cursor *c, char ch)
{
    skip_space(c);
    if (c->s >= c->end || *c->s != ch)
        return ESR_FAIL("%s: .npy header: expected '%c' at character %ld", c->name, ch,
                        (long)(c->s - c->begin));
    c->s++;
    return ESR_OK;
}

/* 1 when the next non-space character is ch (consumed), else 0. */
static int accept(struct cursor *c, char ch)
{
    skip_space(c);
    if (c->s < c->end && *c->s == ch) {
        c->s++;
        return 1;
    }
    return 0;
}

/* A quoted Python string without escapes, at most KEY_MAX - 1 characters. */
static int parse_string(struct cursor *c, char out[KEY_MAX])
{
    skip_space(c);
    if (c->s >= c->end || (*c->s != '\'' && *c->s != '"'))
        return ESR_FAIL("%s: .npy header: expected a quoted string", c->name);
    const char quote = *c->s++;
    size_t n = 0;
    while (c->s < c->end && *c->s != quote) {
        if (*c->s == '\\' || n + 1 >= KEY_MAX)
            return ESR_FAIL("%s: .npy header: unexpected string", c->name);
        out[n++] = *c->s++;
    }
    if (c->s >= c->end)
        return ESR_FAIL("%s: .npy header: unterminated string", c->name);
    c->s++;
    out[n] = '\0';
    return ESR_OK;
}

static int parse_bool(struct cursor *c, int *out)
{
    skip_space(c);
    size_t left = (size_t)(c->end - c->s);
    if (left >= 4 && !memcmp(c->s, "True", 4)) {
        *out = 1;
        c->s += 4;
    } else if (left >= 5 && !memcmp(c->s, "False", 5)) {
        *out = 0;
        c->s += 5;
    } else {
        return ESR_FAIL("%s: .npy header: fortran_order must be True or False", c->name);
    }
    return ESR_OK;
}

/* A non-negative decimal integer that fits a size_t. */
static int parse_dim(struct cursor *c, size_t *out)
{
    skip_space(c);
    if (c->s >= c->end || *c->s < '0' || *c->s > '9')
        return ESR_FAIL("%s: .npy header: shape must be a tuple of non-negative integers", c->name);
    size_t v = 0;
    while (c->s < c->end && *c->s >= '0' && *c->s <= '9') {
        size_t digit = (size_t)(*c->s++ - '0');
        if (v > (SIZE_MAX - digit) / 10)
            return ESR_FAIL("%s: .npy header: a shape dimension is too large", c->name);
        v = v * 10 + digit;
    }
    *out = v;
    return ESR_OK;
}

/* "()" , "(n,)" or "(n, m, ...)" with an optional trailing comma (required for one element, as in
 * Python: "(n)" is an integer, not a tuple). */
static int parse_shape(struct cursor *c, struct esr_npy_header *h)
{
    ESR_TRY(expect(c, '('));
    h->ndim = 0;
    if (accept(c, ')'))
        return ESR_OK;
    for (;;) {
        if (h->ndim == ESR_NPY_MAX_DIMS)
            return ESR_FAIL("%s: .npy header: more than %d dimensions", c->name, ESR_NPY_MAX_DIMS);
        ESR_TRY(parse_dim(c, &h->shape[h->ndim++]));
        int comma = accept(c, ',');
        if (accept(c, ')')) {
            if (h->ndim == 1 && !comma)
                return ESR_FAIL("%s: .npy header: shape '(n)' is not a tuple; expected '(n,)'", c->name);
            return ESR_OK;
        }
        if (!comma)
            return ESR_FAIL("%s: .npy header: expected ',' or ')' in the shape", c->name);
    }
}

static int parse_descr(struct cursor *c, struct esr_npy_header *h)
{
    char descr[KEY_MAX];
    ESR_TRY(parse_string(c, descr));
    if (!strcmp(descr, "<f8"))
        h->item_size = 8;
    else if (!strcmp(descr, "<f4"))
        h->item_size = 4;
    else
        return ESR_FAIL("%s: dtype '%s' is not supported (expected little-endian float64 '<f8' or float32 '<f4')",
                        c->name, descr);
    return ESR_OK;
}

/* The dict literal: each of the three keys exactly once, in any order, nothing else. */
static int parse_dict(struct cursor *c, struct esr_npy_header *h)
{
    enum { DESCR = 1, FORTRAN = 2, SHAPE = 4 };
    int seen = 0, fortran = 0;
    ESR_TRY(expect(c, '{'));
    while (!accept(c, '}')) {
        char key[KEY_MAX];
        ESR_TRY(parse_string(c, key));
        ESR_TRY(expect(c, ':'));
        int bit = !strcmp(key, "descr") ? DESCR : !strcmp(key, "fortran_order") ? FORTRAN
                : !strcmp(key, "shape") ? SHAPE : 0;
        if (!bit || (seen & bit))
            return ESR_FAIL("%s: .npy header: %s key '%s'", c->name, bit ? "repeated" : "unexpected", key);
        seen |= bit;
        if (bit == DESCR)
            ESR_TRY(parse_descr(c, h));
        else if (bit == FORTRAN)
            ESR_TRY(parse_bool(c, &fortran));
        else
            ESR_TRY(parse_shape(c, h));
        if (!accept(c, ',')) {
            ESR_TRY(expect(c, '}'));
            break;
        }
    }
    if (seen != (DESCR | FORTRAN | SHAPE))
        return ESR_FAIL("%s: .npy header lacks '%s'", c->name,
                        !(seen & DESCR) ? "descr" : !(seen & FORTRAN) ? "fortran_order" : "shape");
    if (fortran)
        return ESR_FAIL("%s: the array is stored in Fortran order; esr reads C-order arrays only", c->name);
    skip_space(c);
    if (c->s != c->end)
        return ESR_FAIL("%s: .npy header: unexpected text after the dict", c->name);
    return ESR_OK;
}

int esr_npy_parse_header(const void *bytes, size_t size, const char *name, struct esr_npy_header *h)
{
    static const unsigned char magic[6] = {0x93, 'N', 'U', 'M', 'P', 'Y'};
    const unsigned char *b = (const unsigned char *)bytes;
    memset(h, 0, sizeof *h);
    if (size < 10 || memcmp(b, magic, sizeof magic))
        return ESR_FAIL("%s is not a .npy array (no \\x93NUMPY magic)", name);
    const int major = b[6];
    if (major < 1 || major > 3 || b[7] != 0)
        return ESR_FAIL("%s: .npy format version %d.%d is not supported (1.0, 2.0, 3.0)", name, major, b[7]);
    size_t len_bytes = major == 1 ? 2 : 4, header_len = 0;
    if (size < 8 + len_bytes)
        return ESR_FAIL("%s: .npy file is truncated in its header", name);
    for (size_t i = 0; i < len_bytes; i++)
        header_len |= (size_t)b[8 + i] << (8 * i);
    size_t start = 8 + len_bytes;
    if (header_len > size - start)
        return ESR_FAIL("%s: .npy header of %zu bytes runs past the end of the %zu-byte file", name, header_len,
                        size);
    const char *text = (const char *)b + start;
    struct cursor c = {text, text + header_len, text, name};
    ESR_TRY(parse_dict(&c, h));
    h->data_offset = start + header_len;
    h->count = 1;
    for (int i = 0; i < h->ndim; i++) {
        if (h->shape[i] && h->count > SIZE_MAX / 8 / h->shape[i])
            return ESR_FAIL("%s: .npy shape is too large", name);
        h->count *= h->shape[i];
    }
    return ESR_OK;
}

/* Little-endian IEEE value i of the data. */
static double element(const unsigned char *p, int item_size, size_t i)
{
    p += i * (size_t)item_size;
    if (item_size == 8) {
        uint64_t u = 0;
        for (int k = 0; k < 8; k++)
            u |= (uint64_t)p[k] << (8 * k);
        double d;
        memcpy(&d, &u, sizeof d);
        return d;
    }
    uint32_t u = 0;
    for (int k = 0; k < 4; k++)
        u |= (uint32_t)p[k] << (8 * k);
    float f;
    memcpy(&f, &u, sizeof f);
    return (double)f;
}

int esr_npy_parse(const void *bytes, size_t size, const char *name, struct esr_npy_array *out)
{
    memset(out, 0, sizeof *out);
    struct esr_npy_header h;
    ESR_TRY(esr_npy_parse_header(bytes, size, name, &h));
    const size_t need = h.count * (size_t)h.item_size, have = size - h.data_offset;
    if (have < need)
        return ESR_FAIL("%s: .npy data is truncated (%zu of %zu bytes)", name, have, need);
    if (have > need)
        return ESR_FAIL("%s: .npy file has %zu bytes after its data", name, have - need);
    double *data = malloc((h.count ? h.count : 1) * sizeof *data);
    if (!data)
        return ESR_FAIL("%s: out of memory for %zu values", name, h.count);
    const unsigned char *p = (const unsigned char *)bytes + h.data_offset;
    for (size_t i = 0; i < h.count; i++)
        data[i] = element(p, h.item_size, i);
    out->header = h;
    out->data = data;
    return ESR_OK;
}

void esr_npy_free(struct esr_npy_array *a)
{
    free(a->data);
    memset(a, 0, sizeof *a);
}
