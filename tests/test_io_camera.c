/* Pinhole camera: focal from FOV, ray/projection inverse pair, the dataset's convention (cameras
 * look at the origin, which must project to the image centre). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <string.h>

#include "core/error.h"
#include "io/camera.h"
#include "io/dataset.h"
#include "test_support.h"

/* Camera at centre looking at the origin with +Z up (Blender convention: looks along local -Z). */
static void look_at_origin(const float centre[3], struct esr_camera *cam)
{
    double z[3] = {centre[0], centre[1], centre[2]}; /* local +Z points away from the target */
    double n = sqrt(z[0] * z[0] + z[1] * z[1] + z[2] * z[2]);
    for (int k = 0; k < 3; k++)
        z[k] /= n;
    double up[3] = {0, 0, 1};
    double x[3] = {up[1] * z[2] - up[2] * z[1], up[2] * z[0] - up[0] * z[2], up[0] * z[1] - up[1] * z[0]};
    n = sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]);
    for (int k = 0; k < 3; k++)
        x[k] /= n;
    double y[3] = {z[1] * x[2] - z[2] * x[1], z[2] * x[0] - z[0] * x[2], z[0] * x[1] - z[1] * x[0]};
    for (int r = 0; r < 3; r++) {
        cam->c2w[r][0] = (float)x[r];
        cam->c2w[r][1] = (float)y[r];
        cam->c2w[r][2] = (float)z[r];
        cam->c2w[r][3] = centre[r];
    }
}

static double point_ray_distance(const float p[3], const float o[3], const float d[3])
{
    double v[3] = {p[0] - o[0], p[1] - o[1], p[2] - o[2]};
    double t = v[0] * d[0] + v[1] * d[1] + v[2] * d[2];
    double s = 0.0;
    for (int k = 0; k < 3; k++) {
        double e = v[k] - t * d[k];
        s += e * e;
    }
    return sqrt(s);
}

static void test_focal(void **state)
{
    (void)state;
    /* 90 degrees: tan(45) = 1, so f = W / 2 exactly. */
    assert_float_equal(esr_focal_from_fov(160, (float)(M_PI / 2)), 80.0f, 1e-4);
    /* The lamp scene's angle is Blender's 50 mm lens on a 36 mm sensor: f = 160 * 50 / 36. */
    assert_float_equal(esr_focal_from_fov(160, 0.691100001335144f), 160.0 * 50.0 / 36.0, 0.01);
}

static void check_round_trips(const struct esr_camera *cam)
{
    const float points[4][3] = {{0, 0, 0}, {0.3f, -0.7f, 0.5f}, {-1.2f, 0.4f, 0.9f}, {1.0f, 1.0f, -0.1f}};
    for (int i = 0; i < 4; i++) {
        float px, py, o[3], d[3];
        assert_int_equal(esr_camera_project(cam, points[i], &px, &py), 1);
        esr_camera_ray(cam, px, py, o, d);
        assert_float_equal(d[0] * d[0] + d[1] * d[1] + d[2] * d[2], 1.0f, 1e-5);
        double dist = point_ray_distance(points[i], o, d);
        if (dist > 1e-4)
            fail_msg("point %d: distance to its ray %g", i, dist);
    }
    /* The origin (look-at target) projects to the image centre. */
    const float origin[3] = {0, 0, 0};
    float px, py;
    assert_int_equal(esr_camera_project(cam, origin, &px, &py), 1);
    assert_float_equal(px, 0.5f * (float)cam->width, 2e-3);
    assert_float_equal(py, 0.5f * (float)cam->height, 2e-3);
}

static void test_synthetic_camera(void **state)
{
    (void)state;
    struct esr_camera cam;
    const float centre[3] = {2.5f, -3.0f, 1.5f};
    look_at_origin(centre, &cam);
    cam.width = 160;
    cam.height = 120;
    cam.focal = esr_focal_from_fov(160, 0.6911f);
    check_round_trips(&cam);
    /* +Y is image-up: a point above the origin lands above the centre (smaller row). */
    const float above[3] = {0, 0, 0.5f};
    float px, py;
    assert_int_equal(esr_camera_project(&cam, above, &px, &py), 1);
    assert_true(py < 60.0f);
    /* Behind the camera. */
    const float behind[3] = {5.0f, -6.0f, 3.0f};
    assert_int_equal(esr_camera_project(&cam, behind, &px, &py), 0);
    /* Ray through the centre pixel position is the viewing axis -Z. */
    float o[3], d[3];
    esr_camera_ray(&cam, 80.0f, 60.0f, o, d);
    for (int k = 0; k < 3; k++)
        assert_float_equal(d[k], -cam.c2w[k][2], 1e-6);
}

