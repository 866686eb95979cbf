#!/usr/bin/env python3
"""Refuses a csrbf wheel whose tags, metadata or imports are wrong:

    check_wheel.py WHEEL --version 0.2.0 --platform linux|windows|macos-arm64|macos-x64

- the file name's tags (cp39-abi3-PLATFORM) agree with the WHEEL file and
  the platform asked for (Linux: manylinux2014 / manylinux_2_17 x86_64;
  Windows: win_amd64; macOS: macosx_*_arm64 / _x86_64);
- METADATA names csrbf at the version, its licence expression and files
  (present in the wheel), its description and Python requirement; every
  RECORD hash matches;
- the extension module: on Linux an x86-64 ELF needing only glibc's
  libraries, no symbol version newer than GLIBC_2.17, and `auditwheel show`
  agreeing on manylinux_2_17; on Windows an x86-64 PE importing python3.dll
  (the stable ABI, never python3X.dll) and Windows' own DLLs only, exporting
  PyInit__csrbf; on macOS a Mach-O of the platform's architecture linking
  only macOS's own libraries (libSystem, iconv; Python's symbols looked up
  when loaded) and needing no macOS newer than its tag says.

Prints what it checked; exits 1 naming the first problem.
"""

import argparse
import base64
import hashlib
import re
import struct
import subprocess
import sys
import tempfile
import zipfile
from email.parser import Parser
from pathlib import Path

# Windows' own DLLs (as scripts/windows/env.sh lists them) and the stable ABI's python3.dll.
WINDOWS_DLLS = re.compile(
    r"^(kernel32|user32|gdi32|advapi32|ntdll|ws2_32|shell32|ole32|oleaut32|combase|rpcrt4|bcrypt|"
    r"bcryptprimitives|userenv|msvcrt|ucrtbase|api-ms-win-[a-z0-9-]+|synchronization|powrprof|"
    r"dbghelp|secur32|crypt32|ncrypt|python3)\.dll$"
)
# What a manylinux2014 extension may need (PEP 599's list, less what csrbf never uses).
LINUX_LIBS = {"libc.so.6", "libm.so.6", "libpthread.so.0", "libdl.so.2", "librt.so.1",
              "libgcc_s.so.1", "ld-linux-x86-64.so.2"}
GLIBC_MAX = (2, 17)


class Refused(Exception):
    pass


def run(*cmd: str) -> str:
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode != 0:
        raise Refused(f"{' '.join(cmd)} failed: {done.stderr.strip() or done.stdout.strip()}")
    return done.stdout


def check_record(z: zipfile.ZipFile, dist_info: str) -> None:
    rows = z.read(f"{dist_info}/RECORD").decode().splitlines()
    listed = set()
    for row in rows:
        name, digest, size = row.rsplit(",", 2)
        listed.add(name)
        if name == f"{dist_info}/RECORD":
            continue
        algo, _, want = digest.partition("=")
        data = z.read(name)
        got = base64.urlsafe_b64encode(hashlib.new(algo, data).digest()).rstrip(b"=").decode()
        if got != want or int(size) != len(data):
            raise Refused(f"RECORD: {name} does not match its hash or size")
    missing = set(z.namelist()) - listed
    if missing:
        raise Refused(f"RECORD does not list {sorted(missing)}")


def check_metadata(z: zipfile.ZipFile, dist_info: str, version: str) -> None:
    meta = Parser().parsestr(z.read(f"{dist_info}/METADATA").decode())
    if meta["Name"] != "csrbf" or meta["Version"] != version:
        raise Refused(f"METADATA names {meta['Name']} {meta['Version']}, not csrbf {version}")
    for field in ("Summary", "License-Expression", "Requires-Python", "Description-Content-Type"):
        if not meta[field]:
            raise Refused(f"METADATA has no {field}")
    if not meta.get_payload().strip():
        raise Refused("METADATA has no description (the package's README)")
    licences = meta.get_all("License-File") or []
    if not licences:
        raise Refused("METADATA names no License-File")
    for name in licences:
        if f"{dist_info}/licenses/{name}" not in z.namelist():
            raise Refused(f"METADATA's License-File {name} is not in the wheel")
    if not any(u.startswith("Homepage") for u in meta.get_all("Project-URL") or []):
        raise Refused("METADATA has no Project-URL")


