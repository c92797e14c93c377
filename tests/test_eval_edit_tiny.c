/* `esr eval` on an edit phase (test_nvi, direct) of a copy of the shared tiny run's pdra run
 * (tests/support/tiny_run.h): the scores per edit asked, what each esr light was edited as, the
 * warnings without the dataset's light masks, and a frame asking an edit no light can take
 * refused before anything is written. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cjson/cJSON.h>

#include "core/error.h"
#include "model/model.h"
#include "test_support.h"
#include "tiny_run.h"

/* esr eval on an edit phase (test_nvi, direct): the scores, and what each esr light was edited
 * as (the dataset light its pixels overlap most, -1 none); without the dataset's light masks no
 * esr light can follow an edited light, and eval says so instead of scoring unedited frames
 * silently. */
static void test_edit_eval_follows_lights(void **state)
{
    (void)state;
    char run[4300], data[4300], cmd[24000], out[16384];
    snprintf(run, sizeof run, "%s/run_edit_eval", test_tmpdir);
    snprintf(data, sizeof data, "%s/data_no_masks", test_tmpdir);
    snprintf(cmd, sizeof cmd, "mkdir -p '%s' && cp '%s'/run_pdra/config.json '%s'/run_pdra/run.json "
             "'%s'/run_pdra/ckpt_*.bin '%s'/ && cp -r '%s' '%s' && rm -r '%s'/masks", run, tiny_dir,
             tiny_dir, tiny_dir, run, data_dir, data, data);
    assert_int_equal(system(cmd), 0);
    struct esr_model m;
    snprintf(cmd, sizeof cmd, "%s/ckpt_pdra.bin", run);
    assert_int_equal(esr_model_load(&m, cmd), ESR_OK);
    const int n_lights = m.lights.n;
    esr_model_free(&m);
    if (n_lights == 0)
        skip(); /* edits need lights; test_pdra_finds_lights prints how many the tiny run found */
    snprintf(cmd, sizeof cmd, "eval '%s' --data '%s' --phase test_nvi --method direct", run, data_dir);
    int rc = test_run_esr(cmd, out, sizeof out);
    if (rc != 0)
        fail_msg("esr %s: exit %d:\n%s", cmd, rc, out);
    snprintf(cmd, sizeof cmd, "%s/eval/test_nvi_direct.json", run);
    cJSON *root = test_read_json(cmd);
    assert_non_null(root);
    const cJSON *sp = cJSON_GetObjectItemCaseSensitive(root, "light_split");
    const cJSON *follow = cJSON_GetObjectItemCaseSensitive(sp, "esr_lights_follow");
    assert_int_equal(cJSON_GetArraySize(follow), n_lights);
    int following = 0, followed[2] = {0, 0};
    for (int j = 0; j < n_lights; j++) {
        const int k = (int)cJSON_GetArrayItem(follow, j)->valuedouble;
        assert_true(k >= -1 && k < 2);
        following += k >= 0;
        if (k >= 0)
            followed[k] = 1;
    }
    assert_true(following > 0); /* the tiny run always finds the lampshade */
    /* the means per edit asked (the _ind frames apart), in the order the views first ask them:
     * recomputed here from the views */
    const cJSON *views = cJSON_GetObjectItemCaseSensitive(root, "views");
    const cJSON *by_edit = cJSON_GetObjectItemCaseSensitive(root, "by_edit");
    assert_int_equal(cJSON_GetArraySize(by_edit), 3); /* x0.5 both, x2 both, lampshade off */
    int grouped = 0, first_seen = 0;
    const char *edits[3];
    for (int g = 0; g < 3; g++) {
        const cJSON *grp = cJSON_GetArrayItem(by_edit, g);
        const cJSON *edit = cJSON_GetObjectItemCaseSensitive(grp, "edit");
        assert_true(cJSON_IsString(edit));
        edits[g] = edit->valuestring;
        for (int h = 0; h < g; h++)
            assert_string_not_equal(edits[h], edits[g]);
        double psnr = 0.0, ssim = 0.0;
        int count = 0, first = -1;
        for (int i = 0; i < cJSON_GetArraySize(views); i++) {
            const cJSON *v = cJSON_GetArrayItem(views, i);
            const cJSON *ve = cJSON_GetObjectItemCaseSensitive(v, "edit");
            assert_true(cJSON_IsString(ve));
            if (!strcmp(ve->valuestring, edits[g])) {
                psnr += cJSON_GetObjectItemCaseSensitive(v, "psnr")->valuedouble;
                ssim += cJSON_GetObjectItemCaseSensitive(v, "ssim")->valuedouble;
                first = first < 0 ? i : first;
                count++;
            }
        }
        assert_true(count > 0 && (g == 0 ? first == 0 : first > first_seen)); /* asked order */
        first_seen = first;
        const double n_views = cJSON_GetObjectItemCaseSensitive(grp, "n_views")->valuedouble;
        const double g_psnr = cJSON_GetObjectItemCaseSensitive(grp, "psnr")->valuedouble;
        const double g_ssim = cJSON_GetObjectItemCaseSensitive(grp, "ssim")->valuedouble;
        assert_int_equal((int)n_views, count);
        assert_true(fabs(g_psnr - psnr / count) < 1e-9 && fabs(g_ssim - ssim / count) < 1e-12);
        grouped += count;
    }
    assert_int_equal(grouped, cJSON_GetArraySize(views));
    assert_non_null(strstr(out, "edit mean"));
    snprintf(cmd, sizeof cmd, "grep -q 'Mean per edit asked' '%s'/report_test_nvi_direct.html",
             run);
    assert_int_equal(system(cmd), 0);
    /* a dataset light no esr light follows (one the tiny run did not find) is in the JSON and
     * warned about, and only such a light */
    const cJSON *unmatched = cJSON_GetObjectItemCaseSensitive(sp, "edited_lights_unmatched");
    assert_int_equal(cJSON_GetArraySize(unmatched), 2 - followed[0] - followed[1]);
    for (int k = 0; k < 2; k++) {
        char warning[96];
        snprintf(warning, sizeof warning, "warning: dataset light %d is edited", k);
        assert_true((strstr(out, warning) != NULL) == !followed[k]);
    }
    cJSON_Delete(root);
    /* the same without masks: every edited light unmatched, said */
    snprintf(cmd, sizeof cmd, "eval '%s' --data '%s' --phase test_nvi --method direct", run, data);
    rc = test_run_esr(cmd, out, sizeof out);
    if (rc != 0)
        fail_msg("esr %s: exit %d:\n%s", cmd, rc, out);
    if (!strstr(out, "warning: dataset light 0 is edited by 9 frame(s), but no esr light follows it"))
        fail_msg("esr %s said:\n%s", cmd, out);
    /* light 1 stays as it is in the _ind frames (x1): 6 of its 9 frames change it */
    if (!strstr(out, "warning: dataset light 1 is edited by 6 frame(s)"))
        fail_msg("esr %s said:\n%s", cmd, out);
    snprintf(cmd, sizeof cmd, "%s/eval/test_nvi_direct.json", run);
    root = test_read_json(cmd);
    assert_non_null(root);
    sp = cJSON_GetObjectItemCaseSensitive(root, "light_split");
    assert_int_equal(cJSON_GetArraySize(cJSON_GetObjectItemCaseSensitive(sp, "edited_lights_unmatched")), 2);
    cJSON_Delete(root);
    /* a frame asking an edit no light can take (x2e6: past esr's cap, where the radiance leaves
     * float) is refused, naming it, before anything is written */
    snprintf(data, sizeof data, "%s/data_edit_too_strong", test_tmpdir);
    snprintf(cmd, sizeof cmd, "cp -r '%s' '%s' && rm -r '%s'/render/test_nvi_direct '%s'/eval", data_dir,
             data, run, run);
    assert_int_equal(system(cmd), 0);
    snprintf(cmd, sizeof cmd, "%s/transforms/transforms_test_nvi.json", data);
    root = test_read_json(cmd);
    assert_non_null(root);
    const cJSON *frame = cJSON_GetArrayItem(cJSON_GetObjectItemCaseSensitive(root, "frames"), 0);
    cJSON *light = cJSON_GetArrayItem(cJSON_GetObjectItemCaseSensitive(frame, "lights"), 0);
    cJSON_SetNumberValue(cJSON_GetObjectItemCaseSensitive(light, "intensity"), 2e6);
    char *text = cJSON_Print(root), name[128];
    snprintf(name, sizeof name, "%s", cJSON_GetObjectItemCaseSensitive(frame, "file_path")->valuestring);
    cJSON_Delete(root);
    assert_int_equal(test_write_file(cmd, text), 0);
    free(text);
    snprintf(cmd, sizeof cmd, "eval '%s' --data '%s' --phase test_nvi --method direct", run, data);
    assert_int_not_equal(test_run_esr(cmd, out, sizeof out), 0);
    char want[256];
    snprintf(want, sizeof want, "frame %s asks dataset light 0 for an edit esr cannot make: intensity "
             "2e+06 is not a number in [0, 1e+06]", strrchr(name, '/') + 1);
    if (!strstr(out, want))
        fail_msg("esr %s said:\n%s\n(expected: %s)", cmd, out, want);
    snprintf(cmd, sizeof cmd, "%s/render/test_nvi_direct", run);
    assert_int_not_equal(access(cmd, F_OK), 0);
    snprintf(cmd, sizeof cmd, "%s/eval", run);
    assert_int_not_equal(access(cmd, F_OK), 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_edit_eval_follows_lights),
    };
    return cmocka_run_group_tests(tests, tiny_setup, test_teardown_tmpdir);
}
