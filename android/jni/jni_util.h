// What the JNI glue files share: an engine error as an org.mcpt.RendererException, Java
// strings as UTF-8 and back. Nothing here touches the engine's C++.
#pragma once
#include <jni.h>

#include <string>
#include <vector>

#include "mcpt/mcpt.h"

namespace mcpt_jni {

// Throws RendererException(status, "MCPT_ERROR_...: message") unless one is pending.
inline void throw_error(JNIEnv* env, int status, const std::string& message) {
    if (env->ExceptionCheck()) return;  // one pending exception at a time
    jclass cls = env->FindClass("org/mcpt/RendererException");
    if (!cls) return;  // NoClassDefFoundError pending
    jmethodID ctor = env->GetMethodID(cls, "<init>", "(ILjava/lang/String;)V");
    if (!ctor) return;
    const std::string text = std::string(mcpt_status_name(mcpt_status(status))) + ": " + message;
    jstring msg = env->NewStringUTF(text.c_str());
    if (!msg) return;
    jobject ex = env->NewObject(cls, ctor, jint(status), msg);
    if (ex) env->Throw(static_cast<jthrowable>(ex));
}

// A Java string as UTF-8 (empty for null), or false with an exception pending.
inline bool utf8(JNIEnv* env, jstring js, std::string& out) {
    out.clear();
    if (!js) return true;
    const char* c = env->GetStringUTFChars(js, nullptr);
    if (!c) return false;  // OutOfMemoryError pending
    out = c;
    env->ReleaseStringUTFChars(js, c);
    return true;
}

// A String[] of `v`, or null with an exception pending.
inline jobjectArray strings(JNIEnv* env, const std::vector<std::string>& v) {
    jclass cls = env->FindClass("java/lang/String");
    if (!cls) return nullptr;
    jobjectArray arr = env->NewObjectArray(jsize(v.size()), cls, nullptr);
    for (size_t i = 0; arr && i < v.size(); ++i) {
        jstring s = env->NewStringUTF(v[i].c_str());
        if (!s) return nullptr;
        env->SetObjectArrayElement(arr, jsize(i), s);
        env->DeleteLocalRef(s);
    }
    return arr;
}

}  // namespace mcpt_jni
