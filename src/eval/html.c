/* Writing into the HTML reports: escaped text, metric cells (see html.h). */
#include "eval/html.h"

#include <math.h>

void esr_html_put_escaped(FILE *out, const char *text)
{
    for (const char *p = text; *p; p++) {
        switch (*p) {
        case '&': fputs("&amp;", out); break;
        case '<': fputs("&lt;", out); break;
        case '>': fputs("&gt;", out); break;
        case '"': fputs("&quot;", out); break;
        default: fputc(*p, out);
        }
    }
}

void esr_html_put_number(FILE *out, const char *fmt, double v)
{
    fputs("<td>", out);
    if (isnan(v))
        fputs("-", out);
    else
        fprintf(out, fmt, v);
    fputs("</td>", out);
}
