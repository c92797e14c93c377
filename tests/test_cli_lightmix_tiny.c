/* `esr lightmix` and `esr edit --mix` end to end on the shared tiny run's pdra model
 * (tests/support/tiny_run.h): the light groups a lightmix writes, mixed as an edit says, give
 * that edit's view (direct and ratio; unedited the layers' plain sum, intensity-only edits,
 * recolours, exposure) to 1e-4 relative; an edit given as --mix JSON renders what the same edit
 * given as --light/--intensity/--color does; bad mix files, a run without lights and output
 * folders lightmix must not write are refused before any rendering; and OpenImageIO's oiiotool,
 * an independent reader, sums and scales the layers to the same views (skipped, said so, when
 * oiiotool is not installed: Debian's openimageio-tools). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cjson/cJSON.h>

#include "core/error.h"
#include "io/file.h"
#include "io/image.h"
#include "model/model.h"
#include "test_support.h"
#include "tiny_run.h"

/* the views of the tiny run's test_nv phase (one camera each for its off and on frames) */
static const char *const frames[] = {"c000_off", "c000_on", "c001_on", "c002_on"};
#define N_FRAMES (int)(sizeof frames / sizeof frames[0])

/* An edit as the test states it: --light options for esr edit, the same as a mix JSON, and each
 * light's weights on its layers as worked out by hand (light_K, or light_K_value where value).
 * An edit of every light (`--light all`) has its JSON's lights written for the run's lights:
 * json then has a %s for the list, each light's entry its id and the fields `each`, and the
 * lights past 1 weigh as light 0; lights past 1 of any other case stay as found. */
struct mix_case {
    const char *name, *args, *json, *each;
    float w[2][3];  /* lights 0 and 1 */
    int value[2];
    float gain;     /* 2^exposure */
};

/* hsv(0.6, 1, 1) = (0, 0.4, 1): H' = 3.6, chroma 1, x = 1 - |3.6 mod 2 - 1| = 0.4 */
static const struct mix_case cases[] = {
    {"unedited", "--light 0 --intensity 1", "{\"lights\": []}", NULL, {{1, 1, 1}, {1, 1, 1}}, {0, 0}, 1},
    {"light 0 off", "--light 0 --intensity 0", "{\"lights\": [{\"id\": 0, \"intensity\": 0}]}",
     NULL, {{0, 0, 0}, {1, 1, 1}}, {0, 0}, 1},
    {"light 1 x3", "--light 1 --intensity 3", "{\"lights\": [{\"id\": 1, \"intensity\": 3}]}",
     NULL, {{1, 1, 1}, {3, 3, 3}}, {0, 0}, 1},
    {"light 0 blue", "--light 0 --color 0.6,1",
     "{\"lights\": [{\"id\": 0, \"hue\": 0.6, \"saturation\": 1}]}", NULL, {{0, 0.4f, 1}, {1, 1, 1}},
     {1, 0}, 1},
    {"all x0.5, exposure +1", "--light all --intensity 0.5 --exposure 1",
     "{\"lights\": [%s], \"exposure\": 1}", "\"intensity\": 0.5", {{0.5f, 0.5f, 0.5f}, {0.5f, 0.5f, 0.5f}},
     {0, 0}, 2},
};
#define N_CASES (int)(sizeof cases / sizeof cases[0])

/* The largest |a - b| / (|b| + 1e-3) over the two images (same size required). */
static double rel_diff(const struct esr_image *a, const struct esr_image *b)
{
    assert_int_equal(a->width, b->width);
    assert_int_equal(a->height, b->height);
    double worst = 0.0;
    const size_t px = (size_t)a->width * (size_t)a->height;
    for (size_t p = 0; p < px; p++)
        for (int c = 0; c < 3; c++) {
            const double x = a->data[p * a->channels + c], y = b->data[p * b->channels + c];
            worst = fmax(worst, fabs(x - y) / (fabs(y) + 1e-3));
        }
    return worst;
}

