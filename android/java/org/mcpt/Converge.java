package org.mcpt;

/**
 * The error curve (the C API's mcpt_converge_*): progressive renders on each run's devices,
 * one run after the other, their error against a reference (exact where known, else a cached
 * high-sample render) at 1, 2, 4, ... samples per pixel, the log-log fit, a bias flag, and the
 * time to reach a relative error.
 *
 * <pre>
 * try (Converge c = new Converge(new String[] {"opencl", "vulkan"})) {
 *     c.loadBuiltin("furnace");
 *     c.setBudget(5, 0);
 *     ConvergeResult r = c.run();           // r.runs[k].sppSlope near -0.5 unless biased
 *     double t = c.timeToError(0, 0.05);    // seconds to 5 % relative RMSE
 * }
 * </pre>
 */
public final class Converge extends Job {
    /** References of {@link #setOptions}. */
    public static final int REFERENCE_AUTO = 0, REFERENCE_EXACT = 1, REFERENCE_CACHED = 2;

    public Converge(String[] runs) { super(nativeCreate(runs)); }

    /** Render time per run in seconds (10) and a sample cap (0: none); one may be 0. */
    public void setBudget(double seconds, long maxSpp) {
        setOptions(seconds, maxSpp, 1, false, false, REFERENCE_AUTO);
    }

    /**
     * The budget, the first run's seed (each further run adds 100000), independent samples
     * instead of Owen-scrambled Sobol, adaptive sampling, and the reference.
     */
    public void setOptions(double seconds, long maxSpp, int seed, boolean independent,
        boolean adaptive, int reference) {
        nativeSetOptions(job, seconds, maxSpp, seed, independent, adaptive, reference);
    }

    /** Runs every curve; a cancelled run's result has {@code cancelled} set. */
    public ConvergeResult run() {
        runJob();
        double[] r = nativeResult(job);
        ConvergeResult.Run[] runs = new ConvergeResult.Run[(int) r[0]];
        for (int k = 0; k < runs.length; ++k)
            runs[k] = new ConvergeResult.Run(nativeRun(job, k), nativeRunNames(job, k));
        return new ConvergeResult(r, runs);
    }

    /**
     * Seconds run {@code run} of the last result took (or would take, extrapolated along its
     * local slope) to reach relative RMSE {@code target}; 0 if never (flat or biased).
     */
    public double timeToError(int run, double target) {
        return nativeTimeToError(job, run, target)[0];
    }

    private static native long nativeCreate(String[] runs);
    private static native void nativeSetOptions(long j, double seconds, long maxSpp, int seed,
        boolean independent, boolean adaptive, int reference);
    private static native double[] nativeResult(long j);
    private static native double[] nativeRun(long j, int run);
    private static native String[] nativeRunNames(long j, int run);
    private static native double[] nativeTimeToError(long j, int run, double target);
}
