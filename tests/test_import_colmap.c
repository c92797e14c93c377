/* COLMAP input: every camera model's projection against values computed independently, the
 * distortion's inverse, the pose conversion to esr's cameras, the text and binary readers on
 * models written here (binary with fwrite), bad models, JPEG decoding with EXIF orientation
 * (encoded here with libjpeg), undistortion and area downscaling, and `esr import colmap` end to
 * end on a small synthetic capture whose output loads with esr's dataset loader. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <dirent.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cjson/cJSON.h>
#include <jpeglib.h>

#include "core/error.h"
#include "io/camera.h"
#include "import/colmap.h"
#include "import/colmap_camera.h"
#include "import/colmap_scene.h"
#include "import/colmap_undistort.h"
#include "io/dataset.h"
#include "io/exif.h"
#include "io/exif_exposure.h"
#include "io/image.h"
#include "io/file.h"
#include "test_support.h"

/* ---- fixtures: models, JPEGs, poses ---- */

static void put_bytes(FILE *f, uint64_t v, int n)
{
    for (int i = 0; i < n; i++)
        fputc((int)(v >> (8 * i) & 0xff), f);
}

static void put_f64(FILE *f, double d)
{
    uint64_t bits;
    memcpy(&bits, &d, sizeof bits);
    put_bytes(f, bits, 8);
}

static FILE *open_in(const char *dir, const char *name)
{
    char path[1400];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    return f;
}

/* Cameras whose model is >= ESR_COLMAP_MODEL_COUNT stand for a model esr does not support:
 * written as that number (binary) or as OPENCV_FISHEYE (text), 8 parameters. */
static int n_params_written(const struct esr_colmap_camera *c)
{
    return c->model < ESR_COLMAP_MODEL_COUNT ? esr_colmap_model_n_params(c->model) : 8;
}

static void write_binary(const char *dir, const struct esr_colmap_model *m)
{
    FILE *f = open_in(dir, "cameras.bin");
    put_bytes(f, (uint64_t)m->n_cameras, 8);
    for (int i = 0; i < m->n_cameras; i++) {
        const struct esr_colmap_camera *c = &m->cameras[i];
        put_bytes(f, c->id, 4);
        put_bytes(f, (uint64_t)c->model, 4);
        put_bytes(f, (uint64_t)c->width, 8);
        put_bytes(f, (uint64_t)c->height, 8);
        for (int k = 0; k < n_params_written(c); k++)
            put_f64(f, c->params[k]);
    }
    fclose(f);
    f = open_in(dir, "images.bin");
    put_bytes(f, (uint64_t)m->n_images, 8);
    for (int i = 0; i < m->n_images; i++) {
        const struct esr_colmap_image *im = &m->images[i];
        put_bytes(f, im->id, 4);
        for (int k = 0; k < 4; k++)
            put_f64(f, im->q[k]);
        for (int k = 0; k < 3; k++)
            put_f64(f, im->t[k]);
        put_bytes(f, im->camera_id, 4);
        fwrite(im->name, 1, strlen(im->name) + 1, f);
        put_bytes(f, 2, 8); /* two keypoints, one without a 3D point */
        put_f64(f, 10.5), put_f64(f, 20.25), put_bytes(f, 7, 8);
        put_f64(f, 1.0), put_f64(f, 2.0), put_bytes(f, UINT64_MAX, 8);
    }
    fclose(f);
    f = open_in(dir, "points3D.bin");
    put_bytes(f, (uint64_t)m->n_points, 8);
    for (long i = 0; i < m->n_points; i++) {
        put_bytes(f, (uint64_t)i + 1, 8);
        for (int k = 0; k < 3; k++)
            put_f64(f, m->points[3 * i + k]);
        put_bytes(f, 0x102030, 3);
        put_f64(f, 0.5);
        put_bytes(f, 2, 8);
        put_bytes(f, 1, 4), put_bytes(f, 0, 4), put_bytes(f, 2, 4), put_bytes(f, 1, 4);
    }
    fclose(f);
}

static void write_text(const char *dir, const struct esr_colmap_model *m)
{
    FILE *f = open_in(dir, "cameras.txt");
    fprintf(f, "# Camera list with one line of data per camera:\n#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n");
    for (int i = 0; i < m->n_cameras; i++) {
        const struct esr_colmap_camera *c = &m->cameras[i];
        fprintf(f, "%u %s %d %d", c->id, c->model < ESR_COLMAP_MODEL_COUNT ? esr_colmap_model_name(c->model) : "OPENCV_FISHEYE",
                c->width, c->height);
        for (int k = 0; k < n_params_written(c); k++)
            fprintf(f, " %.17g", c->params[k]);
        fprintf(f, "\n");
    }
    fclose(f);
    f = open_in(dir, "images.txt");
    fprintf(f, "# Image list with two lines of data per image:\n\n");
    for (int i = 0; i < m->n_images; i++) {
        const struct esr_colmap_image *im = &m->images[i];
        fprintf(f, "%u %.17g %.17g %.17g %.17g %.17g %.17g %.17g %u %s\r\n", im->id, im->q[0], im->q[1], im->q[2],
                im->q[3], im->t[0], im->t[1], im->t[2], im->camera_id, im->name);
        /* an image without keypoints has an empty second line, which must not be skipped */
        fprintf(f, "%s\n", i % 2 ? "" : "10.5 20.25 7 1 2 -1");
    }
    fclose(f);
    f = open_in(dir, "points3D.txt");
    fprintf(f, "# 3D point list\n");
    for (long i = 0; i < m->n_points; i++)
        fprintf(f, "%ld %.17g %.17g %.17g 16 32 48 0.5 1 0 2 1\n", i + 1, m->points[3 * i], m->points[3 * i + 1],
                m->points[3 * i + 2]);
    fclose(f);
}

static void write_model(const char *dir, const struct esr_colmap_model *m, int text)
{
    mkdir(dir, 0755);
    if (text)
        write_text(dir, m);
    else
        write_binary(dir, m);
}

/* An EXIF APP1 payload whose IFD0 holds only the orientation tag. */
static size_t exif_payload(unsigned char *b, int orientation, int big)
{
    static const unsigned char le[] = {'I', 'I', 42, 0, 8, 0, 0, 0, 1, 0, 0x12, 0x01, 3, 0, 1, 0, 0, 0};
    static const unsigned char be[] = {'M', 'M', 0, 42, 0, 0, 0, 8, 0, 1, 0x01, 0x12, 0, 3, 0, 0, 0, 1};
    memcpy(b, "Exif\0\0", 6);
    memcpy(b + 6, big ? be : le, sizeof le);
    unsigned char *value = b + 6 + sizeof le;
    value[0] = big ? 0 : (unsigned char)orientation;
    value[1] = big ? (unsigned char)orientation : 0;
    memset(value + 2, 0, 6); /* padding of the value field, next-IFD offset 0 */
    return 6 + sizeof le + 8;
}

/* img (1 or 3 channels) as a quality-100 JPEG; orientation 1..8 adds an EXIF segment, or app1
 * (app1_size bytes, when not NULL) is the EXIF segment. */
static void write_jpeg_app1(const char *path, const struct esr_image *img, int orientation, int big_endian,
                            const unsigned char *app1, size_t app1_size)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    struct jpeg_compress_struct c;
    struct jpeg_error_mgr err;
    c.err = jpeg_std_error(&err);
    jpeg_create_compress(&c);
    jpeg_stdio_dest(&c, f);
    c.image_width = (JDIMENSION)img->width;
    c.image_height = (JDIMENSION)img->height;
    c.input_components = img->channels;
    c.in_color_space = img->channels == 1 ? JCS_GRAYSCALE : JCS_RGB;
    jpeg_set_defaults(&c);
    jpeg_set_quality(&c, 100, TRUE);
    for (int i = 0; i < c.num_components; i++) /* no chroma subsampling: flat blocks stay exact */
        c.comp_info[i].h_samp_factor = c.comp_info[i].v_samp_factor = 1;
    jpeg_start_compress(&c, TRUE);
    if (app1)
        jpeg_write_marker(&c, JPEG_APP0 + 1, app1, (unsigned)app1_size);
    else if (orientation) {
        unsigned char seg[64];
        jpeg_write_marker(&c, JPEG_APP0 + 1, seg, (unsigned)exif_payload(seg, orientation, big_endian));
    }
    JSAMPLE *row = malloc((size_t)img->width * (size_t)img->channels);
    while (c.next_scanline < c.image_height) {
        const float *src = img->data + (size_t)c.next_scanline * (size_t)img->width * (size_t)img->channels;
        for (int i = 0; i < img->width * img->channels; i++)
            row[i] = (JSAMPLE)lroundf(fminf(fmaxf(src[i], 0.0f), 1.0f) * 255.0f);
        jpeg_write_scanlines(&c, &row, 1);
    }
    jpeg_finish_compress(&c);
    jpeg_destroy_compress(&c);
    free(row);
    fclose(f);
}

