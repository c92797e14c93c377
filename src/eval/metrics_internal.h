/* Shared between the metric files; not part of the public API. */
#ifndef ESR_EVAL_METRICS_INTERNAL_H
#define ESR_EVAL_METRICS_INTERNAL_H

#include "io/image.h"

/* ESR_OK when a and b hold data of identical width, height and channels; else ESR_ERR with a
 * message that starts with `what` and names both shapes. */
int esr_metric_check_same_shape(const struct esr_image *a, const struct esr_image *b, const char *what);

#endif
