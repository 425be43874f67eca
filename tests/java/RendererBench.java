import java.util.Arrays;
import org.mcpt.RenderStats;
import org.mcpt.Renderer;

/**
 * The cost of a JNI call: the same measurement as tests/bench/embed_bench.c through
 * org.mcpt.Renderer (throughput of the default scene at 256x256 for SECONDS, then the median
 * wall time of a 1-spp pass at 64x64, the engine's own time for it, and their difference).
 * Usage: java RendererBench DEVICE [SECONDS] [PASSES]; prints one CSV line.
 */
public final class RendererBench {
    private static double median(double[] v) {
        double[] s = v.clone();
        Arrays.sort(s);
        int n = s.length;
        return n % 2 == 1 ? s[n / 2] : 0.5 * (s[n / 2 - 1] + s[n / 2]);
    }

    public static void main(String[] args) {
        String device = args[0];
        double seconds = args.length > 1 ? Double.parseDouble(args[1]) : 5.0;
        int passes = args.length > 2 ? Integer.parseInt(args[2]) : 200;
        try (Renderer r = new Renderer(device)) {
            r.loadBuiltin("cornell");
            r.setSize(256, 256);
            RenderStats st = r.render(1000.0 * seconds, 0, 0);
            double samplesPerS = st.samples * 256.0 * 256.0 / st.seconds;
            r.setSize(64, 64);
            double[] wall = new double[passes], inside = new double[passes];
            for (int i = -20; i < passes; ++i) {  // more warm-up: the JIT compiles the loop
                long t0 = System.nanoTime();
                st = r.render(0, 0, st.spp + 1);
                if (i >= 0) {
                    wall[i] = 1e-9 * (System.nanoTime() - t0);
                    inside[i] = st.seconds;
                }
            }
            double w = median(wall), in = median(inside);
            double[] over = new double[passes];
            for (int i = 0; i < passes; ++i) over[i] = wall[i] - inside[i];
            System.out.printf("jni,%s,%.4g,%.4f,%.4f,%.2f%n", device, samplesPerS, 1e3 * w,
                              1e3 * in, 1e6 * median(over));
        }
    }
}
