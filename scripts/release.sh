#!/usr/bin/env bash
# Builds every release artifact of csrbf into dist/, checked, with SHA256SUMS:
#
#   csrbf-V-cp39-abi3-manylinux2014_x86_64.manylinux_2_17_x86_64.whl  Python, Linux x86_64, glibc 2.17+
#   csrbf-V-cp39-abi3-win_amd64.whl                                    Python, Windows x86_64
#   csrbf-V-cp39-abi3-macosx_11_0_arm64.whl, ..._10_12_x86_64.whl       Python, macOS (built here, untested on a Mac)
#   csrbf-V.tar.gz                                                     Python sdist (builds with a Rust toolchain)
#   csrbf-blender-V-linux_x64.zip, -windows_x64.zip, -macos_arm64.zip,  Blender 4.2+ extensions
#     -macos_x64.zip
#   csrbf-V-linux-x86_64.tar.gz                                        csrbf and csrbf-studio, glibc 2.17+
#   csrbf-V-windows-x86_64.zip                                         csrbf.exe and csrbf-studio.exe
#   SHA256SUMS
#
#   scripts/release.sh                 # release profile, into dist/
#   scripts/release.sh --dev           # dev profile, wheels, sdist and Blender zips only (no macOS), into
#                                      # target/release-dev/ (what scripts/test_release.sh runs in CI)
#   ... --macos / --no-macos           # with or without the macOS wheels (default: with, but not with --dev)
#   ... --out DIR                      # into DIR instead
#   ... --keep-others                  # go on although DIR holds another version's files
#
# Installs what it needs (sudo when not root): a venv .venv-release/ with
# maturin, zig (PyPI's ziglang, the linker that targets glibc 2.17),
# cargo-zigbuild, auditwheel and twine (scripts/release/requirements.txt);
# Debian's Rust and mingw-w64 for the Windows builds (scripts/windows/env.sh);
# headless Blender for its extension tool (scripts/blender_venv.sh, CPython 3.11).
#
# Every artifact is checked before it is kept: the wheels' tags, metadata and
# imports (scripts/release/check_wheel.py: auditwheel's manylinux_2_17 for
# Linux, python3.dll and Windows' own DLLs only for Windows), `twine check`,
# Blender's own validation of each zip, the programs' glibc symbols; then the
# Linux wheel is installed with no compiler on PATH and runs the guide's
# example and the smoke tests; the Windows wheel runs under Wine in
# python.org's Windows CPython and gives the Linux wheel's results bit for
# bit (scripts/release/windows_wheel_test.sh); the Linux Blender zip is
# installed into headless Blender and deforms a mesh. A failed step stops the
# run naming the step; the artifacts are built in a stage and moved into DIR
# only when all of them passed, each written whole (a temporary name, then
# renamed), SHA256SUMS last (the old one removed first, so DIR never has one
# that does not match its files). A DIR holding another version's files is
# refused (--keep-others goes on).
set -euo pipefail
self=$(realpath "$0")
cd "$(dirname "$self")/.."
root=$PWD
profile=release
out=""
macos=""
keep_others=""
while [ $# -gt 0 ]; do
  case "$1" in
    --dev) profile=dev; shift ;;
    --out) out=$2; shift 2 ;;
    --macos) macos=1; shift ;;
    --no-macos) macos=0; shift ;;
    --keep-others) keep_others=1; shift ;;
    -h|--help) sed -n '2,40p' "$self"; exit 0 ;;
    *) echo "release: unknown argument $1 (--dev, --out DIR, --macos, --no-macos, --keep-others)" >&2; exit 2 ;;
  esac
done
[ -n "$out" ] || { [ "$profile" = release ] && out=dist || out=target/release-dev; }
[ -n "$macos" ] || { [ "$profile" = release ] && macos=1 || macos=0; }
cargo_profile=(--release)
[ "$profile" = dev ] && cargo_profile=(--profile dev)

