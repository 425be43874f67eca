package org.mcpt;

import static org.mcpt.Checks.check;
import static org.mcpt.Checks.expectError;

/**
 * org.mcpt.Compare and Converge on a desktop JVM, run by CTest on the CPU drivers: an A/B of
 * OpenCL against Vulkan and of two trees agree, and a 1.02 light on B's side is told apart
 * (the negative control); the furnace's error curve falls as spp^-1/2 and 2 bounces are
 * flagged biased (the control); misuse raises RendererException while the JVM lives on.
 * Usage: JobsTest OPENCL_DEVICE VULKAN_DEVICE
 */
public final class JobsTest {
    static CompareResult compare(String a, String b, float lightScaleB) {
        try (Compare ab = new Compare(a, b)) {
            ab.loadBuiltin("cornell");
            ab.setOptions(32, 4, 4, 0.01, lightScaleB, false);
            CompareResult r = ab.run();
            check(ab.progress() == 1.0, "progress 1 after the run");
            float[] p = ab.readMap(Compare.MAP_P_VALUE);
            boolean probabilities = p.length == 4 * 64 * 64;
            for (int i = 0; i < p.length; i += 4) probabilities &= p[i] >= 0 && p[i] <= 1;
            check(probabilities, "p-value map of " + p.length / 4 + " pixels in [0, 1]");
            return r;
        }
    }

    static ConvergeResult converge(String[] runs, int bounces) {
        try (Converge c = new Converge(runs)) {
            c.loadBuiltin("furnace");
            c.setSize(32, 32);
            c.setMaxBounces(bounces);
            c.setOptions(0, 256, 11, true, false, Converge.REFERENCE_EXACT);
            ConvergeResult r = c.run();
            if (r.runs.length > 0 && !r.biased)
                check(c.timeToError(0, 0.10) > 0, "time to 10 %: " + c.timeToError(0, 0.10) + " s");
            return r;
        }
    }

    public static void main(String[] args) {
        String opencl = args[0], vulkan = args[1];

        // OpenCL against Vulkan, and its negative control.
        CompareResult same = compare(opencl, vulkan, 1.f);
        check(same.agree && same.statisticalTested && same.sameSeedTested,
            "OpenCL against Vulkan: " + same);
        check(same.device[0].startsWith("opencl") && same.device[1].startsWith("vulkan"),
            "sides " + same.device[0] + " | " + same.device[1]);
        check(same.batchesDone[0] == 32 && same.batchesDone[1] == 32 && same.speedRatio > 0,
            "32 batches a side, speed ratio " + same.speedRatio);
        CompareResult brighter = compare(opencl, vulkan, 1.02f);
        check(!brighter.agree && !brighter.statisticalAgree && !brighter.sameSeedAgree,
            "a 1.02 light on B differs: " + brighter);

        // Two trees on one API.
        CompareResult trees = compare(opencl + ",tree=bvh", opencl + ",tree=sah", 1.f);
        check(trees.agree && "bvh".equals(trees.tree[0]) && "sah".equals(trees.tree[1]),
            "bvh against sah: " + trees.tree[0] + " | " + trees.tree[1] + ": " + trees);

        // The furnace's error curve, and 2 bounces (radiance 1.75 against 2) as its control.
        ConvergeResult curve = converge(new String[] {opencl, vulkan}, -1);
        check(curve.runs.length == 2 && !curve.biased && curve.referenceExact,
            curve.runs.length + " runs, biased " + curve.biased);
        for (ConvergeResult.Run run : curve.runs)
            check(Math.abs(run.sppSlope + 0.5) < 0.08 && run.spp.length == 9 && run.spp[8] == 256,
                run.backend + ": RMSE ~ spp^" + run.sppSlope + " over " + run.spp.length
                    + " checkpoints");
        ConvergeResult short2 = converge(new String[] {opencl}, 2);
        check(short2.biased && short2.runs[0].biased,
            "2 bounces biased, relative bias " + short2.runs[0].relativeBias);

        // Misuse: every one an exception with the engine's status and message.
        expectError("an empty side", -1, "an empty device in ''", () -> new Compare(opencl, ""));
        expectError("an unknown API", -1, "names no API", () -> new Compare("metal", opencl));
        try (Compare ab = new Compare(opencl, opencl)) {
            expectError("run before a scene", -3, "no scene", () -> ab.run());
            expectError("one batch", -1, "batches", () -> ab.setOptions(1, 4, 4, 0.01, 1, false));
            expectError("a missing file", -4, "", () -> ab.loadFile("/no/such.glb"));
            ab.close();
            expectError("closed", -2, "job is closed", () -> ab.loadBuiltin("cornell"));
            ab.close(); // twice is allowed
        }
        expectError("no runs", -1, "count", () -> new Converge(new String[0]));

        Checks.finish();
    }
}
