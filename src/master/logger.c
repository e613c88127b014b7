/* C shim for the FMI 2.0 logger callback of the osiris co-simulation master.
 *
 * fmi2CallbackLogger is C-variadic. Rust cannot define variadic functions on stable, and calling a
 * non-variadic function through a variadic pointer is undefined behaviour, so this shim formats the message
 * with vsnprintf and forwards the plain text to `osiris_master_log_sink` (src/master/instance.rs). */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>

void osiris_master_log_sink(void *env, const char *instance, int status, const char *category,
                            const char *message);

void osiris_master_logger(void *env, const char *instance, int status, const char *category,
                          const char *message, ...) {
    char small[1024];
    char *text = small;
    char *heap = NULL;
    if (message == NULL) {
        osiris_master_log_sink(env, instance, status, category, NULL);
        return;
    }
    va_list args, again;
    va_start(args, message);
    va_copy(again, args);
    int n = vsnprintf(small, sizeof small, message, args);
    if (n < 0) {
        text = (char *)message; /* encoding error: forward the raw format */
    } else if ((size_t)n >= sizeof small && (heap = (char *)malloc((size_t)n + 1)) != NULL) {
        vsnprintf(heap, (size_t)n + 1, message, again);
        text = heap;
    } /* else: allocation failed, `small` holds the truncated text */
    va_end(again);
    va_end(args);
    osiris_master_log_sink(env, instance, status, category, text);
    free(heap);
}
