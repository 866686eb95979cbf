#!/usr/bin/env bash
# Builds csrbf for Windows (x86_64-pc-windows-gnu) on Debian/Ubuntu and packs
# dist/csrbf-windows-x86_64.zip: csrbf.exe, csrbf-studio.exe, a README for
# Windows users and the licences (csrbf's, the bundled models', and those of
# every crate linked into the executables).
#
#   scripts/build-windows.sh            # release build, packed and checked
#   scripts/build-windows.sh --dev      # dev profile (dependencies optimised), not packed:
#                                       # what scripts/test_windows.py tests when asked to
#
# rustup's toolchain has no Windows standard library and none can be fetched
# here, so this uses Debian's own Rust (rustc-web, cargo-web, 1.96) with the
# standard library's source (rust-web-src), built for the target with
# -Zbuild-std, and mingw-w64's linker. It installs them when missing (with
# sudo when not root, like scripts/setup.sh). The build goes to
# target-windows/ (CSRBF_WINDOWS_TARGET_DIR), apart from the Linux target/.
#
# The executables must need no DLL but Windows' own: their imports are
# checked against a list of system DLLs, and the zip is refused otherwise
# (and if it would hold the ProcessPrng shim the Wine tests use).
set -euo pipefail
cd "$(dirname "$0")/.."

profile=release
case "${1:-}" in
  --dev) profile=dev ;;
  "") ;;
  *) echo "usage: scripts/build-windows.sh [--dev]" >&2; exit 2 ;;
esac

need=()
[ -x /usr/bin/rustc ] && /usr/bin/rustc --version 2>/dev/null | grep -q . || need+=(rustc-web)
[ -x /usr/bin/cargo ] || need+=(cargo-web)
[ -e /usr/lib/rustlib/src/rust/library/std/Cargo.toml ] || need+=(rust-web-src)
command -v x86_64-w64-mingw32-gcc >/dev/null 2>&1 || need+=(mingw-w64)
command -v python3 >/dev/null 2>&1 || need+=(python3)
if [ ${#need[@]} -gt 0 ]; then
  command -v apt-get >/dev/null 2>&1 || {
    echo "build-windows: please install ${need[*]} (Debian 12 bookworm-security or newer has them)" >&2
    exit 1
  }
  sudo=""; [ "$(id -u)" = 0 ] || sudo="sudo"
  echo "build-windows: installing ${need[*]}"
  export DEBIAN_FRONTEND=noninteractive
  $sudo apt-get update -qq
  $sudo apt-get install -y -qq "${need[@]}" >/dev/null
fi

target=x86_64-pc-windows-gnu
export CARGO_TARGET_DIR="${CSRBF_WINDOWS_TARGET_DIR:-$PWD/target-windows}"
export CARGO_TARGET_X86_64_PC_WINDOWS_GNU_LINKER=x86_64-w64-mingw32-gcc
# Debian's compiler, not rustup's (first on PATH, without a Windows std).
export RUSTC=/usr/bin/rustc
unset RUSTUP_TOOLCHAIN RUSTC_WRAPPER
# -Zbuild-std is unstable: Debian's stable compiler accepts it with this.
export RUSTC_BOOTSTRAP=1
start=$(date +%s)
# Debian's cargo reads the same Cargo.lock: --locked keeps it unchanged.
/usr/bin/cargo build --locked --profile "$profile" -Zbuild-std=std,panic_abort \
  --target "$target" -p csrbf-cli -p csrbf-studio
dir="$CARGO_TARGET_DIR/$target/$([ "$profile" = dev ] && echo debug || echo release)"
echo "build-windows: built in $(( $(date +%s) - start )) s ($profile): $dir/csrbf.exe $dir/csrbf-studio.exe"

# Only Windows' own DLLs may be imported (nothing from mingw: libgcc,
# libwinpthread, libstdc++ are linked statically by the gnu target).
system_dlls='^(kernel32|user32|gdi32|advapi32|ntdll|ws2_32|shell32|ole32|oleaut32|combase|rpcrt4|opengl32|bcrypt|bcryptprimitives|userenv|imm32|comctl32|comdlg32|dwmapi|uxtheme|shcore|winmm|version|dxgi|d3d11|d3d12|d3dcompiler_47|propsys|setupapi|cfgmgr32|secur32|crypt32|ncrypt|msvcrt|ucrtbase|api-ms-win-[a-z0-9-]+|synchronization|powrprof|hid|usp10|dbghelp)\.dll$'
for exe in csrbf.exe csrbf-studio.exe; do
  dlls=$(x86_64-w64-mingw32-objdump -p "$dir/$exe" | sed -n 's/^\s*DLL Name: //p' | tr 'A-Z' 'a-z' | sort -u)
  bad=$(echo "$dlls" | grep -Ev "$system_dlls" || true)
  if [ -n "$bad" ]; then
    echo "build-windows: $exe imports DLLs Windows does not have: $bad" >&2
    exit 1
  fi
  echo "build-windows: $exe imports only Windows DLLs: $(echo $dlls)"
done
[ "$profile" = release ] || exit 0

# The zip, whole or not at all: staged, packed beside the target, renamed.
stage=$(mktemp -d)
trap 'rm -rf "$stage"' EXIT
pack="$stage/csrbf-windows-x86_64"
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
mkdir -p dist
out=dist/csrbf-windows-x86_64.zip
python3 scripts/zip_folder.py "$stage" "$out"
echo "build-windows: wrote $out ($(du -h "$out" | cut -f1)); csrbf.exe $(du -h "$pack/csrbf.exe" | cut -f1), csrbf-studio.exe $(du -h "$pack/csrbf-studio.exe" | cut -f1) stripped"
