/* What the two COLMAP harnesses (fuzz_colmap_text.c, fuzz_colmap_bin.c) share: how one input
 * holds a model's three files, the contract an accepted model must meet, and the scene
 * placement `esr import colmap` computes from it next.
 *
 * One input = cameras SEP images SEP points3D, split at the first two FUZZ_COLMAP_SEP; a part
 * that is missing is an empty file. A separator rather than length prefixes: a mutation inside
 * one file then never moves the other files' boundaries, and the seeds stay readable. It is a
 * comment line in the text format and appears in no seed's binary data. */
#ifndef ESR_FUZZ_COLMAP_H
#define ESR_FUZZ_COLMAP_H

#ifndef _GNU_SOURCE
#define _GNU_SOURCE /* memmem (libFuzzer also learns the separator from its needle) */
#endif
#include <math.h>
#include <string.h>

#include "fuzz.h"
#include "import/colmap.h"
#include "import/colmap_camera.h"
#include "import/colmap_scene.h"

#define FUZZ_COLMAP_SEP "\n#--next-file--\n"

typedef int (*fuzz_colmap_parser)(const struct esr_colmap_file files[ESR_COLMAP_FILES], struct esr_colmap_model *m);

static inline void fuzz_colmap_split(const uint8_t *data, size_t size, const char *const names[ESR_COLMAP_FILES],
                              struct esr_colmap_file files[ESR_COLMAP_FILES])
{
    const size_t sep = sizeof FUZZ_COLMAP_SEP - 1;
    const uint8_t *p = data, *end = data + size;
    for (int i = 0; i < ESR_COLMAP_FILES; i++) {
        const uint8_t *cut = i < ESR_COLMAP_FILES - 1 ? memmem(p, (size_t)(end - p), FUZZ_COLMAP_SEP, sep) : NULL;
        files[i].data = p;
        files[i].size = cut ? (size_t)(cut - p) : (size_t)(end - p);
        files[i].name = names[i];
        p = cut ? cut + sep : end;
    }
}

static inline int fuzz_all_finite(const double *v, int n)
{
    for (int i = 0; i < n; i++)
        if (!isfinite(v[i]))
            return 0;
    return 1;
}

/* What validate promises of an accepted model. Every record is read, so ASan sees any array
 * shorter than its count. */
static inline void fuzz_colmap_check(const struct esr_colmap_model *m)
{
    if (m->n_cameras < 0 || m->n_images < 0 || m->n_points < 0 || (m->n_cameras && !m->cameras) ||
        (m->n_images && !m->images) || (m->n_points && !m->points))
        abort();
    for (int i = 0; i < m->n_cameras; i++) {
        const struct esr_colmap_camera *c = &m->cameras[i];
        int n = esr_colmap_model_n_params(c->model);
        struct esr_colmap_intrinsics k;
        esr_colmap_intrinsics_of(c, &k);
        if ((unsigned)c->model >= ESR_COLMAP_MODEL_COUNT || c->width < 1 || c->height < 1 || c->width > 1 << 16 ||
            c->height > 1 << 16 || !fuzz_all_finite(c->params, n) || !(k.fx > 0.0) || !(k.fy > 0.0))
            abort();
        for (int p = n; p < ESR_COLMAP_MAX_PARAMS; p++) /* a model's unused parameters are 0 */
            if (c->params[p] != 0.0)
                abort();
        if (esr_colmap_find_camera(m, c->id) != c) /* ids unique */
            abort();
    }
    for (int i = 0; i < m->n_images; i++) {
        const struct esr_colmap_image *im = &m->images[i];
        size_t len = strnlen(im->name, sizeof im->name);
        if (len == 0 || len == sizeof im->name || !fuzz_all_finite(im->q, 4) || !fuzz_all_finite(im->t, 3) ||
            !esr_colmap_find_camera(m, im->camera_id))
            abort();
    }
    for (long i = 0; i < m->n_points; i++)
        if (!fuzz_all_finite(m->points + 3 * i, 3))
            abort();
}

/* An accepted model's placement is either refused with a message or finite with a positive
 * scale (the import writes every camera through it). */
static inline void fuzz_colmap_place(const struct esr_colmap_model *m)
{
    if (m->n_images < 1)
        return;
    struct esr_scene_frame f;
    int status = esr_colmap_scene_frame(m, &f);
    if (status == ESR_OK && (!fuzz_all_finite(f.centre, 3) || !fuzz_all_finite(&f.rotation[0][0], 9) ||
                             !(f.scale > 0.0) || !isfinite(f.scale)))
        abort();
    fuzz_done(status);
}

static inline void fuzz_colmap_run(const uint8_t *data, size_t size, const char *const names[ESR_COLMAP_FILES],
                            fuzz_colmap_parser parse)
{
    fuzz_setup();
    struct esr_colmap_file files[ESR_COLMAP_FILES];
    fuzz_colmap_split(data, size, names, files);
    struct esr_colmap_model m;
    int status = parse(files, &m);
    if (status == ESR_OK) {
        fuzz_colmap_check(&m);
        fuzz_colmap_place(&m);
        esr_colmap_model_free(&m);
    } else if (m.cameras || m.images || m.points) { /* a refusal leaves m freed */
        abort();
    }
    fuzz_done(status);
}

#endif
