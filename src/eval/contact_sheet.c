#include "eval/contact_sheet.h"

#include <math.h>
#include <string.h>

#include "core/error.h"

int esr_contact_sheet_init(struct esr_contact_sheet *cs, int cols, int rows, int thumb, int pad)
{
    memset(cs, 0, sizeof *cs);
    if (cols <= 0 || rows <= 0 || thumb <= 0 || pad < 0)
        return ESR_FAIL("invalid contact sheet layout %dx%d, thumbnails %d px, padding %d", cols, rows, thumb, pad);
    ESR_TRY(esr_image_alloc(&cs->canvas, cols * (thumb + pad) + pad, rows * (thumb + pad) + pad, 3));
    for (size_t i = 0; i < esr_image_count(&cs->canvas); i++)
        cs->canvas.data[i] = 1.0f;
    cs->cols = cols;
    cs->rows = rows;
    cs->thumb = thumb;
    cs->pad = pad;
    return ESR_OK;
}

/* Overlap of [a0,a1) with [b0,b1). */
static double overlap(double a0, double a1, double b0, double b1)
{
    double lo = a0 > b0 ? a0 : b0, hi = a1 < b1 ? a1 : b1;
    return hi > lo ? hi - lo : 0.0;
}

int esr_image_resample_box(const struct esr_image *img, int w, int h, struct esr_image *out)
{
    ESR_TRY(esr_image_alloc(out, w, h, img->channels));
    double sx = (double)img->width / w, sy = (double)img->height / h;
    int c = img->channels;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            double y0 = y * sy, y1 = (y + 1) * sy, x0 = x * sx, x1 = (x + 1) * sx;
            double acc[4] = {0, 0, 0, 0}, wsum = 0.0;
            for (int iy = (int)floor(y0); iy < (int)ceil(y1) && iy < img->height; iy++)
                for (int ix = (int)floor(x0); ix < (int)ceil(x1) && ix < img->width; ix++) {
                    double wgt = overlap(y0, y1, iy, iy + 1) * overlap(x0, x1, ix, ix + 1);
                    const float *s = img->data + ((size_t)iy * (size_t)img->width + (size_t)ix) * (size_t)c;
                    for (int k = 0; k < c; k++)
                        acc[k] += wgt * s[k];
                    wsum += wgt;
                }
            float *d = out->data + ((size_t)y * (size_t)w + (size_t)x) * (size_t)c;
            for (int k = 0; k < c; k++)
                d[k] = (float)(acc[k] / wsum);
        }
    return ESR_OK;
}

int esr_contact_sheet_add(struct esr_contact_sheet *cs, const struct esr_image *img)
{
    if (cs->placed >= cs->cols * cs->rows)
        return ESR_FAIL("contact sheet is full (%d cells)", cs->cols * cs->rows);
    if (img->channels != 1 && img->channels != 3)
        return ESR_FAIL("contact sheet thumbnails must be grey or RGB, got %d channels", img->channels);
    int longest = img->width > img->height ? img->width : img->height;
    int w = (int)lround((double)img->width * cs->thumb / longest);
    int h = (int)lround((double)img->height * cs->thumb / longest);
    w = w > 0 ? w : 1;
    h = h > 0 ? h : 1;
    struct esr_image small;
    ESR_TRY(esr_image_resample_box(img, w, h, &small));
    int cell = cs->placed++;
    int ox = cs->pad + (cell % cs->cols) * (cs->thumb + cs->pad) + (cs->thumb - w) / 2;
    int oy = cs->pad + (cell / cs->cols) * (cs->thumb + cs->pad) + (cs->thumb - h) / 2;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            const float *s = small.data + ((size_t)y * (size_t)w + (size_t)x) * (size_t)small.channels;
            float *d = cs->canvas.data + ((size_t)(oy + y) * (size_t)cs->canvas.width + (size_t)(ox + x)) * 3;
            for (int k = 0; k < 3; k++)
                d[k] = s[small.channels == 3 ? k : 0];
        }
    esr_image_free(&small);
    return ESR_OK;
}

void esr_contact_sheet_skip(struct esr_contact_sheet *cs)
{
    if (cs->placed < cs->cols * cs->rows)
        cs->placed++;
}

void esr_contact_sheet_free(struct esr_contact_sheet *cs) { esr_image_free(&cs->canvas); }
