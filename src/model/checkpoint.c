/* Checkpoint files (model.h): a versioned binary snapshot written atomically.
 *   "ESRCKPT\0" | u32 version | u32 sizeof(config) | config | i32 stage | i64 step | i32 done |
 *   f32 scene_min[3], scene_max[3] | u64 n | f32 w[n] | f32 adam_m[n] | f32 adam_v[n] |
 *   i32 has_mask | (i32 nx, ny, nz | f32 bmin[3], bmax[3] | u8 occ[nx*ny*nz])
 * The parameter layout is a pure function of (config, stage), so loading rebuilds the model from
 * those and then checks that the stored count matches before copying the values. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "core/error.h"
#include "io/file.h"
#include "model/model.h"

#define CKPT_MAGIC "ESRCKPT"
#define CKPT_VERSION 1u

struct wbuf {
    unsigned char *p;
    size_t n, cap;
};

static int put(struct wbuf *b, const void *src, size_t n)
{
    if (b->n + n > b->cap) {
        size_t cap = (b->n + n) * 2;
        unsigned char *p = realloc(b->p, cap);
        if (!p)
            return ESR_FAIL("checkpoint: out of memory (%zu bytes)", cap);
        b->p = p;
        b->cap = cap;
    }
    memcpy(b->p + b->n, src, n);
    b->n += n;
    return ESR_OK;
}

static int serialise(const struct esr_model *m, struct wbuf *b)
{
    uint32_t ver = CKPT_VERSION, cs = sizeof(m->cfg);
    int32_t stage = m->stage, done = m->stage_done, has = m->has_mask;
    int64_t step = m->step;
    uint64_t n = m->params.count;
    ESR_TRY(put(b, CKPT_MAGIC, 8));
    ESR_TRY(put(b, &ver, 4));
    ESR_TRY(put(b, &cs, 4));
    ESR_TRY(put(b, &m->cfg, sizeof(m->cfg)));
    ESR_TRY(put(b, &stage, 4));
    ESR_TRY(put(b, &step, 8));
    ESR_TRY(put(b, &done, 4));
    ESR_TRY(put(b, m->scene_min, 12));
    ESR_TRY(put(b, m->scene_max, 12));
    ESR_TRY(put(b, &n, 8));
    ESR_TRY(put(b, m->params.w, n * 4));
    ESR_TRY(put(b, m->adam.m, n * 4));
    ESR_TRY(put(b, m->adam.v, n * 4));
    ESR_TRY(put(b, &has, 4));
    if (has) {
        int32_t dims[3] = {m->mask.nx, m->mask.ny, m->mask.nz};
        ESR_TRY(put(b, dims, 12));
        ESR_TRY(put(b, m->mask.bmin, 12));
        ESR_TRY(put(b, m->mask.bmax, 12));
        ESR_TRY(put(b, m->mask.occ, (size_t)dims[0] * dims[1] * dims[2]));
    }
    return ESR_OK;
}

int esr_model_save(const struct esr_model *m, const char *path)
{
    struct wbuf b = {NULL, 0, 0};
    int rc = serialise(m, &b);
    if (rc == ESR_OK)
        rc = esr_file_write_atomic(path, b.p, b.n);
    free(b.p);
    return rc;
}

struct rbuf {
    const unsigned char *p;
    size_t n, at;
    const char *path;
};

static int get(struct rbuf *b, void *dst, size_t n)
{
    if (b->at + n > b->n)
        return ESR_FAIL("checkpoint %s: truncated (needs more than %zu bytes)", b->path, b->n);
    memcpy(dst, b->p + b->at, n);
    b->at += n;
    return ESR_OK;
}

static int read_mask(struct esr_model *m, struct rbuf *b)
{
    int32_t dims[3];
    float bmin[3], bmax[3];
    ESR_TRY(get(b, dims, 12));
    ESR_TRY(get(b, bmin, 12));
    ESR_TRY(get(b, bmax, 12));
    struct esr_grid lat;
    if (dims[0] < 2 || dims[1] < 2 || dims[2] < 2 || dims[0] > 4096 || dims[1] > 4096 ||
        dims[2] > 4096 || esr_grid_init(&lat, 1, dims[0], dims[1], dims[2], bmin, bmax) != ESR_OK)
        return ESR_FAIL("checkpoint %s: corrupt mask cache header", b->path);
    ESR_TRY(esr_mask_alloc(&m->mask, &lat));
    m->has_mask = 1;
    return get(b, m->mask.occ, esr_grid_voxels(&lat));
}

static int deserialise(struct esr_model *m, struct rbuf *b)
{
    char magic[8];
    uint32_t ver = 0, cs = 0;
    ESR_TRY(get(b, magic, 8));
    if (memcmp(magic, CKPT_MAGIC, 8))
        return ESR_FAIL("checkpoint %s: not an esr checkpoint (bad magic)", b->path);
    ESR_TRY(get(b, &ver, 4));
    ESR_TRY(get(b, &cs, 4));
    if (ver != CKPT_VERSION || cs != sizeof(struct esr_train_config))
        return ESR_FAIL("checkpoint %s: version %u (config size %u) but this build reads version "
                        "%u (config size %zu)",
                        b->path, ver, cs, CKPT_VERSION, sizeof(struct esr_train_config));
    struct esr_train_config cfg;
    int32_t stage = 0, done = 0, has = 0;
    int64_t step = 0;
    uint64_t n = 0;
    float smin[3], smax[3];
    ESR_TRY(get(b, &cfg, sizeof cfg));
    ESR_TRY(get(b, &stage, 4));
    ESR_TRY(get(b, &step, 8));
    ESR_TRY(get(b, &done, 4));
    ESR_TRY(get(b, smin, 12));
    ESR_TRY(get(b, smax, 12));
    ESR_TRY(get(b, &n, 8));
    if (stage < 0 || stage >= ESR_STAGE_COUNT || step < 0)
        return ESR_FAIL("checkpoint %s: corrupt header (stage %d, step %lld)", b->path, (int)stage,
                        (long long)step);
    if (esr_model_init(m, &cfg, (enum esr_stage)stage, NULL, smin, smax) != ESR_OK)
        return ESR_FAIL("checkpoint %s: invalid stored configuration: %s", b->path,
                        esr_error_message());
    if (n != m->params.count) {
        esr_model_free(m);
        return ESR_FAIL("checkpoint %s: %llu parameters stored, the configuration needs %zu",
                        b->path, (unsigned long long)n, m->params.count);
    }
    m->step = step;
    m->stage_done = done;
    m->inv_s = esr_model_inv_s_at(m, step);
    int rc = get(b, m->params.w, n * 4);
    if (rc == ESR_OK)
        rc = get(b, m->adam.m, n * 4);
    if (rc == ESR_OK)
        rc = get(b, m->adam.v, n * 4);
    if (rc == ESR_OK)
        rc = get(b, &has, 4);
    if (rc == ESR_OK && has)
        rc = read_mask(m, b);
    if (rc != ESR_OK)
        esr_model_free(m);
    return rc;
}

/* The most advanced stage checkpoint in a run directory. */
static int pick_in_dir(const char *dir, char *out, size_t n)
{
    for (int s = ESR_STAGE_COUNT - 1; s >= 0; s--) {
        snprintf(out, n, "%s/ckpt_%s.bin", dir, esr_stage_name((enum esr_stage)s));
        if (esr_file_exists(out))
            return ESR_OK;
    }
    return ESR_FAIL("run directory %s: no checkpoint (ckpt_{alphamask,coarse,fine}.bin) in it",
                    dir);
}

int esr_model_load(struct esr_model *m, const char *path)
{
    memset(m, 0, sizeof(*m));
    struct stat st;
    char file[4096];
    if (stat(path, &st) != 0)
        return ESR_FAIL("checkpoint %s: no such file or directory", path);
    if (S_ISDIR(st.st_mode))
        ESR_TRY(pick_in_dir(path, file, sizeof file));
    else
        snprintf(file, sizeof file, "%s", path);
    unsigned char *data;
    size_t size;
    ESR_TRY(esr_file_read_all(file, &data, &size));
    struct rbuf b = {data, size, 0, file};
    int rc = deserialise(m, &b);
    free(data);
    return rc;
}