/* The view mix case c gives from the layers of dir/frame.exr (read here, layer by layer) of a
 * run with n_lights lights (the tiny run's training decides how many). */
static void mix_layers(const char *dir, const char *frame, const struct mix_case *c, int n_lights,
                       struct esr_image *out)
{
    char path[8900];
    snprintf(path, sizeof path, "%s/%s.exr", dir, frame);
    if (esr_exr_read_layer(path, "off", out) != ESR_OK)
        fail_msg("%s", esr_error_message());
    const size_t px = (size_t)out->width * (size_t)out->height;
    for (int k = 0; k < n_lights; k++) {
        char layer[32];
        snprintf(layer, sizeof layer, k < 2 && c->value[k] ? "light_%d_value" : "light_%d", k);
        struct esr_image L;
        if (esr_exr_read_layer(path, layer, &L) != ESR_OK)
            fail_msg("%s", esr_error_message());
        for (size_t p = 0; p < px; p++)
            for (int ch = 0; ch < 3; ch++)
                out->data[p * 4 + ch] += (k < 2 ? c->w[k][ch] : c->each ? c->w[0][ch] : 1.0f) * L.data[p * 4 + ch];
        esr_image_free(&L);
    }
    for (size_t p = 0; p < px; p++)
        for (int ch = 0; ch < 3; ch++)
            out->data[p * 4 + ch] *= c->gain;
}

static void read_view(const char *dir, const char *frame, struct esr_image *img)
{
    char path[8900];
    snprintf(path, sizeof path, "%s/%s.exr", dir, frame);
    if (esr_exr_read(path, img) != ESR_OK)
        fail_msg("%s", esr_error_message());
}

static void run_ok(const char *cmd)
{
    static char out[16384];
    if (test_run_esr(cmd, out, sizeof out) != 0)
        fail_msg("esr %s failed:\n%s", cmd, out);
}

/* Skips the test, saying what was not checked, unless `tool` is installed. */
static void need_tool(const char *tool, const char *package, const char *unchecked)
{
    char cmd[256];
    snprintf(cmd, sizeof cmd, "command -v %s >/dev/null 2>&1", tool);
    if (system(cmd) != 0) {
        print_message("skipped: %s is not installed (Debian package %s): %s\n", tool, package,
                      unchecked);
        skip();
    }
}

/* The number of lights run's model found (the fixture's, whatever its training gave). */
static int lights_of(const char *run)
{
    char path[4400];
    snprintf(path, sizeof path, "%s/ckpt_pdra.bin", run);
    struct esr_model m;
    assert_int_equal(esr_model_load(&m, path), ESR_OK);
    const int n = m.lights.n;
    esr_model_free(&m);
    assert_true(n >= 2); /* the cases below edit lights 0 and 1 */
    return n;
}

/* A copy of the fixture's pdra run at test_tmpdir/as (its path into run) and its lightmix of
 * frame c001_on into test_tmpdir/out (into lm). */
static void lightmix_c001(const char *as, const char *out, char run[4300], char lm[4400])
{
    char cmd[24000];
    tiny_copy_run("run_pdra", as, run, 4300);
    snprintf(lm, 4400, "%s/%s", test_tmpdir, out);
    snprintf(cmd, sizeof cmd, "lightmix %s --out %s --frames c001_on", run, lm);
    run_ok(cmd);
}

/* Per method: one lightmix, then each case as an edit given by options and by --mix; the
 * layers mixed per the case equal the edit's views, and the --mix views the options' ones. */
