/* Checkpoint files (model.h): a versioned snapshot written atomically, matched by name on load.
 *   "ESRCKPT\0" | u32 version | u64 header bytes | header (JSON text) |
 *   f32 w[n] | f32 adam_m[n] | f32 adam_v[n] | u8 mask occupancy [nx*ny*nz] (when it has one) |
 *   u8 light labels [lattice points] (when it has lights) | u32 CRC-32 of every byte before it
 * (version 3; version 2 files, without it, still load) with the header
 *   {"stage": "fine", "step": 2000, "done": 1, "scene_min": [..], "scene_max": [..],
 *    "lr_scale": 0.5 (only after a non-finite step: the learning rates' factor),
 *    "config": {every option, flat}, "params": n,
 *    "components": [{"name": "sdf", "offset": 0, "count": 2097152}, ...],
 *    "mask": {"dims": [nx, ny, nz], "bmin": [..], "bmax": [..]},
 *    "lights": {"dims": [..], "bmin": [..], "bmax": [..], "table": [{"centroid", "area", "points",
 *               "field_rgb", "scale", "radiance", "power", "calib_points"}...],
 *               "balance": [r, g, b] (only when the lights carry a colour balance)}}
 *   (model/lights.h)
 * Loading rebuilds the model from the stored options (missing options take their preset default,
 * so adding an option never breaks old files) and then copies every stored component into the
 * component of the same name (a component the file lacks keeps its initial values: a new
 * component added to a stage starts fresh). A size mismatch, an unknown component or a header
 * that does not parse is refused, naming the file and the mismatch; nothing is written. The
 * CRC catches what no structural check can: flipped bits in the arrays (a bad disk or copy)
 * that still parse and are finite, and would render as silent garbage. */
#include <cjson/cJSON.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <zlib.h>

#include "core/error.h"
#include "io/dir.h"
#include "io/file.h"
#include "io/json_file.h"
#include "model/model.h"
#include "nn/guard.h"

#define CKPT_MAGIC "ESRCKPT"
#define CKPT_VERSION 3u
#define CKPT_VERSION_NO_CRC 2u /* still read */
#define CKPT_MAX_HEADER (16u << 20)

/* zlib's CRC-32 of n bytes, in chunks (its length argument is 32-bit). */
static uint32_t file_crc(const unsigned char *p, size_t n)
{
    uLong crc = crc32(0L, Z_NULL, 0);
    for (size_t at = 0; at < n;) {
        const size_t k = n - at < (1u << 30) ? n - at : (1u << 30);
        crc = crc32(crc, p + at, (uInt)k);
        at += k;
    }
    return (uint32_t)crc;
}

