/* `esr synth` end to end: a tiny default-scene dataset loads with the dataset loader, has the
 * FORMAT.md counts, light schedule, PNG/EXR/mask conventions and ground truth, matches the JSON
 * structure of the reference lamp scene, is reproducible; bad input fails cleanly. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <cjson/cJSON.h>
#include <dirent.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/colour.h"
#include "io/dataset.h"
#include "io/file.h"
#include "synth/plan.h"
#include "synth/scene.h"
#include "synth/trace.h"
#include "test_support.h"

static char *tmp;
static char out[8192];

static int setup(void **state)
{
    (void)state;
    tmp = test_make_tmpdir();
    char args[512];
    snprintf(args, sizeof args, "synth --res 16 --spp 4 --train 3 --test 2 --seed 5 %s/ds", tmp);
    int rc = test_run_esr(args, out, sizeof out);
    if (rc != 0)
        fprintf(stderr, "%s\n", out);
    return rc;
}

static int teardown(void **state)
{
    (void)state;
    test_rmtree(tmp);
    free(tmp);
    return 0;
}

static void path_in(char *buf, size_t n, const char *rel)
{
    snprintf(buf, n, "%s/ds/%s", tmp, rel);
}

static void test_loads_with_right_counts(void **state)
{
    (void)state;
    char dir[1024];
    path_in(dir, sizeof dir, "");
    struct esr_dataset ds;
    assert_int_equal(esr_dataset_load(dir, &ds), 0);
    assert_int_equal(ds.layout, ESR_LAYOUT_ESR);
    assert_int_equal(ds.n_lights, 2);
    assert_int_equal(ds.width, 16);
    assert_int_equal(ds.phases[ESR_PHASE_TRAIN].n_frames, 6);
    assert_int_equal(ds.phases[ESR_PHASE_TEST_NV].n_frames, 4);
    assert_int_equal(ds.phases[ESR_PHASE_TEST_NVI].n_frames, 6);
    assert_int_equal(ds.phases[ESR_PHASE_TEST_NVC].n_frames, 4);
    assert_int_equal(ds.phases[ESR_PHASE_TEST_NVIC].n_frames, 4);
    assert_int_equal(esr_dataset_check(&ds, NULL, NULL), 0);
    /* Train: first half off, second half on. */
    assert_int_equal(ds.phases[ESR_PHASE_TRAIN].frames[2].lights_on, 0);
    assert_int_equal(ds.phases[ESR_PHASE_TRAIN].frames[3].lights_on, 1);
    assert_string_equal(ds.phases[ESR_PHASE_TRAIN].frames[3].file_path, "train/r_003");
    /* Colour schedule: camera 1, condition 1 -> j = 3: light 0 cyan, light 1 red (nvc);
     * nvic light 0 P[4] magenta, light 1 P[1] green, intensity 2. */
    const struct esr_frame *c = &ds.phases[ESR_PHASE_TEST_NVC].frames[3];
    assert_string_equal(c->name, "c001_c1");
    assert_float_equal(c->lights[0].hsv[0], 0.5f, 1e-6f);
    assert_float_equal(c->lights[1].hsv[0], 0.0f, 1e-6f);
    assert_string_equal(c->lights[1].mask_path, "masks/nvc_c001_c1_l1");
    const struct esr_frame *ic = &ds.phases[ESR_PHASE_TEST_NVIC].frames[3];
    assert_float_equal(ic->lights[0].hsv[0], 0.833333f, 1e-6f);
    assert_float_equal(ic->lights[1].hsv[0], 0.333333f, 1e-6f);
    assert_float_equal(ic->lights[0].intensity, 2.0f, 0.0f);
    const struct esr_frame *ind = &ds.phases[ESR_PHASE_TEST_NVI].frames[2];
    assert_string_equal(ind->name, "c000_ind");
    assert_float_equal(ind->lights[0].intensity, 0.0f, 0.0f);
    assert_float_equal(ind->lights[1].intensity, 1.0f, 0.0f);
    /* The same test camera in every test phase; train cameras differ from test cameras. */
    assert_memory_equal(&ds.phases[ESR_PHASE_TEST_NV].frames[2].camera, &ds.phases[ESR_PHASE_TEST_NVIC].frames[3].camera,
                        sizeof(struct esr_camera));
    assert_true(memcmp(ds.phases[ESR_PHASE_TRAIN].frames[0].camera.c2w, ds.phases[ESR_PHASE_TEST_NV].frames[0].camera.c2w,
                       sizeof ds.phases[0].frames[0].camera.c2w) != 0);
    /* Cameras: radius 4, elevation 10..75 degrees, looking at the origin (-Z through it). */
    for (int i = 0; i < 6; i++) {
        const float(*m)[4] = ds.phases[ESR_PHASE_TRAIN].frames[i].camera.c2w;
        float r = sqrtf(m[0][3] * m[0][3] + m[1][3] * m[1][3] + m[2][3] * m[2][3]);
        assert_float_equal(r, 4.0f, 1e-4f);
        float el = asinf(m[2][3] / r) * 180.0f / (float)M_PI;
        assert_true(el >= 10.0f - 1e-3f && el <= 75.0f + 1e-3f);
        for (int k = 0; k < 3; k++)
            assert_float_equal(m[k][2] * 4.0f, m[k][3], 1e-4f);
    }
    esr_dataset_free(&ds);
}

