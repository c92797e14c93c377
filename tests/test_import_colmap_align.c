/* COLMAP against known cameras: a small `esr synth` dataset's true train cameras written as a
 * COLMAP model in another world (a known similarity away), then esr_colmap_align must find the
 * inverse similarity with zero camera errors, report a camera turned about its centre by exactly
 * its angle, and refuse photos named unlike the true frames; `esr import colmap --align-to` end
 * to end: the import lands in the true world (cameras equal to the true ones), in the true
 * pinhole, with the true test views copied, and a model shifted by a known error is reported. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include <cjson/cJSON.h>

#include "core/error.h"
#include "core/similarity.h"
#include "import/colmap.h"
#include "import/colmap_align.h"
#include "io/dataset.h"
#include "io/file.h"
#include "test_support.h"

#define PI 3.14159265358979323846

/* The COLMAP world = scale * R * (true world) + t. */
static const double world_scale = 0.37, world_t[3] = {5.0, -2.0, 11.0};
static double world_r[3][3];
static char truth_dir[1200];

static int setup(void **state)
{
    ESR_TRY(test_setup_tmpdir(state));
    const double q[4] = {0.3, -0.5, 0.7, 0.2};
    esr_quaternion_to_rotation(q, world_r);
    snprintf(truth_dir, sizeof truth_dir, "%s/truth", test_tmpdir);
    return test_synth_small(truth_dir) == 0 ? 0 : -1;
}

static void no_problem(void *user, const char *message)
{
    (void)user;
    fail_msg("dataset check: %s", message);
}

/* The COLMAP pose of true frame f moved into the COLMAP world; `turn_deg` turns the camera about
 * its own x axis and `shift` moves its centre (true-world units) to plant a known error. COLMAP:
 * x_cam = R x_world + t with R = diag(1, -1, -1) (c2w rotation)^T, t = -R centre. */
static void colmap_pose(const struct esr_frame *f, double turn_deg, double shift, struct esr_colmap_image *im)
{
    double c2w[3][3], turned[3][3], centre[3], h = turn_deg * PI / 180.0;
    const double turn[3][3] = {{1, 0, 0}, {0, cos(h), -sin(h)}, {0, sin(h), cos(h)}};
    for (int a = 0; a < 3; a++) {
        double c = f->camera.c2w[a][3] + (a == 2 ? shift : 0.0);
        for (int b = 0; b < 3; b++)
            turned[a][b] = f->camera.c2w[a][0] * turn[0][b] + f->camera.c2w[a][1] * turn[1][b] +
                           f->camera.c2w[a][2] * turn[2][b];
        centre[a] = c;
    }
    double moved[3];
    for (int a = 0; a < 3; a++) {
        moved[a] = world_t[a];
        for (int b = 0; b < 3; b++) {
            moved[a] += world_scale * world_r[a][b] * centre[b];
            c2w[a][b] = world_r[a][0] * turned[0][b] + world_r[a][1] * turned[1][b] + world_r[a][2] * turned[2][b];
        }
    }
    double r[3][3];
    for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++)
            r[a][b] = (a == 0 ? 1.0 : -1.0) * c2w[b][a];
    test_rotation_to_quaternion(r, im->q);
    for (int a = 0; a < 3; a++)
        im->t[a] = -(r[a][0] * moved[0] + r[a][1] * moved[1] + r[a][2] * moved[2]);
}

/* A model of the true train cameras (frame `odd` turned by turn_deg and shifted by shift), its
 * photos named off/<name>.png or on/<name>.png after the true frames (unless `rename`). */