def platform_ok(platform: str, tag: str) -> bool:
    tags = set(tag.split("."))
    if platform == "linux":
        return bool(tags & {"manylinux2014_x86_64", "manylinux_2_17_x86_64"}) and all(
            re.fullmatch(r"manylinux(2014|_2_17)_x86_64", t) for t in tags)
    if platform == "windows":
        return tags == {"win_amd64"}
    arch = {"macos-arm64": "arm64", "macos-x64": "x86_64"}[platform]
    return all(re.fullmatch(rf"macosx_\d+_\d+_{arch}", t) for t in tags)


def check_linux(path: Path, wheel: Path) -> str:
    header = run("readelf", "-h", str(path))
    if "ELF64" not in header or "X86-64" not in header:
        raise Refused(f"{path.name} is not an x86-64 ELF")
    needed = set(re.findall(r"\(NEEDED\)\s+Shared library: \[(.+?)\]", run("readelf", "-d", str(path))))
    extra = needed - LINUX_LIBS
    if extra:
        raise Refused(f"{path.name} needs {sorted(extra)} (a manylinux wheel may need only glibc's libraries)")
    versions = {tuple(map(int, v.split("."))) for v in re.findall(r"GLIBC_(\d+(?:\.\d+)+)", run("objdump", "-T", str(path)))}
    newest = max(versions) if versions else (0, 0)
    if newest[:2] > GLIBC_MAX:
        raise Refused(f"{path.name} needs GLIBC_{'.'.join(map(str, newest))}, newer than manylinux2014's 2.17")
    shown = run("auditwheel", "show", str(wheel))
    if not re.search(r'consistent with the following platform tag:\s*"manylinux_2_17_x86_64"', shown):
        raise Refused(f"auditwheel does not accept the wheel as manylinux_2_17:\n{shown}")
    return f"ELF x86-64, needs {sorted(needed)}, newest glibc symbol {'.'.join(map(str, newest))}; auditwheel: manylinux_2_17_x86_64"


def check_windows(path: Path) -> str:
    dump = run("x86_64-w64-mingw32-objdump", "-p", str(path))
    if "pei-x86-64" not in run("x86_64-w64-mingw32-objdump", "-f", str(path)):
        raise Refused(f"{path.name} is not an x86-64 PE")
    dlls = sorted({d.lower() for d in re.findall(r"DLL Name: (\S+)", dump)})
    bad = [d for d in dlls if not WINDOWS_DLLS.match(d)]
    if bad:
        raise Refused(f"{path.name} imports {bad}: neither Windows' own DLLs nor python3.dll")
    if "python3.dll" not in dlls:
        raise Refused(f"{path.name} does not import python3.dll (the stable ABI): {dlls}")
    if not re.search(r"\]\s+PyInit__csrbf\b", dump):
        raise Refused(f"{path.name} does not export PyInit__csrbf")
    return f"PE x86-64, imports {' '.join(dlls)}; exports PyInit__csrbf"


MACHO_CPU = {"macos-arm64": 0x0100000C, "macos-x64": 0x01000007}
LC_LOAD_DYLIB, LC_LOAD_WEAK_DYLIB, LC_REEXPORT_DYLIB = 0xC, 0x80000018, 0x8000001F
# The minimum macOS: LC_BUILD_VERSION (macOS 10.14+ targets: platform, minos,
# ...) or the older LC_VERSION_MIN_MACOSX (version, sdk), which x86_64
# builds for 10.12 carry; the offset of the version in each.
MIN_VERSION_AT = {0x32: 12, 0x24: 8}
# Libraries every macOS has (in the dyld shared cache): libSystem, and the
# iconv that Rust's libc crate links on Apple platforms.
MACOS_LIBS = re.compile(r"^/usr/lib/(libSystem\.B|libiconv\.2|libcharset\.1)\.dylib$")


