/* The shared tiny run of the *_tiny tests: where it is, its options, and the helpers that train,
 * compare, copy and render it (tiny_run.h). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "tiny_run.h"

#include "core/error.h"
#include "io/file.h"
#include "test_support.h"

#ifndef ESR_TINY_FIXTURE_DIR
#error "ESR_TINY_FIXTURE_DIR must name the tiny run's fixture folder (tests/CMakeLists.txt)"
#endif

static char tiny_path[4096];
const char *tiny_dir = tiny_path;
char data_dir[4096];

int tiny_locate(void)
{
    const char *env = getenv("ESR_TINY_FIXTURE");
    const char *dir = env && *env ? env : ESR_TINY_FIXTURE_DIR;
    if (snprintf(tiny_path, sizeof tiny_path, "%s", dir) >= (int)sizeof tiny_path)
        return -1;
    if (snprintf(data_dir, sizeof data_dir, "%s/data", tiny_dir) >= (int)sizeof data_dir)
        return -1;
    return 0;
}

int tiny_setup(void **state)
{
    char stamp[4200];
    if (tiny_locate() != 0)
        return -1;
    snprintf(stamp, sizeof stamp, "%s/complete", tiny_dir);
    if (!esr_file_exists(stamp)) {
        print_error("the tiny run fixture %s is not complete: run the tests through ctest (it "
                    "runs the fixture test `tiny_fixture_setup` first), or `ctest -R tiny_fixture_setup` "
                    "once before running this program alone\n", tiny_dir);
        return -1;
    }
    return test_setup_tmpdir(state);
}

void tiny_copy_run(const char *name, const char *as, char *run, size_t size)
{
    char cmd[16384];
    assert_true(snprintf(run, size, "%s/%s", test_tmpdir, as) < (int)size);
    snprintf(cmd, sizeof cmd, "mkdir -p '%s' && rmdir '%s' && cp -r '%s/%s' '%s'", run, run, tiny_dir,
             name, run);
    assert_int_equal(system(cmd), 0);
}

void tiny_copy_run_model(const char *name, const char *as, char *run, size_t size,
                         struct esr_model *m)
{
    char path[4400];
    tiny_copy_run(name, as, run, size);
    snprintf(path, sizeof path, "%s/ckpt_pdra.bin", run);
    assert_int_equal(esr_model_load(m, path), ESR_OK);
}

void run_dir_pair(char straight[4200], char cut[4200], const char *test)
{
    snprintf(straight, 4200, "%s/straight_%s", test_tmpdir, test);
    snprintf(cut, 4200, "%s/cut_%s", test_tmpdir, test);
}

void tiny_config(struct esr_train_config *c)
{
    esr_config_defaults(c, ESR_PRESET_FAST);
    c->threads = 1; /* deterministic speed on a loaded machine; results do not depend on it */
    c->batch_rays = 512;
    c->log_every = 20;
    c->save_every = 20;
    c->alphamask.res = 24;
    c->alphamask.iters = 150;
    c->coarse.res = 24;
    c->coarse.iters = 300;
    c->coarse.lr_grid = 2e-2f;
    c->coarse.feat_channels = 6;
    c->coarse.mlp_width = 32;
    c->coarse.s_div = 1.0f;
    c->fine.res = 32;
    c->fine.iters = 300;
    c->fine.mlp_width = 32;
    c->fine.mlp_depth = 2;
    c->fine.s_div = 1.0f;
    c->tone_width = 16;
    c->lts.res = 32;
    c->lts.iters = 60;
    c->pdra.res = 32;
    c->pdra.iters = 40;
    c->lts_points = 64;
    c->lts_dirs = 16;
    c->field_width = 16;
}

void capture(void *user, const struct esr_train_progress *p)
{
    struct log_capture *lc = user;
    if (p->event == ESR_TRAIN_STAGE_DONE && p->seconds > 0.0 && p->iter == p->iters)
        lc->stages_done++;
    if (p->event == ESR_TRAIN_MESSAGE && lc->len < sizeof lc->text - 1)
        lc->len += (size_t)snprintf(lc->text + lc->len, sizeof lc->text - lc->len, "%s\n",
                                    p->message);
}

void assert_checkpoint(const char *run, const char *stage, long step, int done)
{
    char path[4400];
    snprintf(path, sizeof path, "%s/ckpt_%s.bin", run, stage);
    struct esr_model m;
    if (esr_model_load(&m, path) != ESR_OK)
        fail_msg("%s", esr_error_message());
    if (step >= 0)
        assert_int_equal(m.step, step);
    if (done >= 0)
        assert_int_equal(m.stage_done, done);
    esr_model_free(&m);
}

void opts_for(struct esr_train_opts *o, const char *run, enum esr_stage until,
              struct log_capture *lc)
{
    memset(o, 0, sizeof(*o));
    o->data_dir = data_dir;
    o->run_dir = run;
    o->until = until;
    o->nan_test_iter = -1;
    tiny_config(&o->cfg);
    if (lc) {
        lc->len = 0;
        lc->stages_done = 0;
        lc->text[0] = '\0';
        o->report = capture;
        o->user = lc;
    }
}

