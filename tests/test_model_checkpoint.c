/* Checkpoints by name (model/checkpoint.c): a round trip is exact; a file written before an
 * option and a component existed still loads (the option takes its default, the component its
 * fresh initial values); truncated files, wrong versions, bad magic and layout mismatches are
 * refused with a message naming the file and the mismatch, and the file is left as it was. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

#include "core/error.h"
#include "io/file.h"
#include "model/model.h"
#include "test_model.h"
#include "test_support.h"

struct fx {
    char *dir;
    char path[512];
    struct esr_model m;
};

/* A fine model with every component randomised, a step count, Adam moments and a mask. */
static int setup(void **state)
{
    struct fx *f = calloc(1, sizeof *f);
    f->dir = test_make_tmpdir();
    snprintf(f->path, sizeof f->path, "%s/ckpt_fine.bin", f->dir);
    struct esr_train_config cfg;
    test_small_config(&cfg, 0.5f);
    cfg.fine.tv_sdf_grad = 0.3f; /* not the preset's value, so "took the default" is visible */
    const float bmin[3] = {-1, -2, -1}, bmax[3] = {1, 2, 1.5f};
    /* the mask comes from the previous stage: build an alphamask model and hand it over */
    struct esr_model prev;
    assert_int_equal(esr_model_init(&prev, &cfg, ESR_STAGE_ALPHAMASK, NULL, bmin, bmax), 0);
    struct esr_grid lat;
    assert_int_equal(esr_grid_init(&lat, 1, 5, 6, 7, bmin, bmax), 0);
    assert_int_equal(esr_mask_alloc(&prev.mask, &lat), 0);
    for (size_t i = 0; i < esr_grid_voxels(&lat); i++)
        prev.mask.occ[i] = (uint8_t)(i % 3 == 0);
    prev.has_mask = 1;
    assert_int_equal(esr_model_init(&f->m, &cfg, ESR_STAGE_FINE, &prev, bmin, bmax), 0);
    esr_model_free(&prev);
    for (int c = 0; c < ESR_COMP_COUNT; c++)
        if (esr_model_has(&f->m, (enum esr_component)c))
            test_randomise(&f->m, (enum esr_component)c, 0.1f, 30 + (uint64_t)c);
    for (size_t i = 0; i < f->m.params.count; i++) {
        f->m.adam.m[i] = 1e-3f * (float)(i % 17);
        f->m.adam.v[i] = 1e-6f * (float)(i % 5);
    }
    f->m.step = 1234;
    assert_int_equal(esr_model_save(&f->m, f->path), 0);
    *state = f;
    return 0;
}

static int teardown(void **state)
{
    struct fx *f = *state;
    esr_model_free(&f->m);
    test_rmtree(f->dir);
    free(f->dir);
    free(f);
    return 0;
}

static void assert_component_equal(const struct esr_model *a, const struct esr_model *b,
                                   enum esr_component c)
{
    assert_int_equal(a->part[c].count, b->part[c].count);
    size_t k = a->part[c].count * sizeof(float);
    assert_memory_equal(a->params.w + a->part[c].off, b->params.w + b->part[c].off, k);
    assert_memory_equal(a->adam.m + a->part[c].off, b->adam.m + b->part[c].off, k);
    assert_memory_equal(a->adam.v + a->part[c].off, b->adam.v + b->part[c].off, k);
}

