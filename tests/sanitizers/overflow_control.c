/* Negative control of the sanitizer build: the caller says its buffer holds one pixel more
 * than it does, the engine fills what it was told, and AddressSanitizer must report the
 * heap-buffer-overflow inside the engine (proving the engine's code is instrumented). */
#include <mcpt/mcpt.h>
#include <stdio.h>
#include <stdlib.h>

int main(void) {
    mcpt_session s = NULL;
    mcpt_render_stats stats;
    float* pixels = malloc(sizeof(float) * 4 * (8 * 8 - 1));
    if (!pixels || mcpt_session_create("", &s) != MCPT_OK ||
        mcpt_session_load_builtin(s, "cornell") != MCPT_OK ||
        mcpt_session_set_size(s, 8, 8) != MCPT_OK ||
        mcpt_session_render(s, 0.0, 0.0, 1, &stats) != MCPT_OK) {
        fprintf(stderr, "setup failed: %s\n", mcpt_last_error(s));
        return 2;
    }
    mcpt_session_read_rgba32f(s, pixels, 4 * 8 * 8); /* one pixel too many */
    printf("no overflow reported\n");
    free(pixels);
    return mcpt_session_release(s) == MCPT_OK ? 0 : 1;
}
