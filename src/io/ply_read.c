/* PLY reader: ASCII and binary little-endian, any scalar property types. Only vertex x/y/z
 * and triangle/polygon faces (fan-triangulated) are kept; that is what the geometry metrics
 * need, for our own meshes and for ground truth from other tools. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "io/file.h"
#include "io/ply.h"

enum ply_type { PLY_NONE, PLY_I8, PLY_U8, PLY_I16, PLY_U16, PLY_I32, PLY_U32, PLY_F32, PLY_F64 };

struct ply_property {
    enum ply_type type;       /* scalar type, or the item type of a list */
    enum ply_type count_type; /* PLY_NONE for scalars */
    int role;                 /* 0..2 = x,y,z; 3 = vertex_indices list; -1 = skipped */
};

#define PLY_MAX_PROPS 32

struct ply_element {
    size_t count;
    int n_props;
    struct ply_property props[PLY_MAX_PROPS];
};

struct ply_cursor {
    const char *path;
    const unsigned char *p, *end;
    int ascii;
};

static enum ply_type ply_type_from_name(const char *s)
{
    static const struct { const char *name; enum ply_type type; } names[] = {
        {"char", PLY_I8},   {"int8", PLY_I8},     {"uchar", PLY_U8},   {"uint8", PLY_U8},
        {"short", PLY_I16}, {"int16", PLY_I16},   {"ushort", PLY_U16}, {"uint16", PLY_U16},
        {"int", PLY_I32},   {"int32", PLY_I32},   {"uint", PLY_U32},   {"uint32", PLY_U32},
        {"float", PLY_F32}, {"float32", PLY_F32}, {"double", PLY_F64}, {"float64", PLY_F64},
    };
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++)
        if (!strcmp(s, names[i].name))
            return names[i].type;
    return PLY_NONE;
}

static size_t ply_type_size(enum ply_type t)
{
    static const size_t sizes[] = {0, 1, 1, 2, 2, 4, 4, 4, 8};
    return sizes[t];
}

/* Reads one value of type t; returns ESR_ERR at the end of the data or on a malformed token. */
static int ply_next(struct ply_cursor *c, enum ply_type t, double *out)
{
    if (c->ascii) {
        while (c->p < c->end && (*c->p == ' ' || *c->p == '\n' || *c->p == '\r' || *c->p == '\t'))
            c->p++;
        if (c->p >= c->end)
            return ESR_FAIL("%s: PLY data ends early", c->path);
        char token[64];
        size_t n = 0;
        while (c->p < c->end && n + 1 < sizeof token && *c->p > ' ')
            token[n++] = (char)*c->p++;
        token[n] = '\0';
        char *stop;
        *out = strtod(token, &stop);
        if (*stop != '\0')
            return ESR_FAIL("%s: malformed PLY value '%s'", c->path, token);
        return ESR_OK;
    }
    size_t size = ply_type_size(t);
    if ((size_t)(c->end - c->p) < size)
        return ESR_FAIL("%s: PLY data ends early", c->path);
    union { int8_t i8; uint8_t u8; int16_t i16; uint16_t u16; int32_t i32; uint32_t u32; float f32; double f64; } v;
    memcpy(&v, c->p, size); /* little-endian file on a little-endian host */
    c->p += size;
    switch (t) {
    case PLY_I8: *out = v.i8; break;
    case PLY_U8: *out = v.u8; break;
    case PLY_I16: *out = v.i16; break;
    case PLY_U16: *out = v.u16; break;
    case PLY_I32: *out = v.i32; break;
    case PLY_U32: *out = v.u32; break;
    case PLY_F32: *out = v.f32; break;
    default: *out = v.f64; break;
    }
    return ESR_OK;
}