step="starting"
started=$(date +%s)
stage=$(mktemp -d "${TMPDIR:-/tmp}/csrbf-release.XXXXXX")
written="nothing was written to $out"
trap 'status=$?; rm -rf "$stage"; [ $status -eq 0 ] || echo "release: FAILED at: $step ($written)" >&2' EXIT
mkdir -p "$stage/out"
times=()
begin() { step=$1; step_start=$(date +%s); echo "release: $step"; }
done_step() { times+=("$step: $(( $(date +%s) - step_start )) s"); }
fail() { echo "release: $step: $*" >&2; exit 1; }

begin "checking the version and the tools"
version=$(sed -n 's/^version = "\(.*\)"/\1/p' Cargo.toml | head -1)
manifest_version=$(sed -n 's/^version = "\(.*\)"/\1/p' blender/csrbf_blender/blender_manifest.toml)
[ "$manifest_version" = "$version" ] || fail "the Blender manifest says $manifest_version, Cargo.toml $version"
grep -q "^## \[$version\]" CHANGELOG.md || fail "CHANGELOG.md has no section ## [$version]"
for f in LICENSE-MIT LICENSE-APACHE; do
  cmp -s "$f" "crates/csrbf-py/$f" || fail "crates/csrbf-py/$f differs from $f (the package's copy must be the workspace's)"
done
command -v cargo >/dev/null || fail "cargo is missing: install Rust (https://rustup.rs)"
command -v python3 >/dev/null || fail "python3 is missing"
# Blender's extension tool comes with bpy 5.0.1, which is for CPython 3.11 only.
python3 -c 'import sys; sys.exit(sys.version_info[:2] != (3, 11))' \
  || fail "python3 is $(python3 --version 2>&1); Blender's tool (bpy 5.0.1) needs CPython 3.11 (set PATH so python3 is a 3.11)"
if [ -d "$out" ] && [ -z "$keep_others" ]; then
  others=$(cd "$out" && for f in *; do [ -e "$f" ] || continue; case "$f" in SHA256SUMS|*-"$version"[-.]*) ;; *) echo "$f" ;; esac; done)
  [ -z "$others" ] || fail "$out holds files of another release: $(echo $others) (move them away, or pass --keep-others)"
fi
tools=.venv-release
[ -x "$tools/bin/python" ] || python3 -m venv "$tools" || fail "could not make the venv $tools (python3-venv missing?)"
if ! cmp -s scripts/release/requirements.txt "$tools/.requirements"; then
  "$tools/bin/python" -m pip install -q --disable-pip-version-check -r scripts/release/requirements.txt \
    || fail "could not install scripts/release/requirements.txt from PyPI"
  cp scripts/release/requirements.txt "$tools/.requirements"
fi
export PATH="$root/$tools/bin:$PATH"
for t in maturin cargo-zigbuild auditwheel twine python-zig; do
  command -v "$t" >/dev/null || fail "$t is missing from $tools"
done
# The csrbf-py cdylib is a Python extension: pyo3 must not link libpython.
export PYO3_BUILD_EXTENSION_MODULE=1
echo "release: csrbf $version, $profile profile, into $out"
done_step

begin "the Linux wheel (manylinux2014, zig)"
strip=(); [ "$profile" = release ] && strip=(--strip)
maturin build -q "${cargo_profile[@]}" "${strip[@]}" --locked --zig --compatibility manylinux2014 \
  --target x86_64-unknown-linux-gnu -m crates/csrbf-py/Cargo.toml -o "$stage/linux" || fail "maturin failed"
linux_wheel=$(ls "$stage"/linux/csrbf-*.whl)
python3 scripts/release/check_wheel.py "$linux_wheel" --version "$version" --platform linux || fail "the Linux wheel was refused"
done_step

begin "the sdist"
maturin sdist -m crates/csrbf-py/Cargo.toml -o "$stage/sdist" >/dev/null || fail "maturin sdist failed"
sdist=$(ls "$stage"/sdist/csrbf-*.tar.gz)
[ "$(basename "$sdist")" = "csrbf-$version.tar.gz" ] || fail "the sdist is $(basename "$sdist"), not csrbf-$version.tar.gz"
listing=$(tar tzf "$sdist")
for f in PKG-INFO pyproject.toml Cargo.toml Cargo.lock LICENSE-MIT LICENSE-APACHE python/csrbf/__init__.py \
    crates/csrbf-py/Cargo.toml crates/csrbf/Cargo.toml crates/csrbf-edit/Cargo.toml; do
  grep -qx "csrbf-$version/$f" <<< "$listing" || fail "the sdist holds no $f"
