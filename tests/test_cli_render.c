/* `esr render`, `esr eval` and `esr export` (and `esr bench` argument errors) end to end on a tiny synthetic dataset (esr synth,
 * 16x16) and an initialised coarse model whose SDF is a sphere. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "core/error.h"
#include "fields/sdf.h"
#include "io/dataset.h"
#include "io/file.h"
#include "io/image.h"
#include "io/ply.h"
#include "synth/synth.h"
#include "test_support.h"
#include "model/model.h"

#define RES 16
#define SPHERE_RADIUS 0.5f /* in the box normalised to [-1,1]^3 */
static char out[1 << 16];
static char ds_dir[1100], run_dir[1100];
static float box_half; /* half edge of the (cubic) scene box */

/* A coarse model at initialisation with a sphere SDF of SPHERE_RADIUS, saved as <dir>/ckpt_coarse.bin,
 * and <dir>/run.json naming the dataset. */
static void make_run(const struct esr_dataset *ds, const char *dir)
{
    struct esr_train_config cfg;
    struct esr_model m;
    char path[1300];
    esr_config_defaults(&cfg, ESR_PRESET_FAST);
    assert_int_equal(esr_config_set(&cfg, "coarse.res=24"), ESR_OK);
    assert_int_equal(esr_model_init(&m, &cfg, ESR_STAGE_COARSE, NULL, ds->bbox_min, ds->bbox_max), ESR_OK);
    assert_int_equal(esr_sdf_init_sphere(esr_model_grid(&m, ESR_COMP_SDF), esr_model_values(&m, ESR_COMP_SDF),
                                         SPHERE_RADIUS), ESR_OK);
    assert_int_equal(mkdir(dir, 0755), 0);
    snprintf(path, sizeof path, "%s/ckpt_coarse.bin", dir);
    assert_int_equal(esr_model_save(&m, path), ESR_OK);
    esr_model_free(&m);
    snprintf(path, sizeof path, "%s/run.json", dir);
    char text[1300];
    snprintf(text, sizeof text, "{\"data\": \"%s\"}", ds->root);
    assert_int_equal(test_write_file(path, text), 0);
}

/* The default scene at RES px, 1 sample per pixel, one training and one test camera, without
 * its true mesh; `seed` places the cameras. */
static int write_dataset(const char *dir, uint64_t seed)
{
    struct esr_synth_options opt;
    memset(&opt, 0, sizeof opt);
    opt.scene = "default";
    opt.res = RES;
    opt.spp = 1;
    opt.n_train = 1;
    opt.n_test = 1;
    opt.seed = seed;
    if (esr_synth_write_dataset(dir, &opt) != ESR_OK)
        return -1;
    /* without the true mesh: the Chamfer distance of the sphere model's 24^3 surface to the
     * scene (200,000 samples each way, every far query visiting most of the small mesh's
     * samples) took most of this test's time, and test_eval_evaluate scores geometry */
    char mesh[4200];
    snprintf(mesh, sizeof mesh, "%s/gt/mesh.ply", dir);
    return unlink(mesh) == 0 ? ESR_OK : -1;
}

static int setup(void **state)
{
    if (test_setup_tmpdir(state))
        return -1;
    snprintf(ds_dir, sizeof ds_dir, "%s/ds", test_tmpdir);
    if (write_dataset(ds_dir, 1) != ESR_OK)
        return -1;
    struct esr_dataset ds;
    if (esr_dataset_load(ds_dir, &ds) != ESR_OK)
        return -1;
    box_half = 0.5f * (ds.bbox_max[0] - ds.bbox_min[0]);
    snprintf(run_dir, sizeof run_dir, "%s/run", test_tmpdir);
    make_run(&ds, run_dir);
    esr_dataset_free(&ds);
    return 0;
}

static void expect_image(const char *dir, const char *file, int channels)
{
    char path[1400];
    struct esr_image img;
    snprintf(path, sizeof path, "%s/%s", dir, file);
    if (esr_image_read(path, &img) != ESR_OK)
        fail_msg("%s: %s", path, esr_error_message());
    assert_int_equal(img.width, RES);
    assert_int_equal(img.height, RES);
    assert_int_equal(img.channels, channels);
    for (size_t i = 0; i < esr_image_count(&img); i++)
        assert_true(isfinite(img.data[i]));
    esr_image_free(&img);
}

