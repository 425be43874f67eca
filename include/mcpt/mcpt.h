/* mcpt.h: the C API of mcpt, a Monte Carlo path tracer with a k-d tree on OpenCL and Vulkan.
 *
 * C99, no C++ needed by the caller. Link -lmcpt (pkg-config mcpt, or CMake find_package(mcpt)
 * and target mcpt::mcpt).
 *
 * Contents
 *   1. Version
 *   2. Status codes and errors
 *   3. Devices
 *   4. Sessions: create, release
 *   5. Scenes: from a file, from memory, built in
 *   6. Settings
 *   7. Rendering: passes with a time budget, target error, cancel
 *   8. Images: linear float RGBA, 8-bit sRGB RGBA, EXR/PNG files
 *   9. Checkpoints
 *  10. Jobs: the A/B test (compare) and the error curve (converge)
 *
 * Handles are opaque: a released or never-created handle is recognised and refused with
 * MCPT_ERROR_INVALID_HANDLE, never dereferenced. Every function returns a status (or a value
 * that cannot fail); on failure, mcpt_last_error() gives the message. No C++ exception, abort
 * or signal crosses this boundary.
 *
 * Thread safety: device enumeration and session creation may be called from any thread.
 * Calls on one session are serialised by the session (a second thread waits), except
 * mcpt_session_cancel(), which never waits and may be called from any thread at any time.
 * Different sessions run independently. Jobs (section 10) follow the same rules.
 */
#ifndef MCPT_MCPT_H
#define MCPT_MCPT_H

#include <stddef.h>
#include <stdint.h>

#if defined(_WIN32)
#define MCPT_API __declspec(dllexport)
#elif defined(__GNUC__)
#define MCPT_API __attribute__((visibility("default")))
#else
#define MCPT_API
#endif

