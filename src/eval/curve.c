/* JSON-lines training log -> SVG polyline. */
#include "eval/curve.h"

#include <cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "eval/html.h"
#include "io/file.h"

static int append_point(struct esr_curve *c, int *cap, double x, double y)
{
    if (c->n == *cap) {
        int next = *cap ? 2 * *cap : 256;
        double *nx = realloc(c->x, (size_t)next * sizeof *nx);
        if (nx)
            c->x = nx;
        double *ny = nx ? realloc(c->y, (size_t)next * sizeof *ny) : NULL;
        if (!ny)
            return ESR_FAIL("out of memory reading a training log");
        c->y = ny;
        *cap = next;
    }
    c->x[c->n] = x;
    c->y[c->n] = y;
    c->n++;
    return ESR_OK;
}

/* Lines are cut by length, not by NUL: the text need not be NUL-terminated (a fuzzer's input,
 * a buffer), and each line is parsed with cJSON_ParseWithLength. */
int esr_curve_parse_jsonl(const char *text, size_t size, const char *name, const char *key, struct esr_curve *c)
{
    memset(c, 0, sizeof *c);
    int cap = 0, record = 0, line_no = 0, status = ESR_OK;
    for (size_t at = 0; at < size && status == ESR_OK;) {
        const char *line = text + at, *nl = memchr(line, '\n', size - at);
        size_t len = nl ? (size_t)(nl - line) : size - at;
        at += len + 1;
        line_no++;
        size_t blank = 0;
        while (blank < len && strchr(" \t\r", line[blank]) && line[blank])
            blank++;
        if (blank == len)
            continue;
        cJSON *obj = cJSON_ParseWithLength(line, len);
        if (!cJSON_IsObject(obj)) {
            status = ESR_FAIL("'%s' line %d is not a JSON object", name, line_no);
        } else {
            const cJSON *v = cJSON_GetObjectItemCaseSensitive(obj, key);
            const cJSON *st = cJSON_GetObjectItemCaseSensitive(obj, "stage");
            if (cJSON_IsString(st) && c->n_stages < ESR_CURVE_MAX_STAGES &&
                (c->n_stages == 0 || strncmp(c->stage[c->n_stages - 1], st->valuestring,
                                             sizeof c->stage[0] - 1))) {
                c->stage_x[c->n_stages] = record;
                snprintf(c->stage[c->n_stages++], sizeof c->stage[0], "%s", st->valuestring);
            }
            if (cJSON_IsNumber(v) && isfinite(v->valuedouble))
                status = append_point(c, &cap, record, v->valuedouble);
            record++;
        }
        cJSON_Delete(obj);
    }
    if (status != ESR_OK)
        esr_curve_free(c);
    return status;
}

int esr_curve_load_jsonl(const char *path, const char *key, struct esr_curve *c)
{
    memset(c, 0, sizeof *c);
    unsigned char *text;
    size_t size;
    ESR_TRY(esr_file_read_all(path, &text, &size));
    int status = esr_curve_parse_jsonl((const char *)text, size, path, key, c);
    free(text);
    return status;
}

void esr_curve_free(struct esr_curve *c)
{
    free(c->x);
    free(c->y);
    memset(c, 0, sizeof *c);
}

/* Maps v from [lo, hi] to [a, b]; the middle when the range is empty. */
static double map_range(double v, double lo, double hi, double a, double b)
{
    return hi > lo ? a + (v - lo) / (hi - lo) * (b - a) : 0.5 * (a + b);
}

int esr_curve_write_svg(FILE *out, const struct esr_curve *c, const char *label, int width, int height)
{
    double xlo = c->x[0], xhi = c->x[0], ylo = c->y[0], yhi = c->y[0];
    for (int i = 1; i < c->n; i++) {
        xlo = fmin(xlo, c->x[i]);
        xhi = fmax(xhi, c->x[i]);
        ylo = fmin(ylo, c->y[i]);
        yhi = fmax(yhi, c->y[i]);
    }
    /* a loss falls over orders of magnitude: linear, all but its first records lie flat */
    const int log_y = ylo > 0.0 && yhi > 20.0 * ylo;
    const double top = 20.0, bottom = height - 24.0, margin = 40.0; /* room for the labels */
    fprintf(out, "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"%d\" height=\"%d\">\n", width, height);
    fprintf(out, "<rect width=\"100%%\" height=\"100%%\" fill=\"#fff\" stroke=\"#ccc\"/>\n");
    fprintf(out, "<text x=\"%g\" y=\"14\" font-size=\"12\">%s%s</text>\n", margin, label,
            log_y ? " (log scale)" : "");
    fprintf(out, "<text x=\"2\" y=\"%g\" font-size=\"10\">%.4g</text>\n", top + 8.0, yhi);
    fprintf(out, "<text x=\"2\" y=\"%g\" font-size=\"10\">%.4g</text>\n", bottom, ylo);
    fprintf(out, "<text x=\"%g\" y=\"%d\" font-size=\"10\">log records %.0f .. %.0f (the stages in "
                 "turn)</text>\n", margin, height - 4, xlo, xhi);
    for (int s = 0; s < c->n_stages; s++) {
        const double x = map_range(c->stage_x[s], xlo, xhi, margin, width - 8.0);
        fprintf(out, "<line x1=\"%.1f\" y1=\"%g\" x2=\"%.1f\" y2=\"%g\" stroke=\"#bbb\"/>"
                     "<text x=\"%.1f\" y=\"%g\" font-size=\"9\" fill=\"#777\">",
                x, top, x, bottom, x + 2.0, top + 8.0 + 10.0 * (s % 2));
        esr_html_put_escaped(out, c->stage[s]); /* a log's own text */
        fputs("</text>\n", out);
    }
    const double ly0 = log_y ? log(ylo) : ylo, ly1 = log_y ? log(yhi) : yhi;
    fprintf(out, "<polyline fill=\"none\" stroke=\"#1f5fbf\" stroke-width=\"1.2\" points=\"");
    for (int i = 0; i < c->n; i++)
        fprintf(out, "%.1f,%.1f ", map_range(c->x[i], xlo, xhi, margin, width - 8.0),
                map_range(log_y ? log(c->y[i]) : c->y[i], ly0, ly1, bottom, top));
    fprintf(out, "\"/>\n</svg>\n");
    return ferror(out) ? ESR_FAIL("error writing an SVG curve") : ESR_OK;
}
