/* The small JSON files of a run folder and a dataset, each through the in-memory reader its
 * command uses: RUN/train_log.jsonl (src/eval/curve.c, the report's curves), a render stamp
 * render.json (src/render/view_frames.c, render again or not), RUN/run.json's dataset key
 * (src/eval/run_dir.c) and scene.json's tight box (src/import/colmap_align.c, `esr import colmap
 * --align-to`, a user's file).
 * Every input goes through all four rather than a first byte choosing one: the seeds stay the real
 * files as written, unprefixed, and any file a user puts in one place is tried in the others. */
#include <math.h>
#include <string.h>

#include "eval/curve.h"
#include "eval/run_dir.h"
#include "fuzz.h"
#include "import/colmap_align.h"
#include "render/view.h"

/* An accepted curve: record numbers that rise from 0 and finite values. */
static void curve(const char *text, size_t size, const char *key)
{
    struct esr_curve c;
    int status = esr_curve_parse_jsonl(text, size, "fuzz.jsonl", key, &c);
    if (status == ESR_OK) {
        if (c.n < 0 || (c.n && (!c.x || !c.y)))
            abort();
        for (int i = 0; i < c.n; i++)
            if (!isfinite(c.y[i]) || !(c.x[i] >= 0) || (i && !(c.x[i] > c.x[i - 1])))
                abort();
    } else if (c.n || c.x || c.y) {
        abort(); /* a refusal leaves nothing to free */
    }
    esr_curve_free(&c);
    fuzz_done(status);
}

/* Render again (NULL) or the stamp of exactly this model (the seed render.json's): its frames an
 * object. */
static void stamp(const char *text, size_t size)
{
    cJSON *frames = esr_view_stamp_frames(text, size, "4d25767f9dce13f5");
    if (frames && !cJSON_IsObject(frames))
        abort();
    cJSON_Delete(frames);
    if (esr_error_message()[0])
        abort(); /* "never an error" */
}

/* A found key fits its buffer with its NUL and is not empty; else out is untouched. */
static void data_key(const char *text, size_t size, size_t n)
{
    char out[64];
    memset(out, 'x', sizeof out);
    if (esr_run_data_key(text, size, out, n)) {
        size_t len = strnlen(out, sizeof out);
        if (len == 0 || len >= n)
            abort();
    } else if (out[0] != 'x') {
        abort();
    }
    esr_error_clear();
}

/* A refusal has a message; an accepted radius is finite and positive (it divides the errors). */
static void scene_radius(const char *text, size_t size)
{
    double r;
    int status = esr_colmap_scene_radius_parse(text, size, "scene.json", &r);
    if (status == ESR_OK && !(isfinite(r) && r > 0))
        abort();
    fuzz_done(status);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fuzz_setup();
    const char *text = (const char *)data;
    curve(text, size, "loss");
    curve(text, size, "psnr");
    stamp(text, size);
    data_key(text, size, 8);
    data_key(text, size, 64);
    scene_radius(text, size);
    return 0;
}
