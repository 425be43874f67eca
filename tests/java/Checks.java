package org.mcpt;

/** The Java tests' checks: each prints ok or FAIL with what it checked, and counts failures. */
final class Checks {
    static int failures = 0;

    static void check(boolean ok, String what) {
        System.out.println((ok ? "ok:   " : "FAIL: ") + what);
        if (!ok) failures++;
    }

    interface Call {
        void run();
    }

    // The call must throw a RendererException with this status and a message containing text.
    static void expectError(String what, int status, String text, Call call) {
        try {
            call.run();
            check(false, what + ": no exception");
        } catch (RendererException e) {
            check(e.status == status && e.getMessage().contains(text),
                what + ": " + e.status + " \"" + e.getMessage() + "\"");
        }
    }

    // Exits with the verdict: 0 when every check passed.
    static void finish() {
        System.out.println(failures == 0 ? "all passed" : failures + " failed");
        System.exit(failures == 0 ? 0 : 1);
    }
}
