/* Exclusive-time profile of the training step's parts (see profile.h). */
#include "core/profile.h"

#include <omp.h>
#include <string.h>

#define PROF_DEPTH 16

static struct {
    int on, depth, in_step;
    double step_start;
    struct {
        enum esr_prof_part part;
        double start, inner; /* inner: time of the parts entered inside it */
    } stack[PROF_DEPTH];
    struct esr_prof_totals tot;
} prof;

static int counting(void)
{
    return prof.on && !omp_in_parallel() && (prof.on != ESR_PROF_STEPS || prof.in_step);
}

void esr_prof_enable(int mode)
{
    prof.on = mode;
    prof.in_step = 0;
}

void esr_prof_reset(void)
{
    prof.depth = 0;
    prof.in_step = 0;
    memset(&prof.tot, 0, sizeof prof.tot);
}

void esr_prof_step_begin(void)
{
    if (prof.on != ESR_PROF_STEPS || omp_in_parallel())
        return;
    prof.in_step = 1;
    prof.depth = 0;
    prof.step_start = omp_get_wtime();
}

void esr_prof_step_end(void)
{
    if (!prof.in_step || omp_in_parallel())
        return;
    prof.tot.step_seconds += omp_get_wtime() - prof.step_start;
    prof.tot.steps++;
    prof.in_step = 0;
}

void esr_prof_enter(enum esr_prof_part part)
{
    if (!counting())
        return;
    if (prof.depth < PROF_DEPTH) {
        prof.stack[prof.depth].part = part;
        prof.stack[prof.depth].start = omp_get_wtime();
        prof.stack[prof.depth].inner = 0.0;
    }
    prof.depth++;
}

void esr_prof_exit(enum esr_prof_part part)
{
    if (!counting() || prof.depth == 0)
        return;
    prof.depth--;
    if (prof.depth >= PROF_DEPTH || prof.stack[prof.depth].part != part)
        return; /* too deep, or unbalanced: not counted */
    const double dt = omp_get_wtime() - prof.stack[prof.depth].start;
    prof.tot.seconds[part] += dt - prof.stack[prof.depth].inner;
    if (prof.depth > 0 && prof.depth - 1 < PROF_DEPTH)
        prof.stack[prof.depth - 1].inner += dt;
}

void esr_prof_work(enum esr_prof_part part, double flops, double bytes)
{
    if (!counting())
        return;
    prof.tot.flops[part] += flops;
    prof.tot.bytes[part] += bytes;
}

void esr_prof_totals(struct esr_prof_totals *out)
{
    *out = prof.tot;
}

const char *esr_prof_part_name(enum esr_prof_part part)
{
    static const char *const names[ESR_PROF_PARTS] = {
        "march", "fields", "mlp forward", "mlp backward", "composite", "lts secondary rays",
        "lts loss", "pdra", "regularisers", "adam"};
    return (unsigned)part < ESR_PROF_PARTS ? names[part] : "?";
}