static void run_ok(const char *args)
{
    int rc = test_run_esr(args, out, sizeof out);
    if (rc != 0)
        fail_msg("esr %s exited %d:\n%s", args, rc, out);
}

static void test_render(void **state)
{
    (void)state;
    char args[3000], dir[1200];
    snprintf(args, sizeof args, "render '%s' --out '%s/r' --frames c000_on", run_dir, test_tmpdir);
    run_ok(args);
    snprintf(dir, sizeof dir, "%s/r", test_tmpdir);
    expect_image(dir, "c000_on.png", 3);
    expect_image(dir, "c000_on_linear.png", 3);
    expect_image(dir, "c000_on.exr", 4); /* RGB file, read back with A = 1 */
    expect_image(dir, "c000_on_normal.png", 3);
    expect_image(dir, "c000_on_depth.png", 1);
    expect_image(dir, "c000_on_depth.exr", 4);
    expect_image(dir, "c000_on_normal.exr", 4);
    char path[1300];
    /* N_normal.exr: composited normal (length at most the opacity) and opacity in [0,1]; the
     * sphere covers the image centre */
    struct esr_image nrm;
    snprintf(path, sizeof path, "%s/c000_on_normal.exr", dir);
    assert_int_equal(esr_exr_read(path, &nrm), ESR_OK);
    for (int i = 0; i < RES * RES; i++) {
        const float *p = nrm.data + 4 * i;
        assert_true(p[3] >= 0.0f && p[3] <= 1.0f + 1e-5f);
        assert_true(sqrtf(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]) <= p[3] + 1e-4f);
    }
    assert_true(nrm.data[4 * (RES / 2 * RES + RES / 2) + 3] > 0.5f);
    esr_image_free(&nrm);
    snprintf(path, sizeof path, "%s/c000_off.png", dir);
    assert_false(esr_file_exists(path)); /* not selected */
    snprintf(path, sizeof path, "%s/render.json", dir);
    unsigned char *text;
    size_t size;
    assert_int_equal(esr_file_read_all(path, &text, &size), ESR_OK);
    assert_non_null(strstr((char *)text, "\"coarse\""));
    assert_non_null(strstr((char *)text, "c000_on"));
    free(text);
}

