/* DTU input: the .npy header parser (good and bad headers), files written by NumPy itself (the
 * npz seed corpus), the projection matrix decomposition against the K, R, C it was built from
 * (scaled, negated, and against OpenCV's sign convention as NeuS uses it), and `esr import dtu`
 * end to end on a small scan written here (the npz with libzip), loaded by esr's dataset loader,
 * plus broken scans: each refused naming the file, nothing written. */
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
#include <zip.h>

#include <cjson/cJSON.h>

#include "core/error.h"
#include "io/camera.h"
#include "io/dataset.h"
#include "io/file.h"
#include "io/image.h"
#include "io/npy.h"
#include "io/npz.h"
#include "import/projection.h"
#include "test_support.h"

#define NPZ_CORPUS ESR_SOURCE_DIR "/../fuzz/corpus/npz"

/* ---- .npy bytes ---- */

/* A .npy file (version 1.0) with header dict `dict`, padded as NumPy pads it, then data_len bytes
 * of data. Returns its length; buf holds at least 4096 bytes. */
static size_t npy_bytes(unsigned char *buf, const char *dict, const void *data, size_t data_len)
{
    size_t dict_len = strlen(dict), total = 10 + dict_len + 1;
    size_t pad = (64 - total % 64) % 64, header_len = dict_len + pad + 1;
    memcpy(buf, "\x93NUMPY\x01\x00", 8);
    buf[8] = (unsigned char)(header_len & 0xff);
    buf[9] = (unsigned char)(header_len >> 8);
    memcpy(buf + 10, dict, dict_len);
    memset(buf + 10 + dict_len, ' ', pad);
    buf[10 + dict_len + pad] = '\n';
    memcpy(buf + 10 + header_len, data, data_len);
    return 10 + header_len + data_len;
}

static const char *const F8_4X4 = "{'descr': '<f8', 'fortran_order': False, 'shape': (4, 4), }";

static void test_npy_good_headers(void **state)
{
    (void)state;
    unsigned char buf[4096];
    double m[16];
    for (int i = 0; i < 16; i++)
        m[i] = i * 0.5 - 3.0;
    struct esr_npy_array a;
    assert_int_equal(esr_npy_parse(buf, npy_bytes(buf, F8_4X4, m, sizeof m), "m", &a), ESR_OK);
    assert_int_equal(a.header.ndim, 2);
    assert_int_equal(a.header.shape[0], 4);
    assert_int_equal(a.header.count, 16);
    assert_memory_equal(a.data, m, sizeof m);
    esr_npy_free(&a);
    /* float32, a one-element tuple, keys in another order and double quotes */
    float v[3] = {1.5f, -2.0f, 0.25f};
    assert_int_equal(esr_npy_parse(buf, npy_bytes(buf, "{\"shape\": (3,), \"fortran_order\": False, \"descr\": \"<f4\"}",
                                                  v, sizeof v), "v", &a), ESR_OK);
    assert_int_equal(a.header.item_size, 4);
    assert_true(a.data[0] == 1.5 && a.data[1] == -2.0 && a.data[2] == 0.25);
    esr_npy_free(&a);
    /* a scalar: shape () holds one value */
    double x = 7.0;
    assert_int_equal(esr_npy_parse(buf, npy_bytes(buf, "{'descr': '<f8', 'fortran_order': False, 'shape': (), }",
                                                  &x, sizeof x), "x", &a), ESR_OK);
    assert_int_equal(a.header.ndim, 0);
    assert_true(a.header.count == 1 && a.data[0] == 7.0);
    esr_npy_free(&a);
    /* version 2.0: a 4-byte header length */
    size_t n = npy_bytes(buf + 2, F8_4X4, m, sizeof m) - 10;
    memcpy(buf, "\x93NUMPY\x02\x00", 8);
    uint32_t len = (uint32_t)(buf[10] | buf[11] << 8);
    for (int i = 0; i < 4; i++)
        buf[8 + i] = (unsigned char)(len >> (8 * i));
    assert_int_equal(esr_npy_parse(buf, 12 + n, "v2", &a), ESR_OK);
    assert_memory_equal(a.data, m, sizeof m);
    esr_npy_free(&a);
}