/* PNG = sRGB(clip(EXR / A)) with straight alpha; masks are grey 0/255 and the emission mask is
 * the union of the per-light masks. */
static void test_image_conventions(void **state)
{
    (void)state;
    char p[1024];
    struct esr_image png, exr, m0, m1, em;
    path_in(p, sizeof p, "test_nv/c001_on.png");
    assert_int_equal(esr_png_read(p, &png), 0);
    path_in(p, sizeof p, "test_nv/exr/c001_on.exr");
    assert_int_equal(esr_exr_read(p, &exr), 0);
    assert_int_equal(png.channels, 4);
    int covered = 0;
    for (int i = 0; i < 16 * 16; i++) {
        float a = exr.data[4 * i + 3];
        assert_float_equal(png.data[4 * i + 3], a, 0.5f / 255.0f + 1e-3f);
        if (a < 0.05f)
            continue;
        covered++;
        for (int c = 0; c < 3; c++) {
            float expect = esr_srgb_from_linear(fminf(fmaxf(exr.data[4 * i + c] / a, 0.0f), 1.0f));
            assert_float_equal(png.data[4 * i + c], expect, 0.5f / 255.0f + 4e-3f); /* half-float EXR */
        }
    }
    assert_true(covered > 20);
    path_in(p, sizeof p, "masks/nv_c001_on_l0.png");
    assert_int_equal(esr_png_read(p, &m0), 0);
    path_in(p, sizeof p, "masks/nv_c001_on_l1.png");
    assert_int_equal(esr_png_read(p, &m1), 0);
    path_in(p, sizeof p, "test_nv/emission/c001_on.png");
    assert_int_equal(esr_png_read(p, &em), 0);
    assert_int_equal(em.channels, 1);
    for (int i = 0; i < 16 * 16; i++) {
        assert_true(m0.data[i] == 0.0f || m0.data[i] == 1.0f);
        assert_float_equal(em.data[i], fmaxf(m0.data[i], m1.data[i]), 0.0f);
    }
    esr_image_free(&png);
    esr_image_free(&exr);
    esr_image_free(&m0);
    esr_image_free(&m1);
    esr_image_free(&em);
}

/* Mean linear radiance per channel of an RGBA image (premultiplied). */
static void image_mean(const struct esr_image *img, double mean[3])
{
    const size_t n = (size_t)img->width * (size_t)img->height;
    mean[0] = mean[1] = mean[2] = 0.0;
    for (size_t i = 0; i < n; i++)
        for (int c = 0; c < 3; c++)
            mean[c] += img->data[4 * i + c] / (double)n;
}

/* Mean alpha of an RGBA image. */
static double alpha_mean(const struct esr_image *img)
{
    const size_t n = (size_t)img->width * (size_t)img->height;
    double sum = 0.0;
    for (size_t i = 0; i < n; i++)
        sum += img->data[4 * i + 3] / (double)n;
    return sum;
}

/* The frames of synth run `name` (res 12, 256 spp, two test cameras, seed 7; with the backdrop
 * when backdrop is 1) against the same frames path-traced whole at 1024 spp, each from its own
 * random stream: image means per channel within 3% (the Monte Carlo noise is 1.3% at most) and
 * mean alpha within 2%; the frames of a camera carry the same alpha bit for bit (its basis images
 * share their camera rays). Returns the frames checked. */
