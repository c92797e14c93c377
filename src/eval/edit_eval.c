/* Relighting on the edit phases (see edit_eval.h). */
#define _GNU_SOURCE /* open_memstream */
#include "eval/edit_eval.h"

#include <math.h>
#include <stdio.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "core/colour.h"
#include "core/error.h"
#include "edit/editor.h"
#include "eval/evaluate.h"
#include "eval/html.h"
#include "eval/metrics.h"
#include "io/dir.h"
#include "io/file.h"
#include "io/json_file.h"
#include "render/view.h"

/* frames whose light ids decide the dataset -> esr light mapping */
#define MAP_VIEWS 10

void esr_edit_eval_free(struct esr_edit_eval *res)
{
    free(res->views);
    free(res->groups);
    memset(res, 0, sizeof(*res));
}

/* N_lights.png of a frame: its light ids on the emitter mask (render/view.h's convention). */
static int write_light_ids(const struct esr_model *m, const struct esr_camera *cam,
                           const char *dir, const char *name)
{
    const size_t n = (size_t)cam->width * (size_t)cam->height;
    float *o = malloc(n * 3 * sizeof(float)), *d = malloc(n * 3 * sizeof(float));
    float *e = malloc(n * 3 * sizeof(float));
    int32_t *ids = malloc(n * sizeof(int32_t));
    struct esr_image img = {0};
    int rc = o && d && e && ids ? ESR_OK : ESR_FAIL("out of memory for a %zu-pixel view", n);
    if (rc == ESR_OK) {
        esr_camera_pixel_rays(cam, o, d);
        struct esr_render_out out = {.emission = e, .light_id = ids};
        rc = esr_model_render_rays(m, o, d, n, 0, &out);
    }
    if (rc == ESR_OK)
        rc = esr_image_alloc(&img, cam->width, cam->height, 1);
    for (size_t p = 0; rc == ESR_OK && p < n; p++)
        img.data[p] = esr_view_light_code(e + p * 3, ids[p], m->cfg.emitter_k);
    char path[ESR_PATH_MAX + 64];
    if (rc == ESR_OK)
        rc = esr_view_path(path, sizeof path, dir, name, "_lights.png");
    if (rc == ESR_OK)
        rc = esr_png_write(path, &img, 8);
    esr_image_free(&img);
    free(o), free(d), free(e), free(ids);
    return rc;
}

/* Dataset light k's edit in frame f. */
static struct esr_light_edit light_state_edit(const struct esr_frame *f, int k)
{
    const struct esr_light_state *st = &f->lights[k];
    return (struct esr_light_edit){st->mode == ESR_LIGHT_OFF ? 0.0f : st->intensity,
                                   st->mode == ESR_LIGHT_C_CHANGE || st->mode == ESR_LIGHT_IC_CHANGE,
                                   st->hsv[0], st->hsv[1]};
}

/* Fails, naming the frame and the light, when a frame asks an edit no light can take (an
 * intensity past ESR_LIGHT_EDIT_MAX_INTENSITY, say): checked before anything is written. */
static int check_frame_edits(const struct esr_dataset *ds, const struct esr_phase *ph,
                             const int *idx, int n)
{
    for (int i = 0; i < n; i++)
        for (int k = 0; k < ds->n_lights; k++) {
            const struct esr_frame *f = &ph->frames[idx[i]];
            const struct esr_light_edit e = light_state_edit(f, k);
            char why[96];
            if (esr_light_edit_problem(&e, why, sizeof why))
                return ESR_FAIL("frame %s asks dataset light %d for an edit esr cannot make: %s",
                                f->name, k, why);
        }
    return ESR_OK;
}

/* The esr-light edits of frame f: each esr light takes the edit of the dataset light it
 * overlaps most (light_split.h); one that overlaps none stays as found. */
