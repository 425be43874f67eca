package org.mcpt;

import java.nio.ByteBuffer;

/**
 * The mcpt path tracer through its C API (include/mcpt/mcpt.h): one session on one device.
 * Every engine error is a {@link RendererException} carrying the engine's message; a closed
 * renderer refuses every call the same way. Calls on one renderer are serialised by the
 * engine, except {@link #cancel}, which any thread may call at any time.
 *
 * <pre>
 * try (Renderer r = new Renderer("")) {           // the first GPU of any API
 *     r.loadScene(glbBytes);                       // a .glb from the app's assets
 *     r.setSize(bitmap.getWidth(), bitmap.getHeight());
 *     r.render(30, 0, 0);                          // about 30 ms of samples
 *     r.readRgba8(buffer);                         // then bitmap.copyPixelsFromBuffer(buffer)
 * }
 * </pre>
 */
public final class Renderer implements AutoCloseable {
    static {
        System.loadLibrary("mcpt_jni");
    }

    private volatile long session;

    /** Opens a session: "" (first GPU of any API), "vulkan", "opencl", "vulkan:0", ... */
    public Renderer(String device) {
        session = nativeCreate(device);
    }

    /**
     * Opens a session on several devices at once (specs as above; one may repeat): one image,
     * its samples handed in chunks to whichever device asks next, sized to each one's speed.
     * Reproducible renders (multiples of 16 samples per pixel) are one device's bit for bit
     * when the devices are of one kind. {@link #device} is the first.
     */
    public Renderer(String[] devices) {
        session = nativeCreateDevices(devices);
    }

    /** The library's version, e.g. "0.1.0". */
    public static native String version();

    /** Every device: "spec\tname\ttype" per entry, spec being what the constructor takes. */
    public static native String[] devices();

    /** The device this renderer runs on, as "spec\tname\ttype". */
    public String device() { return nativeDevice(session); }

    /** A .glb (or .gltf) in memory; external files are refused. */
    public void loadScene(byte[] data) { nativeLoadMemory(session, data); }

    /** A .gltf/.glb file. */
    public void loadFile(String path) { nativeLoadFile(session, path); }

    /** A built-in scene: "cornell", "furnace", "spheres". */
    public void loadBuiltin(String name) { nativeLoadBuiltin(session, name); }

    /**
     * An equirectangular environment map (.exr or .hdr, linear, +Y up) lighting this scene and
     * every scene loaded after, turned by rotateDeg about +Y and scaled; null removes it.
     */
    public void setEnvironment(String path, float rotateDeg, float scale) {
        nativeSetEnvironmentFile(session, path, rotateDeg, scale);
    }

    /** The same from the file's bytes (an asset). */
    public void setEnvironment(byte[] data, float rotateDeg, float scale) {
        nativeSetEnvironmentMemory(session, data, rotateDeg, scale);
    }

    /** A constant background radiance lighting the scene; (0, 0, 0) removes it. */
    public void setBackground(float r, float g, float b) { nativeSetBackground(session, r, g, b); }

    public void setSize(int width, int height) { nativeSetSize(session, width, height); }

    /** Bounces per path; -1: the scene's default. */
    public void setMaxBounces(int bounces) { nativeSetMaxBounces(session, bounces); }

    /** "auto", "sah", "median" or "none"; depth -1 for the default. */
    public void setTree(String kind, int depth) { nativeSetTree(session, kind, depth); }

    public void setSeed(int seed) { nativeSetSeed(session, seed); }

    /** "sobol" (Owen-scrambled Sobol points, the default) or "independent". */
    public void setSampler(String sampler) { nativeSetSampler(session, sampler); }

    public void setSpecialize(boolean on) { nativeSetSpecialize(session, on); }

    /** The image depends only on seed and sample count, not on the passes' timing. */
    public void setReproducible(boolean on) { nativeSetReproducible(session, on); }