static int check_frames_against_whole(const char *name, int backdrop)
{
    char args[512], p[1024];
    snprintf(args, sizeof args, "synth --res 12 --spp 256 --train 1 --test 2 --seed 7 %s %s/%s",
             backdrop ? "--backdrop" : "", tmp, name);
    assert_int_equal(test_run_esr(args, out, sizeof out), 0);
    struct esr_synth_scene scene;
    assert_int_equal(esr_synth_scene_get("default", &scene), 0);
    struct esr_synth_plan plan;
    assert_int_equal(esr_synth_plan_make(&scene, 12, 1, 2, 7, &plan), 0);
    const enum esr_phase_id phs[] = {ESR_PHASE_TEST_NV, ESR_PHASE_TEST_NVI, ESR_PHASE_TEST_NVC,
                                     ESR_PHASE_TEST_NVIC};
    struct esr_image first_alpha[2] = {{0}, {0}}; /* per camera, its first frame */
    int checked = 0;
    for (size_t q = 0; q < sizeof phs / sizeof phs[0]; q++)
        for (int i = 0; i < plan.n_frames[phs[q]]; i++) {
            const struct esr_synth_frame *f = &plan.frames[phs[q]][i];
            assert_true(f->cam >= 0 && f->cam < 2);
            snprintf(p, sizeof p, "%s/%s/%s/exr/%s.exr", tmp, name, esr_phase_name(phs[q]), f->name);
            struct esr_image got, whole;
            assert_int_equal(esr_exr_read(p, &got), 0);
            struct esr_synth_trace_params params;
            esr_synth_trace_setup(&scene, (const float(*)[3])f->emission, &params);
            params.backdrop = backdrop;
            assert_int_equal(esr_synth_render(&params, &plan.test_cams[f->cam], 1024, 99, (uint64_t)checked,
                                              &whole), 0);
            double a[3], b[3];
            image_mean(&got, a);
            image_mean(&whole, b);
            for (int c = 0; c < 3; c++) {
                if (fabs(a[c] - b[c]) > 0.03 * b[c] + 1e-4)
                    fail_msg("%s %s channel %d: mean %.5f from the basis, %.5f path-traced whole", name,
                             f->name, c, a[c], b[c]);
            }
            if (fabs(alpha_mean(&got) - alpha_mean(&whole)) > 0.02 * alpha_mean(&whole))
                fail_msg("%s %s: mean alpha %.4f from the basis, %.4f path-traced whole", name, f->name,
                         alpha_mean(&got), alpha_mean(&whole));
            struct esr_image *first = &first_alpha[f->cam];
            if (!first->data)
                *first = got;
            else {
                for (int px = 0; px < 12 * 12; px++)
                    assert_float_equal(got.data[4 * px + 3], first->data[4 * px + 3], 0.0f);
                esr_image_free(&got);
            }
            checked++;
            esr_image_free(&whole);
        }
    for (int cam = 0; cam < 2; cam++) {
        assert_non_null(first_alpha[cam].data); /* both cameras' frames were checked */
        for (int px = 0; backdrop && px < 12 * 12; px++)
            assert_float_equal(first_alpha[cam].data[4 * px + 3], 1.0f, 0.0f); /* opaque */
        esr_image_free(&first_alpha[cam]);
    }
    esr_synth_plan_free(&plan);
    return checked;
}

/* The test frames come from each camera's light basis (synth/dataset.c): a frame must match, in
 * expectation, the same frame path-traced whole (its own lights, colours, the world light and
 * the backdrop), and frames of a camera must differ by exactly their lights' light. */
static void test_frames_from_light_basis(void **state)
{
    (void)state;
    char p[1024];
    const int checked = check_frames_against_whole("basis", 0);
    assert_true(check_frames_against_whole("basis_backdrop", 1) == checked);
    assert_true(checked >= 16);
    /* i200 - off is 4 (i050 - off): the same basis images, scaled (half-float EXR precision) */
    struct esr_image off, i050, i200;
    snprintf(p, sizeof p, "%s/basis/test_nv/exr/c001_off.exr", tmp);
    assert_int_equal(esr_exr_read(p, &off), 0);
    snprintf(p, sizeof p, "%s/basis/test_nvi/exr/c001_i050.exr", tmp);
    assert_int_equal(esr_exr_read(p, &i050), 0);
    snprintf(p, sizeof p, "%s/basis/test_nvi/exr/c001_i200.exr", tmp);
    assert_int_equal(esr_exr_read(p, &i200), 0);
    double lit = 0.0;
    for (size_t i = 0; i < 12 * 12 * 4; i++) {
        if (i % 4 == 3) {
            assert_float_equal(i200.data[i], off.data[i], 0.0f); /* coverage: the basis's */
            continue;
        }
        const float d050 = i050.data[i] - off.data[i], d200 = i200.data[i] - off.data[i];
        assert_float_equal(d200, 4.0f * d050, 4e-3f * (fabsf(i200.data[i]) + 4.0f * fabsf(i050.data[i]) + 1e-3f));
        lit += d050;
    }
    assert_true(lit > 0.1); /* the lights light the view */
    esr_image_free(&off);
    esr_image_free(&i050);
    esr_image_free(&i200);
}