/* Parses the header up to end_header; fills the vertex and face element descriptions. */
static int ply_parse_header(struct ply_cursor *c, struct ply_element *vertex, struct ply_element *face)
{
    const char *text = (const char *)c->p;
    size_t len = (size_t)(c->end - c->p);
    /* header lines may end in CRLF (files from Windows tools); the magic line too */
    const size_t magic = len >= 4 && !memcmp(text, "ply\n", 4) ? 4 : len >= 5 && !memcmp(text, "ply\r\n", 5) ? 5 : 0;
    if (!magic)
        return ESR_FAIL("%s: not a PLY file (missing 'ply' magic)", c->path);
    struct ply_element *current = NULL;
    const char *line = text + magic;
    int format_seen = 0;
    for (;;) {
        const char *nl = memchr(line, '\n', (size_t)(text + len - line));
        if (!nl)
            return ESR_FAIL("%s: PLY header has no end_header", c->path);
        char buf[256];
        size_t n = (size_t)(nl - line) < sizeof buf - 1 ? (size_t)(nl - line) : sizeof buf - 1;
        memcpy(buf, line, n);
        buf[n] = '\0';
        if (n && buf[n - 1] == '\r')
            buf[n - 1] = '\0';
        line = nl + 1;
        char a[64] = "", b[64] = "", d[64] = "", e[64] = "", f[64] = "";
        int words = sscanf(buf, "%63s %63s %63s %63s %63s", a, b, d, e, f);
        if (words <= 0 || !strcmp(a, "comment") || !strcmp(a, "obj_info"))
            continue;
        if (!strcmp(a, "end_header"))
            break;
        if (!strcmp(a, "format")) {
            if (!strcmp(b, "ascii"))
                c->ascii = 1;
            else if (strcmp(b, "binary_little_endian") != 0)
                return ESR_FAIL("%s: PLY format '%s' is not supported (ascii, binary_little_endian)", c->path, b);
            format_seen = 1;
        } else if (!strcmp(a, "element")) {
            char *stop;
            double count = strtod(d, &stop);
            if (words < 3 || *stop || !(count >= 0 && count <= 1e9)) /* NaN included */
                return ESR_FAIL("%s: malformed PLY element line '%s'", c->path, buf);
            current = !strcmp(b, "vertex") ? vertex : !strcmp(b, "face") ? face : NULL;
            if (!current)
                return ESR_FAIL("%s: PLY element '%s' is not supported (vertex, face)", c->path, b);
            if (current->n_props || (current == face && !vertex->n_props))
                return ESR_FAIL("%s: PLY elements must be one vertex element, then faces", c->path);
            current->count = (size_t)count;
        } else if (!strcmp(a, "property")) {
            if (!current || current->n_props == PLY_MAX_PROPS)
                return ESR_FAIL("%s: PLY property outside an element or too many: '%s'", c->path, buf);
            struct ply_property *p = &current->props[current->n_props++];
            const char *name;
            if (!strcmp(b, "list")) {
                p->count_type = ply_type_from_name(d);
                p->type = ply_type_from_name(e);
                name = f;
            } else {
                p->count_type = PLY_NONE;
                p->type = ply_type_from_name(b);
                name = d;
            }
            if (p->type == PLY_NONE || (!strcmp(b, "list") && p->count_type == PLY_NONE))
                return ESR_FAIL("%s: unknown PLY property type in '%s'", c->path, buf);
            p->role = -1;
            if (current == vertex && p->count_type == PLY_NONE && name[0] >= 'x' && name[0] <= 'z' && !name[1])
                p->role = name[0] - 'x';
            if (current == face && p->count_type != PLY_NONE &&
                (!strcmp(name, "vertex_indices") || !strcmp(name, "vertex_index")))
                p->role = 3;
        } else {
            return ESR_FAIL("%s: unexpected PLY header line '%s'", c->path, buf);
        }
    }
    if (!format_seen)
        return ESR_FAIL("%s: PLY header has no format line", c->path);
    c->p = (const unsigned char *)line;
    return ESR_OK;
}

static int ply_read_vertices(struct ply_cursor *c, const struct ply_element *el, float *pos)
{
    for (size_t i = 0; i < el->count; i++) {
        for (int k = 0; k < el->n_props; k++) {
            const struct ply_property *p = &el->props[k];
            double v;
            ESR_TRY(ply_next(c, p->count_type != PLY_NONE ? p->count_type : p->type, &v));
            if (p->count_type != PLY_NONE) { /* a list on vertices: skip its items */
                if (!(v >= 0 && v <= (double)(c->end - c->p)))
                    return ESR_FAIL("%s: vertex %zu has a list of %g items", c->path, i, v);
                for (long j = 0; j < (long)v; j++) {
                    double skip;
                    ESR_TRY(ply_next(c, p->type, &skip));
                }
            } else if (p->role >= 0) {
                if (!isfinite(v))
                    return ESR_FAIL("%s: vertex %zu has a non-finite coordinate", c->path, i);
                pos[i * 3 + (size_t)p->role] = (float)v;
            }
        }
    }
    return ESR_OK;
}