    /**
     * Adaptive sampling: after 16 samples everywhere, samples go where the estimated noise is;
     * the spp of render() is then the mean over pixels. Not with setReproducible(true).
     */
    public void setAdaptive(boolean on) { nativeSetAdaptive(session, on); }

    /**
     * Adds samples for about budgetMs milliseconds, stopping early at maxSpp samples per pixel
     * (0: no cap) or at the relative error targetError (0: none).
     */
    public RenderStats render(double budgetMs, double targetError, long maxSpp) {
        return nativeRender(session, budgetMs, targetError, maxSpp);
    }

    /** Ends a running render after its current pass; any thread, never waits. */
    public void cancel() { nativeCancel(session); }

    public int width() { return nativeImageSize(session)[0]; }

    public int height() { return nativeImageSize(session)[1]; }

    /** 8-bit sRGB RGBA into a direct buffer (Bitmap.copyPixelsFromBuffer, ARGB_8888). */
    public void readRgba8(ByteBuffer direct) { nativeReadRgba8(session, direct); }

    /** 8-bit sRGB RGBA, 4 bytes per pixel, top row first. */
    public byte[] readRgba8() {
        byte[] out = new byte[4 * width() * height()];
        nativeReadRgba8Array(session, out);
        return out;
    }

    /** Linear radiance RGBA, 4 floats per pixel. */
    public float[] readRgba32f() {
        float[] out = new float[4 * width() * height()];
        nativeReadRgba32f(session, out);
        return out;
    }

    /** .exr (linear) or .png (sRGB), by extension. */
    public void writeImage(String path) { nativeWriteImage(session, path); }

    /**
     * Saves the accumulation with a fingerprint of the version, scene, settings and device,
     * atomically (e.g. in onPause). With setReproducible(true) a render resumed from it equals
     * the uninterrupted one bit for bit.
     */
    public void saveCheckpoint(String path) { nativeSaveCheckpoint(session, path); }

    /**
     * Continues from a checkpoint, after the scene and settings are set as when it was saved;
     * throws RendererException naming what differs, or that the file is truncated or corrupted.
     */
    public void resumeCheckpoint(String path) { nativeResumeCheckpoint(session, path); }

    /** Cancels a running render, waits for it and frees the device. Closing twice is allowed. */
    @Override
    public void close() {
        long s = session;
        session = 0;
        if (s != 0) nativeRelease(s);
    }

    private static native long nativeCreate(String device);
    private static native long nativeCreateDevices(String[] devices);
    private static native void nativeRelease(long s);
    private static native String nativeDevice(long s);
    private static native void nativeLoadMemory(long s, byte[] data);
    private static native void nativeLoadFile(long s, String path);
    private static native void nativeLoadBuiltin(long s, String name);
    private static native void nativeSetEnvironmentFile(long s, String path, float rotate, float scale);
    private static native void nativeSetEnvironmentMemory(long s, byte[] data, float rotate, float scale);
    private static native void nativeSetBackground(long s, float r, float g, float b);
    private static native void nativeSetSize(long s, int width, int height);
    private static native void nativeSetMaxBounces(long s, int bounces);
    private static native void nativeSetTree(long s, String kind, int depth);
    private static native void nativeSetSeed(long s, int seed);
    private static native void nativeSetSampler(long s, String sampler);
    private static native void nativeSetSpecialize(long s, boolean on);
    private static native void nativeSetReproducible(long s, boolean on);
    private static native void nativeSetAdaptive(long s, boolean on);
    private static native RenderStats nativeRender(long s, double budgetMs, double targetError,
                                                   long maxSpp);
    private static native void nativeCancel(long s);
    private static native int[] nativeImageSize(long s);
    private static native void nativeReadRgba8(long s, ByteBuffer direct);
    private static native void nativeReadRgba8Array(long s, byte[] out);
    private static native void nativeReadRgba32f(long s, float[] out);
    private static native void nativeSaveCheckpoint(long s, String path);
    private static native void nativeResumeCheckpoint(long s, String path);
    private static native void nativeWriteImage(long s, String path);
}