static void test_ground_truth_files(void **state)
{
    (void)state;
    char p[1024];
    const char *files[] = {"gt/mesh.ply", "gt/c001_normal.exr", "gt/c001_base_color.exr", "gt/c001_roughness.exr",
                           "gt/c001_metallic.exr", "gt/c001_emission.exr"};
    for (size_t i = 0; i < sizeof files / sizeof files[0]; i++) {
        path_in(p, sizeof p, files[i]);
        assert_true(esr_file_exists(p));
    }
    struct esr_image n;
    path_in(p, sizeof p, "gt/c001_normal.exr");
    assert_int_equal(esr_exr_read(p, &n), 0);
    int hits = 0;
    for (int i = 0; i < 16 * 16; i++) {
        float len = sqrtf(n.data[4 * i] * n.data[4 * i] + n.data[4 * i + 1] * n.data[4 * i + 1] +
                          n.data[4 * i + 2] * n.data[4 * i + 2]);
        assert_true(len < 1e-6f || fabsf(len - 1.0f) < 1e-4f);
        hits += len > 0.5f;
    }
    assert_true(hits > 20);
    esr_image_free(&n);
    unsigned char *text;
    size_t size;
    path_in(p, sizeof p, "scene.json");
    assert_int_equal(esr_file_read_all(p, &text, &size), 0);
    cJSON *root = cJSON_Parse((const char *)text);
    assert_non_null(root);
    assert_int_equal(cJSON_GetArraySize(cJSON_GetObjectItem(root, "lights")), 2);
    assert_int_equal(cJSON_GetObjectItem(root, "samples_per_pixel")->valueint, 4);
    cJSON_Delete(root);
    free(text);
}

/* Same field names and nesting as the reference scene's JSON (frame and light keys). */
static void test_json_keys_match_reference(void **state)
{
    (void)state;
    const char *lamp = test_shared_scene("lamp");
    if (!lamp)
        skip();
    const char *names[] = {"train", "test_nv", "test_nvi", "test_nvc", "test_nvic"};
    for (int i = 0; i < 5; i++) {
        char a[1024], b[1024];
        snprintf(a, sizeof a, "%s/transforms/transforms_%s.json", lamp, names[i]);
        snprintf(b, sizeof b, "%s/ds/transforms/transforms_%s.json", tmp, names[i]);
        unsigned char *ta, *tb;
        size_t na, nb;
        assert_int_equal(esr_file_read_all(a, &ta, &na), 0);
        assert_int_equal(esr_file_read_all(b, &tb, &nb), 0);
        cJSON *ja = cJSON_Parse((const char *)ta), *jb = cJSON_Parse((const char *)tb);
        cJSON *fa = cJSON_GetArrayItem(cJSON_GetObjectItem(ja, "frames"), 1);
        cJSON *fb = cJSON_GetArrayItem(cJSON_GetObjectItem(jb, "frames"), 1);
        cJSON *la = cJSON_GetArrayItem(cJSON_GetObjectItem(fa, "lights"), 1);
        cJSON *lb = cJSON_GetArrayItem(cJSON_GetObjectItem(fb, "lights"), 1);
        for (cJSON *k = fa->child; k; k = k->next)
            assert_non_null(cJSON_GetObjectItem(fb, k->string));
        for (cJSON *k = la->child; k; k = k->next) {
            assert_non_null(cJSON_GetObjectItem(lb, k->string));
            if (cJSON_IsString(k))
                assert_string_equal(cJSON_GetObjectItem(lb, "mode")->valuestring,
                                    cJSON_GetObjectItem(la, "mode")->valuestring);
        }
        /* mask naming: "<tag>_<name>_l1" in both. */
        const char *ma = cJSON_GetObjectItem(la, "mask_path")->valuestring;
        const char *mb = cJSON_GetObjectItem(lb, "mask_path")->valuestring;
        assert_int_equal(strlen(ma) > 0, strlen(mb) > 0);
        cJSON_Delete(ja);
        cJSON_Delete(jb);
        free(ta);
        free(tb);
    }
}

