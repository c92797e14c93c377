/* Which frames of a phase `esr render` / `esr eval` work on (--frames a,b,... and --limit N). */
#ifndef ESR_EVAL_SELECT_H
#define ESR_EVAL_SELECT_H

#include "io/dataset.h"

/* Indices into ph->frames: the frames named in `names` (comma-separated frame names such as
 * "c003_on", in the order given; NULL = every frame in phase order), then cut to the first
 * `limit` (0 = no limit). Fails naming the phase and the name when a name is not in the phase or
 * is given twice, when `names` is "" (a list that lost its names), or when limit < 0. *idx is
 * malloc'ed (caller frees) and *n >= 1 on success. */
int esr_select_frames(const struct esr_phase *ph, const char *phase_name, const char *names, int limit, int **idx,
                      int *n);

#endif
