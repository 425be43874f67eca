package org.mcpt;

/** What an A/B test found: both verdicts, the statistics behind them, each side's speed. */
public final class CompareResult {
    /** Both tests ran and agree. */
    public final boolean agree;
    public final boolean cancelled;
    /** The statistical test (independent batches) ran: two batches a side at least. */
    public final boolean statisticalTested, statisticalAgree;
    public final long pixelsTested;
    public final double minP, sidakLevel;
    public final long bhDiscoveries;
    public final double meanZScore, chi2Score, globalZLimit;
    /** The uniform relative bias this test detects with 90 % power. */
    public final double detectableBias;
    /** (mean B - mean A) / mean A over the image. */
    public final double meanRelativeDiff;
    /** The same-seed test ran, and its images agree up to rounding. */
    public final boolean sameSeedTested, sameSeedAgree;
    public final long sameSeedPixels, sameSeedDiverged;
    /** B's samples per second over A's. */
    public final double speedRatio;
    public final double seconds;
    /** Per side (0 = A, 1 = B). */
    public final String[] device = new String[2], tree = new String[2];
    public final int[] devices = new int[2], batchesDone = new int[2];
    public final long[] nonfinite = new long[2];
    public final double[] samplesPerSecond = new double[2], raysPerSecond = new double[2],
                          deviceNsPerSample = new double[2];

    CompareResult(double[] v, String[] sides) {
        int i = 0;
        agree = v[i++] != 0;
        cancelled = v[i++] != 0;
        statisticalTested = v[i++] != 0;
        statisticalAgree = v[i++] != 0;
        pixelsTested = (long) v[i++];
        minP = v[i++];
        sidakLevel = v[i++];
        bhDiscoveries = (long) v[i++];
        meanZScore = v[i++];
        chi2Score = v[i++];
        globalZLimit = v[i++];
        detectableBias = v[i++];
        meanRelativeDiff = v[i++];
        sameSeedTested = v[i++] != 0;
        sameSeedAgree = v[i++] != 0;
        sameSeedPixels = (long) v[i++];
        sameSeedDiverged = (long) v[i++];
        speedRatio = v[i++];
        seconds = v[i++];
        for (int s = 0; s < 2; ++s) {
            devices[s] = (int) v[i++];
            batchesDone[s] = (int) v[i++];
            nonfinite[s] = (long) v[i++];
            samplesPerSecond[s] = v[i++];
            raysPerSecond[s] = v[i++];
            deviceNsPerSample[s] = v[i++];
            device[s] = sides[2 * s];
            tree[s] = sides[2 * s + 1];
        }
    }

    @Override
    public String toString() {
        return (agree ? "AGREE" : "DIFFER") + (cancelled ? " (cancelled)" : "") + ": statistical "
            + (statisticalAgree ? "AGREE" : "DIFFER") + " (min p " + minP + ", mean z " + meanZScore
            + "), same seed " + (sameSeedAgree ? "AGREE" : "DIFFER") + " (" + sameSeedDiverged
            + " of " + sameSeedPixels + " diverged), speed B/A " + speedRatio;
    }
}
