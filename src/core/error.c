#include "core/error.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

static _Thread_local char error_message[1024];
static _Thread_local char error_origin[256];
static _Thread_local int error_is_pending;

int esr_error_set(const char *file, int line, const char *fmt, ...)
{
    if (error_is_pending)
        return ESR_ERR; /* keep the first, root-cause message */
    va_list args;
    va_start(args, fmt);
    vsnprintf(error_message, sizeof error_message, fmt, args);
    va_end(args);
    const char *base = strrchr(file, '/');
    snprintf(error_origin, sizeof error_origin, "%s:%d", base ? base + 1 : file, line);
    error_is_pending = 1;
    return ESR_ERR;
}

void esr_error_append(const char *fmt, ...)
{
    if (!error_is_pending)
        return;
    const size_t len = strlen(error_message);
    va_list args;
    va_start(args, fmt);
    vsnprintf(error_message + len, sizeof error_message - len, fmt, args);
    va_end(args);
}

const char *esr_error_message(void) { return error_is_pending ? error_message : ""; }
const char *esr_error_origin(void) { return error_is_pending ? error_origin : ""; }
int esr_error_pending(void) { return error_is_pending; }

void esr_error_clear(void)
{
    error_is_pending = 0;
    error_message[0] = '\0';
    error_origin[0] = '\0';
}