static void write_jpeg(const char *path, const struct esr_image *img, int orientation, int big_endian)
{
    write_jpeg_app1(path, img, orientation, big_endian, NULL, 0);
}

static void cross(const double a[3], const double b[3], double out[3])
{
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

static void normalise(double v[3])
{
    double n = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    for (int k = 0; k < 3; k++)
        v[k] /= n;
}

/* COLMAP pose of a camera at centre looking at target, image-down along -up: rows of R are
 * the camera's x (right), y (down), z (forward) axes in the world. */
static void look_at(const double centre[3], const double target[3], const double up[3], double q[4], double t[3])
{
    double z[3] = {target[0] - centre[0], target[1] - centre[1], target[2] - centre[2]}, down[3] = {-up[0], -up[1], -up[2]};
    double x[3], y[3];
    normalise(z);
    cross(down, z, x); /* y cross z = x */
    normalise(x);
    cross(z, x, y);
    double r[3][3] = {{x[0], x[1], x[2]}, {y[0], y[1], y[2]}, {z[0], z[1], z[2]}};
    test_rotation_to_quaternion(r, q);
    for (int i = 0; i < 3; i++)
        t[i] = -(r[i][0] * centre[0] + r[i][1] * centre[1] + r[i][2] * centre[2]);
}

/* ---- camera models and poses ---- */

/* The pose and point the expected pixels below were computed for. */
static const double pose_q[4] = {0.9, 0.1, -0.2, 0.3}, pose_t[3] = {0.1, -0.2, 3.0}, pose_x[3] = {1.5, -1.2, 0.5};

static void test_camera_model_projections(void **state)
{
    (void)state;
    /* Expected pixels computed with python3 by COLMAP's formulas, independently of esr: R from the
     * normalised Hamilton quaternion, c = R X + t, u = c_x / c_z, v = c_y / c_z, r2 = u^2 + v^2,
     * radial = k1 r2 + k2 r2^2, ud = u + u radial + 2 p1 u v + p2 (r2 + 2 u^2),
     * vd = v + v radial + 2 p2 u v + p1 (r2 + 2 v^2), pixel = (fx ud + cx, fy vd + cy). */
    static const struct {
        enum esr_colmap_model_id model;
        double params[8];
        double px, py;
    } cases[] = {
        {ESR_COLMAP_SIMPLE_PINHOLE, {500, 320, 240}, 538.6277067571, 176.0813983825},
        {ESR_COLMAP_PINHOLE, {500, 520, 320, 240}, 538.6277067571, 173.5246543178},
        {ESR_COLMAP_SIMPLE_RADIAL, {500, 320, 240, -0.12}, 533.1829678789, 177.6732373146},
        {ESR_COLMAP_RADIAL, {500, 320, 240, -0.12, 0.03}, 533.4654608694, 177.5906468819},
        {ESR_COLMAP_OPENCV, {500, 520, 320, 240, -0.12, 0.03, 0.001, -0.002}, 532.8196441198, 175.3354536373},
    };
    struct esr_colmap_image im = {.id = 1, .camera_id = 1};
    memcpy(im.q, pose_q, sizeof im.q);
    memcpy(im.t, pose_t, sizeof im.t);
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        struct esr_colmap_camera cam = {.id = 1, .model = cases[i].model, .width = 640, .height = 480};
        memcpy(cam.params, cases[i].params, sizeof cam.params);
        double px, py;
        assert_true(esr_colmap_project(&cam, &im, pose_x, &px, &py));
        assert_true(fabs(px - cases[i].px) < 1e-8);
        assert_true(fabs(py - cases[i].py) < 1e-8);
    }
}

static void test_undistort_inverts_distortion(void **state)
{
    (void)state;
    struct esr_colmap_camera cam = {.model = ESR_COLMAP_OPENCV, .params = {500, 520, 320, 240, -0.2, 0.05, 0.003, -0.002}};
    struct esr_colmap_intrinsics k;
    esr_colmap_intrinsics_of(&cam, &k);
    for (double u = -0.6; u <= 0.6; u += 0.1)
        for (double v = -0.45; v <= 0.45; v += 0.15) {
            double ud, vd, u2, v2;
            esr_colmap_distort(&k, u, v, &ud, &vd);
            assert_int_equal(esr_colmap_undistort(&k, ud, vd, &u2, &v2), ESR_OK);
            assert_true(fabs(u2 - u) < 1e-9 && fabs(v2 - v) < 1e-9);
        }
    /* beyond the fold of a strong barrel distortion (ud = u (1 - r^2) peaks at r = 0.577 with
     * 0.385) no undistorted point exists */
    struct esr_colmap_intrinsics barrel = {.fx = 1, .fy = 1, .k1 = -1.0};
    double u, v;
    assert_int_equal(esr_colmap_undistort(&barrel, 0.5, 0.0, &u, &v), ESR_ERR);
}

/* A pinhole COLMAP camera and esr's camera built from the converted pose see a point at the
 * same pixel; behind-camera agrees; the centre is -R^T t. */
static void test_pose_conversion_round_trip(void **state)
{
    (void)state;
    struct esr_colmap_camera cam = {.id = 1, .model = ESR_COLMAP_PINHOLE, .width = 640, .height = 480,
                                    .params = {500, 500, 320, 240}};
    struct esr_colmap_image im = {.id = 1, .camera_id = 1};
    memcpy(im.q, pose_q, sizeof im.q);
    memcpy(im.t, pose_t, sizeof im.t);
    double c2w[3][4];
    esr_colmap_camera_to_world(&im, c2w);
    struct esr_camera e = {.width = 640, .height = 480, .focal = 500.0f};
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 4; c++)
            e.c2w[r][c] = (float)c2w[r][c];
    /* centre by python3 (-R^T t for the same pose) */
    assert_true(fabs(c2w[0][3] - -1.2936842105263158) < 1e-12);
    assert_true(fabs(c2w[1][3] - 0.029473684210526263) < 1e-12);
    assert_true(fabs(c2w[2][3] - -2.7157894736842105) < 1e-12);
    const double points[3][3] = {{1.5, -1.2, 0.5}, {0.3, -0.4, 0.5}, {-0.7, 0.9, 1.1}};
    for (int i = 0; i < 3; i++) {
        double px, py;
        float fp[3] = {(float)points[i][0], (float)points[i][1], (float)points[i][2]}, ex, ey;
        assert_true(esr_colmap_project(&cam, &im, points[i], &px, &py));
        assert_true(esr_camera_project(&e, fp, &ex, &ey));
        assert_true(fabs(px - ex) < 2e-3 && fabs(py - ey) < 2e-3);
        /* and the ray through that pixel passes through the point */
        float o[3], d[3];
        esr_camera_ray(&e, ex, ey, o, d);
        double v[3] = {fp[0] - o[0], fp[1] - o[1], fp[2] - o[2]}, along = v[0] * d[0] + v[1] * d[1] + v[2] * d[2];
        assert_true(along > 0.0);
        for (int k = 0; k < 3; k++)
            assert_true(fabs(v[k] - along * d[k]) < 1e-4);
    }
    /* a point behind the camera: the centre minus the viewing direction (esr's +Z column) */
    double behind[3];
    float fb[3], ex, ey;
    for (int k = 0; k < 3; k++)
        fb[k] = (float)(behind[k] = c2w[k][3] + c2w[k][2]);
    double px, py;
    assert_false(esr_colmap_project(&cam, &im, behind, &px, &py));
    assert_false(esr_camera_project(&e, fb, &ex, &ey));
}

/* Cameras whose distance from the centre overflows (finite positions near 1e308) gave scale 0,
 * which put every camera at the centre; now the placement is refused. */
static void test_scene_placement_needs_a_scale(void **state)
{
    (void)state;
    double c2w[2][3][4] = {{{1, 0, 0, 4}, {0, 1, 0, 0}, {0, 0, 1, 0}}, {{1, 0, 0, 0}, {0, 1, 0, 4}, {0, 0, 1, 0}}};
    struct esr_scene_frame f = {.centre = {0, 0, 0}, .radius = 0.5};
    assert_int_equal(esr_scene_frame_place((const double (*)[3][4])c2w, 2, &f), ESR_OK);
    assert_true(f.scale == 1.0); /* min(1 / 0.5, 4 / 4) */
    c2w[0][0][3] = 1e308, c2w[1][1][3] = -1e308;
    esr_error_clear();
    assert_int_equal(esr_scene_frame_place((const double (*)[3][4])c2w, 2, &f), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "give no usable scale"));
    esr_error_clear();
}

