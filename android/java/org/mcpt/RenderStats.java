package org.mcpt;

/** What one {@link Renderer#render} call did. */
public final class RenderStats {
    /** Samples per pixel this call added, and in the image. */
    public final long samples, spp;
    /** Wall time of the call in seconds. */
    public final double seconds;
    /** Mean per-pixel standard error / mean radiance; -1 while unknown (< 2 samples). */
    public final double relativeError;
    public final boolean targetReached, cancelled;

    RenderStats(long samples, long spp, double seconds, double relativeError,
                boolean targetReached, boolean cancelled) {
        this.samples = samples;
        this.spp = spp;
        this.seconds = seconds;
        this.relativeError = relativeError;
        this.targetReached = targetReached;
        this.cancelled = cancelled;
    }
}