def check_macos(path: Path, platform: str, tag: str) -> str:
    data = path.read_bytes()
    magic, cpu, _sub, _ftype, ncmds, _size, _flags = struct.unpack_from("<7I", data, 0)
    if magic != 0xFEEDFACF:
        raise Refused(f"{path.name} is not a 64-bit Mach-O (magic {magic:#x})")
    if cpu != MACHO_CPU[platform]:
        raise Refused(f"{path.name} is for CPU {cpu:#x}, not {platform}")
    offset, dylibs, minos = 32, [], None
    for _ in range(ncmds):
        cmd, size = struct.unpack_from("<2I", data, offset)
        if cmd in (LC_LOAD_DYLIB, LC_LOAD_WEAK_DYLIB, LC_REEXPORT_DYLIB):
            name_at = struct.unpack_from("<I", data, offset + 8)[0]
            dylibs.append(data[offset + name_at: offset + size].split(b"\0")[0].decode())
        elif cmd in MIN_VERSION_AT:
            version = struct.unpack_from("<I", data, offset + MIN_VERSION_AT[cmd])[0]
            minos = (version >> 16, (version >> 8) & 0xFF)
        offset += size
    bad = [d for d in dylibs if not MACOS_LIBS.match(d)]
    if bad:
        raise Refused(f"{path.name} links {bad}: only macOS's own libSystem and iconv may be linked "
                      "(Python's symbols are looked up when loaded, never linked)")
    if minos is None:
        raise Refused(f"{path.name} has neither LC_BUILD_VERSION nor LC_VERSION_MIN_MACOSX (its minimum macOS)")
    tagged = tuple(int(x) for x in re.match(r"macosx_(\d+)_(\d+)_", tag).groups())
    if minos > tagged:
        raise Refused(f"{path.name} needs macOS {minos[0]}.{minos[1]}, newer than its tag's {tagged[0]}.{tagged[1]}")
    # The symbols it imports: from those libraries, or Python's C API looked
    # up in the interpreter that loads it (two-level namespace otherwise).
    undefined = re.findall(r"\(undefined\) (?:weak )?external (\S+)(?: \(from (\S+)\))?", run("llvm-nm", "-u", "-m", str(path)))
    strays = [name for name, lib in undefined if not lib and not re.match(r"_{1,2}Py", name)]
    if strays:
        raise Refused(f"{path.name} imports {strays[:8]} from no library (only Python's API may be looked up when loaded)")
    libs = sorted({lib for _, lib in undefined if lib})
    python_api = sum(1 for _, lib in undefined if not lib)
    return (f"Mach-O {platform} for macOS {minos[0]}.{minos[1]}+, links {' '.join(dylibs)}; imports "
            f"{len(undefined) - python_api} symbols from {', '.join(libs)} and {python_api} of Python's API")


def check(wheel: Path, version: str, platform: str) -> str:
    m = re.fullmatch(r"csrbf-([^-]+)-(cp39)-(abi3)-(.+)\.whl", wheel.name)
    if not m:
        raise Refused(f"{wheel.name} is not named csrbf-VERSION-cp39-abi3-PLATFORM.whl")
    if m.group(1) != version:
        raise Refused(f"{wheel.name} is version {m.group(1)}, not {version}")
    tag = m.group(4)
    if not platform_ok(platform, tag):
        raise Refused(f"{wheel.name}'s platform tag {tag} is not a {platform} one")
    dist_info = f"csrbf-{version}.dist-info"
    with zipfile.ZipFile(wheel) as z:
        wheel_tags = {line.split(": ", 1)[1] for line in z.read(f"{dist_info}/WHEEL").decode().splitlines()
                      if line.startswith("Tag: ")}
        named = {f"cp39-abi3-{t}" for t in tag.split(".")}
        if wheel_tags != named:
            raise Refused(f"the WHEEL file's tags {sorted(wheel_tags)} are not the name's {sorted(named)}")
        check_record(z, dist_info)
        check_metadata(z, dist_info, version)
        module = "csrbf/_csrbf.pyd" if platform == "windows" else "csrbf/_csrbf.abi3.so"
        if module not in z.namelist():
            raise Refused(f"the wheel holds no {module}: {z.namelist()}")
        for needed in ("csrbf/__init__.py", "csrbf/_csrbf.pyi", "csrbf/py.typed", "csrbf/pyvista.py"):
            if needed not in z.namelist():
                raise Refused(f"the wheel holds no {needed}")
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / Path(module).name
            path.write_bytes(z.read(module))
            if platform == "linux":
                what = check_linux(path, wheel)
            elif platform == "windows":
                what = check_windows(path)
            else:
                what = check_macos(path, platform, tag)
    return f"{wheel.name}: tags {sorted(wheel_tags)}, metadata and RECORD sound; {what}"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("wheel", type=Path)
    parser.add_argument("--version", required=True)
    parser.add_argument("--platform", required=True, choices=["linux", "windows", "macos-arm64", "macos-x64"])
    args = parser.parse_args()
    try:
        print("check-wheel: " + check(args.wheel, args.version, args.platform))
    except (Refused, KeyError, zipfile.BadZipFile, OSError) as e:
        print(f"check-wheel: refused {args.wheel}: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
