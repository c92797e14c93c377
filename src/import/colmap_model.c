/* The COLMAP model container shared by the text and binary readers (see colmap.h). */
#include "import/colmap.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "import/colmap_camera.h"
#include "io/file.h"

static const struct {
    const char *name;
    int n_params;
} model_table[ESR_COLMAP_MODEL_COUNT] = {
    [ESR_COLMAP_SIMPLE_PINHOLE] = {"SIMPLE_PINHOLE", 3}, [ESR_COLMAP_PINHOLE] = {"PINHOLE", 4},
    [ESR_COLMAP_SIMPLE_RADIAL] = {"SIMPLE_RADIAL", 4},   [ESR_COLMAP_RADIAL] = {"RADIAL", 5},
    [ESR_COLMAP_OPENCV] = {"OPENCV", 8},
};

const char *esr_colmap_model_name(enum esr_colmap_model_id model)
{
    return (unsigned)model < ESR_COLMAP_MODEL_COUNT ? model_table[model].name : "?";
}

int esr_colmap_model_from_name(const char *name)
{
    for (int i = 0; i < ESR_COLMAP_MODEL_COUNT; i++)
        if (!strcmp(name, model_table[i].name))
            return i;
    return -1;
}

int esr_colmap_model_n_params(enum esr_colmap_model_id model)
{
    return (unsigned)model < ESR_COLMAP_MODEL_COUNT ? model_table[model].n_params : 0;
}

const struct esr_colmap_camera *esr_colmap_find_camera(const struct esr_colmap_model *m, uint32_t id)
{
    for (int i = 0; i < m->n_cameras; i++)
        if (m->cameras[i].id == id)
            return &m->cameras[i];
    return NULL;
}

void esr_colmap_model_free(struct esr_colmap_model *m)
{
    free(m->cameras);
    free(m->images);
    free(m->points);
    memset(m, 0, sizeof *m);
}

static int all_finite(const double *v, int n)
{
    for (int i = 0; i < n; i++)
        if (!isfinite(v[i]))
            return 0;
    return 1;
}

static int compare_u32(const void *a, const void *b)
{
    const uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return (x > y) - (x < y);
}

/* COLMAP never writes two images with one id; a model that has them is damaged (the points'
 * tracks name images by id), so it is refused rather than imported. */
static int check_image_ids_unique(const struct esr_colmap_model *m, const char *images_file)
{
    if (m->n_images < 2)
        return ESR_OK;
    uint32_t *ids = malloc((size_t)m->n_images * sizeof *ids);
    if (!ids)
        return ESR_FAIL("out of memory checking %d image ids", m->n_images);
    for (int i = 0; i < m->n_images; i++)
        ids[i] = m->images[i].id;
    qsort(ids, (size_t)m->n_images, sizeof *ids, compare_u32);
    int rc = ESR_OK;
    for (int i = 1; i < m->n_images && rc == ESR_OK; i++)
        if (ids[i] == ids[i - 1])
            rc = ESR_FAIL("'%s': image id %u appears twice", images_file, ids[i]);
    free(ids);
    return rc;
}

int esr_colmap_model_validate(const struct esr_colmap_model *m, const char *cameras_file, const char *images_file,
                              const char *points_file)
{
    for (int i = 0; i < m->n_cameras; i++) {
        const struct esr_colmap_camera *c = &m->cameras[i];
        if (c->width <= 0 || c->height <= 0)
            return ESR_FAIL("'%s': camera %u has size %dx%d", cameras_file, c->id, c->width, c->height);
        struct esr_colmap_intrinsics k;
        esr_colmap_intrinsics_of(c, &k);
        if (!all_finite(c->params, ESR_COLMAP_MAX_PARAMS) || !(k.fx > 0.0) || !(k.fy > 0.0))
            return ESR_FAIL("'%s': camera %u has a non-positive focal length or a non-finite parameter",
                            cameras_file, c->id);
        if (esr_colmap_find_camera(m, c->id) != c)
            return ESR_FAIL("'%s': camera id %u appears twice", cameras_file, c->id);
    }
    for (int i = 0; i < m->n_images; i++) {
        const struct esr_colmap_image *im = &m->images[i];
        double qn = im->q[0] * im->q[0] + im->q[1] * im->q[1] + im->q[2] * im->q[2] + im->q[3] * im->q[3];
        if (!all_finite(im->q, 4) || !all_finite(im->t, 3) || !(qn > 1e-12) || !isfinite(qn))
            return ESR_FAIL("'%s': image %u ('%s') has a non-finite or zero pose", images_file, im->id, im->name);
        if (!im->name[0])
            return ESR_FAIL("'%s': image %u has an empty name", images_file, im->id);
        if (!esr_colmap_find_camera(m, im->camera_id))
            return ESR_FAIL("'%s': image %u ('%s') refers to camera %u, which is not in '%s'", images_file, im->id,
                            im->name, im->camera_id, cameras_file);
    }
    ESR_TRY(check_image_ids_unique(m, images_file));
    /* (the scene's placement takes medians and quantiles of the points) */
    for (long i = 0; i < m->n_points; i++)
        if (!all_finite(m->points + 3 * i, 3))
            return ESR_FAIL("'%s': 3D point %ld of %ld has a non-finite position", points_file, i + 1, m->n_points);
    return ESR_OK;
}

