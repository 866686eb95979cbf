/* FOR TESTS UNDER WINE ONLY: a stand-in for ffmpeg.exe that reads the frames
 * from standard input and writes a fixed text to its last argument, so that
 * scripts/windows/compare.py can check that csrbf.exe finds ffmpeg.exe in a
 * folder of the PATH. */
#include <stdio.h>

int main(int argc, char **argv) {
    char buf[65536];
    while (fread(buf, 1, sizeof buf, stdin) > 0) {
    }
    FILE *out = fopen(argv[argc - 1], "wb");
    if (!out) {
        return 1;
    }
    fputs("fake ffmpeg.exe\n", out);
    return fclose(out) == 0 ? 0 : 1;
}
