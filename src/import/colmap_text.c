/* COLMAP's text model files (doc/format.rst): '#' starts a comment line;
 *   cameras.txt   CAMERA_ID MODEL WIDTH HEIGHT PARAMS[]
 *   images.txt    two lines per image: IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME, then the
 *                 keypoints (X Y POINT3D_ID ...; may be an empty line, so it is consumed unread)
 *   points3D.txt  POINT3D_ID X Y Z R G B ERROR TRACK[] */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "import/colmap.h"

/* A growing array of fixed-size records. */
struct records {
    void *data;
    size_t count, capacity;
};

static int records_push(struct records *r, const void *item, size_t size, const char *path)
{
    if (r->count == r->capacity) {
        size_t cap = r->capacity ? 2 * r->capacity : 64;
        void *grown = realloc(r->data, cap * size);
        if (!grown)
            return ESR_FAIL("out of memory reading '%s'", path);
        r->data = grown;
        r->capacity = cap;
    }
    memcpy((char *)r->data + r->count++ * size, item, size);
    return ESR_OK;
}

/* A text file's lines, read without writing to its bytes: each data line is copied into buf
 * (NUL-terminated) for the field splitting; the long keypoint lines are skipped uncopied. */
struct lines {
    const char *next, *end;
    const char *path;
    long line; /* number of the line last returned */
    char *buf;
    size_t cap;
};

/* The next line (without its end-of-line) as start and length; 0 at the end of the file. */
static int lines_next(struct lines *l, const char **start, size_t *len)
{
    if (l->next >= l->end)
        return 0;
    const char *line = l->next, *eol = memchr(line, '\n', (size_t)(l->end - line));
    size_t n = eol ? (size_t)(eol - line) : (size_t)(l->end - line);
    l->next = eol ? eol + 1 : l->end;
    if (n && line[n - 1] == '\r')
        n--;
    l->line++;
    *start = line;
    *len = n;
    return 1;
}

/* The next line that is neither blank nor a comment, copied into l->buf (*line NULL at the end). */
static int lines_next_data(struct lines *l, char **line)
{
    const char *start;
    size_t n;
    *line = NULL;
    while (lines_next(l, &start, &n)) {
        size_t lead = 0;
        while (lead < n && (start[lead] == ' ' || start[lead] == '\t'))
            lead++;
        if (lead == n || start[lead] == '#')
            continue;
        if (n + 1 > l->cap) {
            char *grown = realloc(l->buf, n + 1);
            if (!grown)
                return ESR_FAIL("out of memory reading '%s'", l->path);
            l->buf = grown;
            l->cap = n + 1;
        }
        memcpy(l->buf, start, n);
        l->buf[n] = '\0';
        *line = l->buf;
        return ESR_OK;
    }
    return ESR_OK;
}

#define LINE_FAIL(l, ...) line_fail(l, __FILE__, __LINE__, __VA_ARGS__)
static int line_fail(const struct lines *l, const char *src, int line, const char *what)
{
    return esr_error_set(src, line, "'%s', line %ld: %s", l->path, l->line, what);
}

/* Whitespace-separated fields of one line. */
static int split(char *line, char **field, int max)
{
    int n = 0;
    char *save, *tok = strtok_r(line, " \t", &save);
    for (; tok && n < max; tok = strtok_r(NULL, " \t", &save))
        field[n++] = tok;
    return n;
}

static int parse_double(const char *s, double *v)
{
    char *end;
    errno = 0;
    *v = strtod(s, &end);
    return end != s && !*end && !errno ? ESR_OK : ESR_ERR;
}

static int parse_u32(const char *s, uint32_t *v)
{
    char *end;
    errno = 0;
    unsigned long long x = strtoull(s, &end, 10);
    if (end == s || *end || errno || x > UINT32_MAX || *s == '-')
        return ESR_ERR;
    *v = (uint32_t)x;
    return ESR_OK;
}

static int parse_camera(struct lines *l, char *line, void *record)
{
    struct esr_colmap_camera *c = record;
    char *f[4 + ESR_COLMAP_MAX_PARAMS + 1];
    int n = split(line, f, 4 + ESR_COLMAP_MAX_PARAMS + 1);
    uint32_t w, h;
    if (n < 4 || parse_u32(f[0], &c->id) || parse_u32(f[2], &w) || parse_u32(f[3], &h) || w > 1u << 16 ||
        h > 1u << 16)
        return LINE_FAIL(l, "expected CAMERA_ID MODEL WIDTH HEIGHT PARAMS[]");
    int model = esr_colmap_model_from_name(f[1]);
    if (model < 0) {
        char msg[256];
        snprintf(msg, sizeof msg, "camera model '%.64s' is not supported (supported: SIMPLE_PINHOLE, PINHOLE, "
                                  "SIMPLE_RADIAL, RADIAL, OPENCV)", f[1]);
        return LINE_FAIL(l, msg);
    }
    c->model = (enum esr_colmap_model_id)model;
    c->width = (int)w;
    c->height = (int)h;
    int want = esr_colmap_model_n_params(c->model);
    if (n - 4 != want) {
        char msg[128];
        snprintf(msg, sizeof msg, "%s takes %d parameters, the line has %d", f[1], want, n - 4);
        return LINE_FAIL(l, msg);
    }
    for (int i = 0; i < want; i++)
        if (parse_double(f[4 + i], &c->params[i]))
            return LINE_FAIL(l, "camera parameter is not a number");
    return ESR_OK;
}

