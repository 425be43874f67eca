package org.mcpt;

/**
 * What {@link Compare} and {@link Converge} share: a job of the engine (the C API's mcpt_job)
 * that opens its own devices when it runs. Load a scene, set options, {@link #run}, read the
 * result, close. Every engine error is a {@link RendererException}; a closed job refuses every
 * call the same way. {@link #cancel} may be called from any thread while another runs the job.
 */
public abstract class Job implements AutoCloseable {
    static { System.loadLibrary("mcpt_jni"); }

    volatile long job;

    Job(long job) { this.job = job; }

    /** A .glb (or .gltf) in memory; external files are refused. */
    public void loadScene(byte[] data) { nativeLoadMemory(job, data); }

    /** A .gltf/.glb file. */
    public void loadFile(String path) { nativeLoadFile(job, path); }

    /** A built-in scene: "cornell", "furnace", "spheres". */
    public void loadBuiltin(String name) { nativeLoadBuiltin(job, name); }

    public void setSize(int width, int height) { nativeSetSize(job, width, height); }

    /** Bounces per path; -1: the scene's default. */
    public void setMaxBounces(int bounces) { nativeSetMaxBounces(job, bounces); }

    /** Trace mode: "auto", "bvh", "sah", "median", "none", "rayquery". */
    public void setTree(String kind) { nativeSetTree(job, kind); }

    /**
     * Ends a run in progress (the batches or the step under way finish first); any thread,
     * never waits. The result then holds what was done.
     */
    public void cancel() { nativeCancel(job); }

    /**
     * How far a run is, 0 to 1 (any thread, never waits): a compare's batches done, a
     * converge's runs done with the one under way by its budget; 1 once a run ended.
     */
    public double progress() { return nativeProgress(job); }

    /** The last run's self-contained HTML report, DIR/index.html. */
    public void writeReport(String dir) { nativeWriteReport(job, dir); }

    /** Cancels a run in progress, waits for it and frees everything. Twice is allowed. */
    @Override
    public void close() {
        long j = job;
        job = 0;
        if (j != 0) nativeRelease(j);
    }

    // Runs the job: true when it ran to its end, false when cancelled.
    boolean runJob() { return nativeRun(job); }

    static native void nativeRelease(long j);
    static native void nativeCancel(long j);
    static native double nativeProgress(long j);
    static native void nativeLoadMemory(long j, byte[] data);
    static native void nativeLoadFile(long j, String path);
    static native void nativeLoadBuiltin(long j, String name);
    static native void nativeSetSize(long j, int width, int height);
    static native void nativeSetMaxBounces(long j, int bounces);
    static native void nativeSetTree(long j, String kind);
    static native boolean nativeRun(long j);
    static native void nativeWriteReport(long j, String dir);
}
