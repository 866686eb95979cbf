/* FOR TESTS UNDER WINE ONLY: never shipped.
 *
 * Rust's standard library (1.78+) imports ProcessPrng from
 * bcryptprimitives.dll, which Windows 10 and newer have and Wine 8 lacks.
 * scripts/test_windows.py builds this into the throwaway Wine prefix's
 * system32 (never beside the exe, never into dist/), forwarding to
 * RtlGenRandom. scripts/build-windows.sh refuses a zip that holds it. */
#include <windows.h>
#define SystemFunction036 NTAPI SystemFunction036
#include <ntsecapi.h>
#undef SystemFunction036

__declspec(dllexport) BOOL WINAPI ProcessPrng(PBYTE data, SIZE_T len) {
    return RtlGenRandom(data, (ULONG)len);
}
