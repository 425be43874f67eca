// JNI glue of org.mcpt.Renderer over the C API (include/mcpt/mcpt.h): every native method
// calls the C API and turns a failed status into an org.mcpt.RendererException carrying the
// engine's message. Nothing here touches the engine's C++ directly.
#include <jni.h>

#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

#include "android/jni/jni_util.h"
#include "mcpt/mcpt.h"

namespace {

using namespace mcpt_jni;

mcpt_session handle(jlong s) {
    return reinterpret_cast<mcpt_session>(static_cast<intptr_t>(s));
}

// True when the call succeeded (or was cancelled); else throws and returns false.
bool check(JNIEnv* env, jlong s, mcpt_status status) {
    if (status >= 0) return true;
    throw_error(env, status, mcpt_last_error(handle(s)));
    return false;
}

bool open(JNIEnv* env, jlong s) {
    if (s != 0) return true;
    throw_error(env, MCPT_ERROR_INVALID_HANDLE, "renderer is closed");
    return false;
}

std::string describe(const mcpt_device_info& d) {
    return std::string(d.spec) + "\t" + d.name + "\t" + d.type;
}

}  // namespace

#define JNI_FN(name) extern "C" JNIEXPORT auto JNICALL Java_org_mcpt_Renderer_##name

JNI_FN(version)(JNIEnv* env, jclass)->jstring {
    return env->NewStringUTF(mcpt_version_string());
}

JNI_FN(devices)(JNIEnv* env, jclass)->jobjectArray {
    size_t n = 0;
    if (!check(env, 0, mcpt_devices(nullptr, 0, &n))) return nullptr;
    std::vector<mcpt_device_info> d(n);
    if (!check(env, 0, mcpt_devices(d.data(), d.size(), &n))) return nullptr;
    std::vector<std::string> out;
    for (size_t i = 0; i < n && i < d.size(); ++i) out.push_back(describe(d[i]));
    return strings(env, out);
}

JNI_FN(nativeCreate)(JNIEnv* env, jclass, jstring device)->jlong {
    std::string spec;
    if (!utf8(env, device, spec)) return 0;
    mcpt_session s = nullptr;
    if (!check(env, 0, mcpt_session_create(spec.c_str(), &s))) return 0;
    return static_cast<jlong>(reinterpret_cast<intptr_t>(s));
}

JNI_FN(nativeCreateDevices)(JNIEnv* env, jclass, jobjectArray devices)->jlong {
    if (!devices) {
        throw_error(env, MCPT_ERROR_INVALID_ARGUMENT, "no devices given (null)");
        return 0;
    }
    const jsize n = env->GetArrayLength(devices);
    std::vector<std::string> specs(size_t(std::max<jsize>(n, 0)));
    for (jsize i = 0; i < n; ++i) {
        jstring d = static_cast<jstring>(env->GetObjectArrayElement(devices, i));
        const bool ok = utf8(env, d, specs[size_t(i)]);
        if (d) env->DeleteLocalRef(d);
        if (!ok) return 0;
    }
    std::vector<const char*> c;
    for (const std::string& d : specs) c.push_back(d.c_str());
    mcpt_session s = nullptr;
    if (!check(env, 0, mcpt_session_create_devices(c.data(), c.size(), &s))) return 0;
    return static_cast<jlong>(reinterpret_cast<intptr_t>(s));
}

JNI_FN(nativeRelease)(JNIEnv* env, jclass, jlong s)->void {
    if (open(env, s)) check(env, s, mcpt_session_release(handle(s)));
}

JNI_FN(nativeDevice)(JNIEnv* env, jclass, jlong s)->jstring {
    mcpt_device_info d;
    if (!open(env, s) || !check(env, s, mcpt_session_device(handle(s), &d))) return nullptr;
    return env->NewStringUTF(describe(d).c_str());
}

JNI_FN(nativeLoadMemory)(JNIEnv* env, jclass, jlong s, jbyteArray data)->void {
    if (!open(env, s)) return;
    if (!data) return throw_error(env, MCPT_ERROR_INVALID_ARGUMENT, "scene data is null");
    const jsize n = env->GetArrayLength(data);
    jbyte* bytes = env->GetByteArrayElements(data, nullptr);
    if (!bytes) return;  // OutOfMemoryError pending
    const mcpt_status st = mcpt_session_load_memory(handle(s), bytes, size_t(n), nullptr);
    env->ReleaseByteArrayElements(data, bytes, JNI_ABORT);
    check(env, s, st);
}

