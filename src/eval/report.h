/* The evaluation report page (RUN/report.html): summary numbers, training curves, and per view
 * the ground truth next to the tone-mapped, linear and normal renders with the view's metrics.
 * Self-contained HTML (inline CSS and SVG) whose images are relative links, so the run directory
 * can be moved or copied as a whole. */
#ifndef ESR_EVAL_REPORT_H
#define ESR_EVAL_REPORT_H

#include "eval/chamfer.h"
#include "eval/evaluate.h"
#include "model/lights.h"
#include "io/dataset.h"

struct esr_report_spec {
    const char *path;        /* the HTML file to write */
    const char *title;       /* page heading, e.g. the run directory */
    const struct esr_dataset *ds;
    const struct esr_eval_result *res;
    const char *render_href; /* directory of the renders (N.png, N_linear.png, N_normal.png),
                              * relative to the report */
    const char *gt_dir;      /* directory where ground-truth copies N.png (composited on white)
                              * are written for the page; created if absent */
    const char *gt_href;     /* gt_dir relative to the report */
    const char *train_log;   /* JSON-lines training log, or NULL / a missing file for none */
    const struct esr_lights *lights; /* the lights the model found (model/lights.h), or NULL */
    const struct esr_chamfer_result *geometry; /* against the dataset's mesh, or NULL */
};

/* Writes the ground-truth copies and the page (atomically). Fails naming the file on a write
 * error, an unreadable ground-truth image or a malformed training log. */
int esr_report_write(const struct esr_report_spec *spec);

#endif