static void test_npy_bad_headers(void **state)
{
    (void)state;
    static const struct {
        const char *dict;
        size_t data_len;
        const char *message;
    } rows[] = {
        {"{'descr': '<i8', 'fortran_order': False, 'shape': (4, 4), }", 128, "dtype '<i8' is not supported"},
        {"{'descr': '>f8', 'fortran_order': False, 'shape': (4, 4), }", 128, "dtype '>f8' is not supported"},
        {"{'descr': '<f8', 'fortran_order': True, 'shape': (4, 4), }", 128, "Fortran order"},
        {"{'descr': '<f8', 'fortran_order': False, 'shape': (3), }", 24, "is not a tuple"},
        {"{'descr': '<f8', 'fortran_order': False, 'shape': (-1,), }", 8, "non-negative integers"},
        {"{'descr': '<f8', 'fortran_order': False, }", 8, "lacks 'shape'"},
        {"{'descr': '<f8', 'fortran_order': False, 'shape': (1,), 'extra': 1}", 8, "unexpected key 'extra'"},
        {"{'descr': '<f8', 'descr': '<f8', 'fortran_order': False, 'shape': (1,)}", 8, "repeated key 'descr'"},
        {"{'descr': '<f8', 'fortran_order': Maybe, 'shape': (1,)}", 8, "True or False"},
        {"['<f8', False, (1,)]", 8, "expected '{'"},
        {"{'descr': '<f8', 'fortran_order': False, 'shape': (4, 4), }", 120, "data is truncated (120 of 128 bytes)"},
        {"{'descr': '<f8', 'fortran_order': False, 'shape': (4, 4), }", 136, "8 bytes after its data"},
        {"{'descr': '<f8', 'fortran_order': False, 'shape': (99999999999, 99999999999, 99999999999), }", 8,
         "shape is too large"},
    };
    unsigned char buf[4096], zeros[256] = {0};
    for (size_t i = 0; i < sizeof rows / sizeof rows[0]; i++) {
        struct esr_npy_array a;
        esr_error_clear();
        size_t n = npy_bytes(buf, rows[i].dict, zeros, rows[i].data_len);
        assert_int_equal(esr_npy_parse(buf, n, "'cams.npz' array 'k'", &a), ESR_ERR);
        if (!strstr(esr_error_message(), rows[i].message) || !strstr(esr_error_message(), "'cams.npz' array 'k'"))
            fail_msg("row %zu: expected '%s', got '%s'", i, rows[i].message, esr_error_message());
        assert_null(a.data);
    }
    /* the preamble itself */
    size_t n = npy_bytes(buf, F8_4X4, zeros, 128);
    struct esr_npy_array a;
    static const struct {
        size_t at;
        unsigned char byte;
        size_t size;
        const char *message;
    } pre[] = {{1, 'X', 0, "no \\x93NUMPY magic"}, {6, 4, 0, "version 4.0 is not supported"},
               {8, 0xff, 0, "runs past the end"}, {0, 0x93, 9, "no \\x93NUMPY magic"}};
    for (size_t i = 0; i < sizeof pre / sizeof pre[0]; i++) {
        unsigned char copy[4096];
        memcpy(copy, buf, n);
        copy[pre[i].at] = pre[i].byte;
        esr_error_clear();
        assert_int_equal(esr_npy_parse(copy, pre[i].size ? pre[i].size : n, "f.npy", &a), ESR_ERR);
        if (!strstr(esr_error_message(), pre[i].message))
            fail_msg("preamble row %zu: expected '%s', got '%s'", i, pre[i].message, esr_error_message());
    }
    esr_error_clear();
}

