#!/usr/bin/env bash
# wine_run.sh PROGRAM.exe ARGS...: runs a Windows program under Wine for the
# CLI's bad-input tests (CSRBF_TEST_RUNNER, set by compare.py), passing on its
# standard output, standard error and exit code.
#
# Wine now and then ends a run with exit code 1 and no output at all: twice
# in about 4,600 runs from the tests' harness (once in CI, once in 40 local
# runs of the suite), never in 6,400 runs of the same commands from a shell
# loop; compare.py's drawn() met it once in `animate`. csrbf never fails
# silently (every error path prints its message first), so a run that fails
# with nothing on either stream is Wine's, not csrbf's: it is run again, at most twice, and
# logged to $CSRBF_WINE_RETRIES with what Wine's own error channel said, for
# compare.py to report. A run that fails silently three times is passed on
# as it is, and the test fails.
set -u
out=$(mktemp)
err=$(mktemp)
trap 'rm -f "$out" "$err"' EXIT
# Wine's error channel on (WINEDEBUG=-all hides why a run died); its lines
# are taken out of standard error before the tests read it.
export WINEDEBUG="-all,err+all"
for try in 1 2 3; do
  wine "$@" >"$out" 2>"$err"
  rc=$?
  wine_lines=$(grep -E '^[0-9a-f]{4}:err:' "$err" || true)
  grep -vE '^[0-9a-f]{4}:err:' "$err" >"$err.own" || true
  mv "$err.own" "$err"
  if [ "$rc" = 0 ] || [ -s "$out" ] || [ -s "$err" ] || [ "$try" = 3 ]; then
    break
  fi
  if [ -n "${CSRBF_WINE_RETRIES:-}" ]; then
    printf 'exit %s with no output (try %s): %s; wine: %s\n' "$rc" "$try" "$*" \
      "${wine_lines:-nothing}" >>"$CSRBF_WINE_RETRIES"
  fi
done
cat "$out"
cat "$err" >&2
exit "$rc"
