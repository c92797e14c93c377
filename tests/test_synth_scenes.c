/* The built-in scenes that measure the lights' strengths (issue 48: bulbs, vivid, ratios,
 * shaded): listed by `esr synth --scene list`, their scene.json gives the true lights with the
 * emitted radiance the scene defines, and at the scene's default resolution every light covers
 * at least 40 pixels in at least half of the test views, counted on the per-light masks of a
 * 1-sample render (masks are first-hit geometry, the same at any sample count). */
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

#include "io/dataset.h"
#include "io/image.h"
#include "synth/scene.h"
#include "test_support.h"

#define MIN_PIXELS 40

static char out[8192];

/* What the issue asks of each scene, written here independently of src/synth. */
struct expect {
    const char *name;
    int lights;
    int min_res;                 /* the default resolution must be at least this */
    float radiance0[3];          /* light 0's emitted radiance */
};

static const struct expect scenes[] = {
    {"bulbs", 7, 100, {10.0f, 8.5f, 6.0f}},
    {"vivid", 1, 100, {10.0f, 0.5f, 0.3f}},
    {"ratios", 3, 100, {1.05f, 2.1f, 3.0f}},
    {"shaded", 1, 100, {15.0f, 13.5f, 10.5f}},
};
#define N_SCENES (int)(sizeof scenes / sizeof scenes[0])

static void test_listed(void **state)
{
    (void)state;
    assert_int_equal(test_run_esr("synth --scene list", out, sizeof out), 0);
    for (int i = 0; i < N_SCENES; i++) {
        char line[64];
        snprintf(line, sizeof line, "%s ", scenes[i].name);
        if (!strstr(out, line))
            fail_msg("`esr synth --scene list` does not list %s:\n%s", scenes[i].name, out);
    }
    /* the scenes that were there before stay */
    assert_non_null(strstr(out, "default "));
    assert_non_null(strstr(out, "glossy "));
    assert_non_null(strstr(out, "capture "));
}

/* Pixels of an 8-bit grey mask that are set. */
static long mask_pixels(const char *path)
{
    struct esr_image m = {0};
    if (esr_png_read(path, &m) != 0)
        fail_msg("cannot read %s", path);
    long n = 0;
    for (long p = 0; p < (long)m.width * m.height; p++)
        n += m.data[p * m.channels] > 0.5f;
    esr_image_free(&m);
    return n;
}

/* scene.json's lights: their number, and light 0's emitted_radiance_on into rad0. */
static int json_lights(const char *dir, float rad0[3])
{
    char path[2048];
    snprintf(path, sizeof path, "%s/scene.json", dir);
    cJSON *root = test_read_json(path);
    assert_non_null(root);
    const cJSON *lights = cJSON_GetObjectItemCaseSensitive(root, "lights");
    assert_true(cJSON_IsArray(lights));
    const int n = cJSON_GetArraySize(lights);
    const cJSON *r = cJSON_GetObjectItemCaseSensitive(cJSON_GetArrayItem(lights, 0), "emitted_radiance_on");
    for (int c = 0; c < 3; c++)
        rad0[c] = (float)cJSON_GetArrayItem(r, c)->valuedouble;
    cJSON_Delete(root);
    return n;
}

