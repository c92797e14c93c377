/* The material maps of a render directory read and scored against a dataset's truth maps
 * (eval/materials.h): which cameras, which files, the two passes over them. */
#include <ctype.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "eval/materials.h"
#include "io/file.h"
#include "render/view.h"

/* Length of the camera tag "c<digits>" that starts name, 0 when it does not start with one
 * followed by '_' (FORMAT.md's test-frame names). */
static size_t camera_tag_len(const char *name)
{
    size_t len = 1;
    if (name[0] != 'c')
        return 0;
    while (isdigit((unsigned char)name[len]))
        len++;
    return len > 1 && name[len] == '_' ? len : 0;
}

int esr_material_gt_path(const char *root, const char *name, const char *map, char *out, size_t n)
{
    size_t len = camera_tag_len(name);
    if (n > 0)
        out[0] = '\0';
    if (!len)
        return 0;
    int w = snprintf(out, n, "%s/gt/%.*s_%s.exr", root, (int)len, name, map);
    return w > 0 && (size_t)w < n && esr_file_exists(out);
}

/* The rendered and true maps of one camera. */
struct camera_maps {
    struct esr_image pred[4], truth[4]; /* base, roughness, metallic, normal (with opacity) */
};

static const char *const truth_names[4] = {"base_color", "roughness", "metallic", "normal"};
static const char *const render_suffixes[4] = {"_basecolor.png", "_roughness.png", "_metallic.png",
                                               "_normal.exr"};

static void camera_maps_free(struct camera_maps *m)
{
    for (int k = 0; k < 4; k++) {
        esr_image_free(&m->pred[k]);
        esr_image_free(&m->truth[k]);
    }
}

static int read_sized(const struct esr_dataset *ds, const char *path, const char *what, struct esr_image *img)
{
    if (!esr_file_exists(path))
        return ESR_FAIL("%s '%s' is missing", what, path);
    ESR_TRY(esr_image_read(path, img));
    if (img->width != ds->width || img->height != ds->height)
        return ESR_FAIL("%s '%s' is %dx%d but the dataset's images are %dx%d", what, path, img->width,
                        img->height, ds->width, ds->height);
    return ESR_OK;
}

static int load_camera(const struct esr_dataset *ds, const char *dir, const char *name, struct camera_maps *m)
{
    char path[ESR_PATH_MAX];
    memset(m, 0, sizeof *m);
    for (int k = 0; k < 4; k++) {
        esr_material_gt_path(ds->root, name, truth_names[k], path, sizeof path);
        ESR_TRY(read_sized(ds, path, "ground-truth map", &m->truth[k]));
        ESR_TRY(esr_view_path(path, sizeof path, dir, name, render_suffixes[k]));
        ESR_TRY(read_sized(ds, path, "rendered map", &m->pred[k]));
    }
    if (m->pred[3].channels != 4)
        return ESR_FAIL("rendered normal map of %s in %s has %d channels; expected 4 (normal, opacity)", name, dir,
                        m->pred[3].channels);
    return ESR_OK;
}

static void maps_of(const struct esr_image img[4], struct esr_material_maps *out)
{
    out->base = &img[0];
    out->roughness = &img[1];
    out->metallic = &img[2];
    out->opacity_or_normal = &img[3];
}

/* One pass over the cameras: the first (gain NULL) fills sums[k], the second adds the gained
 * base-colour error to them. */
static int pass(const struct esr_dataset *ds, const char *dir, const struct esr_materials_result *r,
                struct esr_material_sums *sums, const double *gain)
{
    for (int k = 0; k < r->n_views; k++) {
        struct camera_maps m;
        struct esr_material_maps pred, truth;
        int status = load_camera(ds, dir, r->views[k].name, &m);
        maps_of(m.pred, &pred);
        maps_of(m.truth, &truth);
        if (status == ESR_OK)
            status = gain ? esr_material_add_gained(&sums[k], &pred, &truth, gain)
                          : esr_material_add(&sums[k], &pred, &truth);
        camera_maps_free(&m);
        ESR_TRY(status);
    }
    return ESR_OK;
}

/* Why the cameras picked cannot be scored ("" when they can): a truth map missing, or no
 * material maps in the renders. Fails on a render directory with some of them but not all. */