static void frame_edits(const struct esr_dataset *ds, const struct esr_frame *f,
                        const struct esr_light_split *sp, int n_lights,
                        struct esr_light_edit *edits)
{
    for (int j = 0; j < n_lights; j++) {
        const int k = sp->dataset_light[j];
        edits[j] = k < 0 || k >= ds->n_lights ? (struct esr_light_edit){1.0f, 0, 0.0f, 0.0f}
                                              : light_state_edit(f, k);
    }
}

/* The dataset lights that frames edit and no esr light follows (res->unmatched). */
static void find_unmatched(const struct esr_dataset *ds, const struct esr_phase *ph, const int *idx,
                           int n, struct esr_edit_eval *res)
{
    const int lights = ds->n_lights < ESR_MAX_TRUE_LIGHTS ? ds->n_lights : ESR_MAX_TRUE_LIGHTS;
    for (int k = 0; k < lights; k++) {
        int followed = 0, frames = 0;
        for (int j = 0; j < res->n_lights; j++)
            followed |= res->split.dataset_light[j] == k;
        for (int i = 0; i < n && !followed; i++) { /* frames that change light k */
            const struct esr_light_edit e = light_state_edit(&ph->frames[idx[i]], k);
            frames += e.intensity != 1.0f || e.recolour;
        }
        if (frames > 0) {
            res->unmatched[res->n_unmatched] = k;
            res->unmatched_frames[res->n_unmatched++] = frames;
        }
    }
}

static int score_view(const struct esr_dataset *ds, const struct esr_frame *f,
                      const struct esr_image *lin, const char *dir, struct esr_edit_eval_view *v)
{
    struct esr_image png = {0}, gt = {0};
    ESR_TRY(esr_image_alloc(&png, lin->width, lin->height, 3));
    for (size_t i = 0; i < esr_image_count(lin); i++)
        png.data[i] = esr_srgb_from_linear(fminf(fmaxf(lin->data[i], 0.0f), 1.0f));
    char path[ESR_PATH_MAX + 64];
    int rc = esr_view_path(path, sizeof path, dir, f->name, ".png");
    if (rc == ESR_OK)
        rc = esr_png_write(path, &png, 8);
    if (rc == ESR_OK)
        rc = esr_view_path(path, sizeof path, dir, f->name, ".exr");
    if (rc == ESR_OK)
        rc = esr_exr_write(path, lin, 0);
    if (rc == ESR_OK)
        rc = esr_frame_load_rgb(ds, f, &gt, NULL);
    if (rc == ESR_OK) /* beside the render, for the report */
        rc = esr_view_path(path, sizeof path, dir, f->name, "_gt.png");
    if (rc == ESR_OK)
        rc = esr_png_write(path, &gt, 8);
    /* PNGs are what the seed scores: the render as written, 8-bit */
    if (rc == ESR_OK) {
        for (size_t i = 0; i < esr_image_count(&png); i++)
            png.data[i] = roundf(png.data[i] * 255.0f) / 255.0f;
        rc = esr_metric_psnr(&png, &gt, &v->psnr);
        v->psnr = fmin(v->psnr, ESR_EVAL_PSNR_CAP); /* an exact match would make the mean inf */
    }
    if (rc == ESR_OK)
        rc = esr_metric_ssim(&png, &gt, &v->ssim);
    esr_image_free(&png);
    esr_image_free(&gt);
    return rc;
}

/* What frame f asks of each dataset light, for the reports: "lampshade x0.5; bulb hue 0.50 sat
 * 1.00". */
