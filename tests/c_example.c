/* Render the default scene for half a second through the C API and save it. */
#include <mcpt/mcpt.h>
#include <stdio.h>

int main(int argc, char** argv) {
    mcpt_session s = NULL;
    mcpt_render_stats stats;
    if (mcpt_session_create(argc > 1 ? argv[1] : "", &s) != MCPT_OK ||
        mcpt_session_load_builtin(s, "cornell") != MCPT_OK ||
        mcpt_session_set_size(s, 128, 128) != MCPT_OK ||
        mcpt_session_render(s, 500.0, 0.0, 0, &stats) != MCPT_OK ||
        mcpt_session_write_image(s, argc > 2 ? argv[2] : "example.png") != MCPT_OK) {
        fprintf(stderr, "mcpt: %s\n", mcpt_last_error(s));
        mcpt_session_release(s);
        return 1;
    }
    printf("mcpt %s: %llu spp, ", mcpt_version_string(), (unsigned long long)stats.spp);
    if (stats.relative_error < 0) printf("error unknown (under 2 spp)\n");
    else printf("relative error %.2f%%\n", 100.0 * stats.relative_error);
    return mcpt_session_release(s) == MCPT_OK ? 0 : 1;
}
