/* FOR TESTS UNDER WINE ONLY: holds a file open the way many Windows programs
 * do (no sharing), until its standard input closes. scripts/windows/compare.py
 * uses it to check that csrbf.exe refuses to replace such a file with a
 * clear message and keeps the old one. */
#include <windows.h>
#include <stdio.h>

int main(int argc, char **argv) {
    if (argc != 2) {
        fprintf(stderr, "usage: hold FILE\n");
        return 2;
    }
    HANDLE h = CreateFileA(argv[1], GENERIC_READ, 0, NULL, OPEN_EXISTING, 0, NULL);
    if (h == INVALID_HANDLE_VALUE) {
        printf("error %lu\n", GetLastError());
        return 1;
    }
    printf("held\n");
    fflush(stdout);
    char line[16];
    while (fgets(line, sizeof line, stdin)) {
    }
    CloseHandle(h);
    return 0;
}