static void describe_edit(const struct esr_dataset *ds, const struct esr_frame *f, char *buf,
                          size_t n)
{
    size_t used = 0;
    buf[0] = '\0';
    for (int k = 0; k < ds->n_lights && used < n; k++) {
        const struct esr_light_state *s = &f->lights[k];
        char name[ESR_NAME_MAX + 16], what[64] = "on", colour[48] = "";
        if (k < ds->n_true_lights && ds->true_lights[k].name[0])
            snprintf(name, sizeof name, "%s", ds->true_lights[k].name);
        else
            snprintf(name, sizeof name, "light %d", k);
        if (s->mode == ESR_LIGHT_C_CHANGE || s->mode == ESR_LIGHT_IC_CHANGE)
            snprintf(colour, sizeof colour, "hue %.2f sat %.2f", (double)s->hsv[0], (double)s->hsv[1]);
        if (s->mode == ESR_LIGHT_OFF)
            snprintf(what, sizeof what, "off");
        else if (s->mode == ESR_LIGHT_I_CHANGE)
            snprintf(what, sizeof what, "x%.3g", (double)s->intensity);
        else if (s->mode == ESR_LIGHT_C_CHANGE)
            snprintf(what, sizeof what, "%s", colour);
        else if (s->mode == ESR_LIGHT_IC_CHANGE)
            snprintf(what, sizeof what, "x%.3g, %s", (double)s->intensity, colour);
        const int w = snprintf(buf + used, n - used, "%s%s %s", k ? "; " : "", name, what);
        used += w > 0 ? (size_t)w : 0;
    }
}

/* Frame order for the editor: frames with the same edit together, groups in first-seen order
 * (each distinct edit is fine-tuned once). O(n^2) over a phase's few dozen frames. */
static void order_by_edit(const struct esr_light_edit (*edits)[ESR_MAX_LIGHTS], int n, int n_lights,
                          int *order)
{
    const size_t bytes = (size_t)n_lights * sizeof edits[0][0];
    int k = 0;
    for (int g = 0; g < n; g++) { /* g leads a group when no earlier frame has its edit */
        int leads = 1;
        for (int j = 0; j < g && leads; j++)
            leads = memcmp(edits[g], edits[j], bytes) != 0;
        for (int i = g; leads && i < n; i++)
            if (i == g || !memcmp(edits[g], edits[i], bytes))
                order[k++] = i;
    }
}

/* res->groups: the views' means per distinct edit string, in the order the views first ask it. */
static int group_by_edit(struct esr_edit_eval *res)
{
    res->groups = calloc((size_t)(res->n > 0 ? res->n : 1), sizeof *res->groups);
    if (!res->groups)
        return ESR_FAIL("out of memory for %d views", res->n);
    for (int i = 0; i < res->n; i++) {
        const struct esr_edit_eval_view *v = &res->views[i];
        int g = 0;
        while (g < res->n_groups && strcmp(res->groups[g].edit, v->edit))
            g++;
        if (g == res->n_groups)
            snprintf(res->groups[res->n_groups++].edit, sizeof res->groups[0].edit, "%s", v->edit);
        res->groups[g].n++;
        res->groups[g].psnr += v->psnr;
        res->groups[g].ssim += v->ssim;
    }
    for (int g = 0; g < res->n_groups; g++) {
        res->groups[g].psnr /= res->groups[g].n;
        res->groups[g].ssim /= res->groups[g].n;
    }
    return ESR_OK;
}

