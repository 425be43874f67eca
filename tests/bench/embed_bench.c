/* The cost of embedding mcpt through its C API, on one device:
 *   throughput  samples/s of the default scene (SIZE x SIZE, default 256) rendered for
 *               `seconds`, in one call;
 *   pass        median wall time of a 1-spp pass at 64x64 (a few ms of work), the part of it the
 *               engine measured inside (Session::render), and their difference: what the C API
 *               call adds per pass.
 * Usage: mcpt_embed_bench DEVICE [SECONDS] [PASSES] [SIZE]; prints one CSV line (see the
 * header). */
#define _POSIX_C_SOURCE 199309L /* clock_gettime */
#include <mcpt/mcpt.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

static double now(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static int by_value(const void* a, const void* b) {
    const double x = *(const double*)a, y = *(const double*)b;
    return (x > y) - (x < y);
}

static double median(double* v, int n) {
    qsort(v, (size_t)n, sizeof(double), by_value);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

static int fail(mcpt_session s) {
    fprintf(stderr, "mcpt_embed_bench: %s\n", mcpt_last_error(s));
    mcpt_session_release(s);
    return 1;
}

int main(int argc, char** argv) {
    const double seconds = argc > 2 ? atof(argv[2]) : 5.0;
    const int passes = argc > 3 ? atoi(argv[3]) : 200;
    const int size = argc > 4 ? atoi(argv[4]) : 256;
    mcpt_session s = NULL;
    mcpt_render_stats st;
    double *wall = malloc(sizeof(double) * (size_t)passes),
           *inside = malloc(sizeof(double) * (size_t)passes);
    int i;
    if (argc < 2 || passes < 1 || size < 1 || !wall || !inside) {
        fprintf(stderr, "usage: mcpt_embed_bench DEVICE [SECONDS] [PASSES] [SIZE]\n");
        return 2;
    }
    if (mcpt_session_create(argv[1], &s) != MCPT_OK || mcpt_session_load_builtin(s, "cornell") ||
        mcpt_session_set_size(s, size, size) || mcpt_session_commit(s) ||
        mcpt_session_render(s, 1000.0 * seconds, 0.0, 0, &st))
        return fail(s);
    const double samples_per_s = (double)st.samples * (double)size * (double)size / st.seconds;
    /* 1-spp passes at 64x64, after a few to warm up. */
    if (mcpt_session_set_size(s, 64, 64) || mcpt_session_commit(s)) return fail(s);
    for (i = -5; i < passes; ++i) {
        const double t0 = now();
        if (mcpt_session_render(s, 0.0, 0.0, st.spp + 1, &st)) return fail(s);
        if (i >= 0) wall[i] = now() - t0, inside[i] = st.seconds;
    }
    const double w = median(wall, passes), in = median(inside, passes);
    for (i = 0; i < passes; ++i) wall[i] -= inside[i];
    printf("c_api,%s,%.4g,%.4f,%.4f,%.2f\n", argv[1], samples_per_s, 1e3 * w, 1e3 * in,
           1e6 * median(wall, passes));
    free(wall);
    free(inside);
    return mcpt_session_release(s) == MCPT_OK ? 0 : 1;
}
