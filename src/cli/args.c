/* Argument parsing helpers shared by the subcommands (declared in commands.h). */
#include <errno.h>
#include <stdlib.h>

#include "cli/commands.h"

int cli_parse_int(const char *text, long lo, long hi, int *out)
{
    char *end;
    errno = 0;
    long v = strtol(text, &end, 10);
    if (errno || end == text || *end || v < lo || v > hi)
        return -1;
    *out = (int)v;
    return 0;
}