static cJSON *header_json(const struct esr_model *m)
{
    cJSON *h = cJSON_CreateObject();
    cJSON_AddStringToObject(h, "stage", esr_stage_name((enum esr_stage)m->stage));
    cJSON_AddNumberToObject(h, "step", (double)m->step);
    cJSON_AddNumberToObject(h, "done", m->stage_done);
    if (m->lr_scale != 1.0f) /* after a non-finite step (train/trainer.c) */
        cJSON_AddNumberToObject(h, "lr_scale", (double)m->lr_scale);
    cJSON_AddItemToObject(h, "scene_min", esr_json_float_array(m->scene_min, 3));
    cJSON_AddItemToObject(h, "scene_max", esr_json_float_array(m->scene_max, 3));
    cJSON_AddItemToObject(h, "config", esr_config_to_json(&m->cfg));
    cJSON_AddNumberToObject(h, "params", (double)m->params.count);
    cJSON *comps = cJSON_AddArrayToObject(h, "components");
    for (int c = 0; comps && c < ESR_COMP_COUNT; c++) {
        if (!esr_model_has(m, (enum esr_component)c))
            continue;
        cJSON *e = cJSON_CreateObject();
        cJSON_AddStringToObject(e, "name", esr_component_info((enum esr_component)c)->name);
        cJSON_AddNumberToObject(e, "offset", (double)m->part[c].off);
        cJSON_AddNumberToObject(e, "count", (double)m->part[c].count);
        cJSON_AddItemToArray(comps, e);
    }
    if (m->has_mask) {
        cJSON *k = cJSON_AddObjectToObject(h, "mask");
        int dims[3] = {m->mask.nx, m->mask.ny, m->mask.nz};
        cJSON_AddItemToObject(k, "dims", cJSON_CreateIntArray(dims, 3));
        cJSON_AddItemToObject(k, "bmin", esr_json_float_array(m->mask.bmin, 3));
        cJSON_AddItemToObject(k, "bmax", esr_json_float_array(m->mask.bmax, 3));
    }
    if (m->lights.n > 0) {
        const struct esr_grid *g = &m->lights.grid;
        cJSON *k = cJSON_AddObjectToObject(h, "lights");
        int dims[3] = {g->nx, g->ny, g->nz};
        cJSON_AddItemToObject(k, "dims", cJSON_CreateIntArray(dims, 3));
        cJSON_AddItemToObject(k, "bmin", esr_json_float_array(g->bmin, 3));
        cJSON_AddItemToObject(k, "bmax", esr_json_float_array(g->bmax, 3));
        cJSON *t = cJSON_AddArrayToObject(k, "table");
        for (int i = 0; i < m->lights.n; i++) {
            const struct esr_light *l = &m->lights.light[i];
            cJSON *e = cJSON_CreateObject();
            cJSON_AddItemToObject(e, "centroid", esr_json_float_array(l->centroid, 3));
            cJSON_AddNumberToObject(e, "area", l->area);
            cJSON_AddNumberToObject(e, "points", (double)l->points);
            cJSON_AddItemToObject(e, "field_rgb", esr_json_float_array(l->field_rgb, 3));
            cJSON_AddItemToObject(e, "scale", esr_json_float_array(l->scale, 3));
            cJSON_AddItemToObject(e, "radiance", esr_json_float_array(l->radiance, 3));
            cJSON_AddNumberToObject(e, "power", l->power);
            cJSON_AddNumberToObject(e, "calib_points", l->calib_points);
            cJSON_AddNumberToObject(e, "strength_err", l->strength_err);
            cJSON_AddNumberToObject(e, "inseparable", (double)l->inseparable);
            cJSON_AddNumberToObject(e, "bound_only", l->bound_only);
            cJSON_AddNumberToObject(e, "solved", l->solved);
            cJSON_AddItemToArray(t, e);
        }
        if (esr_lights_balanced(&m->lights))
            cJSON_AddItemToObject(k, "balance", esr_json_float_array(m->lights.balance, 3));
    }
    return h;
}

int esr_model_save(const struct esr_model *m, const char *path)
{
    const size_t labels = m->lights.n > 0 ? esr_grid_voxels(&m->lights.grid) : 0;
    for (size_t i = 0; i < labels; i++) /* settled by the calibration (train/lights/lights.h) */
        if (m->lights.label[i] & ESR_LIGHT_UNDECIDED)
            return ESR_FAIL("checkpoint %s: the lights' rims are undecided (calibrate them first)",
                            path);
    cJSON *h = header_json(m);
    char *text = h ? cJSON_PrintUnformatted(h) : NULL;
    cJSON_Delete(h);
    if (!text)
        return ESR_FAIL("checkpoint %s: out of memory for the header", path);
    const uint64_t hn = strlen(text), n = m->params.count;
    const size_t mask_n = m->has_mask ? (size_t)m->mask.nx * m->mask.ny * m->mask.nz : 0;
    const size_t label_n = m->lights.n > 0 ? esr_grid_voxels(&m->lights.grid) : 0;
    const size_t total = 8 + 4 + 8 + hn + 3 * n * sizeof(float) + mask_n + label_n + 4;
    unsigned char *buf = malloc(total), *p = buf;
    if (!buf) {
        free(text);
        return ESR_FAIL("checkpoint %s: out of memory (%zu bytes)", path, total);
    }
    const uint32_t ver = CKPT_VERSION;
    memcpy(p, CKPT_MAGIC, 8), p += 8;
    memcpy(p, &ver, 4), p += 4;
    memcpy(p, &hn, 8), p += 8;
    memcpy(p, text, hn), p += hn;
    memcpy(p, m->params.w, n * sizeof(float)), p += n * sizeof(float);
    memcpy(p, m->adam.m, n * sizeof(float)), p += n * sizeof(float);
    memcpy(p, m->adam.v, n * sizeof(float)), p += n * sizeof(float);
    if (mask_n)
        memcpy(p, m->mask.occ, mask_n), p += mask_n;
    if (label_n)
        memcpy(p, m->lights.label, label_n), p += label_n;
    const uint32_t crc = file_crc(buf, total - 4);
    memcpy(p, &crc, 4);
    free(text);
    int rc = esr_file_write_atomic(path, buf, total);
    free(buf);
    return rc;
}