static void check_scene(const struct expect *e)
{
    struct esr_synth_scene s;
    assert_int_equal(esr_synth_scene_get(e->name, &s), 0);
    assert_int_equal(s.n_lights, e->lights);
    assert_true(s.res >= e->min_res);
    char *tmp = test_make_tmpdir(), args[2048], dir[1024];
    snprintf(dir, sizeof dir, "%s/ds", tmp);
    snprintf(args, sizeof args, "synth --scene %s --spp 1 --train 1 %s", e->name, dir);
    if (test_run_esr(args, out, sizeof out) != 0)
        fail_msg("%s", out);
    float rad0[3];
    assert_int_equal(json_lights(dir, rad0), e->lights);
    for (int c = 0; c < 3; c++)
        assert_float_equal(rad0[c], e->radiance0[c], 1e-5f);
    struct esr_dataset ds;
    assert_int_equal(esr_dataset_load(dir, &ds), 0);
    assert_int_equal(ds.n_lights, e->lights);
    assert_int_equal(ds.n_true_lights, e->lights);
    assert_int_equal(ds.width, s.res);
    const struct esr_phase *nv = &ds.phases[ESR_PHASE_TEST_NV];
    int views = 0;
    char line[256], report[2048] = "";
    for (int k = 0; k < e->lights; k++) {
        int good = 0;
        long least = -1;
        views = 0;
        for (int i = 0; i < nv->n_frames; i++) {
            const struct esr_frame *f = &nv->frames[i];
            if (!f->lights_on)
                continue;
            char path[ESR_PATH_MAX * 2];
            esr_frame_light_mask_path(&ds, f, k, path, sizeof path);
            const long px = mask_pixels(path);
            good += px >= MIN_PIXELS;
            least = least < 0 || px < least ? px : least;
            views++;
        }
        snprintf(line, sizeof line, " light %d: %d of %d views >= %d px (least %ld);", k, good, views, MIN_PIXELS,
                 least);
        strncat(report, line, sizeof report - strlen(report) - 1);
        if (2 * good < views)
            fail_msg("%s at %d px:%s", e->name, s.res, report);
    }
    assert_int_equal(views, s.n_test);
    print_message("%s (%dx%d):%s\n", e->name, s.res, s.res, report);
    esr_dataset_free(&ds);
    test_rmtree(tmp);
    free(tmp);
}

static void test_bulbs(void **state) { (void)state, check_scene(&scenes[0]); }
static void test_vivid(void **state) { (void)state, check_scene(&scenes[1]); }
static void test_ratios(void **state) { (void)state, check_scene(&scenes[2]); }
static void test_shaded(void **state) { (void)state, check_scene(&scenes[3]); }

/* bulbs: identical lights; ratios: strengths 1 : 3 : 8, each of its own colour. */
static void test_light_relations(void **state)
{
    (void)state;
    struct esr_synth_scene s;
    assert_int_equal(esr_synth_scene_get("bulbs", &s), 0);
    for (int k = 1; k < s.n_lights; k++) {
        assert_float_equal(s.lights[k].strength, s.lights[0].strength, 0.0f);
        assert_memory_equal(s.lights[k].rgb, s.lights[0].rgb, sizeof s.lights[0].rgb);
        assert_int_equal(s.prims[s.lights[k].prim].kind, s.prims[s.lights[0].prim].kind);
        assert_float_equal(s.prims[s.lights[k].prim].b.x, s.prims[s.lights[0].prim].b.x, 0.0f);
    }
    int glossy = 0; /* a glossy object among them */
    for (int i = 0; i < s.n_prims; i++)
        glossy |= s.prims[i].light < 0 && s.prims[i].mat.metallic > 0.5f && s.prims[i].mat.roughness < 0.2f;
    assert_true(glossy);
    assert_int_equal(esr_synth_scene_get("ratios", &s), 0);
    assert_float_equal(s.lights[1].strength / s.lights[0].strength, 3.0f, 1e-6f);
    assert_float_equal(s.lights[2].strength / s.lights[0].strength, 8.0f, 1e-6f);
    for (int k = 1; k < s.n_lights; k++)
        assert_memory_not_equal(s.lights[k].rgb, s.lights[k - 1].rgb, sizeof s.lights[0].rgb);
}

