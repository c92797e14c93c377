/* What `esr edit` and `esr lightmix` share: the views they render (a dataset phase's frames or an
 * orbit, named as they write them) and the checks of their output folder. */
#ifndef ESR_CLI_EDIT_VIEWS_H
#define ESR_CLI_EDIT_VIEWS_H

#include "eval/run_dir.h"
#include "io/camera.h"
#include "io/dataset.h"
#include "model/model.h"

struct edit_views {
    struct esr_run_selection sel; /* the run's dataset and the phase's frames */
    int orbit;                    /* 0, or the orbit's camera count */
    int n;                        /* views */
    int width;                    /* 0, or the width the views are rendered at (height to scale) */
    float centre[3];              /* the orbit's: the scene box's centre */
};

/* The views of run (a finished pdra model m): phase (NULL: test_nv) and frames (NULL: all), or an
 * orbit of `orbit` cameras (0: none) around the first test camera's; width 0 or the views' width.
 * An orbit that cannot be made is refused here, before any work. Free with edit_views_free (also
 * after an error). */
int edit_views_open(struct edit_views *v, const char *run, const char *data, const char *phase,
                    const char *frames, int orbit, int width, const struct esr_model *m);
void edit_views_free(struct edit_views *v);
/* View i's camera and name (orbit_000, or the frame's name; name: ESR_NAME_MAX bytes). */
int edit_views_camera(const struct edit_views *v, int i, struct esr_camera *cam, char *name);

/* Refuses an output folder in run's own render and eval folders, or in the dataset outside run
 * (a run may live inside its dataset): views written there would replace renders that
 * render.json vouches for, or the photos. */
int edit_check_out(const char *run, const char *out, const char *dataset);
/* An out that holds something is replaced only when it is an earlier output of the command:
 * nothing but regular files named one of names or ending in one of exts (both NULL-ended), so a
 * user's other files are never deleted; refused (naming one) otherwise. cmd: "esr edit". */
int edit_check_replaceable(const char *out, const char *const *names, const char *const *exts,
                           const char *cmd);

/* An output folder written aside, in a staging folder beside it, and put in place whole once
 * everything is written: a failed or interrupted command leaves it as it was. */
struct edit_output {
    const char *out;
    char parent[4200], made[4200], staging[4200]; /* staging: where to write */
};
/* Refuses an out that edit_check_replaceable refuses (names, exts, cmd as it takes them), makes
 * out's missing parent folders and the staging folder. */
int edit_output_begin(struct edit_output *o, const char *out, const char *const *names,
                      const char *const *exts, const char *cmd);
/* rc ESR_OK: the staging folder replaces out (signals held meanwhile); otherwise, or when that
 * fails, the staging folder and the parents made are removed. Returns rc, or the failure. */
int edit_output_end(struct edit_output *o, int rc);

#endif