/* ---- reading ---- */

struct rbuf {
    const unsigned char *p;
    size_t n, at;      /* n: the bytes the structure may use (a format 3 file's CRC excluded) */
    const char *path;
    size_t file_size;  /* for messages */
};

static int get(struct rbuf *b, void *dst, size_t n)
{
    if (n > b->n - b->at)
        return ESR_FAIL("checkpoint %s: truncated (%zu bytes; needs more)", b->path, b->file_size);
    memcpy(dst, b->p + b->at, n);
    b->at += n;
    return ESR_OK;
}

/* A lattice read from the header may claim up to 4096^3 voxels: the file must hold them before
 * anything is allocated for them. */
static int has_bytes(const struct rbuf *b, size_t n, const char *what)
{
    if (n > b->n - b->at)
        return ESR_FAIL("checkpoint %s: truncated (%zu bytes; %zu needed for the %s, %zu left)",
                        b->path, b->file_size, n, what, b->n - b->at);
    return ESR_OK;
}

static int json_floats(const cJSON *h, const char *key, float *out, int n, const char *path)
{
    const cJSON *a = cJSON_GetObjectItemCaseSensitive(h, key);
    if (!cJSON_IsArray(a) || cJSON_GetArraySize(a) != n)
        return ESR_FAIL("checkpoint %s: header field '%s' missing or not %d numbers", path, key, n);
    for (int i = 0; i < n; i++) {
        const cJSON *v = cJSON_GetArrayItem(a, i);
        if (!cJSON_IsNumber(v))
            return ESR_FAIL("checkpoint %s: header field '%s' holds a non-number", path, key);
        out[i] = (float)v->valuedouble;
    }
    return ESR_OK;
}

static int json_count(const cJSON *o, const char *key, double max, double *out, const char *path)
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, key);
    if (!cJSON_IsNumber(v) || v->valuedouble < 0 || v->valuedouble > max ||
        v->valuedouble != (double)(uint64_t)v->valuedouble)
        return ESR_FAIL("checkpoint %s: header field '%s' missing or not a count", path, key);
    *out = v->valuedouble;
    return ESR_OK;
}

/* The model described by the header: stage, options, box; a fresh model of that layout. */
static int model_from_header(struct esr_model *m, const cJSON *h, const char *path)
{
    const cJSON *st = cJSON_GetObjectItemCaseSensitive(h, "stage");
    enum esr_stage stage;
    if (!cJSON_IsString(st) || esr_stage_from_name(st->valuestring, &stage) != ESR_OK)
        return ESR_FAIL("checkpoint %s: header has no valid stage", path);
    double step = 0, done = 0;
    ESR_TRY(json_count(h, "step", 1e15, &step, path));
    ESR_TRY(json_count(h, "done", 1, &done, path));
    float smin[3], smax[3];
    ESR_TRY(json_floats(h, "scene_min", smin, 3, path));
    ESR_TRY(json_floats(h, "scene_max", smax, 3, path));
    struct esr_train_config cfg;
    const cJSON *cj = cJSON_GetObjectItemCaseSensitive(h, "config");
    if (!cJSON_IsObject(cj))
        return ESR_FAIL("checkpoint %s: header has no config object", path);
    ESR_TRY(esr_config_from_json(&cfg, cj, path, NULL));
    const cJSON *lr = cJSON_GetObjectItemCaseSensitive(h, "lr_scale");
    if (lr && !(cJSON_IsNumber(lr) && lr->valuedouble > 0.0 && lr->valuedouble <= 1.0))
        return ESR_FAIL("checkpoint %s: lr_scale must be a number in (0, 1]", path);
    if (esr_model_init(m, &cfg, stage, NULL, smin, smax) != ESR_OK)
        return ESR_FAIL("checkpoint %s: invalid stored configuration: %s", path, esr_error_message());
    m->step = (long)step;
    m->stage_done = (int)done;
    m->inv_s = esr_stage_inv_s(&m->cfg, stage, m->step);
    if (lr)
        m->lr_scale = (float)lr->valuedouble;
    return ESR_OK;
}

