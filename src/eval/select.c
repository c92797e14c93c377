/* Frame selection by name list and count limit. */
#include "eval/select.h"

#include <stdlib.h>
#include <string.h>

#include "core/error.h"

/* Index of the frame called `name` (length len, not terminated), or -1. */
static int find_frame(const struct esr_phase *ph, const char *name, size_t len)
{
    for (int i = 0; i < ph->n_frames; i++)
        if (strlen(ph->frames[i].name) == len && !strncmp(ph->frames[i].name, name, len))
            return i;
    return -1;
}

static int select_named(const struct esr_phase *ph, const char *phase_name, const char *names, int *idx, int *n)
{
    int count = 0;
    for (const char *p = names; *p;) {
        size_t len = strcspn(p, ",");
        int k = len ? find_frame(ph, p, len) : -1;
        if (k < 0)
            return ESR_FAIL("phase %s has no frame called '%.*s'", phase_name, (int)len, p);
        for (int j = 0; j < count; j++)
            if (idx[j] == k)
                return ESR_FAIL("frame '%.*s' is selected twice", (int)len, p);
        if (count == ph->n_frames)
            return ESR_FAIL("more frames selected than phase %s has", phase_name);
        idx[count++] = k;
        p += len + (p[len] == ',');
    }
    *n = count;
    return ESR_OK;
}

int esr_select_frames(const struct esr_phase *ph, const char *phase_name, const char *names, int limit, int **idx,
                      int *n)
{
    *idx = NULL;
    *n = 0;
    if (limit < 0)
        return ESR_FAIL("frame limit must be >= 0, got %d", limit);
    if (!ph->present || ph->n_frames <= 0)
        return ESR_FAIL("the dataset has no frames in phase %s", phase_name);
    if (names && !*names) /* --frames "": a list that lost its names, not "every frame" */
        return ESR_FAIL("an empty list of frame names (phase %s; leave the option out for every "
                        "frame)", phase_name);
    int *sel = malloc((size_t)ph->n_frames * sizeof *sel);
    if (!sel)
        return ESR_FAIL("out of memory selecting frames of phase %s", phase_name);
    int count = ph->n_frames;
    if (names && *names) {
        if (select_named(ph, phase_name, names, sel, &count) != ESR_OK) {
            free(sel);
            return ESR_ERR;
        }
    } else {
        for (int i = 0; i < count; i++)
            sel[i] = i;
    }
    if (limit > 0 && limit < count)
        count = limit;
    *idx = sel;
    *n = count;
    return ESR_OK;
}