/* The orbit: camera k of n stands on the first one's level circle around the centre's vertical
 * axis, k / n of a turn on (counter-clockwise seen from above), looks at the centre (it projects
 * to the image centre), keeps +Z up (the image's up vector has no sideways tilt) and is a
 * rotation; a first camera straight above the centre is refused. */
static void test_orbit(void **state)
{
    (void)state;
    const float eye[3] = {2.5f, -3.0f, 1.5f}, centre[3] = {0.2f, 0.1f, 0.3f};
    struct esr_camera first;
    look_at_origin(eye, &first);
    first.width = 64;
    first.height = 48;
    first.focal = 50.0f;
    const float r0 = hypotf(eye[0] - centre[0], eye[1] - centre[1]);
    const float phi0 = atan2f(eye[1] - centre[1], eye[0] - centre[0]);
    const int n = 8;
    for (int k = 0; k < n; k++) {
        struct esr_camera c;
        assert_int_equal(esr_camera_orbit(&first, centre, k, n, &c), ESR_OK);
        assert_int_equal(c.width, 64);
        assert_float_equal(c.focal, 50.0f, 0.0f);
        const float phi = phi0 + 2.0f * (float)M_PI * (float)k / (float)n;
        assert_float_equal(c.c2w[0][3], centre[0] + r0 * cosf(phi), 1e-5);
        assert_float_equal(c.c2w[1][3], centre[1] + r0 * sinf(phi), 1e-5);
        assert_float_equal(c.c2w[2][3], eye[2], 0.0f);
        float px, py;
        assert_int_equal(esr_camera_project(&c, centre, &px, &py), 1);
        assert_float_equal(px, 32.0f, 1e-3);
        assert_float_equal(py, 24.0f, 1e-3);
        assert_float_equal(c.c2w[2][0], 0.0f, 1e-6); /* image right is level */
        assert_true(c.c2w[2][1] > 0.0f);            /* image up points up */
        for (int a = 0; a < 3; a++)
            for (int b = 0; b < 3; b++) {
                double dot = 0.0;
                for (int r = 0; r < 3; r++)
                    dot += (double)c.c2w[r][a] * c.c2w[r][b];
                assert_float_equal(dot, a == b ? 1.0 : 0.0, 1e-5);
            }
    }
    struct esr_camera first_k0;
    assert_int_equal(esr_camera_orbit(&first, centre, 0, n, &first_k0), ESR_OK);
    for (int r = 0; r < 3; r++) /* camera 0 is the first camera itself, re-aimed at the centre */
        assert_float_equal(first_k0.c2w[r][3], eye[r], 1e-5);
    const float above[3] = {centre[0], centre[1], 4.0f};
    struct esr_camera down, out;
    look_at_origin(above, &down);
    esr_error_clear();
    assert_int_equal(esr_camera_orbit(&down, centre, 1, n, &out), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "straight above or below the scene's centre"));
    esr_error_clear();
}

static void test_lamp_cameras(void **state)
{
    (void)state;
    const char *scene = test_shared_scene("lamp");
    if (!scene)
        skip();
    struct esr_dataset ds;
    assert_int_equal(esr_dataset_load(scene, &ds), ESR_OK);
    for (int i = 0; i < ds.phases[ESR_PHASE_TRAIN].n_frames; i += 37)
        check_round_trips(&ds.phases[ESR_PHASE_TRAIN].frames[i].camera);
    check_round_trips(&ds.phases[ESR_PHASE_TEST_NVIC].frames[7].camera);
    esr_dataset_free(&ds);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_focal),
        cmocka_unit_test(test_synthetic_camera),
        cmocka_unit_test(test_orbit),
        cmocka_unit_test(test_lamp_cameras),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
