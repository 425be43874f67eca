// JNI glue of org.mcpt.Job, Compare and Converge over the C API's jobs (include/mcpt/mcpt.h
// section 10). Results cross as arrays of numbers and strings that the Java classes name.
#include <jni.h>

#include <cstdint>
#include <string>
#include <vector>

#include "android/jni/jni_util.h"
#include "mcpt/mcpt.h"

namespace {

using namespace mcpt_jni;

mcpt_job handle(jlong j) {
    return reinterpret_cast<mcpt_job>(static_cast<intptr_t>(j));
}

jlong to_java(mcpt_job j) {
    return static_cast<jlong>(reinterpret_cast<intptr_t>(j));
}

// True when the call succeeded (or was cancelled); else throws and returns false.
bool check(JNIEnv* env, jlong j, mcpt_status status) {
    if (status >= 0) return true;
    throw_error(env, status, mcpt_job_last_error(handle(j)));
    return false;
}

bool open(JNIEnv* env, jlong j) {
    if (j != 0) return true;
    throw_error(env, MCPT_ERROR_INVALID_HANDLE, "job is closed");
    return false;
}

jdoubleArray doubles(JNIEnv* env, const std::vector<double>& v) {
    jdoubleArray out = env->NewDoubleArray(jsize(v.size()));
    if (out) env->SetDoubleArrayRegion(out, 0, jsize(v.size()), v.data());
    return out;
}

// The Java strings of an array, or false with an exception pending.
bool string_list(JNIEnv* env, jobjectArray array, std::vector<std::string>& out) {
    if (!array) {
        throw_error(env, MCPT_ERROR_INVALID_ARGUMENT, "no devices given (null)");
        return false;
    }
    const jsize n = env->GetArrayLength(array);
    out.assign(size_t(n > 0 ? n : 0), "");
    for (jsize i = 0; i < n; ++i) {
        jstring s = static_cast<jstring>(env->GetObjectArrayElement(array, i));
        const bool ok = utf8(env, s, out[size_t(i)]);
        if (s) env->DeleteLocalRef(s);
        if (!ok) return false;
    }
    return true;
}

}  // namespace

#define JOB_FN(name) extern "C" JNIEXPORT auto JNICALL Java_org_mcpt_Job_##name
#define COMPARE_FN(name) extern "C" JNIEXPORT auto JNICALL Java_org_mcpt_Compare_##name
#define CONVERGE_FN(name) extern "C" JNIEXPORT auto JNICALL Java_org_mcpt_Converge_##name

// ---- every job

JOB_FN(nativeRelease)(JNIEnv* env, jclass, jlong j)->void {
    if (open(env, j)) check(env, j, mcpt_job_release(handle(j)));
}

JOB_FN(nativeCancel)(JNIEnv* env, jclass, jlong j)->void {
    if (open(env, j)) check(env, j, mcpt_job_cancel(handle(j)));
}

JOB_FN(nativeProgress)(JNIEnv* env, jclass, jlong j)->jdouble {
    double f = 0;
    if (open(env, j)) check(env, j, mcpt_job_progress(handle(j), &f));
    return f;
}

JOB_FN(nativeLoadMemory)(JNIEnv* env, jclass, jlong j, jbyteArray data)->void {
    if (!open(env, j)) return;
    if (!data) return throw_error(env, MCPT_ERROR_INVALID_ARGUMENT, "scene data is null");
    const jsize n = env->GetArrayLength(data);
    jbyte* bytes = env->GetByteArrayElements(data, nullptr);
    if (!bytes) return;  // OutOfMemoryError pending
    const mcpt_status st = mcpt_job_load_memory(handle(j), bytes, size_t(n), nullptr);
    env->ReleaseByteArrayElements(data, bytes, JNI_ABORT);
    check(env, j, st);
}

JOB_FN(nativeLoadFile)(JNIEnv* env, jclass, jlong j, jstring path)->void {
    std::string p;
    if (open(env, j) && utf8(env, path, p)) check(env, j, mcpt_job_load_file(handle(j), p.c_str()));
}

JOB_FN(nativeLoadBuiltin)(JNIEnv* env, jclass, jlong j, jstring name)->void {
    std::string n;
    if (open(env, j) && utf8(env, name, n))
        check(env, j, mcpt_job_load_builtin(handle(j), n.c_str()));
}