/* ---- readers ---- */

/* Two cameras (one OPENCV), three images, four points. */
static void small_model(struct esr_colmap_model *m, struct esr_colmap_camera cams[2], struct esr_colmap_image ims[3],
                        double pts[12])
{
    memset(m, 0, sizeof *m);
    memset(cams, 0, 2 * sizeof *cams);
    memset(ims, 0, 3 * sizeof *ims);
    cams[0] = (struct esr_colmap_camera){.id = 3, .model = ESR_COLMAP_SIMPLE_RADIAL, .width = 64, .height = 48,
                                         .params = {60, 32, 24, -0.05}};
    cams[1] = (struct esr_colmap_camera){.id = 9, .model = ESR_COLMAP_OPENCV, .width = 64, .height = 48,
                                         .params = {61, 59, 31, 25, -0.04, 0.01, 0.001, -0.001}};
    for (int i = 0; i < 3; i++) {
        ims[i].id = (uint32_t)(10 + i);
        ims[i].camera_id = i == 2 ? 9 : 3;
        ims[i].q[0] = 0.8, ims[i].q[1] = 0.1 * i, ims[i].q[2] = -0.3, ims[i].q[3] = 0.2;
        ims[i].t[0] = 0.5, ims[i].t[1] = -0.25 * i, ims[i].t[2] = 4.0;
        snprintf(ims[i].name, sizeof ims[i].name, "%s/p%d.jpg", i ? "on" : "off", i);
    }
    for (int i = 0; i < 12; i++)
        pts[i] = 0.125 * i - 0.5;
    m->cameras = cams, m->n_cameras = 2;
    m->images = ims, m->n_images = 3;
    m->points = pts, m->n_points = 4;
}

static void assert_same_model(const struct esr_colmap_model *a, const struct esr_colmap_model *b)
{
    assert_int_equal(a->n_cameras, b->n_cameras);
    assert_int_equal(a->n_images, b->n_images);
    assert_int_equal(a->n_points, b->n_points);
    for (int i = 0; i < a->n_cameras; i++) {
        assert_int_equal(a->cameras[i].id, b->cameras[i].id);
        assert_int_equal(a->cameras[i].model, b->cameras[i].model);
        assert_int_equal(a->cameras[i].width, b->cameras[i].width);
        assert_int_equal(a->cameras[i].height, b->cameras[i].height);
        assert_memory_equal(a->cameras[i].params, b->cameras[i].params, sizeof a->cameras[i].params);
    }
    for (int i = 0; i < a->n_images; i++) {
        assert_int_equal(a->images[i].id, b->images[i].id);
        assert_int_equal(a->images[i].camera_id, b->images[i].camera_id);
        assert_memory_equal(a->images[i].q, b->images[i].q, sizeof a->images[i].q);
        assert_memory_equal(a->images[i].t, b->images[i].t, sizeof a->images[i].t);
        assert_string_equal(a->images[i].name, b->images[i].name);
    }
    assert_memory_equal(a->points, b->points, (size_t)a->n_points * 3 * sizeof(double));
}

static void test_text_and_binary_readers(void **state)
{
    (void)state;
    struct esr_colmap_model m, got;
    struct esr_colmap_camera cams[2];
    struct esr_colmap_image ims[3];
    double pts[12];
    small_model(&m, cams, ims, pts);
    for (int text = 0; text < 2; text++) {
        char dir[1200];
        snprintf(dir, sizeof dir, "%s/model_%s", test_tmpdir, text ? "txt" : "bin");
        write_model(dir, &m, text);
        assert_int_equal(esr_colmap_model_read(dir, &got), ESR_OK);
        assert_string_equal(got.format, text ? "text" : "binary");
        assert_same_model(&m, &got); /* %.17g round-trips doubles exactly */
        assert_non_null(esr_colmap_find_camera(&got, 9));
        assert_null(esr_colmap_find_camera(&got, 4));
        esr_colmap_model_free(&got);
    }
}

/* The parsers read the files from memory, never writing to them: what the fuzz harnesses call. */
static void test_parse_from_memory(void **state)
{
    (void)state;
    static const char cameras[] = "# c\n1 PINHOLE 8 6 10 10 4 3", /* no final newline */
                      images[] = "5 1 0 0 0 0 0 1 1 off/x.jpg\r\n\r\n", points[] = "";
    struct esr_colmap_file files[ESR_COLMAP_FILES] = {{cameras, sizeof cameras - 1, "c.txt"},
                                                      {images, sizeof images - 1, "i.txt"},
                                                      {points, 0, "p.txt"}};
    struct esr_colmap_model m;
    assert_int_equal(esr_colmap_model_parse_text(files, &m), ESR_OK);
    assert_int_equal(m.n_cameras, 1);
    assert_int_equal(m.n_images, 1);
    assert_int_equal(m.n_points, 0);
    assert_string_equal(m.images[0].name, "off/x.jpg");
    assert_int_equal(m.cameras[0].height, 6);
    esr_colmap_model_free(&m);
    /* a NUL byte: not a text file, named as given */
    static const char nul[] = "1 PINHOLE 8 6 10 10 4 3\n\0";
    files[ESR_COLMAP_CAMERAS] = (struct esr_colmap_file){nul, sizeof nul - 1, "c.txt"};
    esr_error_clear();
    assert_int_equal(esr_colmap_model_parse_text(files, &m), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "'c.txt' is not a text file"));
    assert_null(m.cameras);
    /* binary: an empty cameras file is refused, naming it */
    files[ESR_COLMAP_CAMERAS] = (struct esr_colmap_file){NULL, 0, "c.bin"};
    esr_error_clear();
    assert_int_equal(esr_colmap_model_parse_binary(files, &m), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "'c.bin' is truncated or corrupt"));
    esr_error_clear();
}

/* Reading dir fails with a message containing `what`. */
static void assert_read_fails(const char *dir, const char *what)
{
    struct esr_colmap_model got;
    esr_error_clear();
    assert_int_equal(esr_colmap_model_read(dir, &got), ESR_ERR);
    if (!strstr(esr_error_message(), what))
        fail_msg("message '%s' lacks '%s'", esr_error_message(), what);
    assert_null(got.cameras);
    esr_error_clear();
}

static void copy_prefix(const char *from, const char *to, long n)
{
    FILE *in = fopen(from, "rb"), *out = fopen(to, "wb");
    assert_non_null(in);
    assert_non_null(out);
    for (long i = 0; i < n; i++) {
        int c = fgetc(in);
        assert_true(c != EOF);
        fputc(c, out);
    }
    fclose(in);
    fclose(out);
}

static long file_size(const char *path)
{
    struct stat st;
    assert_int_equal(stat(path, &st), 0);
    return (long)st.st_size;
}

/* Every proper prefix of each binary file is refused, naming the file. */
static void test_binary_truncated_everywhere(void **state)
{
    (void)state;
    struct esr_colmap_model m;
    struct esr_colmap_camera cams[2];
    struct esr_colmap_image ims[3];
    double pts[12];
    small_model(&m, cams, ims, pts);
    char good[1200], bad[1200];
    snprintf(good, sizeof good, "%s/trunc_good", test_tmpdir);
    snprintf(bad, sizeof bad, "%s/trunc_bad", test_tmpdir);
    write_model(good, &m, 0);
    static const char *const files[] = {"cameras.bin", "images.bin", "points3D.bin"};
    for (int f = 0; f < 3; f++) {
        write_model(bad, &m, 0);
        char src[1300], dst[1300];
        snprintf(src, sizeof src, "%s/%s", good, files[f]);
        snprintf(dst, sizeof dst, "%s/%s", bad, files[f]);
        long size = file_size(src);
        for (long n = 0; n < size; n++) {
            copy_prefix(src, dst, n);
            assert_read_fails(bad, files[f]);
        }
        copy_prefix(src, dst, size);
    }
}