/* Whether x is inside p by more than eps (written here from prim.h's parameters). */
static int inside(const struct esr_synth_prim *p, float x, float y, float z, float eps)
{
    if (p->kind == ESR_SYNTH_SPHERE) {
        const float dx = x - p->a.x, dy = y - p->a.y, dz = z - p->a.z, r = p->b.x - eps;
        return r > 0.0f && dx * dx + dy * dy + dz * dz < r * r;
    }
    if (p->kind == ESR_SYNTH_BOX)
        return x > p->a.x + eps && x < p->b.x - eps && y > p->a.y + eps && y < p->b.y - eps && z > p->a.z + eps &&
               z < p->b.z - eps;
    const float dx = x - p->a.x, dy = y - p->a.y, r = p->b.x - eps;
    return r > 0.0f && dx * dx + dy * dy < r * r && z > p->a.z + eps && z < p->a.z + p->b.y - eps;
}

/* Axis-aligned bounds of p. */
static void prim_box(const struct esr_synth_prim *p, float lo[3], float hi[3])
{
    const float a[3] = {p->a.x, p->a.y, p->a.z}, b[3] = {p->b.x, p->b.y, p->b.z};
    for (int k = 0; k < 3; k++) {
        if (p->kind == ESR_SYNTH_SPHERE)
            lo[k] = a[k] - b[0], hi[k] = a[k] + b[0];
        else if (p->kind == ESR_SYNTH_BOX)
            lo[k] = a[k], hi[k] = b[k];
        else
            lo[k] = k < 2 ? a[k] - b[0] : a[2], hi[k] = k < 2 ? a[k] + b[0] : a[2] + b[1];
    }
}

/* No two primitives of the new scenes overlap (gt/mesh.ply's shells would hold hidden surface,
 * and a light inside another object would emit where no camera sees), and all lie in the
 * [-1.5, 1.5]^3 box scene.json states: a 2 mm grid over each pair's common bounds. */
static void test_no_overlap(void **state)
{
    (void)state;
    const float step = 0.002f;
    for (int i = 0; i < N_SCENES; i++) {
        struct esr_synth_scene s;
        assert_int_equal(esr_synth_scene_get(scenes[i].name, &s), 0);
        for (int p = 0; p < s.n_prims; p++) {
            float plo[3], phi[3];
            prim_box(&s.prims[p], plo, phi);
            for (int k = 0; k < 3; k++)
                assert_true(plo[k] > -1.5f && phi[k] < 1.5f);
            for (int q = p + 1; q < s.n_prims; q++) {
                float qlo[3], qhi[3], lo[3], hi[3];
                prim_box(&s.prims[q], qlo, qhi);
                int empty = 0;
                for (int k = 0; k < 3; k++) {
                    lo[k] = fmaxf(plo[k], qlo[k]);
                    hi[k] = fminf(phi[k], qhi[k]);
                    empty |= hi[k] <= lo[k];
                }
                if (empty)
                    continue;
                const int n[3] = {(int)((hi[0] - lo[0]) / step) + 1, (int)((hi[1] - lo[1]) / step) + 1,
                                  (int)((hi[2] - lo[2]) / step) + 1};
                for (int a = 0; a <= n[0]; a++)
                    for (int b = 0; b <= n[1]; b++)
                        for (int c = 0; c <= n[2]; c++) {
                            const float x = lo[0] + (hi[0] - lo[0]) * (float)a / (float)n[0];
                            const float y = lo[1] + (hi[1] - lo[1]) * (float)b / (float)n[1];
                            const float z = lo[2] + (hi[2] - lo[2]) * (float)c / (float)n[2];
                            if (inside(&s.prims[p], x, y, z, 1e-4f) && inside(&s.prims[q], x, y, z, 1e-4f))
                                fail_msg("%s: %s and %s overlap at (%.3f, %.3f, %.3f)", s.name, s.prims[p].name,
                                         s.prims[q].name, x, y, z);
                        }
            }
        }
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_listed), cmocka_unit_test(test_light_relations), cmocka_unit_test(test_no_overlap),
        cmocka_unit_test(test_bulbs),
        cmocka_unit_test(test_vivid),  cmocka_unit_test(test_ratios),          cmocka_unit_test(test_shaded),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