static void test_layers_mix_to_the_edits(void **state)
{
    (void)state;
    char run[4300], cmd[24000];
    tiny_copy_run("run_pdra", "run_lightmix", run, sizeof run);
    static const char *const methods[] = {"direct", "ratio"};
    for (int mi = 0; mi < 2; mi++) {
        char lm[4400];
        snprintf(lm, sizeof lm, "%s/lightmix_%s", test_tmpdir, methods[mi]);
        snprintf(cmd, sizeof cmd, "lightmix %s --out %s --method %s", run, lm, methods[mi]);
        run_ok(cmd);
        char path[4500];
        snprintf(path, sizeof path, "%s/mix.json", lm);
        assert_true(esr_file_exists(path));
        snprintf(path, sizeof path, "%s/lightmix.json", lm);
        cJSON *rec = test_read_json(path);
        assert_non_null(rec);
        /* off, then each light and its _value layer */
        const int n_lights = lights_of(run);
        assert_int_equal(cJSON_GetArraySize(cJSON_GetObjectItem(rec, "layers")), 1 + 2 * n_lights);
        cJSON_Delete(rec);
        for (int ci = 0; ci < N_CASES; ci++) {
            const struct mix_case *c = &cases[ci];
            char ed[4400], edmix[4400], mixfile[4400];
            snprintf(ed, sizeof ed, "%s/edit_%s_%d", test_tmpdir, methods[mi], ci);
            snprintf(edmix, sizeof edmix, "%s/editmix_%s_%d", test_tmpdir, methods[mi], ci);
            snprintf(mixfile, sizeof mixfile, "%s/mix_%d.json", test_tmpdir, ci);
            char json[1024], list[768] = "";
            if (c->each) { /* every light of the run, by id */
                for (int k = 0, at = 0; k < n_lights; k++)
                    at += snprintf(list + at, sizeof list - (size_t)at, "%s{\"id\": %d, %s}",
                                   k ? ", " : "", k, c->each);
                snprintf(json, sizeof json, c->json, list);
            } else {
                snprintf(json, sizeof json, "%s", c->json);
            }
            assert_int_equal(test_write_file(mixfile, json), 0);
            snprintf(cmd, sizeof cmd, "edit %s %s --out %s --method %s", run, c->args, ed,
                     methods[mi]);
            run_ok(cmd);
            snprintf(cmd, sizeof cmd, "edit %s --mix %s --out %s --method %s", run, mixfile, edmix,
                     methods[mi]);
            run_ok(cmd);
            double worst = 0.0;
            for (int f = 0; f < N_FRAMES; f++) {
                struct esr_image mixed, edit, viamix;
                mix_layers(lm, frames[f], c, n_lights, &mixed);
                read_view(ed, frames[f], &edit);
                read_view(edmix, frames[f], &viamix);
                worst = fmax(worst, rel_diff(&mixed, &edit));
                assert_memory_equal(edit.data, viamix.data, esr_image_count(&edit) * sizeof(float));
                esr_image_free(&mixed), esr_image_free(&edit), esr_image_free(&viamix);
            }
            print_message("%s, %s: the layers mixed differ from esr edit by %.3g relative at "
                          "most; --mix renders the same\n", methods[mi], c->name, worst);
            assert_true(worst < 1e-4);
        }
    }
}

/* Bad mix files are refused naming the file and the field, before anything is written; a run
 * without lights has nothing to mix; lightmix will not write into the dataset or the run's render
 * folder, and says so before rendering. */
