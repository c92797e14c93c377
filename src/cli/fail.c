/* How a command says it failed (declared in commands.h): one line naming the command, so a
 * message from a step of `esr demo` says which step it came from. */
#include <stdarg.h>
#include <stdio.h>

#include "cli/commands.h"
#include "core/error.h"

int cli_fail(const struct esr_command *cmd, const char *fmt, ...)
{
    fprintf(stderr, "esr %s: error: ", cmd->name);
    va_list args;
    va_start(args, fmt);
    vfprintf(stderr, fmt, args);
    va_end(args);
    fprintf(stderr, "\n(see `esr %s --help`)\n", cmd->name);
    return 1;
}

int cli_fail_lib(const struct esr_command *cmd)
{
    fprintf(stderr, "esr %s: error: %s\n", cmd->name,
            esr_error_pending() ? esr_error_message() : "unknown failure");
    return 1;
}
