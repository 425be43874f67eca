package org.mcpt;

/** What an error curve found: each run's checkpoints and fits, and the bias flags. */
public final class ConvergeResult {
    /** A run flattens above the noise floor. */
    public final boolean biased;
    public final boolean cancelled;
    public final double referenceMean;
    /** An exact reference; else a render whose noise is subtracted. */
    public final boolean referenceExact;
    public final Run[] runs;

    /** One run's curve: its checkpoints (at 1, 2, 4, ... spp) and what was fitted to them. */
    public static final class Run {
        public final String backend, device;
        /** RMSE ~ seconds^timeSlope, ~ spp^sppSlope (ideal -0.5). */
        public final double timeSlope, sppSlope;
        /** The expected spread of sppSlope for an unbiased estimator. */
        public final double slopeSigma, localSlope;
        public final boolean biased;
        public final double relativeBias;
        /** Per checkpoint. */
        public final double[] seconds, rmse, relRmse, meanSignedError;
        public final long[] spp;

        Run(double[] v, String[] names) {
            backend = names[0];
            device = names[1];
            timeSlope = v[0];
            sppSlope = v[1];
            slopeSigma = v[2];
            localSlope = v[3];
            biased = v[4] != 0;
            relativeBias = v[5];
            int n = (v.length - 6) / 5;
            seconds = new double[n];
            spp = new long[n];
            rmse = new double[n];
            relRmse = new double[n];
            meanSignedError = new double[n];
            for (int k = 0; k < n; ++k) {
                int i = 6 + 5 * k;
                seconds[k] = v[i];
                spp[k] = (long) v[i + 1];
                rmse[k] = v[i + 2];
                relRmse[k] = v[i + 3];
                meanSignedError[k] = v[i + 4];
            }
        }
    }

    ConvergeResult(double[] v, Run[] runs) {
        biased = v[1] != 0;
        cancelled = v[2] != 0;
        referenceMean = v[3];
        referenceExact = v[4] != 0;
        this.runs = runs;
    }
}