/* Copies every stored component (w and both Adam moments) into the model's component of the
 * same name, after checking names and sizes. */
static int read_components(struct esr_model *m, const cJSON *h, const unsigned char *data,
                           double n, const char *path)
{
    const cJSON *comps = cJSON_GetObjectItemCaseSensitive(h, "components");
    if (!cJSON_IsArray(comps))
        return ESR_FAIL("checkpoint %s: header has no component table", path);
    /* the stored arrays start at an arbitrary byte offset: copy bytes, never load floats */
    const size_t N = (size_t)n * sizeof(float);
    const cJSON *e;
    cJSON_ArrayForEach(e, comps)
    {
        const cJSON *nm = cJSON_GetObjectItemCaseSensitive(e, "name");
        double off = 0, cnt = 0;
        if (!cJSON_IsString(nm))
            return ESR_FAIL("checkpoint %s: a component without a name", path);
        ESR_TRY(json_count(e, "offset", n, &off, path));
        ESR_TRY(json_count(e, "count", n, &cnt, path));
        if (off + cnt > n)
            return ESR_FAIL("checkpoint %s: component '%s' lies outside the stored parameters",
                            path, nm->valuestring);
        enum esr_component c = esr_component_from_name(nm->valuestring);
        if (c == ESR_COMP_COUNT)
            return ESR_FAIL("checkpoint %s: component '%s' is unknown to this build", path,
                            nm->valuestring);
        if (!esr_model_has(m, c))
            return ESR_FAIL("checkpoint %s: component '%s' does not belong to the %s stage", path,
                            nm->valuestring, esr_stage_name((enum esr_stage)m->stage));
        if ((size_t)cnt != m->part[c].count)
            return ESR_FAIL("checkpoint %s: component '%s' has %.0f values, the stored "
                            "configuration needs %zu",
                            path, nm->valuestring, cnt, m->part[c].count);
        const size_t o = (size_t)off * sizeof(float), k = m->part[c].count * sizeof(float);
        memcpy(m->params.w + m->part[c].off, data + o, k);
        memcpy(m->adam.m + m->part[c].off, data + N + o, k);
        memcpy(m->adam.v + m->part[c].off, data + 2 * N + o, k);
    }
    return ESR_OK;
}

/* A lattice header {"dims", "bmin", "bmax"} (mask cache, light labels). */
static int read_lattice(const cJSON *k, const char *what, struct esr_grid *lat, const char *path)
{
    float dimf[3], bmin[3], bmax[3];
    ESR_TRY(json_floats(k, "dims", dimf, 3, path));
    ESR_TRY(json_floats(k, "bmin", bmin, 3, path));
    ESR_TRY(json_floats(k, "bmax", bmax, 3, path));
    for (int a = 0; a < 3; a++)
        if (!(dimf[a] >= 2 && dimf[a] <= 4096))
            return ESR_FAIL("checkpoint %s: corrupt %s header", path, what);
    if (esr_grid_init(lat, 1, (int)dimf[0], (int)dimf[1], (int)dimf[2], bmin, bmax) != ESR_OK)
        return ESR_FAIL("checkpoint %s: corrupt %s header", path, what);
    return ESR_OK;
}

static int read_mask(struct esr_model *m, const cJSON *h, struct rbuf *b)
{
    const cJSON *k = cJSON_GetObjectItemCaseSensitive(h, "mask");
    if (!k)
        return ESR_OK;
    struct esr_grid lat;
    ESR_TRY(read_lattice(k, "mask cache", &lat, b->path));
    ESR_TRY(has_bytes(b, esr_grid_voxels(&lat), "mask cache"));
    ESR_TRY(esr_mask_alloc(&m->mask, &lat));
    m->has_mask = 1;
    return get(b, m->mask.occ, esr_grid_voxels(&lat));
}