static void test_eval(void **state)
{
    (void)state;
    char args[3000], path[1300];
    snprintf(args, sizeof args, "eval '%s'", run_dir);
    run_ok(args);
    assert_non_null(strstr(out, "rendering 2 of 2"));
    assert_non_null(strstr(out, "PSNR"));
    assert_non_null(strstr(out, "c000_off"));
    snprintf(path, sizeof path, "%s/eval/test_nv.json", run_dir);
    cJSON *root = test_read_json(path);
    assert_non_null(root);
    assert_int_equal(cJSON_GetArraySize(cJSON_GetObjectItem(root, "views")), 2);
    const cJSON *mean = cJSON_GetObjectItem(root, "mean");
    double psnr = cJSON_GetObjectItem(mean, "psnr")->valuedouble;
    assert_true(psnr > 0.0 && psnr < 100.0);
    assert_non_null(cJSON_GetObjectItem(cJSON_GetObjectItem(root, "by_mode"), "on"));
    /* esr synth wrote gt/c000_normal.exr: the normal error of the sphere model is there */
    const cJSON *nrm = cJSON_GetObjectItem(root, "normals");
    assert_non_null(nrm);
    assert_int_equal(cJSON_GetObjectItem(nrm, "n_views")->valueint, 2);
    double deg = cJSON_GetObjectItem(nrm, "mean_deg")->valuedouble;
    double cover = cJSON_GetObjectItem(nrm, "coverage")->valuedouble;
    print_message("sphere model vs the default scene's normals: mean %.2f deg, coverage %.3f\n", deg, cover);
    assert_true(deg > 1.0 && deg < 90.0); /* a sphere is not the scene, nor its opposite */
    assert_true(cover > 0.1 && cover <= 1.0);
    const cJSON *v0 = cJSON_GetArrayItem(cJSON_GetObjectItem(root, "views"), 0);
    assert_true(cJSON_IsNumber(cJSON_GetObjectItem(v0, "normal_deg")));
    assert_non_null(strstr(out, "normal-deg"));
    assert_non_null(strstr(out, "normals vs gt"));
    /* synth wrote the material maps too, but a coarse model renders none: skipped, saying why */
    const cJSON *mat = cJSON_GetObjectItem(root, "materials");
    assert_non_null(mat);
    assert_non_null(strstr(cJSON_GetObjectItem(mat, "skipped")->valuestring, "before the lts stage"));
    assert_non_null(strstr(out, "material maps not scored"));
    cJSON_Delete(root);
    snprintf(path, sizeof path, "%s/report.html", run_dir);
    assert_true(esr_file_exists(path));
    snprintf(path, sizeof path, "%s/eval/test_nv_gt/c000_on.png", run_dir);
    assert_true(esr_file_exists(path));
    /* same checkpoint: the renders are reused; --rerender renders again */
    run_ok(args);
    assert_null(strstr(out, "rendering"));
    snprintf(args, sizeof args, "eval '%s' --rerender --limit 1", run_dir);
    run_ok(args);
    assert_non_null(strstr(out, "rendering 1 of 1"));
    /* a render directory from before N_normal.exr existed is rendered again */
    snprintf(path, sizeof path, "%s/render/test_nv/c000_on_normal.exr", run_dir);
    assert_int_equal(remove(path), 0);
    snprintf(args, sizeof args, "eval '%s'", run_dir);
    run_ok(args);
    assert_non_null(strstr(out, "rendering 1 of 2"));
    assert_true(esr_file_exists(path));
    /* renders of other cameras are stale: a dataset whose test cameras differ (--data), then the
     * run's own again */
    char ds2[1200];
    snprintf(ds2, sizeof ds2, "%s/ds_seed2", test_tmpdir);
    assert_int_equal(write_dataset(ds2, 2), ESR_OK);
    snprintf(args, sizeof args, "eval '%s' --data '%s'", run_dir, ds2);
    run_ok(args);
    assert_non_null(strstr(out, "rendering 2 of 2"));
    snprintf(args, sizeof args, "eval '%s'", run_dir);
    run_ok(args);
    assert_non_null(strstr(out, "rendering 2 of 2"));
    /* and so are another model's at the same stage and step (a run trained again) */
    struct esr_dataset ds;
    assert_int_equal(esr_dataset_load(ds_dir, &ds), ESR_OK);
    char aside[1300];
    snprintf(aside, sizeof aside, "%s_first", run_dir);
    assert_int_equal(rename(run_dir, aside), 0);
    make_run(&ds, run_dir); /* the same sphere: the same model */
    esr_dataset_free(&ds);
    char move[4000];
    snprintf(move, sizeof move, "mv '%s/render' '%s/render' && rm -rf '%s'", aside, run_dir, aside);
    assert_int_equal(system(move), 0);
    snprintf(args, sizeof args, "eval '%s'", run_dir);
    run_ok(args);
    assert_null(strstr(out, "rendering")); /* bit for bit the model that rendered them */
    struct esr_model m;
    snprintf(path, sizeof path, "%s/ckpt_coarse.bin", run_dir);
    assert_int_equal(esr_model_load(&m, path), ESR_OK);
    assert_int_equal(esr_sdf_init_sphere(esr_model_grid(&m, ESR_COMP_SDF), esr_model_values(&m, ESR_COMP_SDF),
                                         0.8f * SPHERE_RADIUS), ESR_OK);
    assert_int_equal(esr_model_save(&m, path), ESR_OK);
    esr_model_free(&m);
    run_ok(args);
    assert_non_null(strstr(out, "rendering 2 of 2"));
    assert_int_equal(esr_model_load(&m, path), ESR_OK); /* the sphere the later tests expect */
    assert_int_equal(esr_sdf_init_sphere(esr_model_grid(&m, ESR_COMP_SDF), esr_model_values(&m, ESR_COMP_SDF),
                                         SPHERE_RADIUS), ESR_OK);
    assert_int_equal(esr_model_save(&m, path), ESR_OK);
    esr_model_free(&m);
}

