/* `esr demo` after its training, on a copy of the shared tiny run's pdra run
 * (tests/support/tiny_run.h): its later steps (lights, one edit per light, eval, export,
 * lightmix) end to end with the arguments it gives them. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/colour.h"
#include "core/error.h"
#include "io/file.h"
#include "model/model.h"
#include "test_support.h"
#include "tiny_run.h"

/* `esr demo` after its training (a copy of the fixture's run_pdra in place, so the training
 * step resumes finished stages): its later steps, lights, one edit per light, eval and export,
 * run end to end with the arguments it gives them. The demo's own scene takes ten minutes to
 * train, so only this half of it can be tested here (a --data it passed to `esr lights` was
 * refused once, and nothing but a full demo noticed). */
static void test_demo_steps_after_training(void **state)
{
    (void)state;
    char demo[4300], cmd[24576];
    static char out[1 << 18];
    snprintf(demo, sizeof demo, "%s/demo", test_tmpdir);
    snprintf(cmd, sizeof cmd, "mkdir -p '%s/run' && cp '%s'/run_pdra/config.json "
             "'%s'/run_pdra/run.json '%s'/run_pdra/ckpt_*.bin '%s/run/'", demo, tiny_dir,
             tiny_dir, tiny_dir, demo);
    assert_int_equal(system(cmd), 0);
    snprintf(cmd, sizeof cmd, "demo --out '%s' --data '%s'", demo, data_dir);
    const int rc = test_run_esr(cmd, out, sizeof out);
    if (rc != 0)
        fail_msg("esr %s: exit %d:\n%s", cmd, rc, out);
    assert_non_null(strstr(out, "demo finished"));
    const char *made[] = {"run/lights.json", "run/lights.png", "run/eval/test_nv.json",
                          "run/report.html", "mesh.ply", "info.json", "run/lightmix/index.html",
                          "run/lightmix/orbit_015.exr", "run/lightmix/orbit_015.js"};
    for (size_t i = 0; i < sizeof made / sizeof made[0]; i++) {
        snprintf(cmd, sizeof cmd, "%s/%s", demo, made[i]);
        if (!esr_file_exists(cmd))
            fail_msg("esr demo did not write %s", cmd);
    }
    /* each light recoloured to the hue opposite its own (a fixed 0.6 left a blue light blue) */
    struct esr_model m;
    snprintf(cmd, sizeof cmd, "%s/run/ckpt_pdra.bin", demo);
    assert_int_equal(esr_model_load(&m, cmd), ESR_OK);
    int recoloured = 0;
    for (int k = 0; k < m.lights.n; k++) {
        const float *rgb = m.lights.light[k].radiance;
        if (!(rgb[0] > 0.0f || rgb[1] > 0.0f || rgb[2] > 0.0f))
            continue;
        float hsv[3];
        esr_rgb_to_hsv(rgb, hsv);
        snprintf(cmd, sizeof cmd, "--light %d --color %.3f,1 ", k, fmod((double)hsv[0] + 0.5, 1.0));
        if (!strstr(out, cmd))
            fail_msg("esr demo: no '%s' (light %d's hue %.3f) in its output", cmd, k, (double)hsv[0]);
        recoloured++;
    }
    esr_model_free(&m);
    assert_true(recoloured > 0);
    /* light 0 off and recoloured, as PNG and EXR */
    snprintf(cmd, sizeof cmd, "ls '%s'/run/edits/light0_off/*.png '%s'/run/edits/light0_off/*.exr "
             "'%s'/run/edits/light0_recoloured/*.png > /dev/null 2>&1", demo, demo, demo);
    assert_int_equal(system(cmd), 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_demo_steps_after_training),
    };
    return cmocka_run_group_tests(tests, tiny_setup, test_teardown_tmpdir);
}
