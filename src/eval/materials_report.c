/* The material scores' section of the report page, with the rendered maps beside the truth
 * (eval/materials.h). */
#include <math.h>
#include <stdio.h>

#include "core/colour.h"
#include "core/error.h"
#include "eval/html.h"
#include "eval/materials.h"
#include "eval/normals.h"
#include "io/image.h"
#include "render/view.h"

/* Truth maps of one camera shown as the render shows its own (render/view.h): base colour
 * sRGB-encoded, roughness and metallic grey, white where the truth has no surface. */
static int write_truth_view(const struct esr_dataset *ds, const char *name, const char *gt_dir)
{
    static const char *const maps[4] = {"base_color", "roughness", "metallic", "normal"};
    static const char *const suffixes[3] = {"_basecolor_true.png", "_roughness_true.png",
                                            "_metallic_true.png"};
    struct esr_image t[4] = {{0}}, rgb = {0}, grey = {0};
    char path[ESR_PATH_MAX];
    int status = ESR_OK;
    for (int k = 0; k < 4 && status == ESR_OK; k++) {
        esr_material_gt_path(ds->root, name, maps[k], path, sizeof path);
        status = esr_exr_read(path, &t[k]);
        if (status == ESR_OK && (t[k].width != t[0].width || t[k].height != t[0].height))
            status = ESR_FAIL("'%s' is %dx%d but the base colour map is %dx%d", path, t[k].width, t[k].height,
                              t[0].width, t[0].height);
    }
    if (status == ESR_OK)
        status = esr_image_alloc(&rgb, t[0].width, t[0].height, 3);
    if (status == ESR_OK)
        status = esr_image_alloc(&grey, t[0].width, t[0].height, 1);
    const size_t n = (size_t)t[0].width * (size_t)t[0].height;
    for (int j = 0; j < 3 && status == ESR_OK; j++) {
        const struct esr_image *out = j == 0 ? &rgb : &grey;
        for (size_t i = 0; i < n; i++) {
            const float *nrm = t[3].data + 4 * i; /* esr_exr_read gives RGBA */
            const int surface = nrm[0] != 0.0f || nrm[1] != 0.0f || nrm[2] != 0.0f;
            for (int c = 0; c < out->channels; c++) {
                const float v = esr_clamp01(t[j].data[4 * i + (size_t)c]);
                out->data[(size_t)out->channels * i + (size_t)c] =
                    !surface ? 1.0f : j == 0 ? esr_srgb_from_linear(v) : v;
            }
        }
        status = esr_view_path(path, sizeof path, gt_dir, name, suffixes[j]);
        if (status == ESR_OK)
            status = esr_png_write(path, out, 8);
    }
    for (int k = 0; k < 4; k++)
        esr_image_free(&t[k]);
    esr_image_free(&rgb);
    esr_image_free(&grey);
    return status;
}

int esr_materials_write_truth(const struct esr_dataset *ds, const struct esr_materials_result *r,
                              const char *gt_dir)
{
    for (int k = 0; k < r->n_views; k++)
        ESR_TRY(write_truth_view(ds, r->views[k].name, gt_dir));
    return ESR_OK;
}


static void put_thumb(FILE *out, const char *href, const char *name, const char *suffix)
{
    for (int k = 0; k < 2; k++) {
        fputs(k ? "\"><img src=\"" : "<td><a href=\"", out);
        esr_html_put_escaped(out, href);
        fputc('/', out);
        esr_html_put_escaped(out, name);
        fputs(suffix, out);
    }
    fputs("\" width=\"128\" alt=\"\"></a></td>", out);
}

static void put_split_row(FILE *out, const char *what, const struct esr_material_split_stats *s)
{
    fprintf(out, "<tr><td>%s</td><td>%ld</td>", what, s->n);
    esr_html_put_number(out, "%.3f", s->roughness_mae);
    esr_html_put_number(out, "%.3f", s->metallic_mae);
    esr_html_put_number(out, "%.3f", s->mean_metallic);
    fputs("</tr>\n", out);
}