static void make_model(const struct esr_dataset *truth, int odd, double turn_deg, double shift, int rename,
                       struct esr_colmap_model *m)
{
    const struct esr_phase *train = &truth->phases[ESR_PHASE_TRAIN];
    static struct esr_colmap_camera cam;
    cam = (struct esr_colmap_camera){.id = 1, .model = ESR_COLMAP_SIMPLE_PINHOLE, .width = truth->width,
                                     .height = truth->height,
                                     .params = {truth->focal, 0.5 * truth->width, 0.5 * truth->height}};
    memset(m, 0, sizeof *m);
    m->n_cameras = 1;
    m->cameras = &cam;
    m->n_images = train->n_frames;
    m->images = calloc((size_t)train->n_frames, sizeof *m->images);
    assert_non_null(m->images);
    m->format = "text";
    for (int i = 0; i < train->n_frames; i++) {
        const struct esr_frame *f = &train->frames[i];
        struct esr_colmap_image *im = &m->images[i];
        im->id = (uint32_t)i + 1;
        im->camera_id = 1;
        colmap_pose(f, i == odd ? turn_deg : 0.0, i == odd ? shift : 0.0, im);
        snprintf(im->name, sizeof im->name, "%s/%s%s.png", f->lights_on ? "on" : "off", rename && i == 2 ? "x" : "",
                 f->name);
    }
}

static void write_model_text(const char *dir, const struct esr_colmap_model *m)
{
    char path[1500];
    mkdir(dir, 0755);
    snprintf(path, sizeof path, "%s/cameras.txt", dir);
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    const struct esr_colmap_camera *c = &m->cameras[0];
    fprintf(f, "1 SIMPLE_PINHOLE %d %d %.17g %.17g %.17g\n", c->width, c->height, c->params[0], c->params[1],
            c->params[2]);
    fclose(f);
    snprintf(path, sizeof path, "%s/images.txt", dir);
    f = fopen(path, "w");
    assert_non_null(f);
    for (int i = 0; i < m->n_images; i++) {
        const struct esr_colmap_image *im = &m->images[i];
        fprintf(f, "%u %.17g %.17g %.17g %.17g %.17g %.17g %.17g 1 %s\n\n", im->id, im->q[0], im->q[1], im->q[2],
                im->q[3], im->t[0], im->t[1], im->t[2], im->name);
    }
    fclose(f);
    snprintf(path, sizeof path, "%s/points3D.txt", dir);
    assert_int_equal(test_write_file(path, "# no points\n"), 0);
}

/* The true train images copied as the capture's photos (IMAGES/off, IMAGES/on). */
static void copy_photos(const struct esr_dataset *truth, const struct esr_colmap_model *m, const char *images)
{
    char path[2048], src[2400];
    snprintf(path, sizeof path, "%s", images), mkdir(path, 0755);
    snprintf(path, sizeof path, "%s/off", images), mkdir(path, 0755);
    snprintf(path, sizeof path, "%s/on", images), mkdir(path, 0755);
    for (int i = 0; i < m->n_images; i++) {
        esr_frame_image_path(truth, &truth->phases[ESR_PHASE_TRAIN].frames[i], src, sizeof src);
        snprintf(path, sizeof path, "%s/%s", images, m->images[i].name);
        unsigned char *data;
        size_t size;
        assert_int_equal(esr_file_read_all(src, &data, &size), ESR_OK);
        FILE *f = fopen(path, "wb");
        assert_non_null(f);
        assert_int_equal(fwrite(data, 1, size, f), size);
        fclose(f);
        free(data);
    }
}

