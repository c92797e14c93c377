/* Writing text from files (dataset names, run paths, log fields) into the HTML reports. */
#ifndef ESR_EVAL_HTML_H
#define ESR_EVAL_HTML_H

#include <stdio.h>

/* Writes text with the HTML special characters (& < > ") escaped. */
void esr_html_put_escaped(FILE *out, const char *text);

#endif