JNI_FN(nativeLoadFile)(JNIEnv* env, jclass, jlong s, jstring path)->void {
    std::string p;
    if (open(env, s) && utf8(env, path, p))
        check(env, s, mcpt_session_load_file(handle(s), p.c_str()));
}

JNI_FN(nativeLoadBuiltin)(JNIEnv* env, jclass, jlong s, jstring name)->void {
    std::string n;
    if (open(env, s) && utf8(env, name, n))
        check(env, s, mcpt_session_load_builtin(handle(s), n.c_str()));
}

JNI_FN(nativeSetEnvironmentFile)
(JNIEnv* env, jclass, jlong s, jstring path, jfloat rotate, jfloat scale)->void {
    std::string p;
    if (!open(env, s)) return;
    if (!path) return void(check(env, s, mcpt_session_set_environment(handle(s), nullptr, 0, 1)));
    if (utf8(env, path, p))
        check(env, s, mcpt_session_set_environment(handle(s), p.c_str(), rotate, scale));
}

JNI_FN(nativeSetEnvironmentMemory)
(JNIEnv* env, jclass, jlong s, jbyteArray data, jfloat rotate, jfloat scale)->void {
    if (!open(env, s)) return;
    if (!data) return throw_error(env, MCPT_ERROR_INVALID_ARGUMENT, "environment data is null");
    const jsize n = env->GetArrayLength(data);
    jbyte* bytes = env->GetByteArrayElements(data, nullptr);
    if (!bytes) return;  // OutOfMemoryError pending
    const mcpt_status st =
        mcpt_session_set_environment_memory(handle(s), bytes, size_t(n), rotate, scale);
    env->ReleaseByteArrayElements(data, bytes, JNI_ABORT);
    check(env, s, st);
}

JNI_FN(nativeSetBackground)(JNIEnv* env, jclass, jlong s, jfloat r, jfloat g, jfloat b)->void {
    if (open(env, s)) check(env, s, mcpt_session_set_background(handle(s), r, g, b));
}

JNI_FN(nativeSetSize)(JNIEnv* env, jclass, jlong s, jint w, jint h)->void {
    if (open(env, s)) check(env, s, mcpt_session_set_size(handle(s), w, h));
}

JNI_FN(nativeSetMaxBounces)(JNIEnv* env, jclass, jlong s, jint b)->void {
    if (open(env, s)) check(env, s, mcpt_session_set_max_bounces(handle(s), b));
}

JNI_FN(nativeSetTree)(JNIEnv* env, jclass, jlong s, jstring kind, jint depth)->void {
    std::string k;
    if (open(env, s) && utf8(env, kind, k))
        check(env, s, mcpt_session_set_tree(handle(s), k.c_str(), depth));
}

JNI_FN(nativeSetSampler)(JNIEnv* env, jclass, jlong s, jstring sampler)->void {
    std::string name;
    if (open(env, s) && utf8(env, sampler, name))
        check(env, s, mcpt_session_set_sampler(handle(s), name.c_str()));
}

JNI_FN(nativeSetSeed)(JNIEnv* env, jclass, jlong s, jint seed)->void {
    if (open(env, s)) check(env, s, mcpt_session_set_seed(handle(s), uint32_t(seed)));
}

JNI_FN(nativeSetSpecialize)(JNIEnv* env, jclass, jlong s, jboolean on)->void {
    if (open(env, s)) check(env, s, mcpt_session_set_specialize(handle(s), on ? 1 : 0));
}

JNI_FN(nativeSetReproducible)(JNIEnv* env, jclass, jlong s, jboolean on)->void {
    if (open(env, s)) check(env, s, mcpt_session_set_reproducible(handle(s), on ? 1 : 0));
}

JNI_FN(nativeSetAdaptive)(JNIEnv* env, jclass, jlong s, jboolean on)->void {
    if (open(env, s)) check(env, s, mcpt_session_set_adaptive(handle(s), on ? 1 : 0));
}

