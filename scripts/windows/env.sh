# Sourced by the scripts that cross-build for Windows (build-windows.sh, and
# release.sh for the Windows wheel): installs Debian's Rust (rustc-web,
# cargo-web), the standard library's source (rust-web-src) and mingw-w64 when
# missing (sudo when not root), and exports what the cross build needs.
#
# rustup's toolchain has no Windows standard library and none can be fetched
# here, so the build uses Debian's compiler with the standard library built
# for the target (-Zbuild-std, which RUSTC_BOOTSTRAP lets a stable compiler
# take) and mingw-w64's linker, into target-windows/ (CSRBF_WINDOWS_TARGET_DIR).
windows_need=()
[ -x /usr/bin/rustc ] && /usr/bin/rustc --version 2>/dev/null | grep -q . || windows_need+=(rustc-web)
[ -x /usr/bin/cargo ] || windows_need+=(cargo-web)
[ -e /usr/lib/rustlib/src/rust/library/std/Cargo.toml ] || windows_need+=(rust-web-src)
command -v x86_64-w64-mingw32-gcc >/dev/null 2>&1 || windows_need+=(mingw-w64)
command -v python3 >/dev/null 2>&1 || windows_need+=(python3)
if [ ${#windows_need[@]} -gt 0 ]; then
  command -v apt-get >/dev/null 2>&1 || {
    echo "windows build: please install ${windows_need[*]} (Debian 12 bookworm-security or newer has them)" >&2
    exit 1
  }
  windows_sudo=""; [ "$(id -u)" = 0 ] || windows_sudo="sudo"
  echo "windows build: installing ${windows_need[*]}"
  DEBIAN_FRONTEND=noninteractive $windows_sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $windows_sudo apt-get install -y -qq "${windows_need[@]}" >/dev/null
fi

windows_target=x86_64-pc-windows-gnu
export CARGO_TARGET_DIR="${CSRBF_WINDOWS_TARGET_DIR:-$PWD/target-windows}"
export CARGO_TARGET_X86_64_PC_WINDOWS_GNU_LINKER=x86_64-w64-mingw32-gcc
# Debian's compiler and cargo, not rustup's (first on PATH, without a Windows std).
export RUSTC=/usr/bin/rustc
export PATH="/usr/bin:$PATH"
unset RUSTUP_TOOLCHAIN RUSTC_WRAPPER
export RUSTC_BOOTSTRAP=1
# Only Windows' own DLLs may be imported (nothing from mingw: libgcc,
# libwinpthread, libstdc++ are linked statically by the gnu target).
windows_system_dlls='^(kernel32|user32|gdi32|advapi32|ntdll|ws2_32|shell32|ole32|oleaut32|combase|rpcrt4|opengl32|bcrypt|bcryptprimitives|userenv|imm32|comctl32|comdlg32|dwmapi|uxtheme|shcore|winmm|version|dxgi|d3d11|d3d12|d3dcompiler_47|propsys|setupapi|cfgmgr32|secur32|crypt32|ncrypt|msvcrt|ucrtbase|api-ms-win-[a-z0-9-]+|synchronization|powrprof|hid|usp10|dbghelp)\.dll$'

# windows_imports FILE [EXTRA_REGEX]: fails, naming them, when FILE imports a
# DLL that is neither Windows' own nor matched by EXTRA_REGEX.
windows_imports() {
  local file=$1 extra=${2:-'^$'} dlls bad
  dlls=$(x86_64-w64-mingw32-objdump -p "$file" | sed -n 's/^\s*DLL Name: //p' | tr 'A-Z' 'a-z' | sort -u)
  bad=$(echo "$dlls" | grep -Ev "$windows_system_dlls" | grep -Ev "$extra" || true)
  if [ -n "$bad" ]; then
    echo "windows build: $(basename "$file") imports DLLs Windows does not have: $(echo $bad)" >&2
    return 1
  fi
  echo "windows build: $(basename "$file") imports only $(echo $dlls)"
}
