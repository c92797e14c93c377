/* Argument parsing helpers shared by the subcommands (declared in commands.h). */
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "cli/commands.h"

/* A number as people write it: an optional '-', then a digit (or '.' and a digit); strtol and
 * strtod would also take leading spaces, '+', hexadecimal, inf and nan. */
static int plain_number(const char *text)
{
    const char *t = text[0] == '-' ? text + 1 : text;
    const int starts = (t[0] >= '0' && t[0] <= '9') || (t[0] == '.' && t[1] >= '0' && t[1] <= '9');
    return starts && !strpbrk(text, "xX");
}

int cli_parse_int(const char *text, long lo, long hi, int *out)
{
    char *end;
    errno = 0;
    if (!plain_number(text))
        return -1;
    long v = strtol(text, &end, 10);
    if (errno || end == text || *end || v < lo || v > hi)
        return -1;
    *out = (int)v;
    return 0;
}

int cli_parse_double(const char *text, double lo, double hi, double *out)
{
    char *end;
    errno = 0;
    if (!plain_number(text))
        return -1;
    const double v = strtod(text, &end);
    /* ERANGE: 1e-400 would be taken as 0 */
    if (errno || end == text || *end || !isfinite(v) || !(v >= lo && v <= hi))
        return -1;
    *out = v;
    return 0;
}
