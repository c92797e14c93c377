/* COLMAP's binary model files (little-endian, as COLMAP's reconstruction_io writes them):
 *   cameras.bin   u64 count; per camera: u32 id, i32 model, u64 width, u64 height, f64 params[]
 *   images.bin    u64 count; per image: u32 id, f64 qw qx qy qz, f64 tx ty tz, u32 camera id,
 *                 name bytes up to a NUL, u64 n_points2D, n x (f64 x, f64 y, i64 point3D id)
 *   points3D.bin  u64 count; per point: u64 id, f64 x y z, u8 r g b, f64 error, u64 track
 *                 length, length x (u32 image id, u32 point2D index)
 * Every count is checked against the bytes left before anything is allocated or skipped, so a
 * truncated or corrupt file is an error naming it, never a crash or a huge allocation. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "import/colmap.h"

struct reader {
    const unsigned char *p, *end;
    const char *path;
};

static int need(struct reader *r, size_t n, const char *what)
{
    if ((size_t)(r->end - r->p) < n)
        return ESR_FAIL("'%s' is truncated or corrupt (ends inside %s)", r->path, what);
    return ESR_OK;
}

/* Little-endian loads byte by byte: correct on any host and for unaligned data. */
static uint64_t load_le(const unsigned char *p, int bytes)
{
    uint64_t v = 0;
    for (int i = bytes - 1; i >= 0; i--)
        v = v << 8 | p[i];
    return v;
}

static int read_u64(struct reader *r, const char *what, uint64_t *v)
{
    ESR_TRY(need(r, 8, what));
    *v = load_le(r->p, 8);
    r->p += 8;
    return ESR_OK;
}

static int read_u32(struct reader *r, const char *what, uint32_t *v)
{
    ESR_TRY(need(r, 4, what));
    *v = (uint32_t)load_le(r->p, 4);
    r->p += 4;
    return ESR_OK;
}

static int read_f64s(struct reader *r, const char *what, double *v, int n)
{
    ESR_TRY(need(r, 8 * (size_t)n, what));
    for (int i = 0; i < n; i++) {
        uint64_t bits = load_le(r->p, 8);
        memcpy(&v[i], &bits, sizeof bits);
        r->p += 8;
    }
    return ESR_OK;
}

static int skip(struct reader *r, uint64_t count, size_t each, const char *what)
{
    if (count > (uint64_t)(r->end - r->p) / each)
        return ESR_FAIL("'%s' is truncated or corrupt (%llu %s do not fit in the file)", r->path,
                        (unsigned long long)count, what);
    r->p += count * each;
    return ESR_OK;
}

/* The leading record count, refused when `min_record` bytes each cannot fit in what is left or
 * the count exceeds `max`. */
static int read_count(struct reader *r, size_t min_record, uint64_t max, const char *what, uint64_t *n)
{
    ESR_TRY(read_u64(r, "the record count", n));
    if (*n > max || *n > (uint64_t)(r->end - r->p) / min_record)
        return ESR_FAIL("'%s' is truncated or corrupt (claims %llu %s)", r->path, (unsigned long long)*n, what);
    return ESR_OK;
}

static int finish(struct reader *r)
{
    if (r->p != r->end)
        return ESR_FAIL("'%s' is corrupt (%zu bytes after the last record)", r->path, (size_t)(r->end - r->p));
    return ESR_OK;
}

static int read_camera(struct reader *r, void *record)
{
    struct esr_colmap_camera *c = record;
    uint32_t model;
    uint64_t w, h;
    ESR_TRY(read_u32(r, "a camera", &c->id));
    ESR_TRY(read_u32(r, "a camera", &model));
    ESR_TRY(read_u64(r, "a camera", &w));
    ESR_TRY(read_u64(r, "a camera", &h));
    if (model >= ESR_COLMAP_MODEL_COUNT)
        return ESR_FAIL("'%s': camera %u has camera model %d, which esr does not support (supported: "
                        "SIMPLE_PINHOLE 0, PINHOLE 1, SIMPLE_RADIAL 2, RADIAL 3, OPENCV 4)",
                        r->path, c->id, (int32_t)model);
    if (w == 0 || h == 0 || w > 1u << 16 || h > 1u << 16)
        return ESR_FAIL("'%s': camera %u has an implausible size %llux%llu", r->path, c->id, (unsigned long long)w,
                        (unsigned long long)h);
    c->model = (enum esr_colmap_model_id)model;
    c->width = (int)w;
    c->height = (int)h;
    return read_f64s(r, "camera parameters", c->params, esr_colmap_model_n_params(c->model));
}