/* ---- files NumPy wrote (fuzz/corpus/npz: np.savez, np.savez_compressed, np.save) ---- */

static void test_numpy_written_files(void **state)
{
    (void)state;
    /* the seeds' world_mat_0 is K [I | t], K = [[70, 0.01, 33], [0, 68, 22], [0, 0, 1]], t = (0.1, 0.2, 3) */
    const double expect_row0[4] = {70, 0.01, 33, 70 * 0.1 + 0.01 * 0.2 + 33 * 3};
    static const char *const files[] = {NPZ_CORPUS "/cameras_stored.npz", NPZ_CORPUS "/cameras_deflated.npz"};
    for (int f = 0; f < 2; f++) {
        struct esr_npz z;
        assert_int_equal(esr_npz_open(files[f], &z), ESR_OK);
        double w[16], s[16];
        assert_int_equal(esr_npz_read_matrix(&z, "world_mat_0", 4, 4, w), ESR_OK);
        assert_int_equal(esr_npz_read_matrix(&z, "scale_mat_0", 4, 4, s), ESR_OK);
        for (int c = 0; c < 4; c++)
            assert_true(fabs(w[c] - expect_row0[c]) < 1e-12);
        assert_true(s[0] == 2.0 && s[3] == 1.0 && s[7] == 2.0 && s[11] == 3.0 && s[15] == 1.0);
        assert_false(esr_npz_has(&z, "world_mat_1"));
        assert_int_equal(esr_npz_read_matrix(&z, "world_mat_1", 4, 4, w), ESR_ERR);
        assert_non_null(strstr(esr_error_message(), "has no array 'world_mat_1'"));
        esr_error_clear();
        if (f == 0) { /* a float32 array, and a shape check naming both shapes */
            struct esr_npy_array a;
            assert_int_equal(esr_npz_read(&z, "camera_mat_0", &a), ESR_OK);
            assert_int_equal(a.header.item_size, 4);
            assert_true(a.data[0] == 1.0 && a.data[1] == 0.0);
            esr_npy_free(&a);
            assert_int_equal(esr_npz_read_matrix(&z, "camera_mat_0", 3, 4, w), ESR_ERR);
            assert_non_null(strstr(esr_error_message(), "'camera_mat_0' has shape (4, 4); expected (3, 4)"));
            esr_error_clear();
        }
        esr_npz_close(&z);
    }
    unsigned char *data;
    size_t size;
    struct esr_npy_array a;
    assert_int_equal(esr_file_read_all(NPZ_CORPUS "/f4_vector.npy", &data, &size), ESR_OK);
    assert_int_equal(esr_npy_parse(data, size, "f4_vector.npy", &a), ESR_OK);
    assert_true(a.header.ndim == 1 && a.header.count == 3 && a.data[2] == 2.0);
    esr_npy_free(&a);
    free(data);
    /* a file that is not a zip */
    struct esr_npz z;
    assert_int_equal(esr_npz_open(NPZ_CORPUS "/f4_vector.npy", &z), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "f4_vector.npy' is not a zip archive"));
    esr_error_clear();
}

/* ---- projection matrices ---- */

static void rotation(const double axis[3], double angle, double r[3][3])
{
    double n = sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]);
    double k[3] = {axis[0] / n, axis[1] / n, axis[2] / n}, c = cos(angle), s = sin(angle);
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            r[i][j] = (1 - c) * k[i] * k[j] + (i == j ? c : 0.0);
    r[0][1] -= s * k[2], r[1][0] += s * k[2];
    r[0][2] += s * k[1], r[2][0] -= s * k[1];
    r[1][2] -= s * k[0], r[2][1] += s * k[0];
}