/* log_<name>.txt: a first line "stages_done N", then the messages as captured. */
int tiny_write_log(const char *path, const struct log_capture *lc)
{
    FILE *f = fopen(path, "wb");
    if (!f)
        return -1;
    int bad = fprintf(f, "stages_done %d\n", lc->stages_done) < 0;
    bad |= fwrite(lc->text, 1, lc->len, f) != lc->len;
    bad |= fclose(f) != 0;
    return bad ? -1 : 0;
}

void tiny_read_log(const char *name, struct log_capture *lc)
{
    char path[4400];
    unsigned char *text;
    size_t size;
    snprintf(path, sizeof path, "%s/log_%s.txt", tiny_dir, name);
    if (esr_file_read_all(path, &text, &size) != ESR_OK)
        fail_msg("%s", esr_error_message());
    const char *body = strchr((const char *)text, '\n');
    assert_non_null(body);
    assert_int_equal(sscanf((const char *)text, "stages_done %d", &lc->stages_done), 1);
    body++;
    lc->len = size - (size_t)(body - (const char *)text);
    assert_true(lc->len < sizeof lc->text);
    memcpy(lc->text, body, lc->len);
    lc->text[lc->len] = '\0';
    free(text);
}

void assert_same_model(const char *a, const char *b)
{
    struct esr_model ma, mb;
    assert_int_equal(esr_model_load(&ma, a), 0);
    assert_int_equal(esr_model_load(&mb, b), 0);
    assert_int_equal(ma.params.count, mb.params.count);
    assert_int_equal(ma.step, mb.step);
    assert_memory_equal(ma.params.w, mb.params.w, ma.params.count * sizeof(float));
    assert_memory_equal(ma.adam.v, mb.adam.v, ma.params.count * sizeof(float));
    esr_model_free(&ma);
    esr_model_free(&mb);
}

void copy_run_changed(const char *run, const char *dst, void (*change)(struct esr_model *))
{
    char cmd[24576];
    snprintf(cmd, sizeof cmd, "mkdir -p '%s' && cp '%s'/config.json '%s'/run.json '%s'/", dst, run,
             run, dst);
    assert_int_equal(system(cmd), 0);
    struct esr_model m;
    snprintf(cmd, sizeof cmd, "%s/ckpt_pdra.bin", run);
    assert_int_equal(esr_model_load(&m, cmd), ESR_OK);
    change(&m);
    snprintf(cmd, sizeof cmd, "%s/ckpt_pdra.bin", dst);
    assert_int_equal(esr_model_save(&m, cmd), ESR_OK);
    esr_model_free(&m);
}

void make_unfinished(struct esr_model *m)
{
    m->stage_done = 0;
    m->step = 20;
}

void remove_lights(struct esr_model *m)
{
    esr_lights_free(&m->lights);
}

void expect_edit_refused(const char *run, const char *out_dir, const char *message)
{
    char cmd[16384], out[8192];
    snprintf(cmd, sizeof cmd, "edit %s --light all --intensity 0 --out %s --orbit 1", run, out_dir);
    assert_int_equal(test_run_esr(cmd, out, sizeof out), 1);
    if (!strstr(out, message))
        fail_msg("esr %s: expected '%s' in:\n%s", cmd, message, out);
    assert_false(esr_file_exists(out_dir));
}

void render_linear(const struct esr_model *m, const struct esr_camera *cam, int on, float *lin,
                   int32_t *ids)
{
    const size_t n = (size_t)cam->width * (size_t)cam->height;
    float *o = malloc(n * 3 * sizeof(float)), *d = malloc(n * 3 * sizeof(float));
    assert_non_null(o);
    assert_non_null(d);
    esr_camera_pixel_rays(cam, o, d);
    struct esr_render_out r = {.linear = lin, .light_id = ids};
    assert_int_equal(esr_model_render_rays(m, o, d, n, on, &r), ESR_OK);
    free(o);
    free(d);
}

void pdra_view_open(struct pdra_view *v)
{
    char path[4400];
    snprintf(path, sizeof path, "%s/run_pdra/ckpt_pdra.bin", tiny_dir);
    assert_int_equal(esr_model_load(&v->m, path), ESR_OK);
    assert_true(v->m.lights.n > 0);
    assert_int_equal(esr_dataset_load(data_dir, &v->ds), ESR_OK);
    v->cam = &v->ds.phases[ESR_PHASE_TEST_NV].frames[0].camera;
    v->px = (size_t)v->cam->width * (size_t)v->cam->height;
    v->on = malloc(v->px * 3 * sizeof(float));
    v->off = malloc(v->px * 3 * sizeof(float));
    v->ids = malloc(v->px * sizeof(int32_t));
    assert_non_null(v->on);
    assert_non_null(v->off);
    assert_non_null(v->ids);
    render_linear(&v->m, v->cam, 1, v->on, v->ids);
    render_linear(&v->m, v->cam, 0, v->off, NULL);
}

void pdra_view_close(struct pdra_view *v)
{
    esr_dataset_free(&v->ds);
    free(v->on), free(v->off), free(v->ids);
    esr_model_free(&v->m);
}