/* Without a model, complete renders are evaluated as they are: ground-truth copies give the
 * PSNR cap on every view and 0 degrees normal error over every surface pixel. Without the gt/
 * folder the normal error is left out. */
static void test_eval_existing(void **state)
{
    (void)state;
    char run2[1200], dir[1300], args[3000], path[1500];
    snprintf(run2, sizeof run2, "%s/run_gt", test_tmpdir);
    snprintf(dir, sizeof dir, "%s/render/test_nv", run2);
    snprintf(args, sizeof args, "mkdir -p '%s'", dir);
    assert_int_equal(system(args), 0);
    struct esr_dataset ds;
    assert_int_equal(esr_dataset_load(ds_dir, &ds), ESR_OK);
    const struct esr_phase *ph = &ds.phases[ESR_PHASE_TEST_NV];
    static const float white[3] = {1, 1, 1};
    for (int i = 0; i < ph->n_frames; i++) {
        struct esr_image rgb, exr, exr_rgb;
        assert_int_equal(esr_frame_load_rgb(&ds, &ph->frames[i], &rgb, NULL), ESR_OK);
        snprintf(path, sizeof path, "%s/%s.png", dir, ph->frames[i].name);
        assert_int_equal(esr_png_write(path, &rgb, 8), ESR_OK);
        snprintf(path, sizeof path, "%s/%s_linear.png", dir, ph->frames[i].name);
        assert_int_equal(esr_png_write(path, &rgb, 8), ESR_OK);
        esr_frame_exr_path(&ds, &ph->frames[i], path, sizeof path);
        assert_int_equal(esr_exr_read(path, &exr), ESR_OK);
        assert_int_equal(esr_image_composite_premultiplied(&exr, white, &exr_rgb), ESR_OK);
        snprintf(path, sizeof path, "%s/%s.exr", dir, ph->frames[i].name);
        assert_int_equal(esr_exr_write(path, &exr_rgb, 0), ESR_OK);
        /* N_normal.exr from the ground-truth normals, opacity 1 on the surface: the frame's
         * camera is its name's c<CCC> */
        struct esr_image nrm;
        snprintf(path, sizeof path, "%s/gt/%.4s_normal.exr", ds_dir, ph->frames[i].name);
        assert_int_equal(esr_exr_read(path, &nrm), ESR_OK);
        for (int k = 0; k < RES * RES; k++) {
            float *p = nrm.data + 4 * k;
            p[3] = (p[0] != 0.0f || p[1] != 0.0f || p[2] != 0.0f) ? 1.0f : 0.0f;
        }
        snprintf(path, sizeof path, "%s/%s_normal.exr", dir, ph->frames[i].name);
        assert_int_equal(esr_exr_write(path, &nrm, 0), ESR_OK);
        esr_image_free(&nrm);
        esr_image_free(&rgb);
        esr_image_free(&exr);
        esr_image_free(&exr_rgb);
    }
    esr_dataset_free(&ds);
    snprintf(args, sizeof args, "eval '%s' --data '%s'", run2, ds_dir);
    run_ok(args);
    assert_non_null(strstr(out, "no loadable model"));
    snprintf(path, sizeof path, "%s/eval/test_nv.json", run2);
    cJSON *root = test_read_json(path);
    assert_non_null(root);
    const cJSON *mean = cJSON_GetObjectItem(root, "mean");
    assert_true(cJSON_GetObjectItem(mean, "psnr")->valuedouble == 100.0);
    assert_true(cJSON_GetObjectItem(mean, "psnr_linear")->valuedouble == 100.0);
    assert_true(fabs(cJSON_GetObjectItem(mean, "ssim")->valuedouble - 1.0) < 1e-6);
    assert_true(cJSON_GetObjectItem(mean, "hdr_mse")->valuedouble < 1e-12);
    const cJSON *nrm = cJSON_GetObjectItem(root, "normals");
    assert_non_null(nrm);
    assert_true(cJSON_GetObjectItem(nrm, "mean_deg")->valuedouble < 1e-3);
    assert_true(cJSON_GetObjectItem(nrm, "coverage")->valuedouble == 1.0);
    assert_true(cJSON_GetObjectItem(nrm, "frac_good")->valuedouble == 1.0);
    assert_true(cJSON_GetObjectItem(nrm, "n_gt_pixels")->valueint > 0);
    cJSON_Delete(root);
    /* a dataset without ground-truth normal maps: no "normals", a note */
    char gt[1300], gt_aside[1300];
    snprintf(gt, sizeof gt, "%s/gt", ds_dir);
    snprintf(gt_aside, sizeof gt_aside, "%s/gt_aside", ds_dir);
    assert_int_equal(rename(gt, gt_aside), 0);
    int rc = test_run_esr(args, out, sizeof out);
    assert_int_equal(rename(gt_aside, gt), 0);
    if (rc != 0)
        fail_msg("esr %s exited %d:\n%s", args, rc, out);
    assert_non_null(strstr(out, "no ground-truth normal maps"));
    assert_null(strstr(out, "normal-deg"));
    root = test_read_json(path);
    assert_non_null(root);
    assert_null(cJSON_GetObjectItem(root, "normals"));
    assert_null(cJSON_GetObjectItem(cJSON_GetArrayItem(cJSON_GetObjectItem(root, "views"), 0), "normal_deg"));
    assert_non_null(cJSON_GetObjectItem(root, "mean"));
    cJSON_Delete(root);
    /* one file missing and no model: clear error, exit 1 */
    snprintf(path, sizeof path, "%s/c000_on.exr", dir);
    assert_int_equal(remove(path), 0);
    assert_int_equal(test_run_esr(args, out, sizeof out), 1);
    assert_non_null(strstr(out, "no checkpoint"));
}