/* P = lambda K [R | -R C]. */
static void build_projection(const double k[3][3], const double r[3][3], const double c[3], double lambda,
                             double p[3][4])
{
    for (int i = 0; i < 3; i++) {
        double kr[3] = {0, 0, 0};
        for (int j = 0; j < 3; j++)
            for (int m = 0; m < 3; m++)
                kr[j] += k[i][m] * r[m][j];
        for (int j = 0; j < 3; j++)
            p[i][j] = lambda * kr[j];
        p[i][3] = -lambda * (kr[0] * c[0] + kr[1] * c[1] + kr[2] * c[2]);
    }
}

/* The world direction of pixel (u, v) for intrinsics k and world-to-camera rotation r:
 * R^T K^-1 (u, v, 1), K upper triangular. */
static void pixel_ray(const double k[3][3], const double r[3][3], double u, double v, double d[3])
{
    double y = (v - k[1][2]) / k[1][1];
    double x = (u - k[0][2] - k[0][1] * y) / k[0][0];
    double cam[3] = {x, y, 1.0};
    for (int a = 0; a < 3; a++)
        d[a] = r[0][a] * cam[0] + r[1][a] * cam[1] + r[2][a] * cam[2];
}

static void test_projection_decompose(void **state)
{
    (void)state;
    const double k[3][3] = {{2892.3, 0.37, 823.2}, {0, 2883.2, 619.1}, {0, 0, 1}};
    const double axis[3] = {0.3, -0.8, 0.5}, centre[3] = {-1.2, 0.7, 2.9};
    double r[3][3];
    rotation(axis, 2.1, r);
    const double lambdas[] = {1.0, 2.5, 1e-3, -1.7, -400.0};
    for (size_t l = 0; l < sizeof lambdas / sizeof lambdas[0]; l++) {
        double p[3][4];
        build_projection(k, r, centre, lambdas[l], p);
        struct esr_projection_parts parts;
        assert_int_equal(esr_projection_decompose(p, "test camera", &parts), ESR_OK);
        for (int i = 0; i < 3; i++) {
            assert_true(fabs(parts.centre[i] - centre[i]) < 1e-9);
            for (int j = 0; j < 3; j++) {
                if (fabs(parts.k[i][j] - k[i][j]) > 1e-9 * fmax(1.0, fabs(k[i][j])))
                    fail_msg("lambda %g: K[%d][%d] = %.12g, expected %.12g", lambdas[l], i, j, parts.k[i][j], k[i][j]);
                assert_true(fabs(parts.r[i][j] - r[i][j]) < 1e-12);
            }
        }
    }
    /* OpenCV on the negated matrix keeps the sign: K' = K diag(1, 1, -1) (K'[2][2] < 0) and
     * R' = diag(-1, -1, 1) R; NeuS divides K' by K'[2][2] (fx, fy < 0) and uses R'^T as the pose.
     * Those describe the same rays as the decomposition here: same direction for every pixel. */
    double k_neus[3][3], r_cv[3][3];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            k_neus[i][j] = k[i][j] * (j == 2 ? -1.0 : 1.0) / -1.0;
            r_cv[i][j] = r[i][j] * (i == 2 ? 1.0 : -1.0);
        }
    double p[3][4];
    build_projection(k, r, centre, -1.0, p);
    struct esr_projection_parts parts;
    assert_int_equal(esr_projection_decompose(p, "negated", &parts), ESR_OK);
    for (int s = 0; s < 4; s++) {
        double u = 100.0 + 400.0 * s, v = 1100.0 - 300.0 * s, ours[3], neus[3];
        pixel_ray(parts.k, parts.r, u, v, ours);
        pixel_ray(k_neus, r_cv, u, v, neus);
        double no = sqrt(ours[0] * ours[0] + ours[1] * ours[1] + ours[2] * ours[2]);
        double nn = sqrt(neus[0] * neus[0] + neus[1] * neus[1] + neus[2] * neus[2]);
        for (int a = 0; a < 3; a++)
            assert_true(fabs(ours[a] / no - neus[a] / nn) < 1e-12);
    }
    /* a singular left 3x3 */
    double singular[3][4] = {{1, 2, 3, 4}, {2, 4, 6, 1}, {0, 0, 1, 1}};
    assert_int_equal(esr_projection_decompose(singular, "camera 9", &parts), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "camera 9: the projection matrix is singular"));
    esr_error_clear();
}

