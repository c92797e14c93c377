/* Writing into the HTML reports: text from files (dataset names, run paths, log fields), metric cells. */
#ifndef ESR_EVAL_HTML_H
#define ESR_EVAL_HTML_H

#include <stdio.h>

/* Writes text with the HTML special characters (& < > ") escaped. */
void esr_html_put_escaped(FILE *out, const char *text);
/* A metric's table cell: <td>v as fmt</td>, or "-" when the value is missing (NAN). */
void esr_html_put_number(FILE *out, const char *fmt, double v);

#endif