static void test_refusals(void **state)
{
    (void)state;
    char run[4300], cmd[24000], out[8192], dst[4400];
    tiny_copy_run("run_pdra", "run_lightmix_bad", run, sizeof run);
    char no_light[128];
    snprintf(no_light, sizeof no_light, "bad.json: lights[0].id: no light 7: the run found %d", lights_of(run));
    const struct {
        const char *json, *message;
    } bad[] = {
        {"{\"lights\": [{\"id\": 0,}]}", "bad.json:1:23: malformed JSON"},
        {"{\"lights\": [{\"id\": 7}]}", no_light},
        {"{\"lights\": [{\"id\": 0.5}]}", "bad.json: lights[0].id: no light 0.5"},
        {"{\"lights\": [{\"intensity\": 2}]}", "bad.json: lights[0]: no id"},
        {"{\"lights\": [{\"id\": 0}, {\"id\": 0}]}", "bad.json: lights[1].id: light 0 is given twice"},
        {"{\"lights\": [{\"id\": 1, \"intensity\": -1}]}",
         "bad.json: lights[0].intensity: -1 is not a number in [0, 1e+06]"},
        {"{\"lights\": [{\"id\": 1, \"intensity\": \"2\"}]}",
         "bad.json: lights[0].intensity: not a number"},
        {"{\"lights\": [{\"id\": 0, \"hue\": 1.5, \"saturation\": 1}]}",
         "bad.json: lights[0].hue: 1.5 is not a number in [0, 1]"},
        {"{\"lights\": [{\"id\": 0, \"hue\": 0.5}]}", "bad.json: lights[0]: hue without saturation"},
        {"{\"lights\": [{\"id\": 0, \"saturaton\": 0.5}]}",
         "bad.json: lights[0]: unknown field 'saturaton'"},
        {"{\"lights\": [], \"exposure\": 40}", "bad.json: exposure: 40 is not a number in [-20, 20]"},
        {"{\"lights\": {}}", "bad.json: lights: not an array"},
        {"[1, 2]", "bad.json: a mix is a JSON object"},
    };
    char file[4400], edit_out[4400];
    snprintf(file, sizeof file, "%s/bad.json", test_tmpdir);
    snprintf(edit_out, sizeof edit_out, "%s/edit_bad_mix", test_tmpdir);
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        assert_int_equal(test_write_file(file, bad[i].json), 0);
        snprintf(cmd, sizeof cmd, "edit %s --mix %s --out %s --orbit 1", run, file, edit_out);
        assert_int_equal(test_run_esr(cmd, out, sizeof out), 1);
        if (!strstr(out, bad[i].message))
            fail_msg("esr %s with %s: expected '%s' in:\n%s", cmd, bad[i].json, bad[i].message, out);
        assert_false(esr_file_exists(edit_out));
    }
    snprintf(cmd, sizeof cmd, "edit %s --mix %s/missing.json --out %s --orbit 1", run, test_tmpdir,
             edit_out);
    assert_int_equal(test_run_esr(cmd, out, sizeof out), 1);
    assert_non_null(strstr(out, "missing.json"));
    assert_false(esr_file_exists(edit_out));
    snprintf(cmd, sizeof cmd, "edit %s --mix %s --light 0 --intensity 2 --out %s", run, file,
             edit_out);
    assert_int_equal(test_run_esr(cmd, out, sizeof out), 1);
    assert_non_null(strstr(out, "--mix and --light exclude each other"));
    /* a run without lights: nothing to mix */
    char dark[4400];
    snprintf(dark, sizeof dark, "%s/run_no_lights", test_tmpdir);
    copy_run_changed(run, dark, remove_lights);
    snprintf(dst, sizeof dst, "%s/lm_dark", test_tmpdir);
    snprintf(cmd, sizeof cmd, "lightmix %s --out %s --orbit 1", dark, dst);
    assert_int_equal(test_run_esr(cmd, out, sizeof out), 1);
    assert_non_null(strstr(out, "nothing to mix"));
    assert_false(esr_file_exists(dst));
    /* output folders it must not write: inside the dataset, the run's render folder; refused
     * before the first view (no progress line) */
    const char *const inside[2] = {data_dir, run};
    const char *const sub[2] = {"lm", "render/lm"};
    const char *const says[2] = {"the dataset", "the run's render folder"};
    for (int i = 0; i < 2; i++) {
        snprintf(dst, sizeof dst, "%s/%s", inside[i], sub[i]);
        snprintf(cmd, sizeof cmd, "lightmix %s --out %s --orbit 1", run, dst);
        assert_int_equal(test_run_esr(cmd, out, sizeof out), 1);
        if (!strstr(out, says[i]) || strstr(out, "orbit_000"))
            fail_msg("esr %s: expected a refusal naming %s before rendering in:\n%s", cmd, says[i],
                     out);
        assert_false(esr_file_exists(dst));
    }
    /* a folder of someone else's files */
    snprintf(dst, sizeof dst, "%s/lm_foreign", test_tmpdir);
    snprintf(cmd, sizeof cmd, "mkdir -p %s && touch %s/notes.txt", dst, dst);
    assert_int_equal(system(cmd), 0);
    snprintf(cmd, sizeof cmd, "lightmix %s --out %s --orbit 1", run, dst);
    assert_int_equal(test_run_esr(cmd, out, sizeof out), 1);
    assert_non_null(strstr(out, "holds files that no esr lightmix wrote (notes.txt)"));
    snprintf(cmd, sizeof cmd, "lightmix %s --out %s --method finetune", run, dst);
    assert_int_equal(test_run_esr(cmd, out, sizeof out), 1);
    assert_non_null(strstr(out, "--method: expected direct or ratio"));
}

