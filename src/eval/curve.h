/* Training curves for reports: one numeric field of a JSON-lines log as an inline SVG plot. */
#ifndef ESR_EVAL_CURVE_H
#define ESR_EVAL_CURVE_H

#include <stdio.h>

#define ESR_CURVE_MAX_STAGES 8

struct esr_curve {
    int n;
    double *x, *y; /* x = record number (0-based line of the log), y = the field's value */
    int n_stages;  /* where each stage's records begin (records with a "stage" member) */
    double stage_x[ESR_CURVE_MAX_STAGES];
    char stage[ESR_CURVE_MAX_STAGES][16];
};

/* Reads every line of a JSON-lines file (one object per line, blank lines skipped) and keeps the
 * records whose member `key` is a finite number. Fails naming the file and line on a line that
 * is not a JSON object. An absent key gives an empty curve (n = 0). Free with esr_curve_free. */
int esr_curve_load_jsonl(const char *path, const char *key, struct esr_curve *c);
/* The same on text in memory (size bytes, no NUL needed); name is the file named in errors. */
int esr_curve_parse_jsonl(const char *text, size_t size, const char *name, const char *key, struct esr_curve *c);
void esr_curve_free(struct esr_curve *c);

/* Writes the curve as an inline <svg> element of width x height pixels: a polyline, the y range
 * and the x range as text, the stages' starts as labelled lines, titled `label`; y on a log scale
 * when every value is positive and they span more than a factor of 20 (the title says so). Needs
 * c->n >= 1. Returns the stream's error state. */
int esr_curve_write_svg(FILE *out, const struct esr_curve *c, const char *label, int width, int height);

#endif