int esr_edit_eval_phase(struct esr_model *m, const struct esr_run_selection *sel,
                        const char *out_dir, const struct esr_edit_eval_opts *opts,
                        struct esr_edit_eval *res)
{
    const struct esr_dataset *ds = &sel->ds;
    const enum esr_phase_id phase = sel->phase;
    const int *idx = sel->idx, n = sel->n;
    const enum esr_edit_method method = opts->method;
    const int spp = opts->spp;
    memset(res, 0, sizeof(*res));
    res->phase = phase;
    res->method = method;
    res->spp = spp;
    const struct esr_phase *ph = &ds->phases[phase];
    ESR_TRY(check_frame_edits(ds, ph, idx, n));
    if (!(res->views = calloc((size_t)(n > 0 ? n : 1), sizeof *res->views)))
        return ESR_FAIL("out of memory for %d views", n);
    ESR_TRY(esr_dir_prepare_output(out_dir));
    /* pass 1: light ids of up to MAP_VIEWS evenly spread frames, and the dataset -> esr mapping
     * from them (the lights are 3D objects: a few views decide it) */
    int map_idx[MAP_VIEWS], n_map = n < MAP_VIEWS ? n : MAP_VIEWS;
    for (int i = 0; i < n_map; i++) {
        map_idx[i] = idx[(size_t)i * (size_t)n / (size_t)n_map];
        const struct esr_frame *f = &ph->frames[map_idx[i]];
        ESR_TRY(write_light_ids(m, &f->camera, out_dir, f->name));
    }
    ESR_TRY(esr_light_split_eval(ds, phase, map_idx, n_map, out_dir, &res->split));
    res->n_lights = m->lights.n;
    find_unmatched(ds, ph, idx, n, res);
    struct esr_light_edit (*edits)[ESR_MAX_LIGHTS] = calloc((size_t)(n > 0 ? n : 1), sizeof *edits);
    int *order = malloc((size_t)(n > 0 ? n : 1) * sizeof(int));
    if (!edits || !order) {
        free(edits);
        free(order);
        return ESR_FAIL("out of memory for %d views", n);
    }
    for (int i = 0; i < n; i++)
        frame_edits(ds, &ph->frames[idx[i]], &res->split, m->lights.n, edits[i]);
    order_by_edit((const struct esr_light_edit(*)[ESR_MAX_LIGHTS])edits, n, m->lights.n, order);
    struct esr_editor ed;
    int rc = esr_editor_init(&ed, m, ds, method, spp, opts->ft);
    for (int k = 0; k < n && rc == ESR_OK; k++) {
        const int i = order[k];
        const struct esr_frame *f = &ph->frames[idx[i]];
        struct esr_edit_eval_view *v = &res->views[i];
        snprintf(v->name, sizeof v->name, "%s", f->name);
        describe_edit(ds, f, v->edit, sizeof v->edit);
        rc = esr_editor_set(&ed, edits[i], 0x5eedULL);
        struct esr_image lin = {0};
        const double t0 = omp_get_wtime();
        if (rc == ESR_OK)
            rc = esr_editor_view(&ed, &f->camera, (uint64_t)idx[i], &lin);
        v->seconds = omp_get_wtime() - t0;
        if (rc == ESR_OK)
            rc = score_view(ds, f, &lin, out_dir, v);
        esr_image_free(&lin);
        if (rc == ESR_OK && opts->progress) {
            const struct esr_edit_eval_progress p = {f->name, k + 1, n, v->psnr,
                                                     ed.finetunes > res->n_edits};
            opts->progress(opts->user, &p);
        }
        res->n_edits = ed.finetunes;
    }
    res->finetune_seconds = ed.finetunes > 0 ? ed.finetune_seconds / ed.finetunes : 0.0;
    esr_editor_free(&ed);
    free(edits);
    free(order);
    if (rc == ESR_OK) {
        res->n = n;
        for (int i = 0; i < n; i++) {
            res->psnr += res->views[i].psnr / n;
            res->ssim += res->views[i].ssim / n;
            res->seconds += res->views[i].seconds / n;
        }
        rc = group_by_edit(res);
    }
    return rc;
}