static int ply_read_faces(struct ply_cursor *c, const struct ply_element *el, size_t n_vertices,
                          struct esr_mesh *m)
{
    size_t capacity = el->count * 2 + 1;
    m->tri = (uint32_t *)malloc(capacity * 3 * sizeof(uint32_t));
    if (!m->tri)
        return ESR_FAIL("%s: out of memory for %zu faces", c->path, el->count);
    for (size_t i = 0; i < el->count; i++) {
        for (int k = 0; k < el->n_props; k++) {
            const struct ply_property *p = &el->props[k];
            double count = 1.0;
            if (p->count_type != PLY_NONE)
                ESR_TRY(ply_next(c, p->count_type, &count));
            if (!(count >= 0 && count <= 64)) /* NaN included */
                return ESR_FAIL("%s: face %zu has %g vertices", c->path, i, count);
            uint32_t idx[64];
            for (int j = 0; j < (int)count; j++) {
                double v;
                ESR_TRY(ply_next(c, p->type, &v));
                if (p->role != 3)
                    continue;
                if (!(v >= 0 && v < (double)n_vertices))
                    return ESR_FAIL("%s: face %zu refers to vertex %g of %zu", c->path, i, v, n_vertices);
                idx[j] = (uint32_t)v;
            }
            for (int j = 2; p->role == 3 && j < (int)count; j++) { /* fan triangulation */
                if (m->n_triangles == capacity) {
                    capacity *= 2;
                    uint32_t *grown = (uint32_t *)realloc(m->tri, capacity * 3 * sizeof(uint32_t));
                    if (!grown)
                        return ESR_FAIL("%s: out of memory for faces", c->path);
                    m->tri = grown;
                }
                uint32_t *t = m->tri + m->n_triangles++ * 3;
                t[0] = idx[0];
                t[1] = idx[j - 1];
                t[2] = idx[j];
            }
        }
    }
    return ESR_OK;
}

/* Every value takes at least a byte in either format: a header whose counts the data cannot hold
 * is refused before anything is allocated for them. */
static int ply_check_counts(const struct ply_cursor *c, const struct ply_element *vertex,
                            const struct ply_element *face)
{
    const double left = (double)(c->end - c->p);
    if ((double)vertex->count * vertex->n_props > left || (double)face->count * face->n_props > left)
        return ESR_FAIL("%s: PLY header claims %zu vertices and %zu faces, the file holds %.0f bytes of data",
                        c->path, vertex->count, face->count, left);
    if (face->count && !face->n_props)
        return ESR_FAIL("%s: PLY faces have no properties", c->path);
    return ESR_OK;
}

int esr_ply_parse(const void *bytes, size_t size, const char *name, struct esr_mesh *m)
{
    memset(m, 0, sizeof *m);
    struct ply_cursor c = {name, bytes, (const unsigned char *)bytes + size, 0};
    struct ply_element vertex = {0}, face = {0};
    int rc = ply_parse_header(&c, &vertex, &face);
    int has_xyz = 0;
    for (int k = 0; k < vertex.n_props; k++)
        has_xyz |= vertex.props[k].role >= 0 ? 1 << vertex.props[k].role : 0;
    if (rc == ESR_OK && has_xyz != 7)
        rc = ESR_FAIL("%s: PLY vertices lack x, y or z", name);
    if (rc == ESR_OK)
        rc = ply_check_counts(&c, &vertex, &face);
    if (rc == ESR_OK) {
        m->n_vertices = vertex.count;
        m->pos = (float *)calloc(vertex.count * 3 + 3, sizeof(float));
        rc = m->pos ? ply_read_vertices(&c, &vertex, m->pos) : ESR_FAIL("%s: out of memory", name);
    }
    /* The vertex element precedes the face element in every PLY we accept (header order). */
    if (rc == ESR_OK && face.count)
        rc = ply_read_faces(&c, &face, vertex.count, m);
    if (rc != ESR_OK)
        esr_mesh_free(m);
    return rc;
}

int esr_ply_read(const char *path, struct esr_mesh *m)
{
    memset(m, 0, sizeof *m);
    unsigned char *data;
    size_t size;
    ESR_TRY(esr_file_read_all(path, &data, &size));
    int rc = esr_ply_parse(data, size, path, m);
    free(data);
    return rc;
}