done
# Its workspace (the Python package's crates only) resolves offline, and
# every crate keeps the version this lock file pins (cargo drops the other
# members' dependencies from the lock, nothing else).
sd="$stage/sdist-check/csrbf-$version"
mkdir -p "$stage/sdist-check" && tar -C "$stage/sdist-check" -xzf "$sdist"
cp "$sd/Cargo.lock" "$stage/sdist-check/Cargo.lock.shipped"
cargo metadata -q --format-version 1 --offline --manifest-path "$sd/Cargo.toml" >/dev/null \
  || fail "the sdist's workspace does not resolve offline"
# Every file a crate in it includes at compile time (include_bytes!,
# include_str!) is in it: a crate reaching outside the sdist breaks pip's build.
python3 - "$sd" <<'PY' || fail "the sdist lacks files its crates include"
import pathlib, re, sys
root = pathlib.Path(sys.argv[1])
missing = [f"{rs.relative_to(root)}: {lit}" for rs in root.rglob("*.rs")
           for lit in re.findall(r'include_(?:bytes|str)!\(\s*"([^"]+)"', rs.read_text(errors="replace"))
           if not (rs.parent / lit).is_file()]
if missing:
    sys.exit("release: the sdist lacks what its crates include: " + "; ".join(missing))
PY
python3 - "$stage/sdist-check/Cargo.lock.shipped" "$sd/Cargo.lock" <<'PY' || fail "the sdist's build would change a locked version"
import sys, tomllib
shipped, resolved = (tomllib.load(open(p, "rb"))["package"] for p in sys.argv[1:])
pinned = {(p["name"], p["version"]) for p in shipped}
moved = [f"{p['name']} {p['version']}" for p in resolved if (p["name"], p["version"]) not in pinned]
if moved:
    sys.exit("release: the sdist resolves versions its Cargo.lock does not pin: " + ", ".join(moved))
PY
done_step

begin "the Windows wheel (mingw-w64, Debian's Rust)"
# (A subshell followed by || runs without set -e: each command says || exit.)
(
  source scripts/windows/env.sh || exit 1
  maturin build -q "${cargo_profile[@]}" "${strip[@]}" --locked --target "$windows_target" -Zbuild-std=std,panic_abort \
    -m crates/csrbf-py/Cargo.toml -o "$stage/windows" || exit 1
) || fail "the Windows build failed"
windows_wheel=$(ls "$stage"/windows/csrbf-*.whl)
python3 scripts/release/check_wheel.py "$windows_wheel" --version "$version" --platform windows || fail "the Windows wheel was refused"
done_step

macos_wheels=()
if [ "$macos" = 1 ]; then
  begin "the macOS wheels (zig; arm64 and x86_64; untested on a Mac)"
  if ! command -v llvm-nm >/dev/null; then
    sudo=""; [ "$(id -u)" = 0 ] || sudo="sudo"
    { DEBIAN_FRONTEND=noninteractive $sudo apt-get update -qq && DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq llvm >/dev/null; } \
      || fail "llvm-nm is missing and could not be installed (Debian: llvm)"
  fi
  (
    # Debian's Rust with the standard library built for the target (as for
    # Windows), zig's linker and its macOS libSystem stubs; no macOS SDK.
    source scripts/windows/env.sh || exit 1
    export CARGO_TARGET_DIR="${CSRBF_MACOS_TARGET_DIR:-$root/target-macos}"
    export PATH="$root/$tools/bin:$PATH"
    for target in aarch64-apple-darwin x86_64-apple-darwin; do
      maturin build -q "${cargo_profile[@]}" "${strip[@]}" --locked --zig --target "$target" -Zbuild-std=std,panic_abort \
        -m crates/csrbf-py/Cargo.toml -o "$stage/macos" || exit 1
    done
  ) || fail "the macOS build failed"
  for arch in arm64 x86_64; do
    w=$(ls "$stage"/macos/csrbf-*_"$arch".whl)
    python3 scripts/release/check_wheel.py "$w" --version "$version" --platform "macos-${arch/x86_64/x64}" \
      || fail "the macOS $arch wheel was refused"
    macos_wheels+=("$w")
  done
  done_step
