/* Test-only FMI 2.0 logger for osiris-fmu's tests.
 *
 * fmi2CallbackLogger is C-variadic; defining a variadic function is unstable in Rust, and casting a
 * non-variadic Rust fn to the variadic type is undefined behaviour. So the logger is written in C:
 * it formats the message with vsnprintf, exactly as a real importer would, and forwards the
 * result (plus the raw format string, so tests can check it is "%s") to a Rust sink. */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>

/* Implemented in Rust (osiris_fmu_testlog). */
void osiris_testlog_sink(void *env, const char *instance_name, int status, const char *category,
                         const char *format, const char *formatted);

void osiris_testlog_logger(void *env, const char *instance_name, int status, const char *category,
                           const char *message, ...) {
    char small[1024];
    va_list args;
    va_start(args, message);
    int n = message ? vsnprintf(small, sizeof small, message, args) : -1;
    va_end(args);
    if (n < 0) {
        osiris_testlog_sink(env, instance_name, status, category, message, "(vsnprintf failed)");
        return;
    }
    if ((size_t)n < sizeof small) {
        osiris_testlog_sink(env, instance_name, status, category, message, small);
        return;
    }
    char *big = malloc((size_t)n + 1);
    if (!big) {
        osiris_testlog_sink(env, instance_name, status, category, message, "(out of memory)");
        return;
    }
    va_start(args, message);
    vsnprintf(big, (size_t)n + 1, message, args);
    va_end(args);
    osiris_testlog_sink(env, instance_name, status, category, message, big);
    free(big);
}
