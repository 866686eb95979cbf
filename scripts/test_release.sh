#!/usr/bin/env bash
# The release's tests (scripts/test.sh runs this last): scripts/release.sh in
# the dev profile into target/release-dev/ (never dist/): the manylinux2014
# and win_amd64 wheels, the sdist and the Blender zips, with every check
# release.sh makes (tags, auditwheel, imports, twine, Blender's validation,
# the wheel installed with no compiler on PATH running the guide's Python example
# and the smoke tests, the Windows wheel under Wine in a Windows CPython
# agreeing with the Linux one, the Linux zip installed into headless Blender
# and deforming). Then wheels that must be refused are: a host-linked build
# (its glibc symbols are newer than 2.17), a wheel whose name's platform is
# wrong, one whose RECORD does not match.
set -euo pipefail
cd "$(dirname "$0")/.."
# The host-linked extension the refusal tests need: scripts/test.sh's cargo
# build made it.
host_so=target/debug/lib_csrbf.so
[ -f "$host_so" ] || { echo "test-release: no $host_so: run scripts/test.sh, or PYO3_BUILD_EXTENSION_MODULE=1 cargo build --workspace --locked, first" >&2; exit 1; }
out=target/release-dev
rm -rf "$out"
start=$(date +%s)
scripts/release.sh --dev --out "$out"
echo "test-release: release.sh --dev took $(( $(date +%s) - start )) s"
version=$(sed -n 's/^version = "\(.*\)"/\1/p' Cargo.toml | head -1)
export PATH="$PWD/.venv-release/bin:$PATH"
linux=$(ls "$out"/csrbf-"$version"-cp39-abi3-manylinux*.whl)
windows=$(ls "$out"/csrbf-"$version"-cp39-abi3-win_amd64.whl)
[ -f "$out/csrbf-blender-$version-linux_x64.zip" ] && [ -f "$out/csrbf-blender-$version-windows_x64.zip" ] \
  && [ -f "$out/csrbf-$version.tar.gz" ] && [ -f "$out/SHA256SUMS" ] \
  || { echo "test-release: an artifact is missing from $out: $(ls "$out")" >&2; exit 1; }

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
refused() { # refused WHAT EXPECTED-MESSAGE check_wheel.py ARGS...
  local what=$1 expect=$2; shift 2
  if python3 scripts/release/check_wheel.py "$@" > "$work/log" 2>&1; then
    echo "test-release: $what was accepted" >&2; cat "$work/log" >&2; exit 1
  fi
  grep -q "$expect" "$work/log" || { echo "test-release: $what refused for another reason:" >&2; cat "$work/log" >&2; exit 1; }
  echo "test-release: refused, as it must be, $what: $(cut -c1-160 "$work/log")"
}
# doctor WHEEL MEMBER OUT PYTHON-EXPR: a copy of WHEEL with MEMBER's bytes
# replaced by PYTHON-EXPR (of `data`, its bytes) and its RECORD line made to
# match, so only what the expression changed can be refused.
doctor() {
  python3 - "$@" <<'PY'
import base64, hashlib, sys, zipfile
src, member, out, expr = sys.argv[1:]
with zipfile.ZipFile(src) as z, zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as w:
    data = eval(expr, {"data": z.read(member), "open": open})
    digest = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
    for info in z.infolist():
        body = data if info.filename == member else z.read(info.filename)
        if info.filename.endswith("/RECORD"):
            body = "\n".join(f"{member},sha256={digest},{len(data)}" if r.startswith(member + ",") else r
                             for r in body.decode().splitlines()).encode() + b"\n"
        w.writestr(info, body)
PY
}
# The manylinux wheel with the extension cargo built on this machine (linked
# against its own glibc) in place of zig's.
doctor "$linux" csrbf/_csrbf.abi3.so "$work/host.whl" "open('$host_so', 'rb').read()"
mkdir -p "$work/host" && cp "$work/host.whl" "$work/host/$(basename "$linux")"
refused "a host-linked Linux wheel" "newer than manylinux2014" "$work/host/$(basename "$linux")" --version "$version" --platform linux
mkdir -p "$work/named"
cp "$linux" "$work/named/csrbf-$version-cp39-abi3-win_amd64.whl"
refused "a Linux wheel named for Windows" "WHEEL file's tags" "$work/named/csrbf-$version-cp39-abi3-win_amd64.whl" --version "$version" --platform windows
refused "a Windows wheel checked as Linux" "is not a linux one" "$windows" --version "$version" --platform linux
refused "a wheel of another version" "not $version.9" "$linux" --version "$version.9" --platform linux
# The Windows extension importing a Python of its own version (the name
# patched in its import table: pythonX.dll, as python311.dll would be)
# rather than the stable ABI's python3.dll.
doctor "$windows" csrbf/_csrbf.pyd "$work/pythonx.whl" "data.replace(b'python3.dll', b'pythonX.dll')"
mkdir -p "$work/pythonx" && cp "$work/pythonx.whl" "$work/pythonx/$(basename "$windows")"
refused "a Windows wheel importing pythonX.dll" "pythonx.dll" "$work/pythonx/$(basename "$windows")" --version "$version" --platform windows
python3 - "$windows" "$work/record.whl" <<'PY'
import sys, zipfile
with zipfile.ZipFile(sys.argv[1]) as z, zipfile.ZipFile(sys.argv[2], "w") as w:
    for info in z.infolist():
        body = z.read(info.filename)
        w.writestr(info, body + b"\n# changed" if info.filename == "csrbf/__init__.py" else body)
PY
mkdir -p "$work/record" && cp "$work/record.whl" "$work/record/$(basename "$windows")"
refused "a wheel whose RECORD does not match" "does not match its hash" "$work/record/$(basename "$windows")" --version "$version" --platform windows
# release.sh (of this working tree, copied) refuses versions that disagree,
# naming the step and the files, before building anything.
mkdir -p "$work/repo"
git ls-files -co --exclude-standard -z | tar --null -T - -c | tar -x -C "$work/repo"
sed -i 's/^version = ".*"/version = "0.0.1"/' "$work/repo/blender/csrbf_blender/blender_manifest.toml"
if (cd "$work/repo" && scripts/release.sh --dev --out "$work/repo-out") > "$work/log" 2>&1; then
  echo "test-release: release.sh ran with the manifest at 0.0.1" >&2; exit 1
fi
grep -q "the Blender manifest says 0.0.1, Cargo.toml $version" "$work/log" && grep -q "FAILED at: checking the version" "$work/log" \
  || { echo "test-release: release.sh failed without saying why:" >&2; cat "$work/log" >&2; exit 1; }
echo "test-release: refused, as it must be, a release whose versions disagree: $(grep 'manifest says' "$work/log")"
echo "test-release: passed in $(( $(date +%s) - start )) s"
