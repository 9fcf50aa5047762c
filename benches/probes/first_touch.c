/* What a fresh page costs on this machine: 64 MB first touched by one
 * thread, written again, first touched by two threads, pre-faulted with
 * MAP_POPULATE, and first touched after madvise(MADV_HUGEPAGE).
 *
 *     gcc -O2 benches/probes/first_touch.c -o /tmp/first_touch -lpthread && /tmp/first_touch
 *
 * Quoted in the notes on ssmulti's memory per point. On 2026-11-22: a
 * fresh page cost ~0.42 ms a MB on one thread, ~0.25-0.4 on two (26-28,
 * 16-27 ms for 64 MB; written again: 6.5 ms); MAP_POPULATE 16 ms; with
 * madvise(MADV_HUGEPAGE) 177 ms on the first pass (the kernel compacting
 * memory, defrag=madvise), then 10 ms. */
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <time.h>

static const size_t N = (size_t)64 << 20;

static double now(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec + t.tv_nsec * 1e-9;
}

static void *touch_half(void *p) {
    memset(p, 1, N / 2);
    return 0;
}

static char *fresh(int flags) {
    return mmap(0, N, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS | flags, -1, 0);
}

int main(void) {
    for (int k = 0; k < 3; k++) {
        char *p = fresh(0);
        double t0 = now();
        memset(p, 1, N);
        double t1 = now();
        memset(p, 2, N);
        double t2 = now();
        munmap(p, N);
        p = fresh(0);
        double t3 = now();
        pthread_t th;
        pthread_create(&th, 0, touch_half, p);
        touch_half(p + N / 2);
        pthread_join(th, 0);
        double t4 = now();
        munmap(p, N);
        double t5 = now();
        p = fresh(MAP_POPULATE);
        double t6 = now();
        munmap(p, N);
        p = fresh(0);
        madvise(p, N, MADV_HUGEPAGE);
        double t7 = now();
        memset(p, 1, N);
        double t8 = now();
        munmap(p, N);
        printf("64 MB: first touch %.1f ms, again %.1f ms, two threads %.1f ms, "
               "MAP_POPULATE %.1f ms, huge pages first touch %.1f ms\n",
               (t1 - t0) * 1e3, (t2 - t1) * 1e3, (t4 - t3) * 1e3, (t6 - t5) * 1e3,
               (t8 - t7) * 1e3);
    }
    return 0;
}
