/* Error reporting for the library: functions return ESR_OK or ESR_ERR and the first error
 * message (with the file and line that raised it) is kept per thread until cleared.
 * The library never prints or exits; only the CLI does. */
#ifndef ESR_CORE_ERROR_H
#define ESR_CORE_ERROR_H

#ifdef __cplusplus
extern "C" {
#endif

enum esr_status { ESR_OK = 0, ESR_ERR = -1 };

/* Records an error if none is pending; always returns ESR_ERR so callers can `return esr_fail(...)`. */
int esr_error_set(const char *file, int line, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
/* The pending message ("" when none). Valid until the next esr_error_clear on this thread. */
const char *esr_error_message(void);
/* Adds text to the end of the pending message (nothing when none is pending): advice that only
 * the caller knows, such as how to recover from a damaged file. */
void esr_error_append(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
/* Where the pending error was raised ("file:line", "" when none). */
const char *esr_error_origin(void);
void esr_error_clear(void);
int esr_error_pending(void);

#define ESR_FAIL(...) esr_error_set(__FILE__, __LINE__, __VA_ARGS__)
/* Propagates a failing call: `ESR_TRY(esr_png_read(p, &img));` */
#define ESR_TRY(expr) do { if ((expr) != ESR_OK) return ESR_ERR; } while (0)

#ifdef __cplusplus
}
#endif
#endif
