/* Where a training step's time goes (`esr bench train`): exclusive wall time, and the work done
 * (floating-point operations or bytes moved), per part of the step.
 *
 * Parts nest (the LTS calls the point fields, which call the MLPs): enter/exit keep a stack, and
 * a part's time excludes the parts entered inside it, so the parts add up to the time spent in
 * any of them. A part counts wherever it runs while the profile is on, or only inside the
 * training steps (ESR_PROF_STEPS, what `esr bench` uses). Off unless esr_prof_enable: then each
 * enter/exit costs two clock reads. Only
 * the calling thread outside OpenMP parallel regions counts (the training loop's); a call from
 * inside a parallel region is ignored, so concurrent renders cannot race on the counters. */
#ifndef ESR_CORE_PROFILE_H
#define ESR_CORE_PROFILE_H

#ifdef __cplusplus
extern "C" {
#endif

enum esr_prof_part {
    ESR_PROF_MARCH,         /* primary rays: sampling, SDF, alpha, kept list (forward, backward) */
    ESR_PROF_FIELDS,        /* feature grids, encodings and heads round the MLPs (point and
                               material fields, forward and backward, less the MLPs) */
    ESR_PROF_MLP_FWD,       /* the MLPs' forward GEMMs and activations */
    ESR_PROF_MLP_BWD,       /* their backward */
    ESR_PROF_COMPOSITE,     /* volume compositing along the primary rays, forward and backward */
    ESR_PROF_LTS_SECONDARY, /* the LTS's secondary rays: sphere tracing to the first hit */
    ESR_PROF_LTS_LOSS,      /* the LTS's estimates, BRDF and loss */
    ESR_PROF_PDRA,          /* pdra's groups, suppression and regularisers (less its fields) */
    ESR_PROF_REG,           /* SDF smoothing and total variation */
    ESR_PROF_ADAM,          /* the optimiser */
    ESR_PROF_PARTS
};

struct esr_prof_totals {
    double step_seconds; /* ESR_PROF_STEPS: wall time inside the steps, and their count */
    long steps;
    double seconds[ESR_PROF_PARTS];
    double flops[ESR_PROF_PARTS]; /* floating-point operations counted (MLPs) */
    double bytes[ESR_PROF_PARTS]; /* bytes moved counted (Adam) */
};

/* 0: off; ESR_PROF_EVERYWHERE (1): parts count wherever they run; ESR_PROF_STEPS: only inside
 * esr_prof_step_begin/end (the trainer's iterations: batch, step, regularisers, Adam), so what
 * a stage does besides its steps (checkpoints, the lights' estimation) stays out of the parts. */
enum { ESR_PROF_EVERYWHERE = 1, ESR_PROF_STEPS = 2 };
void esr_prof_enable(int mode);
void esr_prof_step_begin(void);
void esr_prof_step_end(void);
/* Zeroes the totals (and drops an unfinished stack). */
void esr_prof_reset(void);
void esr_prof_enter(enum esr_prof_part part);
void esr_prof_exit(enum esr_prof_part part);
/* Adds work to a part's counters (ignored when off or inside a parallel region). */
void esr_prof_work(enum esr_prof_part part, double flops, double bytes);
void esr_prof_totals(struct esr_prof_totals *out);
/* "march", "fields", ... */
const char *esr_prof_part_name(enum esr_prof_part part);

#ifdef __cplusplus
}
#endif
#endif
