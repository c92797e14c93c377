/* `esr export --gltf` of the shared tiny run's pdra model (tests/support/tiny_run.h): the light
 * nodes, and the asset checked by the Khronos glTF validator. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "io/file.h"
#include "model/model.h"
#include "test_support.h"
#include "tiny_run.h"

/* The relightable glTF of the pdra run (`esr export --gltf`, render/model_gltf): one node per
 * light (at a coarse --res, a light without a triangle said and not counted), the surface in as
 * many materials as its roughness and metallic call for (at most --materials), and valid for the
 * Khronos validator when it is installed (make test-tools). From test_pdra_finds_lights. */
static void test_export_gltf_light_nodes(void **state)
{
    (void)state;
    char run[4300], cmd[24000], out[8192];
    struct esr_model m;
    tiny_copy_run_model("run_pdra", "run_pdra", run, sizeof run, &m);

    /* the relightable glTF: one node per light, and valid for the Khronos validator */
    char glb[4400];
    snprintf(glb, sizeof glb, "%s/scene.glb", test_tmpdir);
    snprintf(cmd, sizeof cmd, "export %s --gltf %s", run, glb);
    assert_int_equal(test_run_esr(cmd, out, sizeof out), 0);
    snprintf(cmd, sizeof cmd, "%d light node(s)", m.lights.n);
    assert_non_null(strstr(out, cmd));
    /* the surface in 1..8 materials by its roughness and metallic; --materials 1: one */
    const char *mats = strstr(out, "the surface's ");
    int n_mat = 0;
    assert_non_null(mats);
    assert_int_equal(sscanf(mats, "the surface's %d material(s)", &n_mat), 1);
    print_message("glTF: %d material(s) for the surface\n", n_mat);
    assert_true(n_mat >= 1 && n_mat <= 8);
    snprintf(cmd, sizeof cmd, "export %s --gltf %s --materials 1", run, glb);
    assert_int_equal(test_run_esr(cmd, out, sizeof out), 0);
    assert_non_null(strstr(out, "the surface's 1 material(s)"));
    snprintf(cmd, sizeof cmd, "export %s --gltf %s --materials 17", run, glb);
    assert_int_not_equal(test_run_esr(cmd, out, sizeof out), 0);
    /* at a coarse --res a light may get no triangle: then it is said, and not counted */
    snprintf(cmd, sizeof cmd, "export %s --gltf %s --res 8", run, glb);
    assert_int_equal(test_run_esr(cmd, out, sizeof out), 0);
    int nodes = -1, unsaid = 0;
    const char *said = strstr(out, "the surface and ");
    assert_non_null(said);
    assert_int_equal(sscanf(said, "the surface and %d light node(s)", &nodes), 1);
    for (const char *w = out; (w = strstr(w, "has no triangle at this resolution")); w++)
        unsaid++;
    print_message("glTF at --res 8: %d light node(s), %d without\n", nodes, unsaid);
    assert_int_equal(nodes + unsaid, m.lights.n);
    snprintf(cmd, sizeof cmd, "export %s --gltf %s", run, glb); /* the full one, validated below */
    assert_int_equal(test_run_esr(cmd, out, sizeof out), 0);
    if (esr_file_exists(ESR_GLTF_VALIDATOR "/package.json")) {
        snprintf(cmd, sizeof cmd, "node '%s/validate_gltf.js' '%s' '%s' 2>&1", ESR_TEST_SUPPORT_DIR,
                 ESR_GLTF_VALIDATOR, glb);
        FILE *pipe = popen(cmd, "r");
        assert_non_null(pipe);
        size_t got = fread(out, 1, sizeof out - 1, pipe);
        out[got] = '\0';
        const int status = pclose(pipe);
        print_message("%s", out);
        assert_int_equal(status, 0);
        assert_non_null(strstr(out, " 0 errors"));
    } else {
        print_message("SKIPPED the glTF validation: %s is not installed (make test-tools)\n",
                      ESR_GLTF_VALIDATOR);
    }
    esr_model_free(&m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_export_gltf_light_nodes),
    };
    return cmocka_run_group_tests(tests, tiny_setup, test_teardown_tmpdir);
}