/* OpenImageIO's oiiotool reads the layers by name and sums them (unedited) and scales them (an
 * intensity-only mix): esr edit's views of the same, to 1e-4 relative. */
static void test_oiiotool_reads_the_layers(void **state)
{
    (void)state;
    need_tool("oiiotool", "openimageio-tools", "the layers were not read by an independent reader");
    char run[4300], cmd[24000], lm[4400], ed[2][4400];
    lightmix_c001("run_lightmix_oiio", "lm_oiio", run, lm);
    static const char *const edits[2] = {"--light 0 --intensity 1", "--light 0 --intensity 0.25 "
                                                                    "--light 1 --intensity 4"};
    static const char *const scales[2][2] = {{"1", "1"}, {"0.25", "4"}};
    for (int i = 0; i < 2; i++) {
        snprintf(ed[i], sizeof ed[i], "%s/edit_oiio_%d", test_tmpdir, i);
        snprintf(cmd, sizeof cmd, "edit %s %s --out %s --frames c001_on", run, edits[i], ed[i]);
        run_ok(cmd);
        char in[4500], sum[4500];
        snprintf(in, sizeof in, "%s/c001_on.exr", lm);
        snprintf(sum, sizeof sum, "%s/oiio_sum_%d.exr", test_tmpdir, i);
        snprintf(cmd, sizeof cmd,
                 "oiiotool %s --ch R=off.R,G=off.G,B=off.B "
                 "%s --ch R=light_0.R,G=light_0.G,B=light_0.B --mulc %s --add "
                 "%s --ch R=light_1.R,G=light_1.G,B=light_1.B --mulc %s --add -d float -o %s",
                 in, in, scales[i][0], in, scales[i][1], sum);
        assert_int_equal(system(cmd), 0);
        struct esr_image a, b;
        if (esr_exr_read(sum, &a) != ESR_OK)
            fail_msg("%s", esr_error_message());
        read_view(ed[i], "c001_on", &b);
        const double worst = rel_diff(&a, &b);
        print_message("oiiotool's %s of the layers differs from esr edit %s by %.3g relative\n",
                      i ? "scaled sum" : "sum", edits[i], worst);
        assert_true(worst < 1e-4);
        esr_image_free(&a), esr_image_free(&b);
    }
}

/* The page (DIR/index.html) in headless Chromium, read back as a still (tools/lightmix_page_shot.sh,
 * the stills at once): for one light off and one recoloured blue (and with ESR_PAGE_ALL_MIXES=1
 * also one x3 and all x0.5: a browser's start costs 3 s of the suite's time a still), the page's
 * image equals esr edit's PNG of the same edit given as --light/--intensity/--color to within
 * 1/255 on at least 99.9% of pixels (skipped, said so, without chromium). */