/* ---- a synthetic scan ---- */

#define SRC_W 64
#define SRC_H 48
#define N_CAMS 5

/* How a scan is broken (all 0: a good scan). */
struct scan_faults {
    int no_masks;
    int no_npz;
    int drop_scale_mat;   /* scale_mat_2 missing */
    int extra_image;      /* image/000007.png without a camera */
    int truncate_world;   /* world_mat_1's data cut short */
    int shape_3x4;        /* world_mat_4 stored as 3x4 */
    int int_dtype;        /* scale_mat_0 as '<i8' */
    int garbage_image;    /* image/000001.png not a PNG */
    int small_image;      /* image/000003.png 32x24 */
    int missing_mask;     /* mask/002.png removed */
    int npz_not_zip;      /* cameras_sphere.npz is text */
};

static const double CAM_K[3][3] = {{70.0, 0.5, 33.0}, {0.0, 68.0, 23.5}, {0.0, 0.0, 1.0}};
static const double SCALE = 2.0, SHIFT[3] = {1.0, 2.0, 3.0}; /* world = SCALE x + SHIFT */

/* Camera i of the scan in the normalised frame: on a circle of radius 2.6 at height 1.5 (distance
 * 3), looking at the origin, world +Z up; R world-to-camera (OpenCV frame), C its centre. */
static void scan_camera(int i, double r[3][3], double c[3])
{
    double a = 2.0 * M_PI * i / N_CAMS;
    c[0] = 2.6 * cos(a), c[1] = 2.6 * sin(a), c[2] = 1.5;
    double z[3] = {-c[0], -c[1], -c[2]}, up[3] = {0, 0, 1}, x[3], y[3];
    double nz = sqrt(z[0] * z[0] + z[1] * z[1] + z[2] * z[2]);
    for (int k = 0; k < 3; k++)
        z[k] /= nz;
    /* x = z x up (image right), y = z x x (image down) */
    x[0] = z[1] * up[2] - z[2] * up[1], x[1] = z[2] * up[0] - z[0] * up[2], x[2] = z[0] * up[1] - z[1] * up[0];
    double nx = sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]);
    for (int k = 0; k < 3; k++)
        x[k] /= nx;
    y[0] = z[1] * x[2] - z[2] * x[1], y[1] = z[2] * x[0] - z[0] * x[2], y[2] = z[0] * x[1] - z[1] * x[0];
    for (int k = 0; k < 3; k++)
        r[0][k] = x[k], r[1][k] = y[k], r[2][k] = z[k];
}

/* Adds `name`.npy holding a 4x4 (or rows x 4) array with header dict `dict` to the archive. */
static void add_array(zip_t *za, const char *name, const char *dict, const double *v, size_t bytes)
{
    unsigned char *buf = malloc(4096);
    assert_non_null(buf);
    size_t n = npy_bytes(buf, dict, v, bytes);
    zip_source_t *src = zip_source_buffer(za, buf, n, 1);
    assert_non_null(src);
    char entry[64];
    snprintf(entry, sizeof entry, "%s.npy", name);
    assert_true(zip_file_add(za, entry, src, ZIP_FL_OVERWRITE) >= 0);
}