JNI_FN(nativeRender)
(JNIEnv* env, jclass, jlong s, jdouble budget, jdouble target, jlong max_spp)->jobject {
    if (!open(env, s)) return nullptr;
    if (max_spp < 0) {
        throw_error(env, MCPT_ERROR_INVALID_ARGUMENT, "maxSpp must be >= 0");
        return nullptr;
    }
    mcpt_render_stats st{};
    const mcpt_status status =
        mcpt_session_render(handle(s), budget, target, uint64_t(max_spp), &st);
    if (!check(env, s, status)) return nullptr;
    jclass cls = env->FindClass("org/mcpt/RenderStats");
    if (!cls) return nullptr;
    jmethodID ctor = env->GetMethodID(cls, "<init>", "(JJDDZZ)V");
    if (!ctor) return nullptr;
    return env->NewObject(cls, ctor, jlong(st.samples), jlong(st.spp), st.seconds,
                          st.relative_error, jboolean(st.target_reached != 0),
                          jboolean(status == MCPT_CANCELLED));
}

JNI_FN(nativeCancel)(JNIEnv* env, jclass, jlong s)->void {
    if (open(env, s)) check(env, s, mcpt_session_cancel(handle(s)));
}

JNI_FN(nativeImageSize)(JNIEnv* env, jclass, jlong s)->jintArray {
    int wh[2] = {0, 0};
    if (!open(env, s) || !check(env, s, mcpt_session_image_size(handle(s), &wh[0], &wh[1])))
        return nullptr;
    jintArray out = env->NewIntArray(2);
    if (out) env->SetIntArrayRegion(out, 0, 2, reinterpret_cast<const jint*>(wh));
    return out;
}

JNI_FN(nativeReadRgba8)(JNIEnv* env, jclass, jlong s, jobject buffer)->void {
    if (!open(env, s)) return;
    void* p = buffer ? env->GetDirectBufferAddress(buffer) : nullptr;
    if (!p) return throw_error(env, MCPT_ERROR_INVALID_ARGUMENT, "not a direct ByteBuffer");
    const jlong cap = env->GetDirectBufferCapacity(buffer);
    check(env, s, mcpt_session_read_rgba8(handle(s), static_cast<uint8_t*>(p), size_t(cap)));
}

JNI_FN(nativeReadRgba8Array)(JNIEnv* env, jclass, jlong s, jbyteArray out)->void {
    if (!open(env, s)) return;
    if (!out) return throw_error(env, MCPT_ERROR_INVALID_ARGUMENT, "array is null");
    std::vector<uint8_t> px(size_t(env->GetArrayLength(out)));
    if (check(env, s, mcpt_session_read_rgba8(handle(s), px.data(), px.size())))
        env->SetByteArrayRegion(out, 0, jsize(px.size()),
                                reinterpret_cast<const jbyte*>(px.data()));
}

JNI_FN(nativeReadRgba32f)(JNIEnv* env, jclass, jlong s, jfloatArray out)->void {
    if (!open(env, s)) return;
    if (!out) return throw_error(env, MCPT_ERROR_INVALID_ARGUMENT, "array is null");
    std::vector<float> px(size_t(env->GetArrayLength(out)));
    if (check(env, s, mcpt_session_read_rgba32f(handle(s), px.data(), px.size())))
        env->SetFloatArrayRegion(out, 0, jsize(px.size()), px.data());
}

JNI_FN(nativeWriteImage)(JNIEnv* env, jclass, jlong s, jstring path)->void {
    std::string p;
    if (open(env, s) && utf8(env, path, p))
        check(env, s, mcpt_session_write_image(handle(s), p.c_str()));
}

JNI_FN(nativeSaveCheckpoint)(JNIEnv* env, jclass, jlong s, jstring path)->void {
    std::string p;
    if (open(env, s) && utf8(env, path, p))
        check(env, s, mcpt_session_save_checkpoint(handle(s), p.c_str()));
}

JNI_FN(nativeResumeCheckpoint)(JNIEnv* env, jclass, jlong s, jstring path)->void {
    std::string p;
    if (open(env, s) && utf8(env, path, p))
        check(env, s, mcpt_session_resume_checkpoint(handle(s), p.c_str()));
}