static void test_page_equals_edit(void **state)
{
    (void)state;
    need_tool("chromium", "chromium", "the page was not checked against esr edit");
    char run[4300], cmd[24000], lm[4400];
    lightmix_c001("run_lightmix_page", "lm_page", run, lm);
    static const struct {
        const char *args, *json;
    } mixes[] = {
        {"--light 0 --intensity 0", "{\"lights\":[{\"id\":0,\"intensity\":0}]}"},
        {"--light 0 --color 0.6,1", "{\"lights\":[{\"id\":0,\"hue\":0.6,\"saturation\":1}]}"},
        {"--light 1 --intensity 3", "{\"lights\":[{\"id\":1,\"intensity\":3}]}"},
        {"--light all --intensity 0.5",
         "{\"lights\":[{\"id\":0,\"intensity\":0.5},{\"id\":1,\"intensity\":0.5}]}"},
    };
    enum { ALL = sizeof mixes / sizeof mixes[0] };
    const char *all = getenv("ESR_PAGE_ALL_MIXES");
    const int N = all && !strcmp(all, "1") ? ALL : 2;
    struct esr_image edit[ALL];
    int len = 0;
    for (int i = 0; i < N; i++) {
        char ed[4400];
        snprintf(ed, sizeof ed, "%s/edit_page_%d", test_tmpdir, i);
        snprintf(cmd, sizeof cmd, "edit %s %s --out %s --frames c001_on", run, mixes[i].args, ed);
        run_ok(cmd);
        char png[4500];
        snprintf(png, sizeof png, "%s/c001_on.png", ed);
        assert_int_equal(esr_png_read(png, &edit[i]), ESR_OK);
    }
    len = snprintf(cmd, sizeof cmd, "pids=; ");
    for (int i = 0; i < N; i++) /* every still at once: a browser's start is most of its time */
        len += snprintf(cmd + len, sizeof cmd - (size_t)len,
                        "%s/../tools/lightmix_page_shot.sh %s/index.html c001_on '%s' %d %d "
                        "%s/shot_%d.png & pids=\"$pids $!\"; ", ESR_SOURCE_DIR, lm, mixes[i].json,
                        edit[i].width, edit[i].height, test_tmpdir, i);
    snprintf(cmd + len, sizeof cmd - (size_t)len,
             "fail=0; for p in $pids; do wait $p || fail=1; done; exit $fail");
    assert_int_equal(system(cmd), 0);
    for (int i = 0; i < N; i++) {
        char png[4500];
        struct esr_image shot;
        snprintf(png, sizeof png, "%s/shot_%d.png", test_tmpdir, i);
        assert_int_equal(esr_png_read(png, &shot), ESR_OK);
        assert_true(shot.width >= edit[i].width && shot.height >= edit[i].height);
        size_t off = 0, px = (size_t)edit[i].width * (size_t)edit[i].height;
        double most = 0.0;
        for (int y = 0; y < edit[i].height; y++)
            for (int x = 0; x < edit[i].width; x++) {
                int over = 0;
                for (int c = 0; c < 3; c++) {
                    const double d = fabs(shot.data[((size_t)y * shot.width + x) * shot.channels + c] -
                                          edit[i].data[((size_t)y * edit[i].width + x) * 3 + c]);
                    most = fmax(most, d * 255.0);
                    over |= d > 1.0 / 255.0 + 1e-6;
                }
                off += over;
            }
        print_message("page vs esr edit %s: %zu of %zu pixels more than 1/255 apart (at most "
                      "%.2f/255)\n", mixes[i].args, off, px, most);
        assert_true((double)off <= 0.001 * (double)px);
        esr_image_free(&shot), esr_image_free(&edit[i]);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_layers_mix_to_the_edits),
        cmocka_unit_test(test_refusals),
        cmocka_unit_test(test_oiiotool_reads_the_layers),
        cmocka_unit_test(test_page_equals_edit),
    };
    return cmocka_run_group_tests(tests, tiny_setup, test_teardown_tmpdir);
}