static void write_npz(const char *path, const struct scan_faults *bad)
{
    int err = 0;
    zip_t *za = zip_open(path, ZIP_CREATE | ZIP_TRUNCATE, &err);
    assert_non_null(za);
    for (int i = 0; i < N_CAMS; i++) {
        double r[3][3], c[3], cw[3], p[3][4], world[16] = {0}, scale[16] = {0};
        scan_camera(i, r, c);
        for (int a = 0; a < 3; a++)
            cw[a] = SCALE * c[a] + SHIFT[a];
        /* camera 3's matrix negated: a projection matrix is only defined up to scale */
        build_projection(CAM_K, r, cw, i == 3 ? -1.0 : 1.0, p);
        for (int a = 0; a < 3; a++)
            for (int b = 0; b < 4; b++)
                world[a * 4 + b] = p[a][b];
        world[15] = 1.0;
        for (int a = 0; a < 3; a++)
            scale[a * 4 + a] = SCALE, scale[a * 4 + 3] = SHIFT[a];
        scale[15] = 1.0;
        char name[32];
        snprintf(name, sizeof name, "world_mat_%d", i);
        if (bad->shape_3x4 && i == 4)
            add_array(za, name, "{'descr': '<f8', 'fortran_order': False, 'shape': (3, 4), }", world, 96);
        else
            add_array(za, name, F8_4X4, world, bad->truncate_world && i == 1 ? 100 : 128);
        snprintf(name, sizeof name, "scale_mat_%d", i);
        if (bad->int_dtype && i == 0)
            add_array(za, name, "{'descr': '<i8', 'fortran_order': False, 'shape': (4, 4), }", scale, 128);
        else if (!(bad->drop_scale_mat && i == 2))
            add_array(za, name, F8_4X4, scale, 128);
    }
    assert_int_equal(zip_close(za), 0);
}

/* A scan in root: cameras_sphere.npz, image/00000<i>.png (a constant colour per photo), mask/00<i>.png
 * (foreground right of the principal point). */
static void make_scan(const char *root, const struct scan_faults *bad)
{
    char path[1400];
    mkdir(root, 0755);
    snprintf(path, sizeof path, "%s/image", root), mkdir(path, 0755);
    if (!bad->no_masks)
        snprintf(path, sizeof path, "%s/mask", root), mkdir(path, 0755);
    struct esr_image photo, mask;
    assert_int_equal(esr_image_alloc(&mask, SRC_W, SRC_H, 1), ESR_OK);
    for (int y = 0; y < SRC_H; y++)
        for (int x = 0; x < SRC_W; x++)
            mask.data[y * SRC_W + x] = x + 0.5 > CAM_K[0][2] ? 1.0f : 0.0f;
    for (int i = 0; i < N_CAMS + (bad->extra_image ? 1 : 0); i++) {
        int index = i < N_CAMS ? i : 7, small = bad->small_image && i == 3;
        assert_int_equal(esr_image_alloc(&photo, small ? 32 : SRC_W, small ? 24 : SRC_H, 3), ESR_OK);
        for (size_t p = 0; p < esr_image_count(&photo); p++)
            photo.data[p] = (float)((p % 3) + 1) * 0.2f + 0.05f * (float)i;
        snprintf(path, sizeof path, "%s/image/%06d.png", root, index);
        if (bad->garbage_image && i == 1)
            assert_int_equal(test_write_file(path, "not a PNG"), 0);
        else
            assert_int_equal(esr_png_write(path, &photo, 8), ESR_OK);
        esr_image_free(&photo);
        snprintf(path, sizeof path, "%s/mask/%03d.png", root, index);
        if (!bad->no_masks && !(bad->missing_mask && i == 2))
            assert_int_equal(esr_png_write(path, &mask, 8), ESR_OK);
    }
    esr_image_free(&mask);
    snprintf(path, sizeof path, "%s/cameras_sphere.npz", root);
    if (bad->npz_not_zip)
        assert_int_equal(test_write_file(path, "PK but not really"), 0);
    else if (!bad->no_npz)
        write_npz(path, bad);
}

static void run_import(const char *root, int size, char *out, size_t n, int expect_rc)
{
    char args[4096];
    snprintf(args, sizeof args, "import dtu '%s' --out '%s/data' --size %d", root, root, size);
    int rc = test_run_esr(args, out, n);
    if (rc != expect_rc)
        fail_msg("esr import dtu: exit %d, expected %d: %s", rc, expect_rc, out);
}