JOB_FN(nativeSetSize)(JNIEnv* env, jclass, jlong j, jint w, jint h)->void {
    if (open(env, j)) check(env, j, mcpt_job_set_size(handle(j), w, h));
}

JOB_FN(nativeSetMaxBounces)(JNIEnv* env, jclass, jlong j, jint b)->void {
    if (open(env, j)) check(env, j, mcpt_job_set_max_bounces(handle(j), b));
}

JOB_FN(nativeSetTree)(JNIEnv* env, jclass, jlong j, jstring kind)->void {
    std::string k;
    if (open(env, j) && utf8(env, kind, k)) check(env, j, mcpt_job_set_tree(handle(j), k.c_str()));
}

JOB_FN(nativeRun)(JNIEnv* env, jclass, jlong j)->jboolean {
    if (!open(env, j)) return JNI_FALSE;
    const mcpt_status st = mcpt_job_run(handle(j));
    return check(env, j, st) && st == MCPT_OK ? JNI_TRUE : JNI_FALSE;
}

JOB_FN(nativeWriteReport)(JNIEnv* env, jclass, jlong j, jstring dir)->void {
    std::string d;
    if (open(env, j) && utf8(env, dir, d))
        check(env, j, mcpt_job_write_report(handle(j), d.c_str()));
}

// ---- compare

COMPARE_FN(nativeCreate)(JNIEnv* env, jclass, jstring a, jstring b)->jlong {
    std::string sa, sb;
    if (!utf8(env, a, sa) || !utf8(env, b, sb)) return 0;
    mcpt_job j = nullptr;
    if (!check(env, 0, mcpt_compare_create(sa.c_str(), sb.c_str(), &j))) return 0;
    return to_java(j);
}

COMPARE_FN(nativeSetOptions)
(JNIEnv* env, jclass, jlong j, jint batches, jlong spp, jlong same_seed_spp, jdouble alpha,
 jfloat light_scale_b, jboolean parallel)
    ->void {
    if (!open(env, j)) return;
    if (spp < 1 || same_seed_spp < 1)
        return throw_error(env, MCPT_ERROR_INVALID_ARGUMENT, "spp must be positive");
    mcpt_compare_options o;
    if (!check(env, j, mcpt_compare_default_options(&o))) return;
    o.batches = batches, o.spp = uint64_t(spp), o.same_seed_spp = uint64_t(same_seed_spp);
    o.alpha = alpha, o.light_scale_b = light_scale_b, o.parallel = parallel ? 1 : 0;
    check(env, j, mcpt_compare_set_options(handle(j), &o));
}

// The numbers in CompareResult's order (see its constructor).
COMPARE_FN(nativeResult)(JNIEnv* env, jclass, jlong j)->jdoubleArray {
    mcpt_compare_result r;
    if (!open(env, j) || !check(env, j, mcpt_compare_get_result(handle(j), &r))) return nullptr;
    std::vector<double> v{double(r.agree),
                          double(r.cancelled),
                          double(r.statistical_tested),
                          double(r.statistical_agree),
                          double(r.pixels_tested),
                          r.min_p,
                          r.sidak_level,
                          double(r.bh_discoveries),
                          r.mean_z_score,
                          r.chi2_score,
                          r.global_z_limit,
                          r.detectable_bias,
                          r.mean_relative_diff,
                          double(r.same_seed_tested),
                          double(r.same_seed_agree),
                          double(r.same_seed_pixels),
                          double(r.same_seed_diverged),
                          r.speed_ratio,
                          r.seconds};
    for (const mcpt_compare_side& s : r.side) {
        v.insert(v.end(), {double(s.devices), double(s.batches_done), double(s.nonfinite),
                           s.samples_per_second, s.rays_per_second, s.device_ns_per_sample});
    }
    return doubles(env, v);
}

// Device A, tree A, device B, tree B.
COMPARE_FN(nativeSides)(JNIEnv* env, jclass, jlong j)->jobjectArray {
    mcpt_compare_result r;
    if (!open(env, j) || !check(env, j, mcpt_compare_get_result(handle(j), &r))) return nullptr;
    return strings(env, {r.side[0].device, r.side[0].tree, r.side[1].device, r.side[1].tree});
}