static void test_round_trip_is_exact(void **state)
{
    struct fx *f = *state;
    struct esr_model r;
    assert_int_equal(esr_model_load(&r, f->path), 0);
    assert_int_equal(r.stage, ESR_STAGE_FINE);
    assert_int_equal(r.step, 1234);
    assert_int_equal(r.params.count, f->m.params.count);
    for (int c = 0; c < ESR_COMP_COUNT; c++)
        if (esr_model_has(&f->m, (enum esr_component)c))
            assert_component_equal(&f->m, &r, (enum esr_component)c);
    assert_true(r.has_mask);
    assert_int_equal(r.mask.nx * r.mask.ny * r.mask.nz, 5 * 6 * 7);
    assert_memory_equal(r.mask.occ, f->m.mask.occ, 5 * 6 * 7);
    assert_memory_equal(r.scene_max, f->m.scene_max, sizeof r.scene_max);
    cJSON *a = esr_config_to_json(&f->m.cfg), *b = esr_config_to_json(&r.cfg);
    assert_true(cJSON_Compare(a, b, 1));
    cJSON_Delete(a);
    cJSON_Delete(b);
    assert_true(r.lr_scale == 1.0f); /* the header says nothing: the full rate */
    esr_model_free(&r);
    /* after non-finite steps the learning rates' factor travels with the checkpoint */
    f->m.lr_scale = 0.25f;
    assert_int_equal(esr_model_save(&f->m, f->path), 0);
    f->m.lr_scale = 1.0f;
    assert_int_equal(esr_model_load(&r, f->path), 0);
    assert_true(r.lr_scale == 0.25f);
    esr_model_free(&r);
}

/* Rewrites the file's JSON header with edit(header) and the given version; the arrays after it
 * are kept byte for byte, and version 3 gets the CRC-32 of the new bytes (version 2 has none). */
static void rewrite(const char *path, void (*edit)(cJSON *), uint32_t version)
{
    unsigned char *d;
    size_t n;
    assert_int_equal(esr_file_read_all(path, &d, &n), 0);
    uint32_t was;
    memcpy(&was, d + 8, 4);
    if (was == 3)
        n -= 4; /* its CRC */
    uint64_t hn;
    memcpy(&hn, d + 12, 8);
    cJSON *h = cJSON_ParseWithLength((const char *)d + 20, (size_t)hn);
    assert_non_null(h);
    if (edit)
        edit(h);
    char *text = cJSON_PrintUnformatted(h);
    uint64_t nh = strlen(text);
    size_t tail = n - 20 - (size_t)hn, total = 20 + nh + tail + (version == 3 ? 4 : 0);
    unsigned char *o = malloc(total);
    memcpy(o, d, 8);
    memcpy(o + 8, &version, 4);
    memcpy(o + 12, &nh, 8);
    memcpy(o + 20, text, nh);
    memcpy(o + 20 + nh, d + 20 + hn, tail);
    if (version == 3) {
        const uint32_t crc = (uint32_t)crc32(crc32(0L, Z_NULL, 0), o, (uInt)(total - 4));
        memcpy(o + total - 4, &crc, 4);
    }
    assert_int_equal(esr_file_write_atomic(path, o, total), 0);
    free(o);
    free(text);
    free(d);
    cJSON_Delete(h);
}

/* The file as an older esr wrote it: no 'fine.tv_sdf_grad' option and no tone-mapper
 * component, i.e. both were added after it. */
static void drop_option_and_component(cJSON *h)
{
    cJSON *cfg = cJSON_GetObjectItemCaseSensitive(h, "config");
    assert_non_null(cJSON_GetObjectItemCaseSensitive(cfg, "fine.tv_sdf_grad"));
    cJSON_DeleteItemFromObjectCaseSensitive(cfg, "fine.tv_sdf_grad");
    cJSON *comps = cJSON_GetObjectItemCaseSensitive(h, "components");
    for (int i = 0; i < cJSON_GetArraySize(comps); i++) {
        cJSON *nm = cJSON_GetObjectItemCaseSensitive(cJSON_GetArrayItem(comps, i), "name");
        if (!strcmp(nm->valuestring, esr_component_info(ESR_COMP_TONE_MLP)->name)) {
            cJSON_DeleteItemFromArray(comps, i);
            return;
        }
    }
    fail_msg("no tone-mapper component in the header");
}