static int read_lights(struct esr_model *m, const cJSON *h, struct rbuf *b)
{
    const cJSON *k = cJSON_GetObjectItemCaseSensitive(h, "lights");
    if (!k)
        return ESR_OK;
    struct esr_lights *L = &m->lights;
    ESR_TRY(read_lattice(k, "light labels", &L->grid, b->path));
    /* labels are looked up at SDF lattice indices (train/lights/surface.h): another lattice
     * would read past them */
    const struct esr_grid *g = esr_model_has(m, ESR_COMP_SDF) ? esr_model_grid(m, ESR_COMP_SDF) : NULL;
    int same = g && g->nx == L->grid.nx && g->ny == L->grid.ny && g->nz == L->grid.nz;
    for (int a = 0; same && a < 3; a++)
        same = g->bmin[a] == L->grid.bmin[a] && g->bmax[a] == L->grid.bmax[a];
    if (!same)
        return ESR_FAIL("checkpoint %s: the light labels' lattice (%dx%dx%d) is not the SDF's "
                        "(a corrupt file)", b->path, L->grid.nx, L->grid.ny, L->grid.nz);
    const cJSON *t = cJSON_GetObjectItemCaseSensitive(k, "table");
    const int n = cJSON_IsArray(t) ? cJSON_GetArraySize(t) : -1;
    if (n < 1 || n > ESR_MAX_LIGHTS)
        return ESR_FAIL("checkpoint %s: light table missing or of more than %d lights", b->path,
                        ESR_MAX_LIGHTS);
    for (int i = 0; i < n; i++) {
        const cJSON *e = cJSON_GetArrayItem(t, i);
        struct esr_light *l = &L->light[i];
        double pts = 0;
        ESR_TRY(json_floats(e, "centroid", l->centroid, 3, b->path));
        ESR_TRY(json_floats(e, "field_rgb", l->field_rgb, 3, b->path));
        ESR_TRY(json_floats(e, "scale", l->scale, 3, b->path));
        ESR_TRY(json_floats(e, "radiance", l->radiance, 3, b->path));
        ESR_TRY(json_count(e, "points", 1e12, &pts, b->path));
        l->points = (long)pts;
        const char *keys[3] = {"area", "power", "calib_points"};
        float *vals[3] = {&l->area, &l->power, &l->calib_points};
        for (int j = 0; j < 3; j++) {
            const cJSON *v = cJSON_GetObjectItemCaseSensitive(e, keys[j]);
            if (!cJSON_IsNumber(v))
                return ESR_FAIL("checkpoint %s: light %d has no '%s'", b->path, i, keys[j]);
            *vals[j] = (float)v->valuedouble;
        }
        /* what the strength solve said (absent in older checkpoints: not solved) */
        const cJSON *err = cJSON_GetObjectItemCaseSensitive(e, "strength_err");
        const cJSON *ins = cJSON_GetObjectItemCaseSensitive(e, "inseparable");
        const cJSON *bo = cJSON_GetObjectItemCaseSensitive(e, "bound_only");
        l->strength_err = cJSON_IsNumber(err) && isfinite(err->valuedouble) && err->valuedouble >= 0
                              ? (float)err->valuedouble
                              : 0.0f;
        l->inseparable = cJSON_IsNumber(ins) && ins->valuedouble >= 0 && ins->valuedouble < 65536
                             ? (uint32_t)ins->valuedouble & ((1u << n) - 1u)
                             : 0u;
        l->bound_only = cJSON_IsNumber(bo) && bo->valuedouble == 1;
        const cJSON *sv = cJSON_GetObjectItemCaseSensitive(e, "solved");
        l->solved = cJSON_IsNumber(sv) && sv->valuedouble == 1;
    }
    if (cJSON_GetObjectItemCaseSensitive(k, "balance")) { /* absent: none (older runs too) */
        ESR_TRY(json_floats(k, "balance", L->balance, 3, b->path));
        for (int c = 0; c < 3; c++)
            if (!(L->balance[c] > 0.0f) || !isfinite(L->balance[c]))
                return ESR_FAIL("checkpoint %s: light colour balance %g is not a positive number",
                                b->path, (double)L->balance[c]);
    }
    const size_t nl = esr_grid_voxels(&L->grid);
    ESR_TRY(has_bytes(b, nl, "light labels"));
    if (!(L->label = malloc(nl)))
        return ESR_FAIL("checkpoint %s: out of memory for the light labels", b->path);
    L->n = n;
    ESR_TRY(get(b, L->label, nl));
    for (size_t i = 0; i < nl; i++)
        if (ESR_LIGHT_LABEL_ID(L->label[i]) > n ||
            (L->label[i] & ESR_LIGHT_UNDECIDED) || /* never saved */
            (L->label[i] == ESR_LIGHT_UNSEEN)) /* an unseen part of no light */
            return ESR_FAIL("checkpoint %s: light label %d of %d lights", b->path, L->label[i], n);
    return ESR_OK;
}