static void test_reproducible(void **state)
{
    (void)state;
    char args[512], a[1024], b[1024];
    snprintf(args, sizeof args, "synth --res 16 --spp 4 --train 3 --test 2 --seed 5 %s/again", tmp);
    assert_int_equal(test_run_esr(args, out, sizeof out), 0);
    snprintf(a, sizeof a, "%s/ds/train/r_004.png", tmp);
    snprintf(b, sizeof b, "%s/again/train/r_004.png", tmp);
    assert_true(test_files_equal(a, b));
}

static int no_partial_dirs(void)
{
    DIR *d = opendir(tmp);
    struct dirent *e;
    int clean = 1;
    while ((e = readdir(d)))
        if (strstr(e->d_name, ".partial-") || strstr(e->d_name, ".old-"))
            clean = 0;
    closedir(d);
    return clean;
}

static void expect_failure(const char *args_fmt, const char *message)
{
    char args[512];
    snprintf(args, sizeof args, args_fmt, tmp);
    int rc = test_run_esr(args, out, sizeof out);
    if (rc != 1 || !strstr(out, message)) {
        fprintf(stderr, "esr %s -> %d:\n%s\n", args, rc, out);
        fail();
    }
}

static void test_bad_input(void **state)
{
    (void)state;
    expect_failure("synth --scene nope %s/x", "unknown scene 'nope'");
    expect_failure("synth --res 4 %s/x", "--res must be an integer in 8..2048");
    expect_failure("synth --res 3000 %s/x", "--res");
    expect_failure("synth --res 12abc %s/x", "--res");
    expect_failure("synth --spp 0 %s/x", "--spp must be an integer in 1..65536");
    expect_failure("synth --spp 70000 %s/x", "--spp");
    expect_failure("synth --bogus %s/x", "unknown option");
    expect_failure("synth --res 16 --force%.0s", "missing OUT_DIR"); /* %.0s: no path at all */
    /* An existing non-empty directory is refused and left alone... */
    char marker[1024];
    snprintf(marker, sizeof marker, "%s/ds/keep.txt", tmp);
    assert_int_equal(test_write_file(marker, "x"), 0);
    expect_failure("synth --res 8 --spp 1 --train 1 --test 1 %s/ds", "not empty (use --force");
    assert_true(esr_file_exists(marker));
    /* ... an output below a regular file cannot be created ... */
    expect_failure("synth --res 8 --spp 1 --train 1 --test 1 %s/ds/keep.txt/sub", "Not a directory");
    assert_true(no_partial_dirs());
    /* ... and --force replaces it completely. */
    char args[512];
    snprintf(args, sizeof args, "synth --res 8 --spp 1 --train 1 --test 1 --force %s/ds", tmp);
    assert_int_equal(test_run_esr(args, out, sizeof out), 0);
    assert_false(esr_file_exists(marker));
    assert_true(no_partial_dirs());
}

/* Like `mkdir -p`: `make demo` writes below a runs/ folder that a fresh clone does not have. */
static void test_missing_parents_are_created(void **state)
{
    (void)state;
    char args[512], scene_json[600];
    snprintf(args, sizeof args, "synth --res 8 --spp 1 --train 1 --test 1 %s/new/deeper/ds", tmp);
    if (test_run_esr(args, out, sizeof out) != 0)
        fail_msg("%s", out);
    snprintf(scene_json, sizeof scene_json, "%s/new/deeper/ds/scene.json", tmp);
    assert_true(esr_file_exists(scene_json));
}

static void test_listing(void **state)
{
    (void)state;
    assert_int_equal(test_run_esr("synth --scene list", out, sizeof out), 0);
    assert_non_null(strstr(out, "default"));
    assert_non_null(strstr(out, "glossy"));
    assert_int_equal(test_run_esr("synth --help", out, sizeof out), 0);
    assert_non_null(strstr(out, "--spp"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_loads_with_right_counts), cmocka_unit_test(test_image_conventions),
        cmocka_unit_test(test_ground_truth_files),      cmocka_unit_test(test_json_keys_match_reference),
        cmocka_unit_test(test_reproducible),            cmocka_unit_test(test_listing),
        cmocka_unit_test(test_bad_input),               cmocka_unit_test(test_missing_parents_are_created),
        cmocka_unit_test(test_frames_from_light_basis),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
