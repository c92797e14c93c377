/* Resuming the emitter stages on the tiny dataset (tests/support/tiny_run.h), in runs of their
 * own: a run stopped at a stage's end (--until fine) and one killed inside lts and again inside
 * pdra, each resumed, end with checkpoints bitwise those of a run that never stopped. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "model/model.h"
#include "test_support.h"
#include "tiny_run.h"
#include "train/trainer.h"

/* A run stopped at a stage's end (--until fine) and resumed trains the later stages exactly as
 * a run that never stopped: the in-memory model carries nothing into them that its checkpoint
 * does not (the fine model's inv-s was one step behind: lts renders it for the environment map's
 * starting level, so every lts parameter came out a few ulp off). */
static void test_resume_at_stage_boundary_is_exact(void **state)
{
    (void)state;
    char straight[4200], cut[4200], pa[4300], pb[4300];
    run_dir_pair(straight, cut, "boundary");
    struct esr_train_opts o;
    opts_for(&o, straight, ESR_STAGE_PDRA, NULL);
    assert_int_equal(esr_train_run(&o), 0);
    opts_for(&o, cut, ESR_STAGE_FINE, NULL);
    assert_int_equal(esr_train_run(&o), 0);
    opts_for(&o, cut, ESR_STAGE_PDRA, NULL);
    o.resume = 1;
    assert_int_equal(esr_train_run(&o), 0);
    const char *stages[] = {"lts", "pdra"};
    for (int i = 0; i < 2; i++) {
        snprintf(pa, sizeof pa, "%s/ckpt_%s.bin", straight, stages[i]);
        snprintf(pb, sizeof pb, "%s/ckpt_%s.bin", cut, stages[i]);
        assert_same_model(pa, pb);
    }
}

/* Killed inside lts and again inside pdra (the last checkpoints at lts step 20 and pdra step 20
 * of 60 and 40, saved every 20) and resumed each time: both stages end exactly as in the straight
 * run of test_resume_at_stage_boundary_is_exact. The LTS normals are a smoothed copy of the SDF,
 * refreshed every 50 steps; a resumed stage computes them from the checkpoint's SDF, so the
 * straight run must refresh them where it saves a checkpoint too (before, a run resumed at lts
 * step 20 used step-20 normals where the straight run used step 0's until step 50). */
static void test_resume_inside_lts_and_pdra_is_exact(void **state)
{
    (void)state;
    char straight[4200], cut[4200], pa[4300], pb[4300], cmd[16384];
    run_dir_pair(straight, cut, "boundary"); /* the straight run trained to pdra */
    snprintf(cut, sizeof cut, "%s/cut_inside", test_tmpdir);
    const char *from_straight[] = {"config.json", "ckpt_alphamask.bin", "ckpt_coarse.bin",
                                   "ckpt_fine.bin"};
    for (int i = 0; i < 4; i++) {
        snprintf(cmd, sizeof cmd, "mkdir -p '%s' && cp '%s/%s' '%s/'", cut, straight,
                 from_straight[i], cut);
        assert_int_equal(system(cmd), 0);
    }
    const enum esr_stage stop_in[] = {ESR_STAGE_LTS, ESR_STAGE_PDRA};
    struct esr_train_opts o;
    for (int i = 0; i < 2; i++) {
        opts_for(&o, cut, ESR_STAGE_PDRA, NULL);
        o.resume = 1;
        o.stop_test_stage = stop_in[i];
        o.stop_test_iter = 30;
        if (esr_train_run(&o) != ESR_OK)
            fail_msg("%s", esr_error_message());
        snprintf(pb, sizeof pb, "%s/ckpt_%s.bin", cut, esr_stage_name(stop_in[i]));
        struct esr_model mid;
        assert_int_equal(esr_model_load(&mid, pb), 0);
        assert_int_equal(mid.step, 20);
        assert_int_equal(mid.stage_done, 0);
        esr_model_free(&mid);
    }
    opts_for(&o, cut, ESR_STAGE_PDRA, NULL);
    o.resume = 1;
    if (esr_train_run(&o) != ESR_OK)
        fail_msg("%s", esr_error_message());
    for (int i = 0; i < 2; i++) {
        snprintf(pa, sizeof pa, "%s/ckpt_%s.bin", straight, esr_stage_name(stop_in[i]));
        snprintf(pb, sizeof pb, "%s/ckpt_%s.bin", cut, esr_stage_name(stop_in[i]));
        assert_same_model(pa, pb);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_resume_at_stage_boundary_is_exact),
        cmocka_unit_test(test_resume_inside_lts_and_pdra_is_exact),
    };
    return cmocka_run_group_tests(tests, tiny_setup, test_teardown_tmpdir);
}