static int deserialise(struct esr_model *m, struct rbuf *b)
{
    char magic[8];
    uint32_t ver = 0;
    uint64_t hn = 0;
    ESR_TRY(get(b, magic, 8));
    if (memcmp(magic, CKPT_MAGIC, 8))
        return ESR_FAIL("checkpoint %s: not an esr checkpoint (bad magic)", b->path);
    ESR_TRY(get(b, &ver, 4));
    if (ver != CKPT_VERSION && ver != CKPT_VERSION_NO_CRC)
        return ESR_FAIL("checkpoint %s: format version %u, this build reads versions %u and %u%s",
                        b->path, ver, CKPT_VERSION_NO_CRC, CKPT_VERSION,
                        ver < CKPT_VERSION ? " (written by an older esr: train again)" : "");
    uint32_t crc = 0;
    if (ver == CKPT_VERSION) { /* the CRC-32 trails the file; the rest is what it covers */
        ESR_TRY(has_bytes(b, 4, "checksum"));
        memcpy(&crc, b->p + b->n - 4, 4);
        b->n -= 4;
    }
    ESR_TRY(get(b, &hn, 8));
    if (hn == 0 || hn > CKPT_MAX_HEADER || hn > b->n - b->at)
        return ESR_FAIL("checkpoint %s: truncated or corrupt header (%llu bytes)", b->path,
                        (unsigned long long)hn);
    cJSON *h = cJSON_ParseWithLength((const char *)b->p + b->at, (size_t)hn);
    b->at += (size_t)hn;
    if (!h)
        return ESR_FAIL("checkpoint %s: header is not valid JSON", b->path);
    double n = 0;
    int rc = json_count(h, "params", 1e12, &n, b->path);
    if (rc == ESR_OK && 3.0 * n * sizeof(float) > (double)(b->n - b->at))
        rc = ESR_FAIL("checkpoint %s: truncated (%zu bytes; %.0f parameters need more)", b->path,
                      b->file_size, n);
    if (rc == ESR_OK)
        rc = model_from_header(m, h, b->path);
    if (rc == ESR_OK) {
        rc = read_components(m, h, b->p + b->at, n, b->path);
        b->at += 3 * (size_t)n * sizeof(float);
        /* training never saves a non-finite value (nn/guard stops it first): these are a
         * damaged file, which would render as silent garbage */
        const size_t count = m->params.count;
        if (rc == ESR_OK && !(esr_nn_all_finite(m->params.w, count) &&
                              esr_nn_all_finite(m->adam.m, count) &&
                              esr_nn_all_finite(m->adam.v, count)))
            rc = ESR_FAIL("checkpoint %s: non-finite weights or optimiser moments (a corrupt "
                          "file)", b->path);
        if (rc == ESR_OK)
            rc = read_mask(m, h, b);
        if (rc == ESR_OK)
            rc = read_lights(m, h, b);
        if (rc == ESR_OK && b->at != b->n)
            rc = ESR_FAIL("checkpoint %s: %zu bytes after its end (a corrupt file)", b->path,
                          b->n - b->at);
        if (rc == ESR_OK && ver == CKPT_VERSION && file_crc(b->p, b->n) != crc)
            rc = ESR_FAIL("checkpoint %s: checksum mismatch: the file was damaged after it was "
                          "written (a bad disk or copy); its values cannot be trusted", b->path);
        if (rc != ESR_OK)
            esr_model_free(m);
    }
    cJSON_Delete(h);
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
    return ESR_FAIL("run directory %s: no checkpoint (ckpt_<stage>.bin) in it", dir);
}