static void test_bad_models(void **state)
{
    (void)state;
    struct esr_colmap_model m;
    struct esr_colmap_camera cams[2];
    struct esr_colmap_image ims[3];
    double pts[12];
    char dir[1200];
    for (int text = 0; text < 2; text++) {
        /* a camera model esr does not support (7 = FOV in COLMAP's numbering) */
        small_model(&m, cams, ims, pts);
        cams[1].model = (enum esr_colmap_model_id)7;
        snprintf(dir, sizeof dir, "%s/bad_model_%d", test_tmpdir, text);
        write_model(dir, &m, text);
        assert_read_fails(dir, text ? "camera model 'OPENCV_FISHEYE' is not supported" : "camera model 7");
        /* an image whose camera is not in the model */
        small_model(&m, cams, ims, pts);
        ims[1].camera_id = 5;
        snprintf(dir, sizeof dir, "%s/bad_camera_%d", test_tmpdir, text);
        write_model(dir, &m, text);
        assert_read_fails(dir, "refers to camera 5");
        /* a duplicated camera id */
        small_model(&m, cams, ims, pts);
        cams[1].id = 3;
        snprintf(dir, sizeof dir, "%s/dup_camera_%d", test_tmpdir, text);
        write_model(dir, &m, text);
        assert_read_fails(dir, "camera id 3 appears twice");
        /* a duplicated image id */
        small_model(&m, cams, ims, pts);
        ims[2].id = ims[0].id;
        snprintf(dir, sizeof dir, "%s/dup_image_%d", test_tmpdir, text);
        write_model(dir, &m, text);
        assert_read_fails(dir, "image id 10 appears twice");
        /* a 3D point that is not finite (the scene's placement takes quantiles of the points) */
        small_model(&m, cams, ims, pts);
        pts[4] = NAN;
        snprintf(dir, sizeof dir, "%s/nan_point_%d", test_tmpdir, text);
        write_model(dir, &m, text);
        assert_read_fails(dir, "3D point 2 of 4 has a non-finite position");
        /* a quaternion whose squared norm overflows (it would normalise to the identity) */
        small_model(&m, cams, ims, pts);
        ims[2].q[0] = 1e200;
        snprintf(dir, sizeof dir, "%s/huge_quaternion_%d", test_tmpdir, text);
        write_model(dir, &m, text);
        assert_read_fails(dir, "image 12 ('on/p2.jpg') has a non-finite or zero pose");
    }
    /* a binary count far beyond the file */
    small_model(&m, cams, ims, pts);
    snprintf(dir, sizeof dir, "%s/huge_count", test_tmpdir);
    write_model(dir, &m, 0);
    FILE *f = open_in(dir, "points3D.bin");
    put_bytes(f, UINT64_MAX / 2, 8);
    fclose(f);
    assert_read_fails(dir, "points3D.bin' is truncated or corrupt (claims");
    /* a track length far beyond the file */
    f = open_in(dir, "points3D.bin");
    put_bytes(f, 1, 8), put_bytes(f, 1, 8), put_f64(f, 0), put_f64(f, 0), put_f64(f, 0), put_bytes(f, 0, 3);
    put_f64(f, 0), put_bytes(f, (uint64_t)1 << 60, 8);
    fclose(f);
    assert_read_fails(dir, "track entries do not fit");
    /* bytes after the last record */
    write_model(dir, &m, 0);
    char path[1300];
    snprintf(path, sizeof path, "%s/cameras.bin", dir);
    f = fopen(path, "ab");
    assert_non_null(f);
    fputc(0, f);
    fclose(f);
    assert_read_fails(dir, "bytes after the last record");
    /* text: a wrong parameter count, a malformed line, no model at all */
    snprintf(dir, sizeof dir, "%s/bad_text", test_tmpdir);
    write_model(dir, &m, 1);
    snprintf(path, sizeof path, "%s/cameras.txt", dir);
    assert_int_equal(test_write_file(path, "# c\n1 PINHOLE 64 48 50 50 32\n"), 0);
    assert_read_fails(dir, "cameras.txt', line 2: PINHOLE takes 4 parameters, the line has 3");
    assert_int_equal(test_write_file(path, "1 PINHOLE 64 x 50 50 32 24\n"), 0);
    assert_read_fails(dir, "cameras.txt', line 1: expected CAMERA_ID");
    snprintf(dir, sizeof dir, "%s/empty", test_tmpdir);
    mkdir(dir, 0755);
    assert_read_fails(dir, "neither cameras.bin nor cameras.txt");
}

/* ---- JPEG and EXIF ---- */

static void no_problem(void *user, const char *message)
{
    (void)user;
    fail_msg("dataset check: %s", message);
}

/* A 16x8 RGB image of two flat 8x8 blocks (JPEG keeps flat blocks nearly exact). */
static void two_blocks(struct esr_image *img)
{
    assert_int_equal(esr_image_alloc(img, 16, 8, 3), ESR_OK);
    for (int y = 0; y < 8; y++)
        for (int x = 0; x < 16; x++) {
            float *p = img->data + (y * 16 + x) * 3;
            p[0] = x < 8 ? 0.8f : 0.1f, p[1] = 0.2f, p[2] = x < 8 ? 0.1f : 0.9f;
        }
}

static int is_left_colour(const float *p)
{
    return fabsf(p[0] - 0.8f) < 0.02f && fabsf(p[1] - 0.2f) < 0.02f && fabsf(p[2] - 0.1f) < 0.02f;
}

static void test_jpeg_round_trip_and_orientation(void **state)
{
    (void)state;
    struct esr_image img, got;
    two_blocks(&img);
    char path[1200];
    snprintf(path, sizeof path, "%s/plain.JPG", test_tmpdir);
    write_jpeg(path, &img, 0, 0);
    assert_int_equal(esr_image_read(path, &got), ESR_OK); /* the extension's case does not matter */
    assert_int_equal(got.width, 16);
    assert_int_equal(got.height, 8);
    assert_int_equal(got.channels, 3);
    for (size_t i = 0; i < esr_image_count(&img); i++)
        assert_true(fabsf(got.data[i] - img.data[i]) < 3.0f / 255.0f);
    esr_image_free(&got);
    /* orientation 6 (rotate 90 clockwise): the left block ends up on top, 8 wide, 16 high; 8
     * (counter-clockwise) puts it at the bottom; 3 (180) on the right; both byte orders */
    static const struct {
        int orientation, big, w, h, x, y; /* a pixel that must show the left block's colour */
    } cases[] = {{6, 0, 8, 16, 4, 2}, {8, 1, 8, 16, 4, 13}, {3, 1, 16, 8, 13, 4}, {1, 0, 16, 8, 2, 4}};
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        snprintf(path, sizeof path, "%s/exif%zu.jpeg", test_tmpdir, c);
        write_jpeg(path, &img, cases[c].orientation, cases[c].big);
        assert_int_equal(esr_image_read(path, &got), ESR_OK);
        assert_int_equal(got.width, cases[c].w);
        assert_int_equal(got.height, cases[c].h);
        assert_true(is_left_colour(got.data + (cases[c].y * got.width + cases[c].x) * 3));
        esr_image_free(&got);
        assert_int_equal(esr_jpeg_read_stored(path, &got), ESR_OK); /* what COLMAP sees */
        assert_int_equal(got.width, 16);
        esr_image_free(&got);
    }
    /* grey JPEGs stay one channel */
    struct esr_image grey;
    assert_int_equal(esr_image_alloc(&grey, 8, 8, 1), ESR_OK);
    for (int i = 0; i < 64; i++)
        grey.data[i] = 0.5f;
    snprintf(path, sizeof path, "%s/grey.jpg", test_tmpdir);
    write_jpeg(path, &grey, 0, 0);
    assert_int_equal(esr_image_read(path, &got), ESR_OK);
    assert_int_equal(got.channels, 1);
    assert_true(fabsf(got.data[10] - 0.5f) < 2.0f / 255.0f);
    esr_image_free(&got);
    esr_image_free(&grey);
    esr_image_free(&img);
}

static void test_jpeg_bad_files(void **state)
{
    (void)state;
    struct esr_image img, got;
    two_blocks(&img);
    char path[1200], cut[1200];
    snprintf(path, sizeof path, "%s/whole.jpg", test_tmpdir);
    write_jpeg(path, &img, 0, 0);
    esr_image_free(&img);
    snprintf(cut, sizeof cut, "%s/cut.jpg", test_tmpdir);
    long size = file_size(path);
    /* truncated at every length from inside the header to just before the end */
    for (long n = 1; n < size - 2; n += 7) {
        copy_prefix(path, cut, n);
        esr_error_clear();
        assert_int_equal(esr_image_read(cut, &got), ESR_ERR);
        assert_non_null(strstr(esr_error_message(), "cut.jpg"));
        assert_null(got.data);
    }
    snprintf(cut, sizeof cut, "%s/text.jpg", test_tmpdir);
    assert_int_equal(test_write_file(cut, "not a JPEG at all"), 0);
    esr_error_clear();
    assert_int_equal(esr_image_read(cut, &got), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "'"));
    assert_non_null(strstr(esr_error_message(), "text.jpg' is not a valid JPEG"));
    esr_error_clear();
}

