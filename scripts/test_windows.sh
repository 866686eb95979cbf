#!/usr/bin/env bash
# Issue 22: the Windows build against the Linux one. Builds csrbf.exe and
# csrbf-studio.exe (scripts/build-windows.sh; release, or the dev profile with
# --dev) and the Linux csrbf of the same commit, then runs the exe under Wine
# (in a throwaway prefix, with an X server from Xvfb for the pictures) and
# compares: scripts/windows/compare.py says what and how.
#
# Installs Wine, Xvfb and ImageMagick when missing (sudo when not root).
# Anything missing that cannot be installed is a failure, never a skip.
# The ProcessPrng shim that Wine 8 needs (scripts/windows/prng_shim.c) goes
# into the prefix's system32, never beside the exe nor into dist/.
set -euo pipefail
cd "$(dirname "$0")/.."
build_args=()
[ "${1:-}" = "--dev" ] && build_args=(--dev)

need=()
command -v Xvfb >/dev/null 2>&1 || need+=(xvfb)
command -v compare >/dev/null 2>&1 || need+=(imagemagick)
if [ ${#need[@]} -gt 0 ]; then
  command -v apt-get >/dev/null 2>&1 || { echo "test-windows: please install ${need[*]}" >&2; exit 1; }
  sudo=""; [ "$(id -u)" = 0 ] || sudo="sudo"
  echo "test-windows: installing ${need[*]}"
  export DEBIAN_FRONTEND=noninteractive
  $sudo apt-get update -qq
  $sudo apt-get install -y -qq "${need[@]}" >/dev/null
fi

# Built beside the tests' other outputs, never into dist/ (where a release's
# zip, built in release, would be replaced by this one).
scripts/build-windows.sh "${build_args[@]}" --out target/windows-test-zip
tdir="${CSRBF_WINDOWS_TARGET_DIR:-$PWD/target-windows}"
exe_dir="$tdir/x86_64-pc-windows-gnu/$([ "${1:-}" = "--dev" ] && echo debug || echo release)"
# The Linux binary of this same commit and the CLI's test binary, as
# scripts/test.sh's `cargo test --workspace` built them (the same command and
# settings, so nothing is rebuilt after it).
export PYO3_BUILD_EXTENSION_MODULE=1
built=$(cargo test --workspace --locked --no-run -q --message-format=json-render-diagnostics | python3 -c '
import json, sys
for line in sys.stdin:
    m = json.loads(line)
    if m.get("reason") != "compiler-artifact" or not m.get("executable"):
        continue
    t = m["target"]
    if m["package_id"].split("#")[0].endswith("/csrbf-cli"):
        if t["kind"] == ["bin"] and t["name"] == "csrbf" and not m["profile"]["test"]:
            print("linux=" + m["executable"])
        elif t["kind"] == ["test"] and t["name"] == "tests":
            print("cli_tests=" + m["executable"])
')
linux=$(echo "$built" | sed -n 's/^linux=//p')
cli_tests=$(echo "$built" | sed -n 's/^cli_tests=//p')
[ -x "$linux" ] && [ -x "$cli_tests" ] || { echo "test-windows: cargo test --no-run gave no csrbf or CLI tests: $built" >&2; exit 1; }

# A prefix of our own (with the ProcessPrng shim), and the test helpers.
wine_target_dir=$tdir
source scripts/windows/wine_prefix.sh
x86_64-w64-mingw32-gcc -O2 -o "$wine_dir/hold.exe" scripts/windows/hold.c
x86_64-w64-mingw32-gcc -O2 -o "$wine_dir/fake_ffmpeg.exe" scripts/windows/fake_ffmpeg.c

work="$tdir/wine-tests"
rm -rf "$work"
mkdir -p "$work"
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp/xdg-$(id -u)}"
mkdir -p -m 700 "$XDG_RUNTIME_DIR"
exec 3< <(Xvfb -displayfd 1 -screen 0 1280x860x24 -nolisten tcp -noreset 2>/dev/null)
xvfb=$!
trap 'kill $xvfb 2>/dev/null || true; wineserver -k 2>/dev/null || true' EXIT
read -r -t 30 number <&3 || { echo "test-windows: Xvfb did not start" >&2; exit 1; }
start=$(date +%s)
python3 scripts/windows/compare.py --linux "$linux" --cli-tests "$cli_tests" --exe-dir "$exe_dir" --work "$work" \
  --prefix "$WINEPREFIX" --display ":$number"
echo "test-windows: the comparisons took $(( $(date +%s) - start )) s"
