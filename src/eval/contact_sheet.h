/* Contact sheets: a grid of thumbnails on white, for reports (`esr info`, training reports). */
#ifndef ESR_EVAL_CONTACT_SHEET_H
#define ESR_EVAL_CONTACT_SHEET_H

#include "io/image.h"

struct esr_contact_sheet {
    int cols, rows;
    int thumb;  /* thumbnail edge in pixels (thumbnails keep the aspect ratio inside thumb x thumb) */
    int pad;    /* white border around every cell */
    int placed; /* thumbnails added so far */
    struct esr_image canvas; /* RGB, white */
};

/* Allocates a white cols x rows grid of thumb x thumb cells with pad pixels between them. */
int esr_contact_sheet_init(struct esr_contact_sheet *cs, int cols, int rows, int thumb, int pad);
/* Box-filters an image (1 channel = grey, 3 = RGB) down (or nearest-samples up) to fit the cell
 * and places it in the next free cell, row by row. Fails when the sheet is full. */
int esr_contact_sheet_add(struct esr_contact_sheet *cs, const struct esr_image *img);
/* Leaves the next cell empty (white). */
void esr_contact_sheet_skip(struct esr_contact_sheet *cs);
void esr_contact_sheet_free(struct esr_contact_sheet *cs);

/* Area-average resampling of img to w x h (same channel count): each output pixel is the mean of
 * the input pixels its footprint covers, weighted by overlap. */
int esr_image_resample_box(const struct esr_image *img, int w, int h, struct esr_image *out);

#endif