#ifdef __cplusplus
extern "C" {
#endif

/* ---- 1. Version */

#define MCPT_VERSION_MAJOR 0
#define MCPT_VERSION_MINOR 1
#define MCPT_VERSION_PATCH 0
#define MCPT_VERSION_STRING "0.1.0"

/* The library's version as major * 10000 + minor * 100 + patch, and as "0.1.0". Compare with
 * the MCPT_VERSION_* macros the caller was compiled with. Any thread. */
MCPT_API int mcpt_version(void);
MCPT_API const char* mcpt_version_string(void);

/* ---- 2. Status codes and errors */

typedef enum mcpt_status {
    MCPT_OK = 0,
    MCPT_CANCELLED = 1,               /* a render ended by mcpt_session_cancel(); the
                                         samples it took are kept */
    MCPT_ERROR_INVALID_ARGUMENT = -1, /* NULL pointer, value out of range, buffer too small */
    MCPT_ERROR_INVALID_HANDLE = -2,   /* NULL, released or unknown session */
    MCPT_ERROR_INVALID_STATE = -3,    /* out of order: rendering before a scene is loaded,
                                         reading an image before anything is rendered */
    MCPT_ERROR_SCENE = -4,            /* a scene that cannot be read or rendered */
    MCPT_ERROR_DEVICE = -5,           /* no such device, a driver failure, a scene or image
                                         beyond the device's limits */
    MCPT_ERROR_IO = -6,               /* a file that cannot be written, or a checkpoint refused */
    MCPT_ERROR_OUT_OF_MEMORY = -7,
    MCPT_ERROR_INTERNAL = -8,
    MCPT_ERROR_DEVICE_LOST = -9 /* the device stopped mid-render (a driver reset, a watchdog,
                                   out of resources); the image keeps the samples taken
                                   before, and the session renders no more */
} mcpt_status;

/* "MCPT_ERROR_SCENE" for a status; "unknown status" otherwise. Any thread. */
MCPT_API const char* mcpt_status_name(mcpt_status status);

typedef struct mcpt_session_s* mcpt_session;

/* The message of the last failed call on `session`; with NULL (or a handle that is not a live
 * session), of the last failed call on this thread that had no live session (create, or a
 * call with a bad handle). "" if none. The text stays valid until this thread's next
 * mcpt_last_error() call. */
MCPT_API const char* mcpt_last_error(mcpt_session session);

/* ---- 3. Devices */

typedef struct mcpt_device_info {
    char api[16];       /* "opencl" | "vulkan" */
    int index;          /* position in that API's device list */
    char name[256];     /* device name */
    char platform[256]; /* OpenCL platform or Vulkan driver */
    char type[16];      /* "gpu" | "cpu" | "other" */
    char spec[32];      /* what mcpt_session_create() takes for it, e.g. "vulkan:0" */
} mcpt_device_info;

/* Every device of every API this build has. Writes at most `capacity` entries to `devices`
 * (may be NULL when capacity is 0) and the total number to *count. Any thread. */
MCPT_API mcpt_status mcpt_devices(mcpt_device_info* devices, size_t capacity, size_t* count);

/* ---- 4. Sessions */

/* Opens a session on a device: "" or NULL (the first GPU of any API, else the first device),
 * "opencl", "vulkan", or either with ":index" or ":name substring" (see mcpt_devices()).
 * On failure *out is NULL and mcpt_last_error(NULL) says why. Any thread. */
MCPT_API mcpt_status mcpt_session_create(const char* device, mcpt_session* out);

/* Opens a session on `count` devices at once (specs as above; the same device may appear more
 * than once): one image, its samples split into chunks handed to whichever device asks next,
 * sized to each device's speed. With reproducible rendering (a multiple of 16 samples per
 * pixel) the image is one device's, bit for bit, when the devices are of one kind. A device
 * that fails ends the render with its name in the message, keeping every sample before. */
MCPT_API mcpt_status mcpt_session_create_devices(const char* const* devices, size_t count,
                                                 mcpt_session* out);

/* Cancels a render in progress, waits for it, and frees everything. Releasing a released
 * handle returns MCPT_ERROR_INVALID_HANDLE. Any thread. */
MCPT_API mcpt_status mcpt_session_release(mcpt_session session);

/* The session's device. */
MCPT_API mcpt_status mcpt_session_device(mcpt_session session, mcpt_device_info* out);

/* ---- 5. Scenes (each replaces the session's scene and restarts accumulation) */

/* A glTF 2.0 file (.gltf or .glb). */
MCPT_API mcpt_status mcpt_session_load_file(mcpt_session session, const char* path);

/* A .glb or .gltf held in memory, e.g. read from an Android app's assets. External files
 * that a .gltf references are read from base_dir only; with base_dir NULL the file system is
 * never touched. The bytes are not kept after the call. */
MCPT_API mcpt_status mcpt_session_load_memory(mcpt_session session, const void* data, size_t size,
                                              const char* base_dir);

/* A built-in scene: "cornell" (the default scene), "furnace", "spheres". */
MCPT_API mcpt_status mcpt_session_load_builtin(mcpt_session session, const char* name);

/* Light from every direction no surface covers, for this scene and every scene loaded after:
 * an equirectangular map of linear radiance (.exr or Radiance .hdr, +Y up, as Blender and
 * glTF viewers orient it), turned by rotate_deg about +Y and scaled by `scale`. From a file,
 * or from `size` bytes in memory (an Android asset); path NULL removes the environment.
 * Importance-sampled by luminance and combined with BSDF sampling (MIS). A map too large for
 * the device is halved until it fits, with a warning. */
MCPT_API mcpt_status mcpt_session_set_environment(mcpt_session session, const char* path,
                                                  float rotate_deg, float scale);
MCPT_API mcpt_status mcpt_session_set_environment_memory(mcpt_session session, const void* data,
                                                         size_t size, float rotate_deg,
                                                         float scale);
/* A constant background of radiance (r, g, b) lighting the scene the same way; (0, 0, 0)
 * removes it. */
MCPT_API mcpt_status mcpt_session_set_background(mcpt_session session, float r, float g, float b);

/* What the session renders, after the first render (or mcpt_session_commit()). */
typedef struct mcpt_scene_info {
    uint64_t triangles, spheres, materials, lights;
    char tree[16];         /* the k-d tree built: "sah" | "median" | "none" */
    char tree_reason[512]; /* with tree "auto": why that tree ("" otherwise) */
    char features[256];    /* the device features the scene uses, compiled in */
    int max_bounces;       /* in effect */
} mcpt_scene_info;
MCPT_API mcpt_status mcpt_session_scene_info(mcpt_session session, mcpt_scene_info* out);

/* ---- 6. Settings (take effect at the next render, which then restarts accumulation) */

/* Image size, 1 to 16384 each (default 256 x 256). */
MCPT_API mcpt_status mcpt_session_set_size(mcpt_session session, int width, int height);
/* Bounces per path, 0 to 1000000; -1: the scene's default (8; the furnace: unlimited). */
MCPT_API mcpt_status mcpt_session_set_max_bounces(mcpt_session session, int bounces);
/* k-d tree: "auto" (default: the device's cost model picks SAH or none), "sah", "median",
 * "none"; depth -1 for the kind's default, else 0 to 60. */
MCPT_API mcpt_status mcpt_session_set_tree(mcpt_session session, const char* kind, int depth);
/* Seed of the random stream (default 0): the same seed draws the same samples on every API. */
MCPT_API mcpt_status mcpt_session_set_seed(mcpt_session session, uint32_t seed);
/* 1 (default): compile only the features the scene uses; 0: the full kernel. */
MCPT_API mcpt_status mcpt_session_set_specialize(mcpt_session session, int on);
/* "sobol" (default): Owen-scrambled Sobol points, less error per sample; "independent":
 * independent uniforms (for A/B measurements). Another name: MCPT_ERROR_INVALID_ARGUMENT. */
MCPT_API mcpt_status mcpt_session_set_sampler(mcpt_session session, const char* sampler);
/* 1: samples reach the double-precision sums in fixed groups of 16 (by sample index), each
 * added on the device in sample order, so the image depends only on the seed, the sample count
 * and the device, not on how passes were timed; a checkpoint then resumes bit for bit (twice
 * the host memory). Default 0. */
MCPT_API mcpt_status mcpt_session_set_reproducible(mcpt_session session, int on);
/* 1: adaptive sampling: after 16 samples everywhere, each pass gives the pixels samples in
 * proportion to their estimated noise (the least squared error for the samples spent); "spp"
 * is then the mean over pixels, and the error estimate uses each pixel's own count. Not with
 * reproducible rendering (turning on one while the other is on: MCPT_ERROR_INVALID_ARGUMENT),
 * nor with checkpoints (MCPT_ERROR_IO). Default 0. */
MCPT_API mcpt_status mcpt_session_set_adaptive(mcpt_session session, int on);

/* Prepares and compiles the scene for the device now instead of in the next render. */
MCPT_API mcpt_status mcpt_session_commit(mcpt_session session);

/* ---- 7. Rendering */

typedef struct mcpt_render_stats {
    uint64_t samples;      /* samples per pixel this call added */
    uint64_t spp;          /* samples per pixel in the image */
    double seconds;        /* wall time of this call */
    double relative_error; /* mean per-pixel standard error / mean radiance; -1 while
                              unknown (fewer than 2 samples per pixel) */
    int target_reached;    /* relative_error <= target_error */
} mcpt_render_stats;

/* Adds samples to the image for about budget_ms milliseconds (at least one pass over the
 * image; the budget is not exceeded by more than one pass), stopping early once the image
 * has max_spp samples per pixel (0: no cap) or its relative error is at most target_error
 * (0: no target). Returns MCPT_CANCELLED when mcpt_session_cancel() ended it. `stats` may be
 * NULL. Samples reach the image at least once a second; when the device fails meanwhile
 * (MCPT_ERROR_DEVICE_LOST, or another error), the image keeps every sample taken before and
 * can still be read and written. */
MCPT_API mcpt_status mcpt_session_render(mcpt_session session, double budget_ms,
                                         double target_error, uint64_t max_spp,
                                         mcpt_render_stats* stats);

/* Ends the session's running render after its current pass; never waits. A render that
 * starts after this call is not affected. Any thread. */
MCPT_API mcpt_status mcpt_session_cancel(mcpt_session session);

/* Drops the samples taken; the next render starts from zero. */
MCPT_API mcpt_status mcpt_session_reset(mcpt_session session);

/* ---- 8. Images (top row first, after at least one render) */

MCPT_API mcpt_status mcpt_session_image_size(mcpt_session session, int* width, int* height);
/* Linear radiance, 4 floats per pixel (alpha 1): capacity >= 4 * width * height floats. */
MCPT_API mcpt_status mcpt_session_read_rgba32f(mcpt_session session, float* pixels,
                                               size_t capacity);
/* 8-bit sRGB (exposure 1, clamped), 4 bytes per pixel (alpha 255): what an Android Bitmap
 * of ARGB_8888 takes through copyPixelsFromBuffer. capacity >= 4 * width * height bytes. */
MCPT_API mcpt_status mcpt_session_read_rgba8(mcpt_session session, uint8_t* pixels,
                                             size_t capacity);
/* Writes .exr (linear float) or .png (8-bit sRGB), by the path's extension. */
MCPT_API mcpt_status mcpt_session_write_image(mcpt_session session, const char* path);

/* ---- 9. Checkpoints */

/* Writes the accumulation (sums, sample count) with a fingerprint of the version, the scene,
 * the settings and the device to `path`, atomically (a crash never leaves a partial file).
 * With mcpt_session_set_reproducible(1), a render resumed from it equals the uninterrupted
 * one bit for bit; it then holds the samples up to the last group of 16. */
MCPT_API mcpt_status mcpt_session_save_checkpoint(mcpt_session session, const char* path);
/* Continues from a checkpoint (after the scene and settings are set as when it was saved):
 * the next render adds to it. MCPT_ERROR_IO with a message naming what differs (version,
 * scene, an option, the device) or that the file is truncated or corrupted. */
MCPT_API mcpt_status mcpt_session_resume_checkpoint(mcpt_session session, const char* path);

/* ---- 10. Jobs: the A/B test and the error curve
 *
 * A job renders on devices of its own (it opens them when it runs) and ends with a result read
 * field by field: create, load a scene, set options, run, read, release. mcpt_job_run() takes
 * as long as the job (seconds to minutes); mcpt_job_cancel() from another thread ends it
 * early, and what was done is kept and can be read. Reading a result before a run:
 * MCPT_ERROR_INVALID_STATE; a compare reading on a converge job (or the reverse):
 * MCPT_ERROR_INVALID_ARGUMENT. */

typedef struct mcpt_job_s* mcpt_job;

/* An A/B test: does side B render the same image as side A, and how fast is each? A side is
 * a device as mcpt_session_create() takes it ("opencl", "vulkan:0"), or several that render
 * it together ("opencl:0,opencl:1"), with options for the whole side after a comma:
 * "limits=phone" (a phone's Vulkan limits) and "tree=KIND" (as mcpt_session_set_tree()).
 * Both sides render independent batches (per-pixel Welch tests with Sidak and
 * Benjamini-Hochberg corrections, global tests for a uniform bias) and one image with the
 * same seed (what differs is float rounding). An empty side or an unknown API or option:
 * MCPT_ERROR_INVALID_ARGUMENT; devices are opened by mcpt_job_run(). */
MCPT_API mcpt_status mcpt_compare_create(const char* side_a, const char* side_b, mcpt_job* out);

/* The error curve: progressive renders on each of `count` runs (a run's devices as a side of
 * mcpt_compare_create(): several render one image), one after the other, their error against
 * a reference at doubling sample counts, the log-log fit, a bias flag and the time to reach a
 * relative error. */
MCPT_API mcpt_status mcpt_converge_create(const char* const* runs, size_t count, mcpt_job* out);

/* Cancels a run in progress, waits for it, and frees everything. Any thread. */
MCPT_API mcpt_status mcpt_job_release(mcpt_job job);
/* Ends the job's run in progress (the batches or the step under way finish first, about a
 * second); never waits. A run that starts after this call is not affected. Any thread. */
MCPT_API mcpt_status mcpt_job_cancel(mcpt_job job);
/* How far the job's run is, 0 to 1, without waiting (any thread, while another runs it): a
 * compare's batches done on both sides over all of them; a converge's runs done, the one under
 * way counted by its time or samples against its budget. 1 once a run ended uncancelled; 0
 * before the first. */
MCPT_API mcpt_status mcpt_job_progress(mcpt_job job, double* fraction);
/* The message of the last failed call on `job`; for a handle that is not a live job, of the
 * last failed call on this thread without one. Valid until this thread's next call. */
MCPT_API const char* mcpt_job_last_error(mcpt_job job);

/* The scene, as for sessions: a glTF file, bytes in memory, a built-in name. */
MCPT_API mcpt_status mcpt_job_load_file(mcpt_job job, const char* path);
MCPT_API mcpt_status mcpt_job_load_memory(mcpt_job job, const void* data, size_t size,
                                          const char* base_dir);
MCPT_API mcpt_status mcpt_job_load_builtin(mcpt_job job, const char* name);
/* Image size (compare default 64 x 64, converge 256 x 256), bounces (-1: the scene's
 * default) and trace mode ("auto" default; a side's tree= option wins), as for sessions. */
MCPT_API mcpt_status mcpt_job_set_size(mcpt_job job, int width, int height);
MCPT_API mcpt_status mcpt_job_set_max_bounces(mcpt_job job, int bounces);
MCPT_API mcpt_status mcpt_job_set_tree(mcpt_job job, const char* kind);

/* Runs the job to its end: MCPT_OK, or MCPT_CANCELLED when mcpt_job_cancel() ended it (the
 * result then holds what was done). A failure keeps no result. */
MCPT_API mcpt_status mcpt_job_run(mcpt_job job);
/* The report of the last run as DIR/index.html, self-contained (verdicts or the plot,
 * tables, images), as `mcpt compare --report` and `mcpt converge --report` write it. */
MCPT_API mcpt_status mcpt_job_write_report(mcpt_job job, const char* dir);

typedef struct mcpt_compare_options {
    int batches;            /* independent batches per side, 2 to 100000 (32) */
    uint64_t spp;           /* samples per pixel per batch (4) */
    uint64_t same_seed_spp; /* samples per pixel of the same-seed images (4) */
    double same_seed_limit; /* fraction of pixels the same-seed images may differ in (0.01) */
    double alpha;           /* family-wise false alarm rate of the statistical test (0.01) */
    float light_scale_b;    /* B's lights scaled: 1.02 is a negative control (1) */
    int parallel;           /* 1: both sides render at once, each on its devices (0) */
} mcpt_compare_options;
/* The defaults above. */
MCPT_API mcpt_status mcpt_compare_default_options(mcpt_compare_options* out);
MCPT_API mcpt_status mcpt_compare_set_options(mcpt_job job, const mcpt_compare_options* options);

typedef struct mcpt_compare_side {
    char device[512];   /* description of its first device ("+N more" with several) */
    char tree[16];      /* the trace mode it rendered with */
    int devices;        /* devices that rendered it */
    int batches_done;   /* fewer than asked after a cancel */
    uint64_t nonfinite; /* non-finite samples in its batches */
    double samples_per_second, rays_per_second;
    double device_ns_per_sample; /* kernel time per sample; 0 where unknown */
    double compile_seconds;
} mcpt_compare_side;

typedef struct mcpt_compare_result {
    int agree; /* both tests ran and agree */
    int cancelled;
    int statistical_tested; /* both sides rendered two batches at least */
    int statistical_agree;
    uint64_t pixels_tested;
    double min_p, sidak_level;
    uint64_t sidak_rejections, bh_discoveries;
    double mean_z_score, chi2_score, global_z_limit; /* |mean z| and chi2 z below the limit */
    double detectable_bias;    /* uniform relative bias detected with 90 % power */
    double mean_relative_diff; /* (mean B - mean A) / mean A over the image */
    int same_seed_tested;      /* both sides rendered their same-seed image */
    int same_seed_agree;
    uint64_t same_seed_pixels, same_seed_diverged; /* diverged: relative difference > 1e-3 */
    double same_seed_max_abs_diff;
    double speed_ratio; /* B's samples per second over A's */
    double seconds;     /* the run's wall time */
    mcpt_compare_side side[2];
} mcpt_compare_result;
MCPT_API mcpt_status mcpt_compare_get_result(mcpt_job job, mcpt_compare_result* out);

typedef enum mcpt_compare_map {
    MCPT_MAP_P_VALUE = 0,           /* per-pixel p-value of the statistical test */
    MCPT_MAP_Z = 1,                 /* its signed z of B - A */
    MCPT_MAP_MEAN_DIFFERENCE = 2,   /* batch mean of B - A (radiance) */
    MCPT_MAP_SAME_SEED_RELATIVE = 3 /* same seed: max over channels |B - A| / max(|A|,|B|,1e-3) */
} mcpt_compare_map;
/* A map as RGBA32F (the value in r, g and b, alpha 1), top row first: capacity >= 4 * width *
 * height floats. Zeros where its test did not run (cancelled). */
MCPT_API mcpt_status mcpt_compare_read_map(mcpt_job job, mcpt_compare_map map, float* rgba,
                                           size_t capacity);

typedef struct mcpt_converge_options {
    double seconds;         /* render time per run (10); 0: only max_spp */
    uint64_t max_spp;       /* also stop at this many samples per pixel (0: no limit) */
    int time_checkpoints;   /* 0: at 1, 2, 4, ... spp (default); 1: at the budget / 2^k */
    int reference;          /* 0 auto (exact when known, else a cached render), 1 exact,
                               2 cached (in $XDG_CACHE_HOME/mcpt) */
    uint64_t reference_spp; /* samples per pixel of a new cached reference (1024) */
    uint32_t seed;          /* of the first run; each further run adds 100000 (1) */
    int independent;        /* 1: independent samples instead of Owen-scrambled Sobol (0) */
    int adaptive;           /* 1: adaptive sampling (0) */
} mcpt_converge_options;
MCPT_API mcpt_status mcpt_converge_default_options(mcpt_converge_options* out);
MCPT_API mcpt_status mcpt_converge_set_options(mcpt_job job, const mcpt_converge_options* options);

typedef struct mcpt_converge_result {
    uint64_t runs; /* runs with at least one checkpoint */
    int biased;    /* a run flattens above the noise floor */
    int cancelled;
    double reference_mean; /* mean radiance of the reference */
    int reference_exact;   /* 1: an exact solution; 0: a render, its noise subtracted */
} mcpt_converge_result;
MCPT_API mcpt_status mcpt_converge_get_result(mcpt_job job, mcpt_converge_result* out);

typedef struct mcpt_converge_run {
    char backend[64]; /* "opencl", "opencl x2" */
    char device[512];
    uint64_t checkpoints;
    double time_slope;  /* RMSE ~ seconds^time_slope (ideal -0.5) */
    double spp_slope;   /* RMSE ~ spp^spp_slope */
    double slope_sigma; /* expected spread of spp_slope for an unbiased estimator */
    double local_slope; /* over the last three checkpoints */
    int biased;
    double relative_bias; /* mean signed error at the last checkpoint / mean reference */
} mcpt_converge_run;
MCPT_API mcpt_status mcpt_converge_get_run(mcpt_job job, uint64_t run, mcpt_converge_run* out);

typedef struct mcpt_checkpoint {
    double seconds; /* render time so far */
    uint64_t spp;
    double rmse, rel_rmse, rel_mse, mean_signed_error;
    double reference_noise; /* RMS standard error of the reference (0: exact) */
} mcpt_checkpoint;
MCPT_API mcpt_status mcpt_converge_get_checkpoint(mcpt_job job, uint64_t run, uint64_t index,
                                                  mcpt_checkpoint* out);
/* The time run `run` took (or would take) to reach relative RMSE `target`: *seconds, and
 * *how: 1 reached, 2 extrapolated along the local slope, 3 below target at the first
 * checkpoint, 0 never (flat or biased; *seconds 0). */
MCPT_API mcpt_status mcpt_converge_time_to_error(mcpt_job job, uint64_t run, double target,
                                                 double* seconds, int* how);

#ifdef __cplusplus
}
#endif

#endif /* MCPT_MCPT_H */