int esr_edit_eval_write_json(const char *path, const struct esr_edit_eval *res)
{
    cJSON *root = cJSON_CreateObject();
    cJSON_AddStringToObject(root, "phase", esr_phase_name(res->phase));
    cJSON_AddStringToObject(root, "method", esr_edit_method_name(res->method));
    if (res->method != ESR_EDIT_FINETUNE)
        cJSON_AddNumberToObject(root, "spp", res->spp);
    else {
        cJSON_AddNumberToObject(root, "finetunes", res->n_edits);
        cJSON_AddNumberToObject(root, "finetune_seconds", res->finetune_seconds);
    }
    cJSON_AddNumberToObject(root, "n_views", res->n);
    cJSON *views = cJSON_AddArrayToObject(root, "views");
    for (int i = 0; i < res->n; i++) {
        cJSON *o = cJSON_CreateObject();
        cJSON_AddStringToObject(o, "name", res->views[i].name);
        cJSON_AddStringToObject(o, "edit", res->views[i].edit);
        cJSON_AddNumberToObject(o, "psnr", res->views[i].psnr);
        cJSON_AddNumberToObject(o, "ssim", res->views[i].ssim);
        cJSON_AddNumberToObject(o, "seconds", res->views[i].seconds);
        cJSON_AddItemToArray(views, o);
    }
    cJSON *mean = cJSON_AddObjectToObject(root, "mean");
    cJSON_AddNumberToObject(mean, "psnr", res->psnr);
    cJSON_AddNumberToObject(mean, "ssim", res->ssim);
    cJSON_AddNumberToObject(mean, "seconds", res->seconds);
    cJSON *by_edit = cJSON_AddArrayToObject(root, "by_edit");
    for (int g = 0; g < res->n_groups; g++) {
        cJSON *o = cJSON_CreateObject();
        cJSON_AddStringToObject(o, "edit", res->groups[g].edit);
        cJSON_AddNumberToObject(o, "n_views", res->groups[g].n);
        cJSON_AddNumberToObject(o, "psnr", res->groups[g].psnr);
        cJSON_AddNumberToObject(o, "ssim", res->groups[g].ssim);
        cJSON_AddItemToArray(by_edit, o);
    }
    cJSON *sp = cJSON_AddObjectToObject(root, "light_split");
    cJSON_AddNumberToObject(sp, "mean_iou", res->split.mean_iou);
    cJSON *arr = cJSON_AddArrayToObject(sp, "lights");
    for (int k = 0; k < res->split.n; k++) {
        cJSON *o = cJSON_CreateObject();
        cJSON_AddNumberToObject(o, "light", res->split.rows[k].light);
        cJSON_AddStringToObject(o, "name", res->split.rows[k].name);
        cJSON_AddNumberToObject(o, "esr_light", res->split.rows[k].esr_light);
        cJSON_AddNumberToObject(o, "iou", res->split.rows[k].iou);
        cJSON_AddItemToArray(arr, o);
    }
    /* what each esr light was edited as: the dataset light it overlaps most, -1 none (kept as
     * found) */
    cJSON *follows = cJSON_AddArrayToObject(sp, "esr_lights_follow");
    for (int j = 0; j < res->n_lights; j++)
        cJSON_AddItemToArray(follows, cJSON_CreateNumber(res->split.dataset_light[j]));
    cJSON *unmatched = cJSON_AddArrayToObject(sp, "edited_lights_unmatched");
    for (int u = 0; u < res->n_unmatched; u++)
        cJSON_AddItemToArray(unmatched, cJSON_CreateNumber(res->unmatched[u]));
    return esr_json_write_atomic(path, root);
}

