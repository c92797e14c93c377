/* The lights of the shared tiny run (tests/support/tiny_run.h): the pdra stage finds them and
 * stores them in its checkpoint, `esr lights` lists them, writes them to --json and refuses what
 * it cannot do (no pdra stage, --data without --recompute); lights too dim are not found, a run
 * without lights keeps none; `esr lights --drop` removes lights and recalibrates the others. */
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
#include "model/model.h"
#include "test_support.h"
#include "tiny_run.h"
#include "train/lights/lights.h"
#include "train/trainer.h"

/* The pdra stage, continuing the full run's lts checkpoint (the fixture's run_pdra,
 * tests/support/tiny_fixture_setup.c), ends by finding the lights and storing them in its
 * checkpoint; `esr lights` lists them and writes them to --json, and refuses a run without a pdra
 * stage.
 * Lights too dim: pdra finds none and says so; a run without lights: `esr lights` keeps none and
 * edits are refused. */
static void test_pdra_finds_lights(void **state)
{
    (void)state;
    char run[4300], cmd[24000], out[8192];
    /* `esr lights --json` below writes into the run: a copy of it */
    tiny_copy_run("run_pdra", "run_pdra", run, sizeof run);
    struct esr_train_opts o;
    struct log_capture lc;
    tiny_read_log("pdra", &lc); /* what the fixture's pdra training reported */
    print_message("%s", strstr(lc.text, "lights found") ? strstr(lc.text, "lights found") : lc.text);
    assert_non_null(strstr(lc.text, "lights found: "));
    /* checkpoints but no config.json: --resume says it resumes them with the options given */
    assert_non_null(strstr(lc.text, "has no config.json: its checkpoints (ckpt_alphamask.bin"));
    assert_non_null(strstr(lc.text, "are resumed with the options given now"));
    struct esr_model m;
    snprintf(cmd, sizeof cmd, "%s/ckpt_pdra.bin", run);
    assert_int_equal(esr_model_load(&m, cmd), ESR_OK);
    assert_true(m.lights.n >= 0 && m.lights.n <= ESR_MAX_LIGHTS);
    for (int i = 0; i < m.lights.n; i++) {
        const struct esr_light *l = &m.lights.light[i];
        assert_true(l->points > 0 && l->area > 0.0f);
        for (int c = 0; c < 3; c++)
            assert_true(isfinite(l->scale[c]) && l->scale[c] >= 0.0f);
    }
    snprintf(cmd, sizeof cmd, "lights %s --data /nonexistent", run);
    assert_int_equal(test_run_esr(cmd, out, sizeof out), 1);
    assert_non_null(strstr(out, "--data is read only with --recompute"));
    snprintf(cmd, sizeof cmd, "lights %s --json %s/lights.json", run, run); /* listing alone writes nothing */
    assert_int_equal(test_run_esr(cmd, out, sizeof out), 0);
    snprintf(cmd, sizeof cmd, "%d light", m.lights.n);
    assert_non_null(strstr(out, cmd));
    snprintf(cmd, sizeof cmd, "%s/lights.json", run);
    unsigned char *text;
    size_t size;
    assert_int_equal(esr_file_read_all(cmd, &text, &size), ESR_OK);
    cJSON *root = cJSON_ParseWithLength((const char *)text, size);
    free(text);
    assert_non_null(root);
    assert_int_equal(cJSON_GetArraySize(cJSON_GetObjectItem(root, "lights")), m.lights.n);
    long unseen[ESR_MAX_LIGHTS];
    esr_lights_unseen_points(&m.lights, unseen);
    for (int i = 0; i < m.lights.n; i++) { /* whether its strength was fitted; its unseen part */
        const cJSON *lt = cJSON_GetArrayItem(cJSON_GetObjectItem(root, "lights"), i);
        const cJSON *f = cJSON_GetObjectItem(lt, "strength_fitted");
        assert_true(cJSON_IsBool(f));
        assert_int_equal(cJSON_IsTrue(f), esr_light_strength_fitted(&m.lights, i));
        const cJSON *u = cJSON_GetObjectItem(lt, "unseen_points");
        assert_true(cJSON_IsNumber(u));
        assert_true(u->valuedouble == (double)unseen[i] && unseen[i] <= m.lights.light[i].points);
    }
    cJSON_Delete(root);
    char edit_out[4400];
    snprintf(edit_out, sizeof edit_out, "%s/edit_bad", test_tmpdir);
    /* a run whose pdra stage never ran (the full run stops after lts) */
    snprintf(cmd, sizeof cmd, "lights %s/runs/full", tiny_dir);
    assert_int_equal(test_run_esr(cmd, out, sizeof out), 1);
    assert_non_null(strstr(out, "has no pdra checkpoint"));

    /* lights too dim for the threshold: the pdra stage ends with none and says so (decided over
     * the whole surface the cameras see, not over the last batch's rays) */
    char dim_run[4400];
    snprintf(dim_run, sizeof dim_run, "%s/run_dim", test_tmpdir);
    snprintf(cmd, sizeof cmd, "mkdir -p '%s' && cp '%s'/runs/full/ckpt_*.bin '%s'/", dim_run,
             tiny_dir, dim_run);
    assert_int_equal(system(cmd), 0);
    opts_for(&o, dim_run, ESR_STAGE_PDRA, &lc);
    o.resume = 1;
    o.cfg.pdra_k0 = o.cfg.pdra_k_end = 1e3f; /* far above any emission the field learned */
    if (esr_train_run(&o) != ESR_OK)
        fail_msg("%s", esr_error_message());
    assert_non_null(strstr(lc.text, "no emitters found: no surface point"));
    assert_null(strstr(lc.text, "lights found"));
    snprintf(cmd, sizeof cmd, "%s/ckpt_pdra.bin", dim_run);
    struct esr_model dim;
    assert_int_equal(esr_model_load(&dim, cmd), ESR_OK);
    assert_int_equal(dim.lights.n, 0);
    assert_true(dim.stage_done);
    esr_model_free(&dim);

    /* a run whose pdra stage found no emitters: `esr lights` keeps none and says so (it used to
     * search again whenever the set was empty, inventing lights), and edits are refused */
    char none_run[4400];
    snprintf(none_run, sizeof none_run, "%s/run_no_lights", test_tmpdir);
    copy_run_changed(run, none_run, remove_lights);
    struct esr_model none;
    snprintf(cmd, sizeof cmd, "lights %s", none_run);
    assert_int_equal(test_run_esr(cmd, out, sizeof out), 0);
    assert_non_null(strstr(out, "0 lights"));
    assert_non_null(strstr(out, "found no emitters"));
    snprintf(cmd, sizeof cmd, "%s/ckpt_pdra.bin", none_run);
    assert_int_equal(esr_model_load(&none, cmd), ESR_OK);
    assert_int_equal(none.lights.n, 0);
    esr_model_free(&none);
    expect_edit_refused(none_run, edit_out, "no lights");
    esr_model_free(&m);
}

