#!/usr/bin/env bash
# Builds csrbf for Windows (x86_64-pc-windows-gnu) on Debian/Ubuntu and packs
# dist/csrbf-VERSION-windows-x86_64.zip: csrbf.exe, csrbf-studio.exe, a README for
# Windows users and the licences (csrbf's, the bundled models', and those of
# every crate linked into the executables).
#
#   scripts/build-windows.sh            # release build, packed and checked
#   scripts/build-windows.sh --out DIR  # the zip into DIR (scripts/release.sh stages it)
#   scripts/build-windows.sh --dev      # dev profile (dependencies optimised), not packed:
#                                       # what scripts/test_windows.py tests when asked to
#
# The toolchain (Debian's Rust with the standard library built for the
# target, mingw-w64's linker) is scripts/windows/env.sh's, installed when
# missing. The build goes to target-windows/ (CSRBF_WINDOWS_TARGET_DIR).
#
# The executables must need no DLL but Windows' own: their imports are
# checked against a list of system DLLs, and the zip is refused otherwise
# (and if it would hold the ProcessPrng shim the Wine tests use).
set -euo pipefail
cd "$(dirname "$0")/.."

profile=release
out_dir=dist
while [ $# -gt 0 ]; do
  case "$1" in
    --dev) profile=dev; shift ;;
    --out) out_dir=$2; shift 2 ;;
    *) echo "usage: scripts/build-windows.sh [--dev] [--out DIR]" >&2; exit 2 ;;
  esac
done
version=$(sed -n 's/^version = "\(.*\)"/\1/p' Cargo.toml | head -1)

source scripts/windows/env.sh
target=$windows_target
start=$(date +%s)
# Debian's cargo reads the same Cargo.lock: --locked keeps it unchanged.
/usr/bin/cargo build --locked --profile "$profile" -Zbuild-std=std,panic_abort \
  --target "$target" -p csrbf-cli -p csrbf-studio
dir="$CARGO_TARGET_DIR/$target/$([ "$profile" = dev ] && echo debug || echo release)"
echo "build-windows: built in $(( $(date +%s) - start )) s ($profile): $dir/csrbf.exe $dir/csrbf-studio.exe"

for exe in csrbf.exe csrbf-studio.exe; do
  windows_imports "$dir/$exe"
done
[ "$profile" = release ] || exit 0

# The zip, whole or not at all: staged, packed beside the target, renamed.
stage=$(mktemp -d)
trap 'rm -rf "$stage"' EXIT
pack="$stage/csrbf-$version-windows-x86_64"
mkdir -p "$pack"
# The shipped programs without their line tables (the ones in target-windows/ keep them).
for exe in csrbf.exe csrbf-studio.exe; do
  x86_64-w64-mingw32-strip --strip-debug -o "$pack/$exe" "$dir/$exe"
done
sed "s/\$/\r/" scripts/windows/README-windows.txt > "$pack/README.txt"
mkdir -p "$pack/licences"
cp LICENSE-MIT LICENSE-APACHE "$pack/licences/"
cp assets/ATTRIBUTION.md "$pack/licences/bundled-models.md"
python3 scripts/windows/third_party.py "$target" > "$pack/licences/third-party.txt"
mkdir -p "$pack/examples"
cp assets/models/cgal_head.off assets/controls/head_smile.json "$pack/examples/"
if find "$pack" -iname 'bcryptprimitives*' | grep -q .; then
  echo "build-windows: the ProcessPrng test shim must never ship" >&2
  exit 1
fi
mkdir -p "$out_dir"
out="$out_dir/csrbf-$version-windows-x86_64.zip"
python3 scripts/zip_folder.py "$stage" "$out"
source scripts/sums.sh
update_sums "$out_dir" "$(basename "$out")"
echo "build-windows: wrote $out ($(du -h "$out" | cut -f1)); csrbf.exe $(du -h "$pack/csrbf.exe" | cut -f1), csrbf-studio.exe $(du -h "$pack/csrbf-studio.exe" | cut -f1) stripped"