static void no_problem(void *user, const char *message)
{
    (void)user;
    fail_msg("dataset problem: %s", message);
}

static void test_import_end_to_end(void **state)
{
    (void)state;
    for (int masks = 1; masks >= 0; masks--) {
        char root[1200], out[8192], path[1400];
        snprintf(root, sizeof root, "%s/scan_%d", test_tmpdir, masks);
        struct scan_faults good = {.no_masks = !masks};
        make_scan(root, &good);
        run_import(root, 40, out, sizeof out, 0);
        assert_non_null(strstr(out, "frames    5 (lights off)"));
        snprintf(path, sizeof path, "%s/data", root);
        struct esr_dataset ds;
        assert_int_equal(esr_dataset_load(path, &ds), ESR_OK);
        const struct esr_phase *train = &ds.phases[ESR_PHASE_TRAIN];
        assert_int_equal(train->n_frames, N_CAMS);
        assert_int_equal(ds.width, 40);
        /* the view every camera covers: right of the principal point 31 px less the skew's
         * 0.5 x 0.36 at the corner, over fx 70 -> half_x 0.4403; half_y 23.5 / 68 = 0.3456; so
         * focal 40 / 0.8806 = 45.42 and height floor(2 x 0.3456 x 45.42) = 31 */
        assert_int_equal(ds.height, 31);
        assert_int_equal(esr_dataset_check(&ds, no_problem, NULL), 0);
        snprintf(path, sizeof path, "%s/data/import.json", root);
        cJSON *rec = test_read_json(path);
        assert_non_null(rec);
        assert_true(cJSON_IsTrue(cJSON_GetObjectItem(rec, "masks")) == masks);
        double rot[3][3], scale = cJSON_GetObjectItem(rec, "scale")->valuedouble;
        for (int a = 0; a < 3; a++)
            for (int b = 0; b < 3; b++)
                rot[a][b] = cJSON_GetArrayItem(cJSON_GetArrayItem(cJSON_GetObjectItem(rec, "rotation"), a), b)->valuedouble;
        cJSON_Delete(rec);
        assert_true(fabs(scale - 1.0) < 1e-12); /* cameras at 3: the unit sphere stays the unit sphere */
        /* cameras' world up (+Z of the normalised frame) stays +Z */
        assert_true(fabs(rot[2][2] - 1.0) < 1e-9);
        for (int i = 0; i < N_CAMS; i++) {
            const struct esr_frame *f = &train->frames[i];
            char name[32];
            snprintf(name, sizeof name, "%06d_off", i);
            assert_string_equal(f->name, name);
            assert_false(f->lights_on);
            double r[3][3], c[3];
            scan_camera(i, r, c);
            /* the centre where it was put */
            for (int a = 0; a < 3; a++) {
                double placed = scale * (rot[a][0] * c[0] + rot[a][1] * c[1] + rot[a][2] * c[2]);
                assert_true(fabs(f->camera.c2w[a][3] - placed) < 1e-5);
            }
            /* a point of the normalised frame lands where the source camera's K (skew included),
             * with the principal point moved to the centre and the focal scaled, says */
            const double x[3] = {0.2, -0.1, 0.3};
            double cam[3];
            for (int a = 0; a < 3; a++)
                cam[a] = r[a][0] * (x[0] - c[0]) + r[a][1] * (x[1] - c[1]) + r[a][2] * (x[2] - c[2]);
            double u = cam[0] / cam[2], v = cam[1] / cam[2];
            float placed[3], px, py;
            for (int a = 0; a < 3; a++)
                placed[a] = (float)(scale * (rot[a][0] * x[0] + rot[a][1] * x[1] + rot[a][2] * x[2]));
            assert_true(esr_camera_project(&f->camera, placed, &px, &py));
            assert_true(fabs(px - (0.5 * ds.width + ds.focal * u)) < 1e-3);
            assert_true(fabs(py - (0.5 * ds.height + ds.focal * v)) < 1e-3);
            /* the photo's colour survives the resampling; the mask is the alpha */
            struct esr_image img;
            snprintf(path, sizeof path, "%s/data/train/%s.png", root, name);
            assert_int_equal(esr_png_read(path, &img), ESR_OK);
            assert_int_equal(img.channels, masks ? 4 : 3);
            const float *mid = img.data + ((size_t)(img.height / 2) * (size_t)img.width + (size_t)(img.width - 3)) *
                                              (size_t)img.channels;
            for (int k = 0; k < 3; k++)
                assert_true(fabsf(mid[k] - ((float)(k + 1) * 0.2f + 0.05f * (float)i)) < 0.6f / 255.0f);
            if (masks) { /* foreground right of the principal point: the right half of the view */
                const float *left = img.data + ((size_t)(img.height / 2) * (size_t)img.width + 2) * 4;
                assert_true(mid[3] == 1.0f && left[3] == 0.0f);
            }
            esr_image_free(&img);
        }
        esr_dataset_free(&ds);
    }
}