int esr_edit_eval_write_html(const char *path, const char *title, const struct esr_edit_eval *res,
                             const char *render_href, const char *orig_href)
{
    char *buf = NULL;
    size_t size = 0;
    FILE *out = open_memstream(&buf, &size);
    if (!out)
        return ESR_FAIL("out of memory for %s", path);
    const char *phase = esr_phase_name(res->phase);
    fputs("<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>", out);
    esr_html_put_escaped(out, title);
    fprintf(out, " %s</title><style>body{font-family:sans-serif}td{padding:2px 6px}</style>"
                 "</head><body>\n<h1>", phase);
    esr_html_put_escaped(out, title);
    fprintf(out, ": %s, %s relighting</h1>\n<p>Mean PSNR %.2f dB, SSIM %.4f over %d views "
                 "(%.2f s per view",
            phase, esr_edit_method_name(res->method), res->psnr, res->ssim, res->n, res->seconds);
    if (res->method != ESR_EDIT_FINETUNE)
        fprintf(out, ", %d light samples per pixel and light).</p>\n", res->spp);
    else
        fprintf(out, ", after one fine-tune per distinct edit: %d, %.1f s each).</p>\n",
                res->n_edits, res->finetune_seconds);
    fputs("<table><caption>Mean per edit asked</caption>\n"
          "<tr><th>edit asked</th><th>views</th><th>PSNR</th><th>SSIM</th></tr>\n", out);
    for (int g = 0; g < res->n_groups; g++) {
        fputs("<tr><td>", out);
        esr_html_put_escaped(out, res->groups[g].edit);
        fprintf(out, "</td><td>%d</td><td>%.2f</td><td>%.4f</td></tr>\n", res->groups[g].n,
                res->groups[g].psnr, res->groups[g].ssim);
    }
    fputs("</table>\n<table><tr><th>dataset light</th><th>esr light</th><th>IoU</th></tr>\n", out);
    for (int k = 0; k < res->split.n; k++) {
        fprintf(out, "<tr><td>%d ", res->split.rows[k].light);
        esr_html_put_escaped(out, res->split.rows[k].name);
        fprintf(out, "</td><td>%d</td><td>%.3f</td></tr>\n", res->split.rows[k].esr_light,
                res->split.rows[k].iou);
    }
    fprintf(out, "</table>\n<p>Each dataset light is scored against the esr light whose pixels "
                 "best overlap its mask, and each esr light is edited as the dataset light whose "
                 "masks hold at least half of its pixels (over %d of the phase's views, spread "
                 "evenly; the masks are used by evaluation only).",
            res->split.views);
    for (int j = 0; j < res->n_lights; j++)
        if (res->split.dataset_light[j] < 0)
            fprintf(out, " esr light %d lies in no dataset light's masks and stays as found.", j);
    for (int u = 0; u < res->n_unmatched; u++)
        fprintf(out, " <b>Dataset light %d is edited by %d frame(s), but no esr light follows it "
                     "(none has half its pixels in its masks): those frames are scored without "
                     "its edit.</b>",
                res->unmatched[u], res->unmatched_frames[u]);
    fputs(" The renders are linear radiance through the sRGB curve, as the edits are written.</p>\n", out);
    fputs("<table><tr><th>view</th><th>edit asked</th><th>esr, unedited (lights on)</th>"
          "<th>esr, edited</th><th>ground truth</th><th>PSNR</th><th>SSIM</th></tr>\n", out);
    for (int i = 0; i < res->n; i++) {
        const char *name = res->views[i].name;
        char camera[ESR_NAME_MAX]; /* the unedited view: the camera's lights-on render */
        snprintf(camera, sizeof camera, "%.*s_on", (int)strcspn(name, "_"), name);
        const char *const dir[3] = {orig_href, render_href, render_href};
        const char *const file[3] = {camera, name, name};
        static const char *const suffix[3] = {"_linear.png", ".png", "_gt.png"};
        static const char *const alt[3] = {"esr's render of the view, lights on, unedited",
                                           "esr's edited render", "ground truth"};
        fputs("<tr><td>", out);
        esr_html_put_escaped(out, name);
        fputs("</td><td>", out);
        esr_html_put_escaped(out, res->views[i].edit);
        fputs("</td>", out);
        for (int k = 0; k < 3; k++) {
            fputs("<td><img src=\"", out);
            esr_html_put_escaped(out, dir[k]);
            fputc('/', out);
            esr_html_put_escaped(out, file[k]);
            fprintf(out, "%s\" width=\"160\" alt=\"%s\"></td>", suffix[k], alt[k]);
        }
        fprintf(out, "<td>%.2f</td><td>%.4f</td></tr>\n", res->views[i].psnr, res->views[i].ssim);
    }
    fputs("</table></body></html>\n", out);
    fclose(out);
    int rc = esr_file_write_atomic(path, (const unsigned char *)buf, size);
    free(buf);
    return rc;
}