/* esr lights --drop: the named lights leave the checkpoint (a reflection the user judges no
 * light), the others are calibrated again; bad ids and --drop with --recompute are refused with
 * nothing changed. */
static void test_lights_drop(void **state)
{
    (void)state;
    char run[4300], cmd[24000], out[16384];
    snprintf(run, sizeof run, "%s/run_drop", test_tmpdir);
    snprintf(cmd, sizeof cmd, "mkdir -p '%s' && cp '%s'/run_pdra/config.json '%s'/run_pdra/run.json "
             "'%s'/run_pdra/ckpt_pdra.bin '%s'/", run, tiny_dir, tiny_dir, tiny_dir, run);
    assert_int_equal(system(cmd), 0);
    struct esr_model m;
    snprintf(cmd, sizeof cmd, "%s/ckpt_pdra.bin", run);
    assert_int_equal(esr_model_load(&m, cmd), ESR_OK);
    const int n = m.lights.n;
    struct esr_light last = m.lights.light[n > 0 ? n - 1 : 0];
    esr_model_free(&m);
    if (n == 0)
        skip(); /* test_pdra_finds_lights prints how many the tiny run found */
    snprintf(cmd, sizeof cmd, "lights '%s' --drop %d", run, n);
    assert_int_equal(test_run_esr(cmd, out, sizeof out), 1);
    assert_non_null(strstr(out, "expected light ids from 0 to"));
    snprintf(cmd, sizeof cmd, "lights '%s' --drop 0 --recompute", run);
    assert_int_equal(test_run_esr(cmd, out, sizeof out), 1);
    assert_non_null(strstr(out, "drop them after a --recompute"));
    snprintf(cmd, sizeof cmd, "%s/ckpt_pdra.bin", run);
    assert_int_equal(esr_model_load(&m, cmd), ESR_OK);
    assert_int_equal(m.lights.n, n); /* refused: nothing changed */
    esr_model_free(&m);
    snprintf(cmd, sizeof cmd, "lights '%s' --drop ''", run);
    assert_int_equal(test_run_esr(cmd, out, sizeof out), 1);
    assert_non_null(strstr(out, "expected light ids from 0 to"));
    snprintf(cmd, sizeof cmd, "lights '%s' --drop 0 --data '%s'", run, data_dir);
    if (n == 1) { /* the only light: refused, renders would fall back to the raw field */
        assert_int_equal(test_run_esr(cmd, out, sizeof out), 1);
        assert_non_null(strstr(out, "would leave no lights"));
        return;
    }
    if (test_run_esr(cmd, out, sizeof out) != 0)
        fail_msg("esr %s:\n%s", cmd, out);
    assert_non_null(strstr(out, "dropped light 0"));
    snprintf(cmd, sizeof cmd, "%s/ckpt_pdra.bin", run);
    assert_int_equal(esr_model_load(&m, cmd), ESR_OK);
    assert_int_equal(m.lights.n, n - 1);
    const struct esr_light *moved = &m.lights.light[n - 2]; /* the last light, one id down */
    assert_int_equal(moved->points, last.points);
    assert_float_equal(moved->area, last.area, 0.0f);
    for (int a = 0; a < 3; a++)
        assert_float_equal(moved->centroid[a], last.centroid[a], 0.0f);
    esr_model_free(&m);
    snprintf(cmd, sizeof cmd, "lights '%s' --drop 0 --data '%s'", run, data_dir);
    if (n == 2) { /* dropping the one light left is refused too */
        assert_int_equal(test_run_esr(cmd, out, sizeof out), 1);
        assert_non_null(strstr(out, "would leave no lights"));
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_pdra_finds_lights),
        cmocka_unit_test(test_lights_drop),
    };
    return cmocka_run_group_tests(tests, tiny_setup, test_teardown_tmpdir);
}
