# Sourced after scripts/windows/env.sh: Wine (installed when missing, sudo
# when not root) and a throwaway prefix of our own in
# target-windows/wine/prefix, with the ProcessPrng shim Wine 8 needs
# (scripts/windows/prng_shim.c) in its system32: Rust's standard library
# imports ProcessPrng from bcryptprimitives.dll, which Windows 10+ has and
# Wine 8 lacks. The shim goes there only, never beside a program nor into a
# release. Sets WINEPREFIX, WINEDEBUG and wine_dir; the prefix lies under
# $wine_target_dir when set, else $CARGO_TARGET_DIR (env.sh's).
if ! command -v wine >/dev/null 2>&1; then
  command -v apt-get >/dev/null 2>&1 || { echo "wine: please install wine64" >&2; exit 1; }
  wine_sudo=""; [ "$(id -u)" = 0 ] || wine_sudo="sudo"
  echo "wine: installing wine64"
  DEBIAN_FRONTEND=noninteractive $wine_sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $wine_sudo apt-get install -y -qq wine64 >/dev/null
fi
wine_dir="${wine_target_dir:-$CARGO_TARGET_DIR}/wine"
mkdir -p "$wine_dir"
x86_64-w64-mingw32-gcc -shared -O2 -o "$wine_dir/bcryptprimitives.dll" scripts/windows/prng_shim.c -ladvapi32
export WINEPREFIX="$wine_dir/prefix" WINEDEBUG=-all
if [ ! -d "$WINEPREFIX/drive_c/windows/system32" ]; then
  echo "wine: making a prefix in $WINEPREFIX"
  wineboot -i >/dev/null 2>&1 || true
  wineserver -w
fi
[ -d "$WINEPREFIX/drive_c/windows/system32" ] || { echo "wine: wineboot made no prefix in $WINEPREFIX" >&2; exit 1; }
cp "$wine_dir/bcryptprimitives.dll" "$WINEPREFIX/drive_c/windows/system32/"