static void test_older_file_loads(void **state)
{
    struct fx *f = *state;
    struct esr_train_config def;
    esr_config_defaults(&def, ESR_PRESET_FAST);
    rewrite(f->path, drop_option_and_component, 2);
    struct esr_model r;
    assert_int_equal(esr_model_load(&r, f->path), 0);
    assert_true(f->m.cfg.fine.tv_sdf_grad != def.fine.tv_sdf_grad);
    assert_true(r.cfg.fine.tv_sdf_grad == def.fine.tv_sdf_grad);
    /* the missing component keeps the fresh initialisation of this configuration */
    struct esr_model fresh;
    const float *bmin = f->m.scene_min, *bmax = f->m.scene_max;
    assert_int_equal(esr_model_init(&fresh, &r.cfg, ESR_STAGE_FINE, NULL, bmin, bmax), 0);
    assert_memory_equal(r.params.w + r.part[ESR_COMP_TONE_MLP].off,
                        fresh.params.w + fresh.part[ESR_COMP_TONE_MLP].off,
                        r.part[ESR_COMP_TONE_MLP].count * sizeof(float));
    assert_memory_not_equal(r.params.w + r.part[ESR_COMP_TONE_MLP].off,
                            f->m.params.w + f->m.part[ESR_COMP_TONE_MLP].off,
                            r.part[ESR_COMP_TONE_MLP].count * sizeof(float));
    /* every other component is the stored one */
    for (int c = 0; c < ESR_COMP_COUNT; c++)
        if (esr_model_has(&f->m, (enum esr_component)c) && c != ESR_COMP_TONE_MLP)
            assert_component_equal(&f->m, &r, (enum esr_component)c);
    esr_model_free(&fresh);
    esr_model_free(&r);
}

/* Loading must fail with a message naming the file and containing `want`, and leave the file
 * byte for byte as it was. */
static void assert_refused(const char *path, const char *want)
{
    unsigned char *before, *after;
    size_t nb, na;
    assert_int_equal(esr_file_read_all(path, &before, &nb), 0);
    struct esr_model r;
    esr_error_clear();
    assert_int_equal(esr_model_load(&r, path), ESR_ERR);
    const char *msg = esr_error_message();
    if (!strstr(msg, path) || !strstr(msg, want))
        fail_msg("message '%s' should name %s and say '%s'", msg, path, want);
    esr_error_clear();
    assert_int_equal(esr_file_read_all(path, &after, &na), 0);
    assert_int_equal(na, nb);
    assert_memory_equal(after, before, nb);
    free(before);
    free(after);
}

static void test_truncated_files_refused(void **state)
{
    struct fx *f = *state;
    unsigned char *d;
    size_t n;
    assert_int_equal(esr_file_read_all(f->path, &d, &n), 0);
    char cut[600];
    snprintf(cut, sizeof cut, "%s/cut.bin", f->dir);
    /* in the magic, the version, the header, the parameters, the mask */
    const size_t lens[] = {1, 5, 10, 19, 40, n / 2, n - 3 * 5 * 6 * 7, n - 1};
    for (size_t i = 0; i < sizeof lens / sizeof lens[0]; i++) {
        assert_int_equal(esr_file_write_atomic(cut, d, lens[i]), 0);
        assert_refused(cut, lens[i] > 40 && lens[i] < n - 200 ? "truncated" : "");
    }
    free(d);
}

static void set_wrong_count(cJSON *h)
{
    cJSON *e = cJSON_GetArrayItem(cJSON_GetObjectItemCaseSensitive(h, "components"), 0);
    cJSON_SetNumberValue(cJSON_GetObjectItemCaseSensitive(e, "count"), 7);
}

static void set_unknown_name(cJSON *h)
{
    cJSON *e = cJSON_GetArrayItem(cJSON_GetObjectItemCaseSensitive(h, "components"), 0);
    cJSON_SetValuestring(cJSON_GetObjectItemCaseSensitive(e, "name"), "warp_field");
}

static void set_bad_option(cJSON *h)
{
    cJSON_AddNumberToObject(cJSON_GetObjectItemCaseSensitive(h, "config"), "fine.wobble", 3);
}

