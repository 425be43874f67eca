// Negative control of the ThreadSanitizer job: two threads write one counter without a lock,
// and ThreadSanitizer must report the data race (scripts/test-tsan requires the report).
#include <cstdio>
#include <thread>

int main() {
    static int counter = 0;
    std::thread a([] {
        for (int i = 0; i < 100000; ++i) ++counter;
    });
    std::thread b([] {
        for (int i = 0; i < 100000; ++i) ++counter;
    });
    a.join(), b.join();
    std::printf("%d\n", counter);
    return 0;
}