int esr_colmap_model_assemble(struct esr_colmap_model *m, const char *format, void *const records[ESR_COLMAP_FILES],
                              const size_t count[ESR_COLMAP_FILES], const struct esr_colmap_file files[ESR_COLMAP_FILES],
                              int status)
{
    memset(m, 0, sizeof *m);
    m->format = format;
    m->cameras = records[ESR_COLMAP_CAMERAS];
    m->images = records[ESR_COLMAP_IMAGES];
    m->points = records[ESR_COLMAP_POINTS];
    m->n_cameras = (int)count[ESR_COLMAP_CAMERAS];
    m->n_images = (int)count[ESR_COLMAP_IMAGES];
    m->n_points = (long)count[ESR_COLMAP_POINTS];
    if (status == ESR_OK)
        status = esr_colmap_model_validate(m, files[ESR_COLMAP_CAMERAS].name, files[ESR_COLMAP_IMAGES].name,
                                           files[ESR_COLMAP_POINTS].name);
    if (status != ESR_OK)
        esr_colmap_model_free(m);
    return status;
}

typedef int (*model_parser)(const struct esr_colmap_file files[ESR_COLMAP_FILES], struct esr_colmap_model *m);

/* Reads DIR's three files (names: cameras, images, points3D) whole and parses them from memory,
 * so the readers run exactly the parsers the fuzz harnesses exercise. */
static int read_model(const char *dir, const char *const names[ESR_COLMAP_FILES], model_parser parse,
                      struct esr_colmap_model *m)
{
    char path[ESR_COLMAP_FILES][ESR_COLMAP_NAME_MAX * 2];
    unsigned char *bytes[ESR_COLMAP_FILES] = {NULL, NULL, NULL};
    struct esr_colmap_file files[ESR_COLMAP_FILES];
    int status = ESR_OK;
    for (int i = 0; i < ESR_COLMAP_FILES && status == ESR_OK; i++) {
        snprintf(path[i], sizeof path[i], "%s/%s", dir, names[i]);
        files[i].name = path[i];
        status = esr_file_read_all(path[i], &bytes[i], &files[i].size);
        files[i].data = bytes[i];
    }
    if (status == ESR_OK)
        status = parse(files, m);
    else
        memset(m, 0, sizeof *m);
    for (int i = 0; i < ESR_COLMAP_FILES; i++)
        free(bytes[i]);
    return status;
}

int esr_colmap_model_read_text(const char *dir, struct esr_colmap_model *m)
{
    static const char *const names[ESR_COLMAP_FILES] = {"cameras.txt", "images.txt", "points3D.txt"};
    return read_model(dir, names, esr_colmap_model_parse_text, m);
}

int esr_colmap_model_read_binary(const char *dir, struct esr_colmap_model *m)
{
    static const char *const names[ESR_COLMAP_FILES] = {"cameras.bin", "images.bin", "points3D.bin"};
    return read_model(dir, names, esr_colmap_model_parse_binary, m);
}

int esr_colmap_model_read(const char *dir, struct esr_colmap_model *m)
{
    char path[ESR_COLMAP_NAME_MAX * 2];
    snprintf(path, sizeof path, "%s/cameras.bin", dir);
    if (esr_file_exists(path))
        return esr_colmap_model_read_binary(dir, m);
    snprintf(path, sizeof path, "%s/cameras.txt", dir);
    if (esr_file_exists(path))
        return esr_colmap_model_read_text(dir, m);
    memset(m, 0, sizeof *m);
    return ESR_FAIL("'%s' is not a COLMAP sparse model: neither cameras.bin nor cameras.txt exists", dir);
}