/* `esr import dtu` on a scan broken as `bad` exits 1 naming `what` and leaves no output. */
static void assert_import_fails(const char *tag, const struct scan_faults *bad, const char *what)
{
    char root[1200], out[8192], data[1300];
    snprintf(root, sizeof root, "%s/bad_%s", test_tmpdir, tag);
    make_scan(root, bad);
    run_import(root, 32, out, sizeof out, 1);
    if (!strstr(out, what))
        fail_msg("%s: expected the message to name '%s', got: %s", tag, what, out);
    snprintf(data, sizeof data, "%s/data", root);
    struct stat st;
    assert_int_not_equal(stat(data, &st), 0);
    assert_int_equal(test_count_names(root, ".data"), 0); /* no staging folder left behind */
}

static void test_import_bad_scans(void **state)
{
    (void)state;
    assert_import_fails("no_npz", &(struct scan_faults){.no_npz = 1}, "bad_no_npz/cameras_sphere.npz' is missing");
    assert_import_fails("not_zip", &(struct scan_faults){.npz_not_zip = 1},
                        "cameras_sphere.npz' is not a zip archive");
    assert_import_fails("no_scale", &(struct scan_faults){.drop_scale_mat = 1},
                        "cameras_sphere.npz' has no array 'scale_mat_2' (the camera of '");
    assert_import_fails("extra_image", &(struct scan_faults){.extra_image = 1},
                        "has no array 'world_mat_7' (the camera of '");
    assert_import_fails("truncated", &(struct scan_faults){.truncate_world = 1},
                        "cameras_sphere.npz' array 'world_mat_1': .npy data is truncated (100 of 128 bytes)");
    assert_import_fails("shape", &(struct scan_faults){.shape_3x4 = 1},
                        "array 'world_mat_4' has shape (3, 4); expected (4, 4)");
    assert_import_fails("dtype", &(struct scan_faults){.int_dtype = 1},
                        "array 'scale_mat_0': dtype '<i8' is not supported");
    assert_import_fails("garbage", &(struct scan_faults){.garbage_image = 1},
                        "image/000001.png' is not a valid PNG");
    assert_import_fails("small", &(struct scan_faults){.small_image = 1},
                        "image/000003.png' is 32x24 but the scan's first photo is 64x48");
    assert_import_fails("no_mask", &(struct scan_faults){.missing_mask = 1},
                        "mask/002.png' is missing: the scan has mask/");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_npy_good_headers),
        cmocka_unit_test(test_npy_bad_headers),
        cmocka_unit_test(test_numpy_written_files),
        cmocka_unit_test(test_projection_decompose),
        cmocka_unit_test(test_import_end_to_end),
        cmocka_unit_test(test_import_bad_scans),
    };
    return cmocka_run_group_tests(tests, test_setup_tmpdir, test_teardown_tmpdir);
}