static int find_skip_reason(const struct esr_dataset *ds, const char *dir, struct esr_materials_result *r)
{
    char path[ESR_PATH_MAX];
    for (int k = 0; k < r->n_views; k++)
        for (int j = 0; j < 3; j++)
            if (!esr_material_gt_path(ds->root, r->views[k].name, truth_names[j + 1], path, sizeof path)) {
                snprintf(r->skipped, sizeof r->skipped, "the ground-truth map %s is missing", path);
                return ESR_OK;
            }
    int present = 0;
    const char *name = r->views[0].name;
    for (int j = 0; j < 3; j++) {
        ESR_TRY(esr_view_path(path, sizeof path, dir, name, render_suffixes[j]));
        present += esr_file_exists(path);
    }
    if (present == 0) {
        snprintf(r->skipped, sizeof r->skipped,
                 "the renders in %s have no material maps (%s_basecolor.png): the model has no BRDF "
                 "before the lts stage",
                 dir, name);
    } else if (present < 3) {
        for (int j = 0; j < 3; j++) {
            ESR_TRY(esr_view_path(path, sizeof path, dir, name, render_suffixes[j]));
            if (!esr_file_exists(path))
                return ESR_FAIL("rendered material map '%s' is missing but others of %s are there (render "
                                "this phase again: `esr eval --rerender` or `esr render`)",
                                path, name);
        }
    }
    return ESR_OK;
}

/* The first evaluated frame of each camera that has a truth base colour map. */
static int pick_cameras(const struct esr_dataset *ds, enum esr_phase_id phase, const int *idx, int n,
                        struct esr_materials_result *r)
{
    const struct esr_phase *ph = &ds->phases[phase];
    char path[ESR_PATH_MAX];
    r->views = calloc((size_t)(n > 0 ? n : 1), sizeof *r->views);
    if (!r->views)
        return ESR_FAIL("out of memory scoring the material maps of %d views", n);
    for (int i = 0; i < n; i++) {
        const char *name = ph->frames[idx[i]].name;
        if (!esr_material_gt_path(ds->root, name, "base_color", path, sizeof path))
            continue;
        const size_t len = camera_tag_len(name);
        int seen = 0;
        for (int k = 0; k < r->n_views && !seen; k++)
            seen = !strncmp(r->views[k].name, name, len) && r->views[k].name[len] == '_';
        if (!seen)
            snprintf(r->views[r->n_views++].name, sizeof r->views[0].name, "%s", name);
    }
    r->has_truth = r->n_views > 0;
    return ESR_OK;
}

int esr_materials_check_truth(const struct esr_dataset *ds, enum esr_phase_id phase, const int *idx, int n)
{
    struct esr_materials_result r;
    memset(&r, 0, sizeof r);
    int status = pick_cameras(ds, phase, idx, n, &r);
    char path[ESR_PATH_MAX];
    for (int k = 0; k < r.n_views && status == ESR_OK; k++)
        for (int j = 0; j < 4 && status == ESR_OK; j++) {
            if (!esr_material_gt_path(ds->root, r.views[k].name, truth_names[j], path, sizeof path))
                continue; /* a missing map is a reason to skip the scores, said then */
            struct esr_image img = {0};
            status = read_sized(ds, path, "ground-truth map", &img);
            esr_image_free(&img);
        }
    esr_materials_result_free(&r);
    return status;
}

int esr_materials_eval(const struct esr_dataset *ds, enum esr_phase_id phase, const int *idx, int n,
                       const char *render_dir, struct esr_materials_result *out)
{
    memset(out, 0, sizeof *out);
    ESR_TRY(pick_cameras(ds, phase, idx, n, out));
    if (!out->has_truth)
        return ESR_OK;
    ESR_TRY(find_skip_reason(ds, render_dir, out));
    if (out->skipped[0]) {
        out->n_views = 0; /* nothing scored */
        return ESR_OK;
    }
    struct esr_material_sums *sums = calloc((size_t)out->n_views, sizeof *sums), pooled;
    if (!sums)
        return ESR_FAIL("out of memory scoring the material maps of %d views", out->n_views);
    double gain[3];
    int status = pass(ds, render_dir, out, sums, NULL);
    memset(&pooled, 0, sizeof pooled);
    for (int k = 0; k < out->n_views; k++)
        esr_material_sums_merge(&pooled, &sums[k]);
    esr_material_gains(&pooled, gain);
    if (status == ESR_OK)
        status = pass(ds, render_dir, out, sums, gain);
    if (status == ESR_OK) {
        pooled.se_base_gain = 0.0;
        for (int k = 0; k < out->n_views; k++) {
            pooled.se_base_gain += sums[k].se_base_gain;
            out->views[k].stats = esr_material_stats_of(&sums[k], gain);
        }
        out->pooled = esr_material_stats_of(&pooled, gain);
    }
    free(sums);
    return status;
}

void esr_materials_result_free(struct esr_materials_result *r)
{
    free(r->views);
    memset(r, 0, sizeof *r);
}
