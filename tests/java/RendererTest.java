package org.mcpt;

import static org.mcpt.Checks.check;
import static org.mcpt.Checks.expectError;

import java.nio.ByteBuffer;
import java.nio.file.Files;
import java.nio.file.Paths;
import java.util.Arrays;
import java.util.Random;

/**
 * org.mcpt.Renderer on a desktop JVM, run by CTest: a reproducible render written as raw RGBA
 * bytes (compared by CTest with the same render through the C API), then every misuse, each
 * of which must raise a RendererException with the engine's message while the JVM lives on.
 * Usage: RendererTest DEVICE OUT.rgba GLB_FILE
 */
public final class RendererTest {
    static Renderer reproducible(String device, int seed) {
        Renderer r = new Renderer(device);
        r.loadBuiltin("cornell");
        r.setSize(16, 12);
        r.setSeed(seed);
        r.setReproducible(true);
        return r;
    }

    public static void main(String[] args) throws Exception {
        String device = args[0];
        check(!Renderer.version().isEmpty(), "version " + Renderer.version());
        check(Renderer.devices().length > 0, Renderer.devices().length + " devices");

        // The reproducible render the C API repeats: cornell, 32x32, seed 7, 8 spp.
        try (Renderer r = new Renderer(device)) {
            check(r.device().startsWith(device.contains(":") ? device : device + ":"),
                  "device " + r.device());
            r.loadBuiltin("cornell");
            r.setSize(32, 32);
            r.setSeed(7);
            r.setReproducible(true);
            RenderStats st = r.render(1e6, 0, 8);
            check(st.spp == 8 && !st.cancelled && st.relativeError > 0,
                  "rendered " + st.spp + " spp, relative error " + st.relativeError);
            byte[] rgba = r.readRgba8();
            ByteBuffer direct = ByteBuffer.allocateDirect(4 * 32 * 32);
            r.readRgba8(direct);
            byte[] fromDirect = new byte[rgba.length];
            direct.get(fromDirect);
            check(Arrays.equals(rgba, fromDirect), "direct ByteBuffer equals byte[]");
            check(r.readRgba32f().length == 4 * 32 * 32, "float image");
            Files.write(Paths.get(args[1]), rgba);
        }

        // A checkpoint saved at 40 spp and resumed in another Renderer to 80 spp equals 80 spp
        // at once; one for another seed is refused.
        String ckpt = args[1] + ".ckpt";
        float[] whole, resumed;
        try (Renderer r = reproducible(device, 5)) {
            r.render(1e6, 0, 80);
            whole = r.readRgba32f();
        }
        try (Renderer r = reproducible(device, 5)) {
            r.render(1e6, 0, 40);
            r.saveCheckpoint(ckpt);
        }
        try (Renderer r = reproducible(device, 6)) {
            expectError("checkpoint of another seed", -6, "seed 5 (now 6)",
                        () -> r.resumeCheckpoint(ckpt));
        }
        try (Renderer r = reproducible(device, 5)) {
            r.resumeCheckpoint(ckpt);
            RenderStats st = r.render(1e6, 0, 80);
            check(st.spp == 80, "resumed to " + st.spp + " spp");
            resumed = r.readRgba32f();
        }
        check(Arrays.equals(whole, resumed), "resumed render equals the uninterrupted one");

        // One image on two devices (this one twice): reproducible, it is one device's image
        // bit for bit; no devices at all is an error.
        try (Renderer r = new Renderer(new String[] {device, device})) {
            r.loadBuiltin("cornell");
            r.setSize(16, 12);
            r.setSeed(5);
            r.setReproducible(true);
            RenderStats st = r.render(1e6, 0, 80);
            check(st.spp == 80, "two devices rendered " + st.spp + " spp");
            check(Arrays.equals(whole, r.readRgba32f()), "two devices' image equals one's");
        }
        expectError("no devices", -1, "count must be 1 to 64",
                    () -> new Renderer(new String[0]).close());
        Files.deleteIfExists(Paths.get(ckpt));

        // Adaptive sampling: 48 spp on average, and never together with reproducible sums.
        try (Renderer r = new Renderer(device)) {
            r.loadBuiltin("cornell");
            r.setSize(24, 24);
            r.setAdaptive(true);
            RenderStats st = r.render(1e6, 0, 48);
            check(st.spp == 48 && st.relativeError > 0, "adaptive: " + st.spp + " spp");
            expectError("reproducible after adaptive", -1, "not reproducible",
                        () -> r.setReproducible(true));
        }

        // Misuse: every case raises, the JVM lives on.
        try (Renderer r = new Renderer(device)) {
            expectError("empty byte[]", -4, "empty buffer", () -> r.loadScene(new byte[0]));
            Random rng = new Random(1);
            for (int i = 0; i < 10; i++) {
                byte[] junk = new byte[1 + rng.nextInt(2000)];
                rng.nextBytes(junk);
                if (i % 2 == 1) System.arraycopy("glTF".getBytes(), 0, junk, 0, Math.min(4, junk.length));
                expectError("random byte[] " + junk.length, -4, "memory: cannot load",
                            () -> r.loadScene(junk));
            }
            byte[] glb = Files.readAllBytes(Paths.get(args[2]));
            byte[] cut = Arrays.copyOf(glb, glb.length / 2);
            expectError("truncated .glb", -4, "cannot load", () -> r.loadScene(cut));
            expectError("null byte[]", -1, "null", () -> r.loadScene(null));
            expectError("render before a scene", -3, "no scene loaded", () -> r.render(10, 0, 1));
            expectError("size 0", -1, "between 1x1", () -> r.setSize(0, 0));
            expectError("unknown tree", -1, "unknown tree kind", () -> r.setTree("octree", -1));
            expectError("unknown sampler", -1, "unknown sampler", () -> r.setSampler("halton"));
            expectError("unknown built-in", -4, "cornell", () -> r.loadBuiltin("teapot"));
            expectError("image before render", -3, "nothing rendered", () -> r.readRgba8());
            r.loadScene(glb);
            r.setSize(16, 16);
            RenderStats st = r.render(1e6, 0, 2);
            check(st.spp == 2, ".glb from byte[] rendered " + st.spp + " spp");
            expectError("heap ByteBuffer", -1, "direct", () -> r.readRgba8(ByteBuffer.allocate(1024)));
            expectError("small direct ByteBuffer", -1, "buffer too small",
                        () -> r.readRgba8(ByteBuffer.allocateDirect(16)));
            expectError("bad image format", -6, "x.bmp", () -> r.writeImage("x.bmp"));
            expectError("missing environment", -4, "not a readable regular file",
                        () -> r.setEnvironment("/nonexistent.exr", 0, 1));
            expectError("negative background", -1, ">= 0", () -> r.setBackground(-1, 0, 0));

            // Cancel from another thread.
            RenderStats[] result = new RenderStats[1];
            Thread t = new Thread(() -> result[0] = r.render(120000, 0, 0));
            long t0 = System.nanoTime();
            t.start();
            Thread.sleep(300);
            // Cancelled until it ends: a cancel before the render starts does not count, and a
            // busy machine may start the thread late.
            while (t.isAlive() && System.nanoTime() - t0 < 20e9) {
                r.cancel();
                t.join(50);
            }
            t.join();
            double s = (System.nanoTime() - t0) * 1e-9;
            check(result[0] != null && result[0].cancelled && s < 20, "cancelled after " + s + " s");
            r.close();
            r.close();
            expectError("render after close", -2, "closed", () -> r.render(10, 0, 1));
        }
        expectError("unknown device", -5, "unknown backend", () -> new Renderer("metal"));

        Checks.finish();
    }
}
