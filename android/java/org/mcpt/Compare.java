package org.mcpt;

/**
 * The A/B test (the C API's mcpt_compare_*): does side B render the same image as side A, and
 * how fast is each? A side is a device ("opencl", "vulkan:0"), or several rendering it together
 * ("opencl:0,opencl:1"), with options after a comma: "limits=phone", "tree=bvh".
 *
 * <pre>
 * try (Compare ab = new Compare("vulkan,tree=bvh", "vulkan,tree=rayquery")) {
 *     ab.loadBuiltin("cornell");
 *     CompareResult r = ab.run();          // seconds: batches on both sides, then the tests
 *     if (!r.agree) ...                    // r.minP, r.detectableBias, r.speedRatio, ...
 * }
 * </pre>
 */
public final class Compare extends Job {
    /** The per-pixel maps of {@link #readMap}. */
    public static final int MAP_P_VALUE = 0, MAP_Z = 1, MAP_MEAN_DIFFERENCE = 2,
                            MAP_SAME_SEED_RELATIVE = 3;

    private int width = 64, height = 64;

    public Compare(String sideA, String sideB) { super(nativeCreate(sideA, sideB)); }

    @Override
    public void setSize(int width, int height) {
        super.setSize(width, height);
        this.width = width;
        this.height = height;
    }

    /**
     * Independent batches per side (2 or more; 32), samples per pixel per batch (4) and of the
     * same-seed images (4), the family-wise false alarm rate (0.01), B's lights scaled (1; a
     * negative control: 1.02), and both sides at once (false).
     */
    public void setOptions(int batches, long spp, long sameSeedSpp, double alpha, float lightScaleB,
        boolean parallel) {
        nativeSetOptions(job, batches, spp, sameSeedSpp, alpha, lightScaleB, parallel);
    }

    /** Runs the test; a cancelled run's result has {@code cancelled} set. */
    public CompareResult run() {
        runJob();
        return new CompareResult(nativeResult(job), nativeSides(job));
    }

    /** A map of the last run as RGBA floats (the value in r, g, b), top row first. */
    public float[] readMap(int map) {
        float[] out = new float[4 * width * height];
        nativeReadMap(job, map, out);
        return out;
    }

    private static native long nativeCreate(String a, String b);
    private static native void nativeSetOptions(long j, int batches, long spp, long sameSeedSpp,
        double alpha, float lightScaleB, boolean parallel);
    private static native double[] nativeResult(long j);
    private static native String[] nativeSides(long j);
    private static native void nativeReadMap(long j, int map, float[] out);
}