fi

begin "twine check"
packages=("$linux_wheel" "$windows_wheel" "${macos_wheels[@]}" "$sdist")
twine check --strict "${packages[@]}" >/dev/null || { twine check --strict "${packages[@]}"; fail "twine refused the packages"; }
cp "${packages[@]}" "$stage/out/"
done_step

begin "the Blender extensions (Blender's own tool)"
blender_wheels=()
for w in "$linux_wheel" "$windows_wheel" "${macos_wheels[@]}"; do blender_wheels+=(--wheel "$w"); done
scripts/build-blender-extension.sh "${blender_wheels[@]}" --out "$stage/out" \
  || fail "build-blender-extension.sh failed"
# Each zip is for one platform and holds that platform's wheel, byte for byte
# the one checked above.
python3 - "$stage/out" "$version" "$linux_wheel" "$windows_wheel" "${macos_wheels[@]}" <<'PY' || fail "a Blender zip is not what it should be"
import hashlib, os, sys, tomllib, zipfile
out, version, *wheels = sys.argv[1:]
def platform_of(tag):
    system = "linux" if "linux" in tag else "windows" if tag.startswith("win") else "macos"
    return f"{system}-{'arm64' if tag.endswith('arm64') else 'x64'}"
for w in wheels:
    name = os.path.basename(w)
    platform = platform_of(name[:-len(".whl")].split("-")[-1])
    zip_path = os.path.join(out, f"csrbf-blender-{version}-{platform.replace('-', '_')}.zip")
    with zipfile.ZipFile(zip_path) as z:
        generated = tomllib.loads(z.read("blender_manifest.toml").decode())["build"]["generated"]
        if generated["platforms"] != [platform] or generated["wheels"] != [f"./wheels/{name}"]:
            sys.exit(f"release: {zip_path} names {generated}, not {platform} and {name}")
        inside = hashlib.sha256(z.read(f"wheels/{name}")).hexdigest()
    if inside != hashlib.sha256(open(w, "rb").read()).hexdigest():
        sys.exit(f"release: the wheel in {zip_path} is not the checked {name}")
    print(f"release: {os.path.basename(zip_path)}: {platform}, the checked {name}")
PY
source scripts/blender_venv.sh
done_step

if [ "$profile" = release ]; then
  begin "the Linux programs (glibc 2.17, zig)"
  # A target folder of its own: maturin's zig build of the wheel sets other
  # flags, and the two would rebuild each other's dependencies every run.
  programs_target="$root/target/zig-programs"
  CARGO_TARGET_DIR="$programs_target" cargo-zigbuild build -q --release --locked \
    --target x86_64-unknown-linux-gnu.2.17 -p csrbf-cli -p csrbf-studio || fail "cargo zigbuild failed"
  bin="$programs_target/x86_64-unknown-linux-gnu/release"
  pack="$stage/programs/csrbf-$version-linux-x86_64"
  mkdir -p "$pack/licences" "$pack/examples"
  for exe in csrbf csrbf-studio; do
    strip --strip-debug -o "$pack/$exe" "$bin/$exe"
    newest=$(objdump -T "$pack/$exe" | grep -o 'GLIBC_[0-9.]*' | sed 's/GLIBC_//' | sort -V | tail -1)
    [ "$(printf '%s\n2.17\n' "$newest" | sort -V | tail -1)" = 2.17 ] || fail "$exe needs GLIBC_$newest, newer than 2.17"
    echo "release: $exe: newest glibc symbol $newest"
  done
  cp scripts/release/README-linux.txt "$pack/README.txt"
  cp LICENSE-MIT LICENSE-APACHE "$pack/licences/"
  cp assets/ATTRIBUTION.md "$pack/licences/bundled-models.md"
  python3 scripts/windows/third_party.py x86_64-unknown-linux-gnu > "$pack/licences/third-party.txt"
  cp assets/models/cgal_head.off assets/controls/head_smile.json "$pack/examples/"
  # The packed programs run: a deform of the example, from a copy outside the repository.
  "$pack/csrbf" -q deform --mesh "$pack/examples/cgal_head.off" --controls "$pack/examples/head_smile.json" --out "$stage/smile.ply" \
    || fail "the packed csrbf could not deform its example"
  tar -C "$stage/programs" -czf "$stage/out/csrbf-$version-linux-x86_64.tar.gz" "csrbf-$version-linux-x86_64"
  done_step

  begin "the Windows programs"
  scripts/build-windows.sh --out "$stage/out" || fail "scripts/build-windows.sh failed"
  done_step
