/* The LightMix page `esr lightmix` writes beside its EXRs: DIR/index.html (the page,
 * src/cli/lightmix_page.html, built into the binary), DIR/lightmix.js (the lights, as `esr lights`
 * names them, the views, the method) and per view DIR/<view>.js (its layers as half floats, off
 * then light_K and light_K_value per light, RGB per pixel, rows top first, zlib-deflated, base64), loaded by
 * script tags: the page works from file:// with no network and no server. */
#ifndef ESR_CLI_LIGHTMIX_PAGE_H
#define ESR_CLI_LIGHTMIX_PAGE_H

#include "edit/relight.h"
#include "io/dataset.h"
#include "model/model.h"

/* What lightmix.js says besides the lights. */
struct lightmix_page {
    const char *run, *method, *phase; /* phase: the views' (NULL with an orbit) */
    int spp, orbit, width;            /* width: --size (0: the cameras' own) */
    int n;                            /* views */
    const char (*names)[ESR_NAME_MAX];
    const int (*size)[2];             /* each view's width and height */
    const int *data_of;               /* the view whose <view>.js holds each view's layers (a
                                         phase's off and on frames of one camera share them) */
};

/* DIR/<name>.js: the view's layers. */
int lightmix_page_view(const char *dir, const char *name, const struct esr_relight_layers *L);
/* DIR/index.html and DIR/lightmix.js. */
int lightmix_page_write(const char *dir, const struct lightmix_page *p, const struct esr_model *m);

#endif
