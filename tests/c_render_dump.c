/* The render the Java test makes, through the C API: cornell, 32x32, seed 7, reproducible,
 * 8 spp, written as raw 8-bit RGBA. Usage: c_render_dump DEVICE OUT.rgba [SEED] */
#include <mcpt/mcpt.h>
#include <stdio.h>
#include <stdlib.h>

int main(int argc, char** argv) {
    static uint8_t px[4 * 32 * 32];
    mcpt_session s = NULL;
    FILE* f = NULL;
    if (argc != 3 && argc != 4) return 2;
    if (mcpt_session_create(argv[1], &s) != MCPT_OK || mcpt_session_load_builtin(s, "cornell") ||
        mcpt_session_set_size(s, 32, 32) ||
        mcpt_session_set_seed(s, argc == 4 ? (uint32_t)atoi(argv[3]) : 7) ||
        mcpt_session_set_reproducible(s, 1) || mcpt_session_render(s, 1e6, 0, 8, NULL) ||
        mcpt_session_read_rgba8(s, px, sizeof px)) {
        fprintf(stderr, "c_render_dump: %s\n", mcpt_last_error(s));
        return 1;
    }
    f = fopen(argv[2], "wb");
    if (!f || fwrite(px, 1, sizeof px, f) != sizeof px || fclose(f) != 0) return 1;
    return mcpt_session_release(s) == MCPT_OK ? 0 : 1;
}
