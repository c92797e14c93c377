/* `esr edit` end to end on the shared tiny run's pdra model (tests/support/tiny_run.h): bad
 * edits refused with a clear message and nothing written; the views it writes (one render for a
 * camera's off and on frames, folders it must not write into, a failed view removing the
 * others, the direct relight linear in the intensity). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "io/dir.h"
#include "io/file.h"
#include "io/image.h"
#include "model/model.h"
#include "test_support.h"
#include "tiny_run.h"

/* esr edit refuses bad edits with a clear message and writes nothing: a run without a pdra
 * stage, an unfinished one, and every malformed option. From test_pdra_finds_lights. */
static void test_edit_refuses_bad_edits(void **state)
{
    (void)state;
    char run[4300], cmd[24000], out[8192];
    tiny_copy_run("run_pdra", "run_pdra_bad_edits", run, sizeof run);
    static const struct {
        const char *args, *message;
    } bad[] = {
        {"--light 15 --intensity 0", "no light 15"},
        {"--light all --intensity -1", "--intensity: expected a number >= 0 and at most"},
        {"--light all --intensity nan", "--intensity: expected a number >= 0 and at most"},
        {"--light all --intensity 0x10", "--intensity: expected a number >= 0 and at most"},
        {"--light all --intensity ' 1'", "--intensity: expected a number >= 0 and at most"},
        {"--light +0 --intensity 2", "--light: expected a light id"},
        {"--light 0 --color 1.5,0.2", "--color: expected H,S with both in [0,1]"},
        {"--light 0 --method relit", "--method: expected direct, ratio or finetune"},
        {"--light 0 --method finetune --iters 0", "--iters: expected 1..1000000"},
        {"--light 0 --intensity 2 --iters 5", "--iters is read only with --method finetune"},
        {"--light 0 --intensity 2 --frames c000_on", "--frames and --orbit exclude each other"},
        {"--light 0 --intensity 2 --spp 2 --spp 3", "--spp given twice"},
        {"--light 0 --intensity 2 --intensity 3", "--intensity given twice after one --light"},
        {"--intensity 2", "--intensity before any --light"},
        {"--light all --intensity 1e40", "--intensity: expected a number >= 0 and at most"},
        {"--light 0 --intensity 2 --light 1", "--light 1 has no --intensity or --color"},
    };
    char edit_out[4400];
    snprintf(edit_out, sizeof edit_out, "%s/edit_bad", test_tmpdir);
    /* a run whose pdra stage never ran (the full run stops after lts) */
    snprintf(cmd, sizeof cmd, "edit %s/runs/full --light 0 --intensity 0 --out %s --orbit 1",
             tiny_dir, edit_out);
    assert_int_equal(test_run_esr(cmd, out, sizeof out), 1);
    assert_non_null(strstr(out, "has no pdra checkpoint"));
    assert_false(esr_file_exists(edit_out));
    /* a pdra stage stopped before its end (its periodic checkpoint) */
    char unfinished[4400];
    snprintf(unfinished, sizeof unfinished, "%s/run_pdra_unfinished", test_tmpdir);
    copy_run_changed(run, unfinished, make_unfinished);
    expect_edit_refused(unfinished, edit_out, "the pdra stage has not finished (step 20)");
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        snprintf(cmd, sizeof cmd, "edit %s %s --out %s --orbit 1", run, bad[i].args, edit_out);
        assert_int_equal(test_run_esr(cmd, out, sizeof out), 1);
        if (!strstr(out, bad[i].message))
            fail_msg("esr %s: expected '%s' in:\n%s", cmd, bad[i].message, out);
        assert_false(esr_file_exists(edit_out));
    }
}

/* esr edit on the pdra run: a phase's off and on frames of one camera rendered once, groups
 * that add up and two that set one thing refused, output folders inside the dataset or the run's
 * renders refused, a view that cannot be written removes the views before it, an output folder
 * that cannot be created, and the direct part linear in the intensity (a tiny run that found no
 * lights: its edit refused). From test_pdra_finds_lights. */