/* A dataset frame whose file_path names a JPEG loads through the same loader, turned upright. */
static void test_dataset_reads_jpeg_frames(void **state)
{
    (void)state;
    char dir[1200], path[1400];
    snprintf(dir, sizeof dir, "%s/jpeg_dataset", test_tmpdir);
    snprintf(path, sizeof path, "%s/transforms", dir);
    mkdir(dir, 0755), mkdir(path, 0755);
    snprintf(path, sizeof path, "%s/transforms/transforms_train.json", dir);
    assert_int_equal(test_write_file(path, "{\"camera_angle_x\": 0.7, \"frames\": [{\"file_path\": \"photo.jpg\", "
                                           "\"transform_matrix\": [[1,0,0,0],[0,1,0,0],[0,0,1,4],[0,0,0,1]], "
                                           "\"lights\": [{\"mode\": \"off\", \"intensity\": 0, \"color\": [0,0,1]}]}]}"),
                     0);
    struct esr_image img, rgb;
    two_blocks(&img);
    snprintf(path, sizeof path, "%s/photo.jpg", dir);
    write_jpeg(path, &img, 6, 0);
    esr_image_free(&img);
    struct esr_dataset ds;
    assert_int_equal(esr_dataset_load(dir, &ds), ESR_OK);
    assert_int_equal(ds.width, 8);
    assert_int_equal(ds.height, 16);
    assert_string_equal(ds.phases[ESR_PHASE_TRAIN].frames[0].name, "photo");
    assert_int_equal(esr_frame_load_rgb(&ds, &ds.phases[ESR_PHASE_TRAIN].frames[0], &rgb, NULL), ESR_OK);
    assert_true(is_left_colour(rgb.data + (2 * 8 + 4) * 3));
    esr_image_free(&rgb);
    assert_int_equal(esr_dataset_check(&ds, no_problem, NULL), 0);
    esr_dataset_free(&ds);
}

static void test_exif_parser(void **state)
{
    (void)state;
    unsigned char b[64];
    size_t n = exif_payload(b, 6, 0);
    assert_int_equal(esr_exif_orientation(b, n), 6);
    n = exif_payload(b, 8, 1);
    assert_int_equal(esr_exif_orientation(b, n), 8);
    for (size_t cut = 0; cut < n - 6; cut++) /* the value is in the last 8 bytes read */
        assert_int_equal(esr_exif_orientation(b, cut), 1);
    b[6 + 7] = 200; /* IFD0 offset beyond the segment */
    assert_int_equal(esr_exif_orientation(b, n), 1);
    n = exif_payload(b, 9, 0); /* out of range */
    assert_int_equal(esr_exif_orientation(b, n), 1);
    assert_int_equal(esr_exif_orientation((const unsigned char *)"http://ns.adobe.com/", 20), 1);
}

/* ---- undistortion and resampling ---- */

static void test_area_downscale_is_box_average(void **state)
{
    (void)state;
    /* a centred pinhole shrunk by 3: each output pixel is exactly the mean of a 3x3 block */
    struct esr_colmap_camera cam = {.id = 1, .model = ESR_COLMAP_PINHOLE, .width = 12, .height = 9,
                                    .params = {30, 30, 6, 4.5}};
    struct esr_image src, dst;
    assert_int_equal(esr_image_alloc(&src, 12, 9, 1), ESR_OK);
    for (int i = 0; i < 12 * 9; i++)
        src.data[i] = (float)((i * 37) % 11) / 10.0f;
    struct esr_pinhole_view view = {4, 3, 10.0};
    assert_int_equal(esr_colmap_undistort_image(&cam, &src, &view, &dst), ESR_OK);
    for (int y = 0; y < 3; y++)
        for (int x = 0; x < 4; x++) {
            double sum = 0.0;
            for (int b = 0; b < 3; b++)
                for (int a = 0; a < 3; a++)
                    sum += src.data[(3 * y + b) * 12 + 3 * x + a];
            assert_true(fabs(dst.data[y * 4 + x] - sum / 9.0) < 1e-5);
        }
    esr_image_free(&dst);
    esr_image_free(&src);
}

/* r(1 + k r^2) = rd solved by bisection (the test's own inverse of SIMPLE_RADIAL). */
static double radial_inverse(double k, double rd)
{
    double lo = 0.0, hi = rd * 2.0 + 1.0;
    for (int i = 0; i < 200; i++) {
        double mid = 0.5 * (lo + hi);
        if (mid * (1.0 + k * mid * mid) < rd)
            lo = mid;
        else
            hi = mid;
    }
    return 0.5 * (lo + hi);
}

static void test_undistort_radial_image(void **state)
{
    (void)state;
    /* A photo through a barrel lens of the scene "brightness = 0.5 + 0.4 u" (u the undistorted
     * normalised x); undistorted, every pixel must show 0.5 + 0.4 u at its own centre. */
    const double k = -0.08, f = 40.0, cx = 33.0, cy = 23.0;
    struct esr_colmap_camera cam = {.id = 1, .model = ESR_COLMAP_SIMPLE_RADIAL, .width = 64, .height = 48,
                                    .params = {f, cx, cy, k}};
    struct esr_image src, dst;
    assert_int_equal(esr_image_alloc(&src, 64, 48, 1), ESR_OK);
    for (int y = 0; y < 48; y++)
        for (int x = 0; x < 64; x++) {
            double ud = (x + 0.5 - cx) / f, vd = (y + 0.5 - cy) / f, rd = hypot(ud, vd);
            double s = rd > 0 ? radial_inverse(k, rd) / rd : 1.0;
            src.data[y * 64 + x] = (float)(0.5 + 0.4 * ud * s);
        }
    double hx, hy;
    assert_int_equal(esr_colmap_valid_extent(&cam, &hx, &hy), ESR_OK);
    /* centred on the principal point (33, 23): the right edge (31 px away) and the top (23 px)
     * bind; barrel distortion widens both, to the undistorted positions of those edges' middles
     * (the innermost points of a barrel photo's undistorted border) */
    assert_true(hx <= radial_inverse(k, 31.0 / f) + 1e-9 && hx > 0.99 * radial_inverse(k, 31.0 / f));
    assert_true(hy <= radial_inverse(k, 23.0 / f) + 1e-9 && hy > 0.99 * radial_inverse(k, 23.0 / f));
    assert_true(hx > 31.0 / f);
    struct esr_pinhole_view view = {20, 0, 0.0};
    view.focal = 20 / (2.0 * hx);
    view.height = (int)floor(2.0 * hy * view.focal);
    assert_int_equal(esr_colmap_undistort_image(&cam, &src, &view, &dst), ESR_OK);
    for (int y = 0; y < view.height; y++)
        for (int x = 0; x < view.width; x++) {
            double u = (x + 0.5 - 0.5 * view.width) / view.focal;
            assert_true(fabs(dst.data[y * view.width + x] - (0.5 + 0.4 * u)) < 2e-3);
        }
    esr_image_free(&dst);
    esr_image_free(&src);
}

static void test_valid_extent_off_centre_and_tight(void **state)
{
    (void)state;
    /* a pinhole whose principal point is 30 px from the left edge of 100: the centred view
     * reaches 30 px each way */
    struct esr_colmap_camera pin = {.id = 1, .model = ESR_COLMAP_PINHOLE, .width = 100, .height = 80,
                                    .params = {50, 40, 30, 40}};
    double hx, hy;
    assert_int_equal(esr_colmap_valid_extent(&pin, &hx, &hy), ESR_OK);
    assert_true(fabs(hx - 0.6) < 1e-9 && fabs(hy - 1.0) < 1e-9);
    /* a principal point outside the image leaves nothing */
    pin.params[2] = -5;
    esr_error_clear();
    assert_int_equal(esr_colmap_valid_extent(&pin, &hx, &hy), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "principal point"));
    esr_error_clear();
    /* OPENCV: the rectangle's corners map inside the image, 2% more would not */
    struct esr_colmap_camera cv = {.id = 2, .model = ESR_COLMAP_OPENCV, .width = 80, .height = 60,
                                   .params = {50, 52, 41, 29, -0.15, 0.02, 0.002, -0.001}};
    assert_int_equal(esr_colmap_valid_extent(&cv, &hx, &hy), ESR_OK);
    struct esr_colmap_intrinsics k;
    esr_colmap_intrinsics_of(&cv, &k);
    int outside_bigger = 0;
    for (int grow = 0; grow < 2; grow++)
        for (int e = 0; e < 4; e++) /* around the rectangle's border: left, right, top, bottom */
            for (int s = 0; s <= 100; s++) {
                double g = grow ? 1.02 : 1.0, a = s / 50.0 - 1.0, ud, vd;
                double u = e == 0 ? -hx : e == 1 ? hx : a * hx, v = e == 2 ? -hy : e == 3 ? hy : a * hy;
                esr_colmap_distort(&k, u * g, v * g, &ud, &vd);
                double px = k.fx * ud + k.cx, py = k.fy * vd + k.cy;
                int inside = px >= -1e-6 && px <= 80 + 1e-6 && py >= -1e-6 && py <= 60 + 1e-6;
                if (!grow)
                    assert_true(inside);
                else
                    outside_bigger += !inside;
            }
    assert_true(outside_bigger > 0);
}