static int read_image(struct reader *r, void *record)
{
    struct esr_colmap_image *im = record;
    ESR_TRY(read_u32(r, "an image", &im->id));
    ESR_TRY(read_f64s(r, "an image pose", im->q, 4));
    ESR_TRY(read_f64s(r, "an image pose", im->t, 3));
    ESR_TRY(read_u32(r, "an image", &im->camera_id));
    const unsigned char *nul = memchr(r->p, '\0', (size_t)(r->end - r->p));
    if (!nul)
        return ESR_FAIL("'%s' is truncated or corrupt (image %u's name has no end)", r->path, im->id);
    size_t len = (size_t)(nul - r->p);
    if (len >= sizeof im->name)
        return ESR_FAIL("'%s': image %u's name is longer than %d bytes", r->path, im->id, ESR_COLMAP_NAME_MAX - 1);
    memcpy(im->name, r->p, len);
    im->name[len] = '\0';
    r->p = nul + 1;
    uint64_t n2d;
    ESR_TRY(read_u64(r, "an image's keypoint count", &n2d));
    return skip(r, n2d, 24, "keypoints");
}

static int read_point(struct reader *r, void *record)
{
    double *xyz = record; /* x, y, z */
    uint64_t id, track;
    double error;
    ESR_TRY(read_u64(r, "a 3D point", &id));
    ESR_TRY(read_f64s(r, "a 3D point", xyz, 3));
    ESR_TRY(skip(r, 3, 1, "colour bytes"));
    ESR_TRY(read_f64s(r, "a 3D point", &error, 1));
    ESR_TRY(read_u64(r, "a 3D point's track length", &track));
    return skip(r, track, 8, "track entries");
}

/* One file of a binary model: a count, then that many records of at least min_bytes each. */
struct record_file {
    const char *what;
    size_t min_bytes, size; /* least bytes of a record in the file; bytes of one in memory */
    uint64_t max;
    int (*read_one)(struct reader *r, void *record);
};

/* Parses one file (in) of format f into *records (allocated, *count of them). */
static int read_records(const struct esr_colmap_file *in, const struct record_file *f, void **records,
                        size_t *count)
{
    struct reader r = {in->data, in->data, in->name};
    if (in->size) /* (no arithmetic on the NULL of an empty file) */
        r.end = r.p + in->size;
    uint64_t n = 0;
    int status = read_count(&r, f->min_bytes, f->max, f->what, &n);
    unsigned char *out = NULL;
    if (status == ESR_OK && !(out = calloc(n ? n : 1, f->size)))
        status = ESR_FAIL("out of memory reading '%s'", in->name);
    for (uint64_t i = 0; i < n && status == ESR_OK; i++)
        status = f->read_one(&r, out + i * f->size);
    if (status == ESR_OK)
        status = finish(&r);
    if (status != ESR_OK) {
        free(out);
        return status;
    }
    *records = out;
    *count = (size_t)n; /* at most f->max */
    return ESR_OK;
}

int esr_colmap_model_parse_binary(const struct esr_colmap_file files[ESR_COLMAP_FILES], struct esr_colmap_model *m)
{
    static const struct record_file formats[ESR_COLMAP_FILES] = {
        [ESR_COLMAP_CAMERAS] = {"cameras", 24, sizeof(struct esr_colmap_camera), 1u << 20, read_camera},
        [ESR_COLMAP_IMAGES] = {"images", 73, sizeof(struct esr_colmap_image), 1u << 24, read_image},
        [ESR_COLMAP_POINTS] = {"3D points", 51, 3 * sizeof(double), 1u << 30, read_point}};
    void *records[ESR_COLMAP_FILES] = {NULL, NULL, NULL};
    size_t count[ESR_COLMAP_FILES] = {0, 0, 0}; /* within each format's maximum */
    int status = ESR_OK;
    for (int i = 0; i < ESR_COLMAP_FILES && status == ESR_OK; i++)
        status = read_records(&files[i], &formats[i], &records[i], &count[i]);
    return esr_colmap_model_assemble(m, "binary", records, count, files, status);
}