static void test_align_recovers_inverse_and_errors(void **state)
{
    (void)state;
    struct esr_dataset truth;
    assert_int_equal(esr_dataset_load(truth_dir, &truth), ESR_OK);
    struct esr_colmap_model m;
    struct esr_colmap_alignment a;
    /* exact cameras: the inverse of the world change, no error */
    make_model(&truth, -1, 0.0, 0.0, 0, &m);
    assert_int_equal(esr_colmap_align(&m, &truth, &a), ESR_OK);
    assert_int_equal(a.n_matched, truth.phases[ESR_PHASE_TRAIN].n_frames);
    assert_int_equal(a.n_registered, a.n_matched);
    assert_true(fabs(a.colmap_to_true.scale - 1.0 / world_scale) < 1e-5);
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            assert_true(fabs(a.colmap_to_true.rotation[i][j] - world_r[j][i]) < 1e-6);
    assert_true(a.rot_max_deg < 1e-4 && a.pos_max < 1e-5);
    /* the scene radius: half the largest side of scene.json's tight box */
    char path[1400];
    snprintf(path, sizeof path, "%s/scene.json", truth_dir);
    cJSON *scene = test_read_json(path);
    assert_non_null(scene);
    const cJSON *box = cJSON_GetObjectItem(scene, "bounding_box");
    double half = 0.0;
    for (int k = 0; k < 3; k++)
        half = fmax(half, 0.5 * (cJSON_GetArrayItem(cJSON_GetObjectItem(box, "tight_max"), k)->valuedouble -
                                 cJSON_GetArrayItem(cJSON_GetObjectItem(box, "tight_min"), k)->valuedouble));
    cJSON_Delete(scene);
    assert_true(half > 0.5 && fabs(a.scene_radius - half) < 1e-9);
    free(m.images);
    /* one camera turned about its own centre: the fit (on centres) is unchanged, that camera's
     * error is the turn, the median stays 0 */
    make_model(&truth, 3, 2.0, 0.0, 0, &m);
    assert_int_equal(esr_colmap_align(&m, &truth, &a), ESR_OK);
    assert_true(fabs(a.rot_max_deg - 2.0) < 1e-4);
    assert_true(a.rot_median_deg < 1e-4 && a.pos_max < 1e-5);
    free(m.images);
    assert_int_equal(a.n_inliers, a.n_matched);
    /* one camera moved 0.4 along z: an outlier the robust fit leaves out (a plain least-squares
     * fit would spread it over all), so it alone carries the whole error */
    make_model(&truth, 3, 0.0, 0.4, 0, &m);
    assert_int_equal(esr_colmap_align(&m, &truth, &a), ESR_OK);
    assert_int_equal(a.n_inliers, a.n_matched - 1);
    assert_true(fabs(a.pos_max - 0.4) < 1e-4 && a.pos_median < 1e-5 && a.pos_max_inliers < 1e-5);
    assert_true(a.rot_max_inliers_deg < 1e-4);
    assert_true(fabs(a.pos_max_rel - a.pos_max / a.scene_radius) < 1e-12);
    free(m.images);
    /* a photo named unlike every true frame */
    make_model(&truth, -1, 0.0, 0.0, 1, &m);
    esr_error_clear();
    assert_int_equal(esr_colmap_align(&m, &truth, &a), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "has no train frame of that name"));
    esr_error_clear();
    free(m.images);
    esr_dataset_free(&truth);
}

/* `esr import colmap --align-to` on the exact model: every train camera back to the truth, the
 * true pinhole and the true test views; import.json's alignment. */