/* ---- esr import colmap ---- */

#define CAPTURE_CENTRE {1.0, 2.0, 3.0}

/* A capture of 6 photos (3 off, 3 on; the model registers the first n_images) around (1, 2, 3) with COLMAP world up = -Y, photos of
 * 64x48 from two cameras (SIMPLE_RADIAL; OPENCV with its principal point off-centre), some JPEG
 * some PNG, 300 sparse points within radius 2. */
static void make_capture(const char *root, int text, int n_images)
{
    static struct esr_colmap_camera cams[2];
    static struct esr_colmap_image ims[6];
    static double pts[900];
    cams[0] = (struct esr_colmap_camera){.id = 1, .model = ESR_COLMAP_SIMPLE_RADIAL, .width = 64, .height = 48,
                                         .params = {60, 32, 24, -0.05}};
    cams[1] = (struct esr_colmap_camera){.id = 2, .model = ESR_COLMAP_OPENCV, .width = 64, .height = 48,
                                         .params = {62, 58, 30, 25, -0.03, 0.01, 0.001, -0.001}};
    const double target[3] = CAPTURE_CENTRE, up[3] = {0, -1, 0};
    char path[1300];
    snprintf(path, sizeof path, "%s/images", root);
    mkdir(root, 0755), mkdir(path, 0755);
    snprintf(path, sizeof path, "%s/images/off", root), mkdir(path, 0755);
    snprintf(path, sizeof path, "%s/images/on", root), mkdir(path, 0755);
    struct esr_image photo;
    assert_int_equal(esr_image_alloc(&photo, 64, 48, 3), ESR_OK);
    for (size_t i = 0; i < esr_image_count(&photo); i++)
        photo.data[i] = (float)((i / 3 * 7) % 13) / 12.0f;
    for (int i = 0; i < 6; i++) {
        double a = 2.0 * M_PI * i / 6.0, centre[3] = {target[0] + 8 * cos(a), target[1] - 3.0, target[2] + 8 * sin(a)};
        memset(&ims[i], 0, sizeof ims[i]);
        ims[i].id = (uint32_t)(i + 1);
        ims[i].camera_id = (uint32_t)(1 + i % 2);
        look_at(centre, target, up, ims[i].q, ims[i].t);
        const char *ext = i % 3 == 2 ? "png" : "jpg";
        snprintf(ims[i].name, sizeof ims[i].name, "%s/shot%d.%s", i < 3 ? "off" : "on", i % 3, ext);
        snprintf(path, sizeof path, "%s/images/%s", root, ims[i].name);
        if (i % 3 == 2)
            assert_int_equal(esr_png_write(path, &photo, 8), ESR_OK);
        else
            write_jpeg(path, &photo, 6, 0); /* an EXIF orientation the import must ignore, as COLMAP does */
    }
    for (int i = 0; i < 300; i++) {
        double r = 2.0 * ((i * 7919) % 300) / 300.0, th = i * 2.399963, ph = acos(1.0 - 2.0 * (i + 0.5) / 300.0);
        pts[3 * i] = target[0] + r * sin(ph) * cos(th);
        pts[3 * i + 1] = target[1] + r * sin(ph) * sin(th);
        pts[3 * i + 2] = target[2] + r * cos(ph);
    }
    esr_image_free(&photo);
    struct esr_colmap_model m = {.n_cameras = 2, .n_images = n_images, .n_points = 300,
                                 .cameras = cams, .images = ims, .points = pts};
    snprintf(path, sizeof path, "%s/sparse", root);
    write_model(path, &m, text);
}

/* The number of entries of dir whose name starts with prefix. */
static int count_entries(const char *dir, const char *prefix)
{
    DIR *d = opendir(dir);
    assert_non_null(d);
    int n = 0;
    struct dirent *e;
    while ((e = readdir(d)))
        n += !strncmp(e->d_name, prefix, strlen(prefix));
    closedir(d);
    return n;
}

/* Runs `esr import colmap` on the capture at root (make_capture's layout) into root/data with
 * `size` pixels, and with --masks root/masks when that folder exists; returns the exit status,
 * the output in out. */
static int import_capture(const char *root, int size, char *out, size_t n)
{
    char args[8192], masks[1300];
    snprintf(masks, sizeof masks, "%s/masks", root);
    struct stat st;
    const int has_masks = stat(masks, &st) == 0;
    snprintf(args, sizeof args, "import colmap '%s/sparse' '%s/images' --out '%s/data' --size %d%s%s%s", root, root,
             root, size, has_masks ? " --masks '" : "", has_masks ? masks : "", has_masks ? "'" : "");
    return test_run_esr(args, out, n);
}

static void test_import_end_to_end(void **state)
{
    (void)state;
    for (int text = 0; text < 2; text++) {
        char root[1200], out[8192], data[1300];
        snprintf(root, sizeof root, "%s/capture_%d", test_tmpdir, text);
        make_capture(root, text, 6);
        snprintf(data, sizeof data, "%s/data", root);
        int rc = import_capture(root, 40, out, sizeof out);
        if (rc != 0)
            fail_msg("esr import failed (%d): %s", rc, out);
        assert_non_null(strstr(out, "frames    6 (lights off 3, on 3)"));
        struct esr_dataset ds;
        assert_int_equal(esr_dataset_load(data, &ds), ESR_OK);
        const struct esr_phase *train = &ds.phases[ESR_PHASE_TRAIN];
        assert_int_equal(train->n_frames, 6);
        assert_int_equal(ds.n_lights, 1);
        assert_int_equal(ds.width, 40); /* the longer side */
        assert_true(ds.height > 20 && ds.height < 40);
        int on = 0;
        for (int i = 0; i < 6; i++)
            on += train->frames[i].lights_on;
        assert_int_equal(on, 3);
        assert_string_equal(train->frames[0].name, "shot0_off");
        assert_string_equal(train->frames[3].name, "shot0_on");
        assert_int_equal(esr_dataset_check(&ds, no_problem, NULL), 0);
        /* the capture's centre projects to the middle of every view, and the cameras sit at 4
         * (the points' 90th percentile is about 1.86, 4/8 of the camera distance is smaller) */
        for (int i = 0; i < 6; i++) {
            const struct esr_camera *cam = &train->frames[i].camera;
            const float origin[3] = {0, 0, 0};
            float px, py;
            assert_true(esr_camera_project(cam, origin, &px, &py));
            assert_true(fabsf(px - 0.5f * ds.width) < 0.5f && fabsf(py - 0.5f * ds.height) < 0.5f);
            float d = sqrtf(cam->c2w[0][3] * cam->c2w[0][3] + cam->c2w[1][3] * cam->c2w[1][3] +
                            cam->c2w[2][3] * cam->c2w[2][3]);
            assert_true(fabsf(d - 4.0f) < 0.3f);
            /* COLMAP's world up (-Y) became +Z: the cameras sit above the centre, image-up upwards */
            assert_true(cam->c2w[2][3] > 0.5f && cam->c2w[2][1] > 0.5f);
        }
        esr_dataset_free(&ds);
    }
}

/* The JPEG photos' EXIF exposure goes into the frames (`esr import colmap`), `esr info` reports
 * it per lighting and warns of the lights-on set shot a stop shorter; a frame's absurd exposure
 * is refused by the loader naming the file and the frame. */
