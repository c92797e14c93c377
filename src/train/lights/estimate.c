/* The one entry point to the lights (train/lights/lights.h, esr_lights_estimate): find, calibrate,
 * settle the rims, balance the colour, in that order, for the trainer (pdra's end and its
 * mid-stage hand-over) and `esr lights --recompute` / `--drop` alike; what happened comes back
 * as lines the caller prints or logs. */
#include "train/lights/lights.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "core/error.h"
#include "train/lights/fit.h"
#include "train/lights/solve.h"

static void add(struct esr_lights_report *rep, int warning, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));

static void add(struct esr_lights_report *rep, int warning, const char *fmt, ...)
{
    if (rep->n >= ESR_LIGHTS_REPORT_LINES)
        return;
    va_list args;
    va_start(args, fmt);
    vsnprintf(rep->line[rep->n], sizeof rep->line[0], fmt, args);
    va_end(args);
    rep->warning[rep->n++] = warning;
}

/* Says which lights the solve could not tell apart, and which only a bound fixes. */
static void report_solve(const struct esr_model *m, struct esr_lights_report *rep)
{
    for (int k = 0; k < m->lights.n; k++) {
        const struct esr_light *l = &m->lights.light[k];
        if (l->bound_only)
            add(rep, 1, "light %d: no unclipped pixel shows its light; its strength is the lower "
                        "bound its clipped pixels give", k);
        if (!l->inseparable)
            continue;
        char ids[128] = "";
        size_t at = 0;
        for (int j = 0; j < m->lights.n && at < sizeof ids - 8; j++)
            if (l->inseparable >> j & 1u)
                at += (size_t)snprintf(ids + at, sizeof ids - at, "%s%d", at ? ", " : "", j);
        add(rep, 1, "light %d: the photos fix only its strength plus that of light(s) %s (they light "
                    "the same pixels alike); each one's share is a guess", k, ids);
    }
}

int esr_lights_estimate(struct esr_model *m, const struct esr_ray_set *rs,
                        const struct esr_lights_estimate_opts *o, struct esr_lights_report *rep)
{
    memset(rep, 0, sizeof *rep);
    if (rs->n_off == 0)
        return ESR_FAIL("no lights-off training images to calibrate the lights with");
    if (o->find) {
        ESR_TRY(esr_lights_find(m, rs));
        if (m->lights.n_left_out > 0)
            add(rep, 0, ESR_LIGHTS_LEFT_OUT_FMT, m->lights.n_left_out, ESR_MAX_LIGHTS);
        if (m->lights.n == 0) { /* decided over the whole surface, not one batch's rays */
            add(rep, 0, "no emitters found: no surface point the cameras see has emission above "
                        "k = %.3g (the scene's lights are off or too dim to tell from reflection)",
                (double)m->cfg.emitter_k);
            return ESR_OK;
        }
    }
    if (m->lights.n == 0)
        return ESR_OK;
    ESR_TRY(esr_lights_calibrate(m, rs->orig3, rs->dir3, rs->n_off, m->cfg.lights_calib_points,
                                 o->seed, o->correct_base));
    if (!o->balance)
        return ESR_OK; /* pdra's hand-over: the strengths the BRDF as it stands explains */
    for (int i = 0; i < m->lights.n; i++) {
        char rim[320];
        if (esr_lights_rim_text(&m->lights, i, rim, sizeof rim))
            add(rep, 0, "%s", rim);
    }
    if (m->cfg.lights_balance) {
        struct esr_lights_balance_info bal;
        ESR_TRY(esr_lights_balance(m, rs, &bal));
        char line[256];
        esr_lights_balance_text(m, &bal, line, sizeof line);
        add(rep, 0, "%s", line);
    }
    const int solving = m->cfg.lights_solve && rs->n > rs->n_off; /* else: the calibration's */
    if (solving) {
        struct esr_lights_solve_info si;
        ESR_TRY(esr_lights_solve(m, rs, o->seed, &si));
        /* a light the photos do not show emitting (its strength 0, or within 3 standard errors
         * of it: a reflection the emission field took for a light, a fleck) is no light; the
         * others are solved again without it */
        int dropped = 0;
        for (int k = m->lights.n - 1; m->cfg.lights_solve_drop && k >= 0 && m->lights.n > 1; k--) {
            const struct esr_light *l = &m->lights.light[k];
            const int dark = l->scale[0] == 0.0f && l->scale[1] == 0.0f && l->scale[2] == 0.0f;
            if (!dark && (l->bound_only || !(l->strength_err > ESR_SOLVE_MAX_ERR)))
                continue;
            add(rep, 0, "light %d (area %.3g, at %.2f %.2f %.2f) dropped: the photos do not show it "
                        "emitting (strength %.3g %.3g %.3g +-%.0f%%: within 3 standard errors of "
                        "none; a reflection of a light, or a fleck)",
                k, (double)l->area, (double)l->centroid[0], (double)l->centroid[1],
                (double)l->centroid[2], (double)l->radiance[0], (double)l->radiance[1],
                (double)l->radiance[2], 100.0 * (double)l->strength_err);
            ESR_TRY(esr_lights_drop(&m->lights, k));
            dropped++;
        }
        if (dropped)
            ESR_TRY(esr_lights_solve(m, rs, o->seed, &si));
        add(rep, 0, "strengths solved from %ld lights-on pixels (%ld exact channel rows, %ld "
                    "clipped as lower bounds; residual scale %.3g %.3g %.3g; lights-off "
                    "correction's median %.3g %.3g %.3g) in %.1f s",
            si.rays, si.rows, si.bound_rows, si.sigma[0], si.sigma[1], si.sigma[2],
            (double)si.correction[0], (double)si.correction[1], (double)si.correction[2], si.seconds);
        report_solve(m, rep);
    }
    add(rep, 0, "lights found: %d", m->lights.n);
    if (esr_lights_uncalibrated(&m->lights))
        add(rep, 1, ESR_LIGHTS_UNCALIBRATED_TEXT);
    for (int i = 0; i < m->lights.n; i++) {
        const struct esr_light *l = &m->lights.light[i];
        char from[96];
        if (solving)
            snprintf(from, sizeof from, "solved on %.0f pixel rows, +-%.1f%%%s", (double)l->calib_points,
                     100.0 * (double)l->strength_err, l->bound_only ? ", a lower bound only" : "");
        else if (esr_light_strength_fitted(&m->lights, i))
            snprintf(from, sizeof from, "fitted on %.0f points", (double)l->calib_points);
        else
            snprintf(from, sizeof from, "%s", ESR_LIGHT_BORROWED_TEXT);
        add(rep, 0, "  light %d: at (%.2f, %.2f, %.2f), area %.3g, emitted radiance %.3g %.3g %.3g "
                    "(field %.3g %.3g %.3g x strength %.3g %.3g %.3g, %s)",
            i, (double)l->centroid[0], (double)l->centroid[1], (double)l->centroid[2],
            (double)l->area, (double)l->radiance[0], (double)l->radiance[1],
            (double)l->radiance[2], (double)l->field_rgb[0], (double)l->field_rgb[1],
            (double)l->field_rgb[2], (double)l->scale[0], (double)l->scale[1],
            (double)l->scale[2], from);
    }
    return ESR_OK;
}