static void test_import_align_to_end_to_end(void **state)
{
    (void)state;
    struct esr_dataset truth;
    assert_int_equal(esr_dataset_load(truth_dir, &truth), ESR_OK);
    struct esr_colmap_model m;
    make_model(&truth, 1, 0.5, 0.0, 0, &m);
    char root[1300], sparse[1400], images[1400], data[1400], args[6000], out[8192];
    snprintf(root, sizeof root, "%s/capture", test_tmpdir);
    mkdir(root, 0755);
    snprintf(sparse, sizeof sparse, "%s/sparse", root);
    snprintf(images, sizeof images, "%s/images", root);
    snprintf(data, sizeof data, "%s/data", root);
    write_model_text(sparse, &m);
    copy_photos(&truth, &m, images);
    snprintf(args, sizeof args, "import colmap '%s' '%s' --out '%s' --align-to '%s'", sparse, images, data, truth_dir);
    int rc = test_run_esr(args, out, sizeof out);
    if (rc != 0)
        fail_msg("esr import --align-to failed (%d): %s", rc, out);
    assert_non_null(strstr(out, "rotation  error median 0.0000 deg, max 0.5000 deg"));
    struct esr_dataset ds;
    assert_int_equal(esr_dataset_load(data, &ds), ESR_OK);
    assert_int_equal(ds.width, truth.width);
    assert_int_equal(ds.height, truth.height);
    assert_true(ds.camera_angle_x == truth.camera_angle_x);
    const struct esr_phase *train = &ds.phases[ESR_PHASE_TRAIN], *true_train = &truth.phases[ESR_PHASE_TRAIN];
    assert_int_equal(train->n_frames, true_train->n_frames);
    for (int i = 0; i < train->n_frames; i++) { /* "r_003_off" <- "r_003" */
        const struct esr_frame *f = &train->frames[i], *t = NULL;
        for (int j = 0; j < true_train->n_frames; j++)
            if (!strncmp(f->name, true_train->frames[j].name, strlen(true_train->frames[j].name)))
                t = &true_train->frames[j];
        assert_non_null(t);
        assert_int_equal(f->lights_on, t->lights_on);
        for (int a = 0; a < 3; a++)
            assert_true(fabsf(f->camera.c2w[a][3] - t->camera.c2w[a][3]) < 1e-4f);
    }
    /* the test views are the true ones, files and cameras */
    const struct esr_phase *nv = &ds.phases[ESR_PHASE_TEST_NV], *true_nv = &truth.phases[ESR_PHASE_TEST_NV];
    assert_true(nv->present);
    assert_int_equal(nv->n_frames, true_nv->n_frames);
    for (int i = 0; i < nv->n_frames; i++) {
        char a[2400], b[2400];
        assert_string_equal(nv->frames[i].file_path, true_nv->frames[i].file_path);
        assert_int_equal(nv->frames[i].lights_on, true_nv->frames[i].lights_on);
        assert_memory_equal(nv->frames[i].camera.c2w, true_nv->frames[i].camera.c2w, sizeof nv->frames[i].camera.c2w);
        esr_frame_image_path(&ds, &nv->frames[i], a, sizeof a);
        esr_frame_image_path(&truth, &true_nv->frames[i], b, sizeof b);
        assert_true(test_files_equal(a, b));
        esr_frame_exr_path(&ds, &nv->frames[i], a, sizeof a);
        esr_frame_exr_path(&truth, &true_nv->frames[i], b, sizeof b);
        assert_true(test_files_equal(a, b));
    }
    snprintf(args, sizeof args, "%s/import.json", data);
    cJSON *rec = test_read_json(args);
    assert_non_null(rec);
    const cJSON *al = cJSON_GetObjectItem(rec, "alignment");
    assert_non_null(al);
    assert_string_equal(cJSON_GetObjectItem(rec, "placed_by")->valuestring, "alignment");
    assert_true(fabs(cJSON_GetObjectItem(al, "rotation_error_max_deg")->valuedouble - 0.5) < 1e-4);
    assert_int_equal(cJSON_GetObjectItem(al, "matched_images")->valueint, true_train->n_frames);
    assert_int_equal(cJSON_GetObjectItem(al, "test_views")->valueint, true_nv->n_frames);
    cJSON_Delete(rec);
    assert_int_equal(esr_dataset_check(&ds, no_problem, NULL), 0);
    esr_dataset_free(&ds);
    /* --size has no meaning with --align-to */
    snprintf(args, sizeof args, "import colmap '%s' '%s' --out '%s/b' --align-to '%s' --size 64", sparse, images, root,
             truth_dir);
    assert_int_equal(test_run_esr(args, out, sizeof out), 1);
    assert_non_null(strstr(out, "exclude each other"));
    free(m.images);
    esr_dataset_free(&truth);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_align_recovers_inverse_and_errors),
        cmocka_unit_test(test_import_align_to_end_to_end),
    };
    return cmocka_run_group_tests(tests, setup, test_teardown_tmpdir);
}