static void test_errors(void **state)
{
    (void)state;
    char args[3000];
    static const struct {
        const char *fmt, *expect;
    } cases[] = {
        {"render", "missing RUN"},
        {"render /nonexistent-run", "run directory '/nonexistent-run' does not exist"},
        {"eval /nonexistent-run", "run directory '/nonexistent-run' does not exist"},
        {"render /etc/passwd", "'/etc/passwd' is not a run directory (it is a file)"},
        {"eval '%s' --iters 5", "--iters is read only with --method finetune"},
        {"eval '%s' --limit ' 2'", "--limit must be an integer in 1.."},
        {"render '%s' --limit 0x2", "--limit must be an integer in 1.."},
        {"render '%s' --phase bogus", "unknown phase 'bogus'"},
        {"eval '%s' --phase bogus", "unknown phase 'bogus'"},
        {"render '%s' --phase test_nvi", "relight edit frames with `esr eval RUN --phase P --method"},
        {"render '%s' --frames c999_on", "no frame called 'c999_on'"},
        {"render '%s' --limit -3", "--limit must be"},
        {"render '%s' --limit 0", "--limit must be an integer in 1.."},
        {"eval '%s' --limit 0", "--limit must be an integer in 1.."},
        {"render '%s' --frames ''", "an empty list of frame names"},
        {"eval '%s' --method ratio", "--method applies to the edit phases"},
        {"eval '%s' --spp 4", "--spp applies to the edit phases"},
        {"render '%s' --data /nonexistent-data", "/nonexistent-data"},
        {"eval '%s' --wat", "unknown option"},
        {"export '%s'", "missing --mesh"},
        {"export '%s' --mesh x.ply --res 2", "--res must be"},
        {"export /nonexistent-run --mesh x.ply", "/nonexistent-run"},
        {"bench --wat", "unknown option"},
        /* refused before any measuring, not after it */
        {"bench --quick --out /proc/esr_bench.json", "cannot create a temporary file next to"},
        {"bench --quick --run /nonexistent-run", "has no pdra or lts checkpoint"},
        {"bench --quick --data /nonexistent-data", "/nonexistent-data' is not a dataset"},
        {"import dtu /nonexistent-scan --out /nonexistent-out --align-to /tmp",
         "--align-to is for 'colmap' imports (a DTU scan's cameras are known"},
        {"import dtu /nonexistent-scan --out /nonexistent-out --masks /tmp",
         "--masks is for 'colmap' imports (a DTU scan's masks are SCAN/mask/)"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        snprintf(args, sizeof args, cases[i].fmt, run_dir);
        int rc = test_run_esr(args, out, sizeof out);
        if (rc != 1 || !strstr(out, cases[i].expect))
            fail_msg("esr %s: exit %d, expected 1 and '%s' in:\n%s", args, rc, cases[i].expect, out);
    }
    /* renders into the dataset would replace its photos */
    snprintf(args, sizeof args, "render '%s' --out '%s/test_nv'", run_dir, ds_dir);
    assert_int_equal(test_run_esr(args, out, sizeof out), 1);
    assert_non_null(strstr(out, "lies inside the dataset"));
    /* a broken ground-truth image stops eval before it renders anything */
    char broken[1200], cmd[12288];
    snprintf(broken, sizeof broken, "%s/broken_data", test_tmpdir);
    snprintf(cmd, sizeof cmd, "rm -rf '%s' && cp -r '%s' '%s' && head -c 300 '%s/test_nv/c000_on.png' "
             "> '%s/t.png' && mv '%s/t.png' '%s/test_nv/c000_on.png' && rm -rf '%s/render'",
             broken, ds_dir, broken, ds_dir, broken, broken, broken, run_dir);
    assert_int_equal(system(cmd), 0);
    snprintf(args, sizeof args, "eval '%s' --data '%s' --frames c000_off,c000_on", run_dir, broken);
    assert_int_equal(test_run_esr(args, out, sizeof out), 1);
    assert_non_null(strstr(out, "c000_on.png"));
    assert_non_null(strstr(out, "truncated"));
    /* so does bench, before it measures anything (it used to find it after the kernels) */
    snprintf(args, sizeof args, "bench --quick --no-train --data '%s' --out '%s/b.json'", broken,
             test_tmpdir);
    assert_int_equal(test_run_esr(args, out, sizeof out), 1);
    assert_non_null(strstr(out, "c000_on.png"));
    assert_null(strstr(out, "MLP"));
    snprintf(cmd, sizeof cmd, "%s/render", run_dir);
    assert_false(esr_file_exists(cmd));
    /* both exports or neither: a glTF that cannot be written writes no PLY, and leaves an
     * earlier one as it was (it used to be replaced, then removed) */
    snprintf(args, sizeof args, "export '%s' --mesh '%s/both.ply' --gltf /proc/esr_cannot.glb",
             run_dir, test_tmpdir);
    assert_int_equal(test_run_esr(args, out, sizeof out), 1);
    assert_non_null(strstr(out, "/proc/esr_cannot.glb"));
    snprintf(cmd, sizeof cmd, "%s/both.ply", test_tmpdir);
    assert_false(esr_file_exists(cmd));
    assert_int_equal(test_write_file(cmd, "an earlier mesh\n"), 0);
    assert_int_equal(test_run_esr(args, out, sizeof out), 1);
    unsigned char *kept;
    size_t kept_n;
    assert_int_equal(esr_file_read_all(cmd, &kept, &kept_n), 0);
    assert_true(kept_n == 16 && !memcmp(kept, "an earlier mesh\n", 16));
    free(kept);
    assert_int_equal(test_count_names(test_tmpdir, "both.ply.tmp-"), 0);
    unlink(cmd);
    /* nor an output that would overwrite what the run is read from */
    snprintf(args, sizeof args, "export '%s' --gltf '%s/ckpt_coarse.bin'", run_dir, run_dir);
    assert_int_equal(test_run_esr(args, out, sizeof out), 1);
    assert_non_null(strstr(out, "would replace the run's own ckpt_coarse.bin"));
    snprintf(args, sizeof args, "export '%s/ckpt_coarse.bin' --mesh '%s/ckpt_coarse.bin'", run_dir, run_dir);
    assert_int_equal(test_run_esr(args, out, sizeof out), 1);
    assert_non_null(strstr(out, "is the checkpoint it would be read from"));
    snprintf(args, sizeof args, "export '%s' --mesh '%s/after.ply' --res 8", run_dir, test_tmpdir);
    assert_int_equal(test_run_esr(args, out, sizeof out), 0); /* the run still reads */
    /* nor one file for both: the glTF would replace the PLY */
    snprintf(args, sizeof args, "export '%s' --mesh '%s/both.ply' --gltf '%s/./both.ply'", run_dir,
             test_tmpdir, test_tmpdir);
    assert_int_equal(test_run_esr(args, out, sizeof out), 1);
    assert_non_null(strstr(out, "name the same file"));
    assert_false(esr_file_exists(cmd));
    /* a damaged run.json is named as such */
    char damaged[1200];
    snprintf(damaged, sizeof damaged, "%s/damaged_run", test_tmpdir);
    snprintf(cmd, sizeof cmd, "mkdir -p '%s' && printf '{\"data\": \"/x' > '%s/run.json'", damaged,
             damaged);
    assert_int_equal(system(cmd), 0);
    snprintf(args, sizeof args, "render '%s'", damaged);
    assert_int_equal(test_run_esr(args, out, sizeof out), 1);
    assert_non_null(strstr(out, "run.json is not valid JSON"));
    /* a run that does not record its dataset needs --data */
    snprintf(args, sizeof args, "eval '%s'", test_tmpdir);
    assert_int_equal(test_run_esr(args, out, sizeof out), 1);
    assert_non_null(strstr(out, "--data"));
}

/* The sphere SDF exports as a closed sphere of the right radius with outward normals. */
static void test_export(void **state)
{
    (void)state;
    char args[3000], path[1300];
    snprintf(path, sizeof path, "%s/sphere.ply", test_tmpdir);
    snprintf(args, sizeof args, "export '%s' --mesh '%s' --res 32", run_dir, path);
    run_ok(args);
    unsigned char *data;
    size_t size;
    assert_int_equal(esr_file_read_all(path, &data, &size), ESR_OK);
    assert_memory_equal(data, "ply\nformat binary_little_endian 1.0\n", 36);
    assert_non_null(strstr((char *)data, "property uchar red"));
    free(data);
    struct esr_mesh m;
    assert_int_equal(esr_ply_read(path, &m), ESR_OK);
    assert_true(m.n_vertices > 100 && m.n_triangles > 100);
    float r = SPHERE_RADIUS * box_half, voxel = 2.0f * box_half / 31.0f;
    for (size_t i = 0; i < m.n_vertices; i++) {
        const float *p = m.pos + 3 * i;
        float d = sqrtf(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
        assert_true(fabsf(d - r) < 0.1f * voxel + 0.02f * r);
    }
    esr_mesh_free(&m);
}

/* The real scene: two views evaluated at full size, with HDR MSE against its EXRs. */
static void test_lamp(void **state)
{
    (void)state;
    const char *scene = test_shared_scene("lamp");
    if (!scene)
        skip();
    struct esr_dataset ds;
    char run[1200], args[3000], path[1300];
    assert_int_equal(esr_dataset_load(scene, &ds), ESR_OK);
    snprintf(run, sizeof run, "%s/run_lamp", test_tmpdir);
    make_run(&ds, run);
    esr_dataset_free(&ds);
    snprintf(args, sizeof args, "eval '%s' --frames c003_off,c003_on", run);
    run_ok(args);
    snprintf(path, sizeof path, "%s/render/test_nv/c003_on_normal.png", run);
    struct esr_image img;
    assert_int_equal(esr_png_read(path, &img), ESR_OK);
    assert_int_equal(img.width, 160);
    esr_image_free(&img);
    snprintf(path, sizeof path, "%s/eval/test_nv.json", run);
    cJSON *root = test_read_json(path);
    assert_non_null(root);
    const cJSON *views = cJSON_GetObjectItem(root, "views");
    assert_int_equal(cJSON_GetArraySize(views), 2);
    for (int i = 0; i < 2; i++) {
        const cJSON *hdr = cJSON_GetObjectItem(cJSON_GetArrayItem(views, i), "hdr_mse");
        assert_true(cJSON_IsNumber(hdr) && hdr->valuedouble > 0.0);
    }
    assert_null(cJSON_GetObjectItem(root, "normals")); /* the lamp scene has no gt/ maps */
    cJSON_Delete(root);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_render), cmocka_unit_test(test_eval),   cmocka_unit_test(test_eval_existing),
        cmocka_unit_test(test_errors), cmocka_unit_test(test_export),        cmocka_unit_test(test_lamp),
    };
    return cmocka_run_group_tests(tests, setup, test_teardown_tmpdir);
}
