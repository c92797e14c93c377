/* The tiny trained run that the *_tiny tests share (ctest fixture tiny_run, made once per ctest
 * invocation by tests/support/tiny_fixture_setup.c, test `tiny_fixture_setup`) and the helpers
 * those tests train, copy and render it with.
 *
 * The fixture folder (tiny_dir: $ESR_TINY_FIXTURE, else ESR_TINY_FIXTURE_DIR, which CMake sets to
 * build/tests/tiny_fixture) holds
 *   data/            `esr synth --res 24 --spp 4 --train 16 --test 3`          (data_dir)
 *   runs/full/       tiny_config trained through lts (alphamask, coarse, fine, lts)
 *   run_pdra/        runs/full's checkpoints copied in (no config.json) and resumed through pdra:
 *                    the lights found
 *   log_full.txt, log_pdra.txt   what those two trainings reported (tiny_read_log)
 *   complete         written last: the fixture is whole
 * Tests read it only: one that changes a run (resumes it, recomputes or drops its lights, edits
 * or evaluates it through the CLI, which take its lock or write into it) copies it into its own
 * test_tmpdir first, so the tests stay independent and run in parallel. */
#ifndef ESR_TINY_RUN_H
#define ESR_TINY_RUN_H

#include <stddef.h>
#include <stdint.h>

#include "model/model.h"
#include "io/dataset.h"
#include "train/trainer.h"

/* The fixture's folder and its dataset (tiny_locate fills both). */
extern const char *tiny_dir;
extern char data_dir[4096];

/* The fixture's folder from $ESR_TINY_FIXTURE or ESR_TINY_FIXTURE_DIR, into tiny_dir; 0 on
 * success. */
int tiny_locate(void);
/* cmocka group setup of the *_tiny tests: test_tmpdir, and tiny_dir / data_dir of a complete
 * fixture (else -1, saying how to make it). Teardown: test_teardown_tmpdir. */
int tiny_setup(void **state);

/* A copy of the fixture's folder `name` (runs/full, run_pdra) at test_tmpdir/as, its path into
 * run (size bytes): for a test that writes into the run or runs esr commands on it. */
void tiny_copy_run(const char *name, const char *as, char *run, size_t size);
/* tiny_copy_run, then the copy's ckpt_pdra.bin loaded into *m (the caller frees it). */
void tiny_copy_run_model(const char *name, const char *as, char *run, size_t size,
                         struct esr_model *m);

/* The run folders (in test_tmpdir) of a straight run and of one that is stopped and resumed, for
 * the test `test`. */
void run_dir_pair(char straight[4200], char cut[4200], const char *test);

/* The tiny run's options: the fast preset cut down to seconds. */
void tiny_config(struct esr_train_config *c);

struct log_capture {
    char text[16384];
    size_t len;
    int stages_done; /* ESR_TRAIN_STAGE_DONE events with a positive time */
};

/* esr_train_opts.report that keeps the messages and counts the finished stages in a
 * struct log_capture. */
void capture(void *user, const struct esr_train_progress *p);
/* The options of a tiny training of data_dir into run until `until`, reporting into lc when not
 * NULL (emptied first). */
void opts_for(struct esr_train_opts *o, const char *run, enum esr_stage until,
              struct log_capture *lc);
/* The fixture's log_<name>.txt (a struct log_capture the fixture's training filled) into lc. */
void tiny_read_log(const char *name, struct log_capture *lc);
/* 0 when lc was written to path (tiny_fixture_setup.c). */
int tiny_write_log(const char *path, const struct log_capture *lc);

/* RUN/ckpt_<stage>.bin loads and holds step `step` (-1: any) and the finished flag `done` (-1:
 * either). */
void assert_checkpoint(const char *run, const char *stage, long step, int done);
/* Parameters of two checkpoints are bitwise equal. */
void assert_same_model(const char *a, const char *b);

/* dst: a copy of run's config.json, run.json and ckpt_pdra.bin, the checkpoint changed by
 * `change`. */
void copy_run_changed(const char *run, const char *dst, void (*change)(struct esr_model *));
void make_unfinished(struct esr_model *m);
void remove_lights(struct esr_model *m);
/* `esr edit` of every light on run fails saying `message`, and out_dir is not created. */
void expect_edit_refused(const char *run, const char *out_dir, const char *message);

/* Lights-on (on 1) or lights-off linear render of cam into lin [w*h*3], and the light each
 * pixel sees (-1: none) into ids when not NULL. */
void render_linear(const struct esr_model *m, const struct esr_camera *cam, int on, float *lin,
                   int32_t *ids);

/* The pdra run (it finds the tiny scene's lights, see test_train_lights_tiny.c) seen from the
 * first test_nv camera: its model and dataset, and the lights-on render (with the light each
 * pixel sees) and the lights-off render of that view. Read from the fixture's run_pdra, which
 * it does not change. */
struct pdra_view {
    struct esr_model m;
    struct esr_dataset ds;
    const struct esr_camera *cam;
    size_t px;
    float *on, *off;
    int32_t *ids;
};

void pdra_view_open(struct pdra_view *v);
void pdra_view_close(struct pdra_view *v);

#endif