static void test_import_records_exif_exposure(void **state)
{
    (void)state;
    char root[1200], out[8192], data[1300], path[1400];
    snprintf(root, sizeof root, "%s/capture_exif", test_tmpdir);
    make_capture(root, 1, 6);
    struct esr_image photo;
    assert_int_equal(esr_image_alloc(&photo, 64, 48, 3), ESR_OK);
    for (size_t i = 0; i < esr_image_count(&photo); i++)
        photo.data[i] = (float)((i / 3 * 7) % 13) / 12.0f;
    /* the JPEGs (shots 0 and 1 of each set) again, with exposures: lights off at 1/60 s and
     * 1/30 s, lights on at 1/120 and 1/60 (one stop shorter on average), f/4, ISO 100 */
    for (int on = 0; on < 2; on++)
        for (int k = 0; k < 2; k++) {
            const struct esr_exif_exposure e = {(k ? 2.0 : 1.0) / (on ? 120.0 : 60.0), 4.0, 100};
            unsigned char *app1 = NULL;
            size_t size = 0;
            assert_int_equal(esr_exif_exposure_payload(&e, &app1, &size), ESR_OK);
            snprintf(path, sizeof path, "%s/images/%s/shot%d.jpg", root, on ? "on" : "off", k);
            write_jpeg_app1(path, &photo, 0, 0, app1, size);
            free(app1);
        }
    esr_image_free(&photo);
    snprintf(data, sizeof data, "%s/data", root);
    int rc = import_capture(root, 40, out, sizeof out);
    if (rc != 0)
        fail_msg("esr import failed (%d): %s", rc, out);
    assert_non_null(strstr(out, "EXIF exposure recorded for 4 of 6 photos"));
    assert_non_null(strstr(out, "1.00 stops shorter than the lights-off ones"));
    struct esr_dataset ds;
    assert_int_equal(esr_dataset_load(data, &ds), ESR_OK);
    const struct esr_phase *train = &ds.phases[ESR_PHASE_TRAIN];
    double ev[2][2];
    for (int i = 0; i < train->n_frames; i++) {
        const struct esr_frame *f = &train->frames[i];
        const int shot = f->name[4] - '0';
        assert_int_equal(f->has_exposure, shot < 2); /* the PNG has none */
        if (shot < 2)
            ev[f->lights_on][shot] = f->exposure_ev;
    }
    /* log2(t ISO / N^2): 1/60 s, ISO 100, f/4 is log2(100 / 960) */
    assert_true(fabs(ev[0][0] - log2(100.0 / 960.0)) < 1e-3);
    assert_true(fabs(ev[0][1] - ev[0][0] - 1.0) < 1e-3 && fabs(ev[1][0] - ev[0][0] + 1.0) < 1e-3);
    esr_dataset_free(&ds);
    char args[2800];
    snprintf(args, sizeof args, "info '%s'", data);
    assert_int_equal(test_run_esr(args, out, sizeof out), 0); /* a warning, not a problem */
    assert_non_null(strstr(out, "exposure  lights off 2 photos"));
    assert_non_null(strstr(out, "warning: exposure recorded for 4 of the 6 training photos only"));
    assert_non_null(strstr(out, "warning: the lights-off photos were shot 1.00 stops apart"));
    assert_non_null(strstr(out, "so they will come out 2.00x too weak"));
    /* an absurd exposure in a frame */
    snprintf(path, sizeof path, "%s/transforms/transforms_train.json", data);
    unsigned char *text = NULL;
    size_t n = 0;
    assert_int_equal(esr_file_read_all(path, &text, &n), ESR_OK);
    char *bad = malloc(n + 1);
    memcpy(bad, text, n);
    bad[n] = '\0';
    char *iso = strstr(bad, "\"iso\":");
    assert_non_null(iso);
    iso += strlen("\"iso\":");
    while (*iso == ' ' || *iso == '\t')
        iso++;
    memcpy(iso, "000", 3); /* ISO 100 -> 000 */
    assert_int_equal(test_write_file(path, bad), 0);
    free(bad), free(text);
    esr_error_clear();
    assert_int_equal(esr_dataset_load(data, &ds), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "transforms_train.json"));
    assert_non_null(strstr(esr_error_message(), "'exposure': 'iso' must be a whole number"));
    esr_error_clear();
}

/* Pixel-level check: a point of the COLMAP world lands where COLMAP's own (distorted)
 * projection, undistorted, says, in the written pinhole view. */
static void test_import_projection_agrees_with_colmap(void **state)
{
    (void)state;
    char root[1200], out[8192], data[1300], path[1400];
    snprintf(root, sizeof root, "%s/capture_proj", test_tmpdir);
    make_capture(root, 0, 6);
    snprintf(data, sizeof data, "%s/data", root);
    assert_int_equal(import_capture(root, 48, out, sizeof out), 0);
    struct esr_colmap_model m;
    snprintf(path, sizeof path, "%s/sparse", root);
    assert_int_equal(esr_colmap_model_read(path, &m), ESR_OK);
    snprintf(path, sizeof path, "%s/import.json", data);
    cJSON *rec = test_read_json(path);
    assert_non_null(rec);
    double centre[3], rot[3][3], scale = cJSON_GetObjectItem(rec, "scale")->valuedouble;
    for (int a = 0; a < 3; a++) {
        centre[a] = cJSON_GetArrayItem(cJSON_GetObjectItem(rec, "centre"), a)->valuedouble;
        for (int b = 0; b < 3; b++)
            rot[a][b] = cJSON_GetArrayItem(cJSON_GetArrayItem(cJSON_GetObjectItem(rec, "rotation"), a), b)->valuedouble;
    }
    cJSON_Delete(rec);
    struct esr_dataset ds;
    assert_int_equal(esr_dataset_load(data, &ds), ESR_OK);
    const double world[3] = {1.6, 2.5, 2.2};
    float placed[3];
    for (int a = 0; a < 3; a++)
        placed[a] = (float)(scale * (rot[a][0] * (world[0] - centre[0]) + rot[a][1] * (world[1] - centre[1]) +
                                     rot[a][2] * (world[2] - centre[2])));
    for (int i = 0; i < ds.phases[ESR_PHASE_TRAIN].n_frames; i++) {
        const struct esr_frame *f = &ds.phases[ESR_PHASE_TRAIN].frames[i];
        const struct esr_colmap_image *im = NULL;
        for (int j = 0; j < m.n_images; j++) /* frame i is the photo "<folder>/<stem>.<ext>" */
            if (!strncmp(f->name, strrchr(m.images[j].name, '/') + 1, 5) &&
                !strcmp(strrchr(f->name, '_') + 1, m.images[j].name[1] == 'n' ? "on" : "off"))
                im = &m.images[j];
        assert_non_null(im);
        const struct esr_colmap_camera *cam = esr_colmap_find_camera(&m, im->camera_id);
        double px, py, u, v;
        assert_true(esr_colmap_project(cam, im, world, &px, &py));
        struct esr_colmap_intrinsics k;
        esr_colmap_intrinsics_of(cam, &k);
        assert_int_equal(esr_colmap_undistort(&k, (px - k.cx) / k.fx, (py - k.cy) / k.fy, &u, &v), ESR_OK);
        float ex, ey;
        assert_true(esr_camera_project(&f->camera, placed, &ex, &ey));
        assert_true(fabs(ex - (0.5 * ds.width + ds.focal * u)) < 1e-2);
        assert_true(fabs(ey - (0.5 * ds.height + ds.focal * v)) < 1e-2);
    }
    esr_dataset_free(&ds);
    esr_colmap_model_free(&m);
}

/* A mask for every photo of make_capture's capture: the left half foreground. Photo i's mask is
 * named the COLMAP way (off/shot0.jpg.png) for even i, by its stem (on/shot1.png) for odd i. */
static void write_masks(const char *root)
{
    char path[1400];
    snprintf(path, sizeof path, "%s/masks", root), mkdir(path, 0755);
    snprintf(path, sizeof path, "%s/masks/off", root), mkdir(path, 0755);
    snprintf(path, sizeof path, "%s/masks/on", root), mkdir(path, 0755);
    struct esr_image mask;
    assert_int_equal(esr_image_alloc(&mask, 64, 48, 1), ESR_OK);
    for (int y = 0; y < 48; y++)
        for (int x = 0; x < 64; x++)
            mask.data[y * 64 + x] = x < 32 ? 1.0f : 0.0f;
    for (int i = 0; i < 6; i++) {
        const char *folder = i < 3 ? "off" : "on", *ext = i % 3 == 2 ? "png" : "jpg";
        if (i % 2 == 0)
            snprintf(path, sizeof path, "%s/masks/%s/shot%d.%s.png", root, folder, i % 3, ext);
        else
            snprintf(path, sizeof path, "%s/masks/%s/shot%d.png", root, folder, i % 3);
        assert_int_equal(esr_png_write(path, &mask, 8), ESR_OK);
    }
    esr_image_free(&mask);
}

/* --masks: every written frame carries its mask as alpha, undistorted with the photo (the mask's
 * edge x = 32 of 64 maps to the middle column of the centred pinhole, give or take the
 * distortion and the principal point), and import.json records it. */
