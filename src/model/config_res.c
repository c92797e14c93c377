/* Grid resolutions derived from the training images (config.h, esr_config_resolve_res): the
 * smoke preset's grids, which a fixed 128^3 made 490 MB of checkpoints for a 32 px dataset. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "model/config.h"

/* pixels per lattice point of a surface, and the rule's bounds */
#define RES_PIXELS_PER_POINT 8.0
#define RES_MIN 16
#define RES_MAX 256

int esr_config_resolve_res(struct esr_train_config *c, int width, int height, size_t pixels,
                           char *said, size_t size)
{
    const int side = width > height ? width : height;
    double r = sqrt((double)pixels / RES_PIXELS_PER_POINT);
    if (r > side)
        r = side;
    int fine = (int)(r / 4.0) * 4;
    fine = fine < RES_MIN ? RES_MIN : fine > RES_MAX ? RES_MAX : fine;
    int coarse = (int)(fine * 5.0 / 8.0);
    coarse = coarse < RES_MIN ? RES_MIN : coarse;
    struct esr_stage_config *stage[] = {&c->alphamask, &c->coarse, &c->fine, &c->lts, &c->pdra};
    static const char *const name[] = {"alphamask", "coarse", "fine", "lts", "pdra"};
    int n = 0;
    if (size)
        said[0] = '\0';
    for (int s = 0; s < 5; s++) {
        if (stage[s]->res != 0)
            continue;
        stage[s]->res = s < 2 ? coarse : fine;
        const size_t at = strlen(said);
        if (at < size)
            snprintf(said + at, size - at, "%s%s.res %d", n ? ", " : "", name[s], stage[s]->res);
        n++;
    }
    if (n && strlen(said) < size)
        snprintf(said + strlen(said), size - strlen(said),
                 " (from the images: %dx%d, %zu pixels; lattice points no finer than a pixel, "
                 "about %.0f pixels to each on a surface)", width, height, pixels,
                 RES_PIXELS_PER_POINT);
    return n;
}
