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
#include "io/colmap.h"
#include "io/file.h"

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

/* A text file split into lines in place. */
struct lines {
    char *text, *next;
    const char *path;
    int line; /* number of the line last returned */
};

static int lines_open(const char *path, struct lines *l)
{
    unsigned char *bytes;
    size_t size;
    l->text = l->next = NULL;
    l->path = path;
    l->line = 0;
    ESR_TRY(esr_file_read_all(path, &bytes, &size));
    if (memchr(bytes, '\0', size))
        free(bytes);
    else
        l->text = l->next = (char *)bytes;
    return l->text ? ESR_OK : ESR_FAIL("'%s' is not a text file (it holds NUL bytes)", path);
}

/* The next line (without its end-of-line), or NULL at the end of the file. */
static char *lines_next(struct lines *l)
{
    if (!l->next || !*l->next)
        return NULL;
    char *line = l->next, *eol = strchr(line, '\n');
    l->next = eol ? eol + 1 : line + strlen(line);
    if (eol)
        *eol = '\0';
    size_t n = strlen(line);
    if (n && line[n - 1] == '\r')
        line[n - 1] = '\0';
    l->line++;
    return line;
}

/* The next line that is neither blank nor a comment, or NULL at the end. */
static char *lines_next_data(struct lines *l)
{
    char *line;
    while ((line = lines_next(l))) {
        const char *p = line + strspn(line, " \t");
        if (*p && *p != '#')
            return line;
    }
    return NULL;
}

#define LINE_FAIL(l, ...) line_fail(l, __FILE__, __LINE__, __VA_ARGS__)
static int line_fail(const struct lines *l, const char *src, int line, const char *what)
{
    return esr_error_set(src, line, "'%s', line %d: %s", l->path, l->line, what);
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

static int parse_camera(struct lines *l, char *line, struct esr_colmap_camera *c)
{
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

static int parse_image(struct lines *l, char *line, struct esr_colmap_image *im)
{
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

static int parse_point(struct lines *l, char *line, double xyz[3])
{
    char *f[8];
    int n = split(line, f, 8);
    if (n < 8 || parse_double(f[1], &xyz[0]) || parse_double(f[2], &xyz[1]) || parse_double(f[3], &xyz[2]))
        return LINE_FAIL(l, "expected POINT3D_ID X Y Z R G B ERROR TRACK[]");
    return ESR_OK;
}

static int read_cameras(struct lines *l, struct esr_colmap_model *m)
{
    struct records cams = {0};
    char *line;
    int status = ESR_OK;
    while (status == ESR_OK && (line = lines_next_data(l))) {
        struct esr_colmap_camera c;
        memset(&c, 0, sizeof c);
        status = parse_camera(l, line, &c);
        if (status == ESR_OK)
            status = records_push(&cams, &c, sizeof c, l->path);
    }
    m->cameras = cams.data;
    m->n_cameras = (int)cams.count;
    return status;
}

static int read_images(struct lines *l, struct esr_colmap_model *m)
{
    struct records imgs = {0};
    char *line;
    int status = ESR_OK;
    while (status == ESR_OK && (line = lines_next_data(l))) {
        struct esr_colmap_image im;
        memset(&im, 0, sizeof im);
        status = parse_image(l, line, &im);
        if (status == ESR_OK)
            status = records_push(&imgs, &im, sizeof im, l->path);
        lines_next(l); /* the keypoint line */
    }
    m->images = imgs.data;
    m->n_images = (int)imgs.count;
    return status;
}

static int read_points(struct lines *l, struct esr_colmap_model *m)
{
    struct records pts = {0};
    char *line;
    int status = ESR_OK;
    while (status == ESR_OK && (line = lines_next_data(l))) {
        double xyz[3];
        status = parse_point(l, line, xyz);
        if (status == ESR_OK)
            status = records_push(&pts, xyz, sizeof xyz, l->path);
    }
    m->points = pts.data;
    m->n_points = (long)pts.count;
    return status;
}

typedef int (*file_reader)(struct lines *l, struct esr_colmap_model *m);

static int read_file(const char *dir, const char *name, file_reader fn, char *path, size_t n,
                     struct esr_colmap_model *m)
{
    snprintf(path, n, "%s/%s", dir, name);
    struct lines l;
    ESR_TRY(lines_open(path, &l));
    int status = fn(&l, m);
    free(l.text);
    return status;
}

int esr_colmap_model_read_text(const char *dir, struct esr_colmap_model *m)
{
    memset(m, 0, sizeof *m);
    m->format = "text";
    char cameras[ESR_COLMAP_NAME_MAX * 2], images[ESR_COLMAP_NAME_MAX * 2], points[ESR_COLMAP_NAME_MAX * 2];
    int status = read_file(dir, "cameras.txt", read_cameras, cameras, sizeof cameras, m);
    if (status == ESR_OK)
        status = read_file(dir, "images.txt", read_images, images, sizeof images, m);
    if (status == ESR_OK)
        status = read_file(dir, "points3D.txt", read_points, points, sizeof points, m);
    if (status == ESR_OK)
        status = esr_colmap_model_validate(m, cameras, images);
    if (status != ESR_OK)
        esr_colmap_model_free(m);
    return status;
}