COMPARE_FN(nativeReadMap)(JNIEnv* env, jclass, jlong j, jint map, jfloatArray out)->void {
    if (!open(env, j)) return;
    if (!out) return throw_error(env, MCPT_ERROR_INVALID_ARGUMENT, "array is null");
    std::vector<float> px(size_t(env->GetArrayLength(out)));
    if (check(env, j,
              mcpt_compare_read_map(handle(j), mcpt_compare_map(map), px.data(), px.size())))
        env->SetFloatArrayRegion(out, 0, jsize(px.size()), px.data());
}

// ---- converge

CONVERGE_FN(nativeCreate)(JNIEnv* env, jclass, jobjectArray runs)->jlong {
    std::vector<std::string> specs;
    if (!string_list(env, runs, specs)) return 0;
    std::vector<const char*> c;
    for (const std::string& s : specs) c.push_back(s.c_str());
    mcpt_job j = nullptr;
    if (!check(env, 0, mcpt_converge_create(c.data(), c.size(), &j))) return 0;
    return to_java(j);
}

CONVERGE_FN(nativeSetOptions)
(JNIEnv* env, jclass, jlong j, jdouble seconds, jlong max_spp, jint seed, jboolean independent,
 jboolean adaptive, jint reference)
    ->void {
    if (!open(env, j)) return;
    if (max_spp < 0) return throw_error(env, MCPT_ERROR_INVALID_ARGUMENT, "maxSpp must be >= 0");
    mcpt_converge_options o;
    if (!check(env, j, mcpt_converge_default_options(&o))) return;
    o.seconds = seconds, o.max_spp = uint64_t(max_spp), o.seed = uint32_t(seed);
    o.independent = independent ? 1 : 0, o.adaptive = adaptive ? 1 : 0, o.reference = reference;
    check(env, j, mcpt_converge_set_options(handle(j), &o));
}

// Runs, biased, cancelled, reference mean, reference exact.
CONVERGE_FN(nativeResult)(JNIEnv* env, jclass, jlong j)->jdoubleArray {
    mcpt_converge_result r;
    if (!open(env, j) || !check(env, j, mcpt_converge_get_result(handle(j), &r))) return nullptr;
    return doubles(env, {double(r.runs), double(r.biased), double(r.cancelled), r.reference_mean,
                         double(r.reference_exact)});
}

// A run: time slope, spp slope, slope sigma, local slope, biased, relative bias, then per
// checkpoint seconds, spp, rmse, rel rmse, mean signed error.
CONVERGE_FN(nativeRun)(JNIEnv* env, jclass, jlong j, jint run)->jdoubleArray {
    mcpt_converge_run r;
    if (!open(env, j) || !check(env, j, mcpt_converge_get_run(handle(j), uint64_t(run), &r)))
        return nullptr;
    std::vector<double> v{r.time_slope,  r.spp_slope,      r.slope_sigma,
                          r.local_slope, double(r.biased), r.relative_bias};
    for (uint64_t k = 0; k < r.checkpoints; ++k) {
        mcpt_checkpoint c;
        if (!check(env, j, mcpt_converge_get_checkpoint(handle(j), uint64_t(run), k, &c)))
            return nullptr;
        v.insert(v.end(), {c.seconds, double(c.spp), c.rmse, c.rel_rmse, c.mean_signed_error});
    }
    return doubles(env, v);
}

// A run's backend and device.
CONVERGE_FN(nativeRunNames)(JNIEnv* env, jclass, jlong j, jint run)->jobjectArray {
    mcpt_converge_run r;
    if (!open(env, j) || !check(env, j, mcpt_converge_get_run(handle(j), uint64_t(run), &r)))
        return nullptr;
    return strings(env, {r.backend, r.device});
}

// Seconds and how (0 never, 1 reached, 2 extrapolated, 3 before the first checkpoint).
CONVERGE_FN(nativeTimeToError)
(JNIEnv* env, jclass, jlong j, jint run, jdouble target)->jdoubleArray {
    double seconds = 0;
    int how = 0;
    if (!open(env, j) ||
        !check(env, j,
               mcpt_converge_time_to_error(handle(j), uint64_t(run), target, &seconds, &how)))
        return nullptr;
    return doubles(env, {seconds, double(how)});
}