fi

if [ "$profile" = release ]; then
  # The sdist builds as pip builds it (maturin from PyPI, a release compile).
  begin "building the sdist as pip does"
  python3 -m venv "$stage/sdist-venv" && "$stage/sdist-venv/bin/python" -m pip install -q --disable-pip-version-check numpy \
    || fail "could not make a venv for the sdist"
  "$stage/sdist-venv/bin/python" -m pip install -q --disable-pip-version-check "$sdist" || fail "pip could not build and install the sdist"
  "$stage/sdist-venv/bin/python" -c 'import csrbf, sys; assert csrbf.build_profile == "release"; m = csrbf.read_mesh(sys.argv[1]); print(f"release: the sdist built and read {len(m)} vertices")' \
    assets/models/cgal_head.off || fail "the csrbf built from the sdist does not work"
  done_step
fi

begin "installing the Linux wheel without a compiler"
mkdir -p "$stage/linux-only" && cp "$linux_wheel" "$stage/linux-only/"
scripts/release/python_install_test.sh "$stage/linux-only" "$profile" || fail "the installed wheel failed"
done_step

begin "the Windows wheel under Wine (python.org's Windows CPython), against the Linux wheel"
scripts/release/windows_wheel_test.sh "$windows_wheel" "$linux_wheel" || fail "the Windows wheel failed under Wine"
done_step

begin "installing the Linux Blender extension into headless Blender"
"$blender_python" -m pip uninstall -q -y csrbf
home=$(mktemp -d "$stage/home.XXXXXX")
HOME="$home" "$blender_python" scripts/release/blender_install_test.py "$stage/out/csrbf-blender-$version-linux_x64.zip" \
  --profile "$profile" 2>&1 | grep -v -E '^(Info|Warning|STATUS)' || fail "Blender could not install or use the zip"
done_step

begin "writing $out"
(cd "$stage/out" && sha256sum -- * > SHA256SUMS)
mkdir -p "$out"
# The old SHA256SUMS goes first: until the new one is in place, $out has none
# rather than one that does not match its files.
rm -f "$out/SHA256SUMS"
written="some of this release's files are in $out, without SHA256SUMS: run again"
for f in "$stage"/out/*; do
  name=$(basename "$f")
  [ "$name" = SHA256SUMS ] && continue
  cp "$f" "$out/$name.tmp" || fail "could not copy $name into $out"
  mv "$out/$name.tmp" "$out/$name" || fail "could not rename $name.tmp in $out"
done
cp "$stage/out/SHA256SUMS" "$out/SHA256SUMS.tmp" && mv "$out/SHA256SUMS.tmp" "$out/SHA256SUMS" || fail "could not write SHA256SUMS"
(cd "$out" && sha256sum -c --quiet SHA256SUMS) || fail "the copies in $out do not match SHA256SUMS"
written="$out holds this release and its SHA256SUMS"
others=$(cd "$out" && for f in *; do grep -q "  $f\$" SHA256SUMS || [ "$f" = SHA256SUMS ] || echo "$f"; done)
[ -z "$others" ] || echo "release: WARNING: $out also holds files this run did not make (not in SHA256SUMS; do not publish them): $(echo $others)"
done_step

echo "release: csrbf $version ($profile) in $(( $(date +%s) - started )) s:"
(cd "$out" && while read -r _ name; do printf '  %-72s %s\n' "$name" "$(du -h "$name" | cut -f1)"; done < SHA256SUMS)
printf 'release: %s\n' "${times[@]}"