static int parse_image(struct lines *l, char *line, void *record)
{
    struct esr_colmap_image *im = record;
    char *f[10];
    /* the name is the rest of the line after nine fields (it may not contain blanks in COLMAP's
     * own files, but nothing here needs it not to) */
    char *p = line;
    int n = 0;
    for (; n < 9; n++) {
        p += strspn(p, " \t");
        if (!*p)
            break;
        f[n] = p;
        p += strcspn(p, " \t");
        if (*p)
            *p++ = '\0';
    }
    p += strspn(p, " \t");
    size_t len = strlen(p);
    while (len && (p[len - 1] == ' ' || p[len - 1] == '\t'))
        p[--len] = '\0';
    if (n < 9 || !len)
        return LINE_FAIL(l, "expected IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME");
    if (len >= sizeof im->name)
        return LINE_FAIL(l, "image name is too long");
    int bad = parse_u32(f[0], &im->id) || parse_u32(f[8], &im->camera_id);
    for (int i = 0; i < 4; i++)
        bad |= parse_double(f[1 + i], &im->q[i]);
    for (int i = 0; i < 3; i++)
        bad |= parse_double(f[5 + i], &im->t[i]);
    if (bad)
        return LINE_FAIL(l, "expected IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME");
    memcpy(im->name, p, len + 1);
    return ESR_OK;
}

static int parse_point(struct lines *l, char *line, void *record)
{
    double *xyz = record; /* x, y, z */
    char *f[8];
    int n = split(line, f, 8);
    if (n < 8 || parse_double(f[1], &xyz[0]) || parse_double(f[2], &xyz[1]) || parse_double(f[3], &xyz[2]))
        return LINE_FAIL(l, "expected POINT3D_ID X Y Z R G B ERROR TRACK[]");
    return ESR_OK;
}

/* One of the three files: a record per data line, of `size` bytes, filled by `parse` (zeroed
 * first); in images.txt each record's line is followed by its keypoint line. */
struct text_file {
    size_t size;
    int (*parse)(struct lines *l, char *line, void *record);
    int keypoint_lines;
};

union any_record {
    struct esr_colmap_camera camera;
    struct esr_colmap_image image;
    double xyz[3];
};

static int read_lines(struct lines *l, const struct text_file *f, struct records *out)
{
    for (;;) {
        char *line;
        ESR_TRY(lines_next_data(l, &line));
        if (!line)
            return ESR_OK;
        union any_record record;
        memset(&record, 0, sizeof record);
        ESR_TRY(f->parse(l, line, &record));
        ESR_TRY(records_push(out, &record, f->size, l->path));
        const char *keypoints;
        size_t n;
        if (f->keypoint_lines)
            lines_next(l, &keypoints, &n); /* consumed unread, even when empty */
    }
}

static int read_file(const struct esr_colmap_file *in, const struct text_file *f, struct records *out)
{
    if (in->size && memchr(in->data, '\0', in->size))
        return ESR_FAIL("'%s' is not a text file (it holds NUL bytes)", in->name);
    struct lines l = {in->data, in->data, in->name, 0, NULL, 0};
    if (in->size) /* (no arithmetic on the NULL of an empty file) */
        l.end = l.next + in->size;
    int status = read_lines(&l, f, out);
    free(l.buf);
    return status;
}

int esr_colmap_model_parse_text(const struct esr_colmap_file files[ESR_COLMAP_FILES], struct esr_colmap_model *m)
{
    static const struct text_file formats[ESR_COLMAP_FILES] = {
        [ESR_COLMAP_CAMERAS] = {sizeof(struct esr_colmap_camera), parse_camera, 0},
        [ESR_COLMAP_IMAGES] = {sizeof(struct esr_colmap_image), parse_image, 1},
        [ESR_COLMAP_POINTS] = {3 * sizeof(double), parse_point, 0}};
    struct records r[ESR_COLMAP_FILES] = {{0}};
    int status = ESR_OK;
    for (int i = 0; i < ESR_COLMAP_FILES && status == ESR_OK; i++)
        status = read_file(&files[i], &formats[i], &r[i]);
    void *records[ESR_COLMAP_FILES];
    size_t count[ESR_COLMAP_FILES];
    for (int i = 0; i < ESR_COLMAP_FILES; i++)
        records[i] = r[i].data, count[i] = r[i].count;
    return esr_colmap_model_assemble(m, "text", records, count, files, status);
}