int esr_model_load_buffer(struct esr_model *m, const void *data, size_t size, const char *name)
{
    memset(m, 0, sizeof(*m));
    struct rbuf b = {data, size, 0, name, size};
    return deserialise(m, &b);
}

/* A file named ckpt_<stage>.bin must hold that stage's model: one copied or renamed over it
 * would be resumed, rendered or listed as the stage it is not (a finished coarse model as
 * ckpt_fine.bin: the fine stage never trained). Frees m when it fails. */
/* The stage a file named ckpt_<stage>.bin is named for, or -1. */
static int named_stage(const char *file)
{
    const char *base = strrchr(file, '/');
    base = base ? base + 1 : file;
    for (int s = 0; s < ESR_STAGE_COUNT; s++) {
        char name[64];
        snprintf(name, sizeof name, "ckpt_%s.bin", esr_stage_name((enum esr_stage)s));
        if (!strcmp(base, name))
            return s;
    }
    return -1;
}

static int check_named_stage(struct esr_model *m, const char *file)
{
    const int s = named_stage(file);
    if (s >= 0 && m->stage != s) {
        const int held = m->stage;
        esr_model_free(m);
        return ESR_FAIL("checkpoint %s is named for the %s stage but holds a %s-stage model (a "
                        "file copied or renamed over it?)",
                        file, esr_stage_name((enum esr_stage)s), esr_stage_name((enum esr_stage)held));
    }
    return ESR_OK;
}

/* A run's checkpoint that does not load (truncated, corrupt, of another version) has one way
 * out, and the message says it: remove it and every later stage's (a later stage trained from
 * the damaged one would be resumed as it is), then `esr train --resume` trains those stages again
 * from the earlier stages' checkpoints, which are kept. */
static void advise_damaged(const char *file)
{
    const int s = named_stage(file);
    if (s < 0)
        return;
    const char *slash = strrchr(file, '/');
    const int dir_len = slash ? (int)(slash - file) : 1;
    const char *dir = slash ? file : ".";
    char rm[1024] = "";
    for (int t = s; t < ESR_STAGE_COUNT; t++) {
        const size_t len = strlen(rm);
        snprintf(rm + len, sizeof rm - len, " %.*s/ckpt_%s.bin", dir_len, dir,
                 esr_stage_name((enum esr_stage)t));
    }
    esr_error_append(". To recover: rm -f%s, then `esr train DATA --out %.*s --resume` trains "
                     "the %s stage%s again from the earlier stages' checkpoints (kept)",
                     rm, dir_len, dir, esr_stage_name((enum esr_stage)s),
                     s + 1 < ESR_STAGE_COUNT ? " and those after it" : "");
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
    int rc = esr_model_load_buffer(m, data, size, file);
    free(data);
    if (rc != ESR_OK)
        advise_damaged(file);
    return rc == ESR_OK ? check_named_stage(m, file) : rc;
}

int esr_model_load_finished_pdra(struct esr_model *m, const char *run)
{
    char ckpt[4200];
    snprintf(ckpt, sizeof ckpt, "%s/ckpt_pdra.bin", run);
    ESR_TRY(esr_dir_check_run(run));
    if (!esr_file_exists(ckpt))
        return ESR_FAIL("%s has no pdra checkpoint (ckpt_pdra.bin): the lights are found by the "
                        "last stage, pdra (esr train DATA --out RUN runs all five; a run whose "
                        "dataset has no lights-on images skips it: it has no lights)", run);
    ESR_TRY(esr_model_load(m, ckpt));
    if (m->stage_done)
        return ESR_OK;
    const long step = m->step;
    esr_model_free(m);
    return ESR_FAIL("%s: the pdra stage has not finished (step %ld); train it to the end first "
                    "(esr train --resume)",
                    ckpt, step);
}