static void put_views(FILE *out, const struct esr_materials_result *r, const char *render_href,
                      const char *gt_href)
{
    fputs("<table><tr><th>view</th><th>base colour</th><th>true</th><th>roughness</th><th>true</th>"
          "<th>metallic</th><th>true</th><th>base colour PSNR</th><th>with gains</th><th>roughness MAE</th>"
          "<th>metallic MAE</th><th>coverage</th></tr>\n",
          out);
    static const char *const maps[3] = {"_basecolor", "_roughness", "_metallic"};
    char suffix[32];
    for (int k = 0; k < r->n_views; k++) {
        const struct esr_material_view *v = &r->views[k];
        fputs("<tr><td>", out);
        esr_html_put_escaped(out, v->name);
        fputs("</td>", out);
        for (int j = 0; j < 3; j++) {
            snprintf(suffix, sizeof suffix, "%s.png", maps[j]);
            put_thumb(out, render_href, v->name, suffix);
            snprintf(suffix, sizeof suffix, "%s_true.png", maps[j]);
            put_thumb(out, gt_href, v->name, suffix);
        }
        esr_html_put_number(out, "%.2f", v->stats.base_color_psnr);
        esr_html_put_number(out, "%.2f", v->stats.base_color_psnr_gain);
        esr_html_put_number(out, "%.3f", v->stats.roughness_mae);
        esr_html_put_number(out, "%.3f", v->stats.metallic_mae);
        esr_html_put_number(out, "%.3f", v->stats.coverage);
        fputs("</tr>\n", out);
    }
    fputs("</table>\n", out);
}

void esr_materials_put_html(FILE *out, const struct esr_materials_result *r, const char *render_href,
                            const char *gt_href)
{
    if (!r->has_truth)
        return;
    fputs("<h2>Materials</h2>\n", out);
    if (r->skipped[0]) {
        fputs("<p>Not scored: ", out);
        esr_html_put_escaped(out, r->skipped);
        fputs(".</p>\n", out);
        return;
    }
    const struct esr_material_stats *s = &r->pooled;
    fprintf(out, "<table><tr><th>views</th><th>base colour PSNR (dB)</th><th>with gains</th><th>gains (R G B)</th>"
                 "<th>roughness MAE</th><th>metallic MAE</th><th>coverage</th></tr>\n<tr><td>%d</td>",
            r->n_views);
    esr_html_put_number(out, "%.2f", s->base_color_psnr);
    esr_html_put_number(out, "%.2f", s->base_color_psnr_gain);
    fprintf(out, "<td>%.3f %.3f %.3f</td>", s->gain[0], s->gain[1], s->gain[2]);
    esr_html_put_number(out, "%.3f", s->roughness_mae);
    esr_html_put_number(out, "%.3f", s->metallic_mae);
    esr_html_put_number(out, "%.3f", s->coverage);
    fputs("</tr>\n</table>\n<table><tr><th>pixels</th><th>n</th><th>roughness MAE</th><th>metallic MAE</th>"
          "<th>mean predicted metallic</th></tr>\n",
          out);
    char what[64];
    snprintf(what, sizeof what, "truly metallic (&gt;= %.1f)", ESR_MATERIAL_METAL_AT_LEAST);
    put_split_row(out, what, &s->metal);
    snprintf(what, sizeof what, "non-metallic (&lt;= %.1f)", ESR_MATERIAL_DIELECTRIC_AT_MOST);
    put_split_row(out, what, &s->dielectric);
    fprintf(out, "</table>\n<p>The rendered base colour, roughness and metallic maps against the dataset's "
                 "gt/c&lt;CCC&gt;_*.exr over the %ld pixels (of %ld where the truth has a surface) whose "
                 "rendered opacity is over %.1f, each camera once, pixels pooled. Base colour PSNR is of the "
                 "sRGB-encoded maps; \"with gains\" scales each channel of the render in linear by the "
                 "least-squares gain over all these pixels (the overall scale the photos cannot fix).</p>\n",
            s->n, s->n_gt, (double)ESR_NORMAL_MIN_OPACITY);
    put_views(out, r, render_href, gt_href);
}