static void test_edit_writes_views(void **state)
{
    (void)state;
    char run[4300], cmd[24000], out[8192];
    struct esr_model m;
    tiny_copy_run_model("run_pdra", "run_pdra_views", run, sizeof run, &m);
    char edit_out[4400];
    snprintf(edit_out, sizeof edit_out, "%s/edit_bad", test_tmpdir);

    if (m.lights.n > 0) {
        /* a phase's off and on frames of one camera: one render, written under both names */
        char views_out[4400], a_png[4500], b_png[4500];
        snprintf(views_out, sizeof views_out, "%s/edit_views", test_tmpdir);
        snprintf(cmd, sizeof cmd, "edit %s --light 0 --intensity 0 --views test_nv --out %s", run,
                 views_out);
        if (test_run_esr(cmd, out, sizeof out) != 0)
            fail_msg("esr %s: %s", cmd, out);
        assert_non_null(strstr(out, "(the previous frame's camera: its view)"));
        snprintf(a_png, sizeof a_png, "%s/c000_off.exr", views_out);
        snprintf(b_png, sizeof b_png, "%s/c000_on.exr", views_out);
        assert_true(test_files_equal(a_png, b_png));
        /* groups add up; two that set one thing for one light are refused */
        snprintf(cmd, sizeof cmd, "edit %s --light all --intensity 0 --light 0 --intensity 2 --out "
                 "%s --orbit 1", run, edit_out);
        assert_int_equal(test_run_esr(cmd, out, sizeof out), 1);
        assert_non_null(strstr(out, "light 0 gets its --intensity from two groups (--light all "
                                    "and --light 0)"));
        assert_false(esr_file_exists(edit_out));
        /* an output folder inside the dataset or the run's renders would replace their files */
        const char *inside[2] = {data_dir, run};
        for (int k = 0; k < 2; k++) {
            snprintf(cmd, sizeof cmd, "edit %s --light 0 --intensity 2 --out %s/%s --orbit 1", run,
                     inside[k], k ? "render/test_nv" : "test_nv");
            assert_int_equal(test_run_esr(cmd, out, sizeof out), 1);
            if (!strstr(out, k ? "lies inside the run's render folder" : "lies inside the dataset"))
                fail_msg("esr %s: %s", cmd, out);
        }
        /* a view that cannot be written: the views written before it are removed */
        char blocked[4400];
        snprintf(blocked, sizeof blocked, "%s/edit_blocked/orbit_001.png", test_tmpdir);
        assert_int_equal(esr_dir_create(blocked), ESR_OK);
        snprintf(cmd, sizeof cmd, "edit %s --light all --color 0.6,1 --light 0 --intensity 2 --out "
                 "%s/edit_blocked --orbit 3", run, test_tmpdir);
        assert_int_equal(test_run_esr(cmd, out, sizeof out), 1);
        assert_non_null(strstr(out, "orbit_001.png"));
        const char *gone[3] = {"orbit_000.exr", "orbit_000.png", "orbit_001.exr"};
        for (int k = 0; k < 3; k++) {
            snprintf(cmd, sizeof cmd, "%s/edit_blocked/%s", test_tmpdir, gone[k]);
            assert_false(esr_file_exists(cmd));
        }
        /* an output folder that cannot be created */
        snprintf(cmd, sizeof cmd, "edit %s --light all --intensity 0 --out /proc/esr_cannot --orbit 1",
                 run);
        assert_int_equal(test_run_esr(cmd, out, sizeof out), 1);
        assert_non_null(strstr(out, "/proc/esr_cannot"));
        /* every light off, and doubled: the direct part is linear in the intensity */
        char off_dir[4400], one_dir[4400], two_dir[4400];
        const char *dirs[3] = {off_dir, one_dir, two_dir}, *gain[3] = {"0", "1", "2"};
        snprintf(off_dir, sizeof off_dir, "%s/edit_off", test_tmpdir);
        snprintf(one_dir, sizeof one_dir, "%s/edit_one", test_tmpdir);
        snprintf(two_dir, sizeof two_dir, "%s/edit_two", test_tmpdir);
        struct esr_image img[3];
        for (int k = 0; k < 3; k++) {
            snprintf(cmd, sizeof cmd, "edit %s --light all --intensity %s --out %s --orbit 2",
                     run, gain[k], dirs[k]);
            assert_int_equal(test_run_esr(cmd, out, sizeof out), 0);
            snprintf(cmd, sizeof cmd, "%s/orbit_001.exr", dirs[k]);
            assert_int_equal(esr_exr_read(cmd, &img[k]), ESR_OK);
        }
        double worst = 0.0;
        for (size_t p = 0; p < (size_t)img[0].width * img[0].height; p++)
            for (int c = 0; c < 3; c++) {
                const float base = img[0].data[p * 4 + c], a = img[1].data[p * 4 + c] - base,
                            b = img[2].data[p * 4 + c] - base;
                assert_true(a >= -1e-6f); /* lights only add light */
                worst = fmax(worst, fabs(b - 2.0 * a));
            }
        print_message("edit: intensity 2 adds twice what intensity 1 adds (worst %.2g)\n", worst);
        assert_true(worst < 1e-4);
        for (int k = 0; k < 3; k++)
            esr_image_free(&img[k]);
    } else {
        snprintf(cmd, sizeof cmd, "edit %s --light all --intensity 0 --out %s --orbit 1", run, edit_out);
        assert_int_equal(test_run_esr(cmd, out, sizeof out), 1);
        assert_non_null(strstr(out, "no lights"));
    }
    esr_model_free(&m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_edit_refuses_bad_edits),
        cmocka_unit_test(test_edit_writes_views),
    };
    return cmocka_run_group_tests(tests, tiny_setup, test_teardown_tmpdir);
}