static void set_bad_lr_scale(cJSON *h)
{
    cJSON_AddNumberToObject(h, "lr_scale", 2.0);
}

static void test_mismatches_refused(void **state)
{
    struct fx *f = *state;
    unsigned char *orig;
    size_t n;
    assert_int_equal(esr_file_read_all(f->path, &orig, &n), 0);
    rewrite(f->path, NULL, 1);
    assert_refused(f->path, "format version 1");
    rewrite(f->path, NULL, 99);
    assert_refused(f->path, "format version 99");
    rewrite(f->path, set_wrong_count, 2);
    assert_refused(f->path, "has 7 values");
    assert_int_equal(esr_file_write_atomic(f->path, orig, n), 0);
    rewrite(f->path, set_unknown_name, 2);
    assert_refused(f->path, "'warp_field' is unknown");
    assert_int_equal(esr_file_write_atomic(f->path, orig, n), 0);
    rewrite(f->path, set_bad_option, 2);
    assert_refused(f->path, "unknown option 'fine.wobble'");
    assert_int_equal(esr_file_write_atomic(f->path, orig, n), 0);
    rewrite(f->path, set_bad_lr_scale, 2);
    assert_refused(f->path, "lr_scale must be a number in (0, 1]");
    /* damage a render would not show: bytes after the end, a NaN weight, an infinite moment */
    unsigned char *longer = malloc(n + 100);
    assert_non_null(longer);
    memcpy(longer, orig, n);
    memset(longer + n, 0x5a, 100);
    assert_int_equal(esr_file_write_atomic(f->path, longer, n + 100), 0);
    assert_refused(f->path, "100 bytes after its end");
    free(longer);
    f->m.params.w[f->m.params.count / 3] = NAN;
    assert_int_equal(esr_model_save(&f->m, f->path), 0);
    assert_refused(f->path, "non-finite weights");
    f->m.params.w[f->m.params.count / 3] = 0.0f;
    f->m.adam.v[7] = INFINITY;
    assert_int_equal(esr_model_save(&f->m, f->path), 0);
    assert_refused(f->path, "non-finite weights or optimiser moments");
    f->m.adam.v[7] = 0.0f;
    /* one flipped bit in the weights (finite still, the structure intact): the checksum */
    orig[n / 2] ^= 0x10;
    assert_int_equal(esr_file_write_atomic(f->path, orig, n), 0);
    assert_refused(f->path, "checksum mismatch");
    orig[n / 2] ^= 0x10;
    /* the checksum covers exactly what the helper's does (every byte before it): a file
     * rewritten with a fresh one loads */
    assert_int_equal(esr_file_write_atomic(f->path, orig, n), 0);
    rewrite(f->path, NULL, 3);
    struct esr_model again;
    assert_int_equal(esr_model_load(&again, f->path), ESR_OK);
    esr_model_free(&again);
    orig[0] = 'X';
    assert_int_equal(esr_file_write_atomic(f->path, orig, n), 0);
    assert_refused(f->path, "bad magic");
    free(orig);
    /* a fine model under another stage's checkpoint name (copied over it); any other name is
     * whatever it holds */
    char other[4300];
    snprintf(other, sizeof other, "%s/ckpt_coarse.bin", f->dir);
    assert_int_equal(esr_model_save(&f->m, other), 0);
    assert_refused(other, "named for the coarse stage but holds a fine-stage model");
    snprintf(other, sizeof other, "%s/backup.bin", f->dir);
    assert_int_equal(esr_model_save(&f->m, other), 0);
    struct esr_model m;
    assert_int_equal(esr_model_load(&m, other), ESR_OK);
    esr_model_free(&m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup_teardown(test_round_trip_is_exact, setup, teardown),
        cmocka_unit_test_setup_teardown(test_older_file_loads, setup, teardown),
        cmocka_unit_test_setup_teardown(test_truncated_files_refused, setup, teardown),
        cmocka_unit_test_setup_teardown(test_mismatches_refused, setup, teardown),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
