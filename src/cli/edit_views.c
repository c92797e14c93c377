/* The views and output checks `esr edit` and `esr lightmix` share (see edit_views.h). */
#include "cli/edit_views.h"

#include <dirent.h>
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>

#include "cli/commands.h"
#include "core/error.h"
#include "io/dir.h"
#include "io/staging.h"

int edit_views_open(struct edit_views *v, const char *run, const char *data, const char *phase,
                    const char *frames, int orbit, int width, const struct esr_model *m)
{
    memset(v, 0, sizeof *v);
    v->orbit = orbit;
    v->width = width;
    for (int a = 0; a < 3; a++)
        v->centre[a] = 0.5f * (m->scene_min[a] + m->scene_max[a]);
    ESR_TRY(esr_run_select(run, data, phase ? phase : "test_nv", frames, 0, &v->sel));
    v->n = orbit ? orbit : v->sel.n;
    struct esr_camera first;
    char name[ESR_NAME_MAX];
    return orbit ? edit_views_camera(v, 0, &first, name) : ESR_OK;
}

void edit_views_free(struct edit_views *v)
{
    esr_run_selection_free(&v->sel);
    memset(v, 0, sizeof *v);
}

int edit_views_camera(const struct edit_views *v, int i, struct esr_camera *cam, char *name)
{
    const struct esr_frame *f = &v->sel.ds.phases[v->sel.phase].frames[v->sel.idx[v->orbit ? 0 : i]];
    *cam = f->camera;
    if (v->orbit) {
        ESR_TRY(esr_camera_orbit(&f->camera, v->centre, i, v->orbit, cam));
        snprintf(name, ESR_NAME_MAX, "orbit_%03d", i);
    } else {
        snprintf(name, ESR_NAME_MAX, "%s", f->name);
    }
    if (v->width && v->width != cam->width) { /* the same field of view at the asked width */
        const float s = (float)v->width / (float)cam->width;
        const int h = (int)lrintf((float)cam->height * s);
        cam->focal *= s;
        cam->width = v->width;
        cam->height = h > 0 ? h : 1;
    }
    return ESR_OK;
}

int edit_check_out(const char *run, const char *out, const char *dataset)
{
    char render[4200], eval[4200];
    snprintf(render, sizeof render, "%s/render", run);
    snprintf(eval, sizeof eval, "%s/eval", run);
    const char *const run_folders[2] = {render, eval};
    const char *const run_what[2] = {"the run's render folder", "the run's eval folder"};
    const char *const what = "the dataset";
    ESR_TRY(esr_output_check_outside(out, run_folders, run_what, 2, NULL));
    return esr_output_check_outside(out, &dataset, &what, 1, run);
}

/* Whether file name n is one of names or ends in one of exts. */
static int listed(const char *n, const char *const *names, const char *const *exts)
{
    for (int i = 0; names && names[i]; i++)
        if (!strcmp(n, names[i]))
            return 1;
    const size_t len = strlen(n);
    for (int i = 0; exts && exts[i]; i++) {
        const size_t e = strlen(exts[i]);
        if (len > e && !strcmp(n + len - e, exts[i]))
            return 1;
    }
    return 0;
}

int edit_check_replaceable(const char *out, const char *const *names, const char *const *exts,
                           const char *cmd)
{
    DIR *d = opendir(out);
    if (!d)
        return ESR_OK; /* absent (made later), or not a folder (said when it is made) */
    int foreign = 0;
    char first[256] = "";
    for (struct dirent *e; (e = readdir(d));) {
        const char *n = e->d_name;
        if (!strcmp(n, ".") || !strcmp(n, ".."))
            continue;
        char path[4400];
        struct stat st;
        snprintf(path, sizeof path, "%s/%s", out, n);
        if (lstat(path, &st) == 0 && S_ISREG(st.st_mode) && listed(n, names, exts))
            continue;
        if (!foreign++)
            snprintf(first, sizeof first, "%s", n);
    }
    closedir(d);
    if (foreign)
        return ESR_FAIL("--out %s holds files that no %s wrote (%s%s): give a new or empty "
                        "folder (an earlier output's folder is replaced whole once the new one is "
                        "complete)", out, cmd, first, foreign > 1 ? ", ..." : "");
    return ESR_OK;
}

int edit_output_begin(struct edit_output *o, const char *out, const char *const *names,
                      const char *const *exts, const char *cmd)
{
    memset(o, 0, sizeof *o);
    o->out = out;
    cli_parent_dir(out, o->parent, sizeof o->parent);
    ESR_TRY(edit_check_replaceable(out, names, exts, cmd));
    int rc = esr_dir_prepare_output_made(o->parent, o->made, sizeof o->made);
    if (rc == ESR_OK)
        rc = esr_staging_begin(out, 1, o->staging, sizeof o->staging);
    if (rc != ESR_OK)
        esr_error_append(" (for --out %s)", out);
    return rc;
}

int edit_output_end(struct edit_output *o, int rc)
{
    if (rc == ESR_OK && o->staging[0]) {
        cli_hold_signals(1); /* the swap is not cut in two */
        rc = esr_staging_commit(o->staging, o->out);
        cli_hold_signals(0);
        if (rc == ESR_OK)
            return ESR_OK;
    }
    if (o->staging[0])
        esr_remove_tree(o->staging);
    if (o->out)
        esr_dir_remove_made(o->parent, o->made);
    return rc;
}