static void test_import_masks_become_alpha(void **state)
{
    (void)state;
    char root[1200], out[8192], data[1300], path[1400];
    snprintf(root, sizeof root, "%s/capture_masks", test_tmpdir);
    make_capture(root, 0, 6);
    write_masks(root);
    snprintf(data, sizeof data, "%s/data", root);
    int rc = import_capture(root, 40, out, sizeof out);
    if (rc != 0)
        fail_msg("esr import --masks failed (%d): %s", rc, out);
    assert_non_null(strstr(out, "masks as alpha"));
    static const char *const names[] = {"shot0_off", "shot1_off", "shot2_off", "shot0_on", "shot1_on", "shot2_on"};
    for (int i = 0; i < 6; i++) {
        struct esr_image img;
        snprintf(path, sizeof path, "%s/train/%s.png", data, names[i]);
        assert_int_equal(esr_png_read(path, &img), ESR_OK);
        assert_int_equal(img.channels, 4);
        const int w = img.width, y = img.height / 2;
        /* a quarter of the width inside either side of the edge: fully in or out */
        assert_true(img.data[((size_t)y * w + w / 4) * 4 + 3] > 0.99f);
        assert_true(img.data[((size_t)y * w + 3 * w / 4) * 4 + 3] < 0.01f);
        esr_image_free(&img);
    }
    snprintf(path, sizeof path, "%s/import.json", data);
    cJSON *rec = test_read_json(path);
    assert_non_null(rec);
    assert_true(cJSON_IsTrue(cJSON_GetObjectItem(rec, "masks")));
    cJSON_Delete(rec);
}

/* `esr import colmap` on a broken capture exits 1 naming `what` and leaves no output. */
static void assert_import_fails(const char *root, const char *what)
{
    char out[8192], data[1300];
    snprintf(data, sizeof data, "%s/data", root);
    int rc = import_capture(root, 32, out, sizeof out);
    if (rc != 1 || !strstr(out, what))
        fail_msg("expected exit 1 naming '%s', got %d: %s", what, rc, out);
    struct stat st;
    assert_int_not_equal(stat(data, &st), 0);
    assert_int_equal(count_entries(root, ".data"), 0); /* no staging folder left behind */
}

/* Replaces the first occurrence of `old` in the file at path by `new`. */
static void replace_in_file(const char *path, const char *old, const char *new)
{
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    char text[65536];
    size_t n = fread(text, 1, sizeof text - 1, f);
    fclose(f);
    text[n] = '\0';
    char *at = strstr(text, old);
    assert_non_null(at);
    char out[65536 + 256];
    snprintf(out, sizeof out, "%.*s%s%s", (int)(at - text), text, new, at + strlen(old));
    assert_int_equal(test_write_file(path, out), 0);
}

static void test_import_bad_captures(void **state)
{
    (void)state;
    char root[1200], path[1400];
    /* a photo the model names is missing */
    snprintf(root, sizeof root, "%s/missing", test_tmpdir);
    make_capture(root, 1, 6);
    snprintf(path, sizeof path, "%s/images/on/shot1.jpg", root);
    assert_int_equal(remove(path), 0);
    assert_import_fails(root, "images/on/shot1.jpg' is missing");
    /* a folder where a photo should be */
    assert_int_equal(mkdir(path, 0755), 0);
    assert_import_fails(root, "images/on/shot1.jpg' is not a file");
    assert_int_equal(rmdir(path), 0);
    /* a JPEG that does not decode */
    assert_int_equal(test_write_file(path, "\xff\xd8\xff garbage"), 0);
    assert_import_fails(root, "images/on/shot1.jpg' is not a valid JPEG");
    /* a photo in neither off/ nor on/ */
    snprintf(root, sizeof root, "%s/elsewhere", test_tmpdir);
    make_capture(root, 1, 6);
    snprintf(path, sizeof path, "%s/sparse/images.txt", root);
    replace_in_file(path, "on/shot1.jpg", "dim/shot1.jpg");
    assert_import_fails(root, "'dim/shot1.jpg' is in neither off/ nor on/");
    /* a camera model esr does not support */
    snprintf(root, sizeof root, "%s/fisheye", test_tmpdir);
    make_capture(root, 1, 6);
    snprintf(path, sizeof path, "%s/sparse/cameras.txt", root);
    replace_in_file(path, " OPENCV ", " OPENCV_FISHEYE ");
    assert_import_fails(root, "camera model 'OPENCV_FISHEYE' is not supported");
    /* fewer than 3 registered images */
    snprintf(root, sizeof root, "%s/few", test_tmpdir);
    make_capture(root, 0, 2);
    assert_import_fails(root, "images.bin' has 2 registered images; esr needs at least 3");
    /* a photo whose size is not its camera's */
    snprintf(root, sizeof root, "%s/resized", test_tmpdir);
    make_capture(root, 0, 6);
    struct esr_image small;
    assert_int_equal(esr_image_alloc(&small, 32, 24, 3), ESR_OK);
    snprintf(path, sizeof path, "%s/images/off/shot2.png", root);
    assert_int_equal(esr_png_write(path, &small, 8), ESR_OK);
    esr_image_free(&small);
    assert_import_fails(root, "off/shot2.png' is 32x24 but its COLMAP camera 1 is 64x48");
    /* a corrupt binary model */
    snprintf(root, sizeof root, "%s/corrupt", test_tmpdir);
    make_capture(root, 0, 6);
    snprintf(path, sizeof path, "%s/sparse/images.bin", root);
    FILE *f = fopen(path, "r+b");
    assert_non_null(f);
    put_bytes(f, 1000, 8);
    fclose(f);
    assert_import_fails(root, "images.bin' is truncated or corrupt");
    /* --masks: a photo without its mask, a mask of the wrong size, a mask that is not a PNG */
    snprintf(root, sizeof root, "%s/nomask", test_tmpdir);
    make_capture(root, 0, 6);
    write_masks(root);
    snprintf(path, sizeof path, "%s/masks/on/shot1.jpg.png", root); /* photo 4: COLMAP's naming */
    assert_int_equal(remove(path), 0);
    assert_import_fails(root, "no mask for image 'on/shot1.jpg': with --masks every registered photo needs");
    assert_int_equal(esr_image_alloc(&small, 32, 24, 1), ESR_OK);
    assert_int_equal(esr_png_write(path, &small, 8), ESR_OK);
    esr_image_free(&small);
    assert_import_fails(root, "masks/on/shot1.jpg.png' is 32x24 but its photo");
    assert_int_equal(test_write_file(path, "not a png"), 0);
    assert_import_fails(root, "masks/on/shot1.jpg.png");
    /* --out the photos' own folder, with --force: refused, the photos kept */
    snprintf(root, sizeof root, "%s/onto_inputs", test_tmpdir);
    make_capture(root, 0, 6);
    char args[8192], out[8192];
    snprintf(args, sizeof args, "import colmap '%s/sparse' '%s/images' --out '%s/images' --size 32 --force",
             root, root, root);
    assert_int_equal(test_run_esr(args, out, sizeof out), 1);
    assert_non_null(strstr(out, "would delete the input"));
    snprintf(path, sizeof path, "%s/images/on/shot1.jpg", root);
    assert_true(esr_file_exists(path));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_camera_model_projections),
        cmocka_unit_test(test_undistort_inverts_distortion),
        cmocka_unit_test(test_pose_conversion_round_trip),
        cmocka_unit_test(test_scene_placement_needs_a_scale),
        cmocka_unit_test(test_text_and_binary_readers),
        cmocka_unit_test(test_parse_from_memory),
        cmocka_unit_test(test_binary_truncated_everywhere),
        cmocka_unit_test(test_bad_models),
        cmocka_unit_test(test_jpeg_round_trip_and_orientation),
        cmocka_unit_test(test_jpeg_bad_files),
        cmocka_unit_test(test_dataset_reads_jpeg_frames),
        cmocka_unit_test(test_exif_parser),
        cmocka_unit_test(test_area_downscale_is_box_average),
        cmocka_unit_test(test_undistort_radial_image),
        cmocka_unit_test(test_valid_extent_off_centre_and_tight),
        cmocka_unit_test(test_import_end_to_end),
        cmocka_unit_test(test_import_projection_agrees_with_colmap),
        cmocka_unit_test(test_import_masks_become_alpha),
        cmocka_unit_test(test_import_bad_captures),
        cmocka_unit_test(test_import_records_exif_exposure),
    };
    return cmocka_run_group_tests(tests, test_setup_tmpdir, test_teardown_tmpdir);
}
