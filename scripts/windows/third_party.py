#!/usr/bin/env python3
"""Prints the licences of every crate linked into csrbf and csrbf-studio for
TARGET (default x86_64-pc-windows-gnu): name, version, licence expression,
and the licence files the crate ships. Used by scripts/build-windows.sh for
the zip's licences/third-party.txt and by scripts/release.sh for the Linux
archive's."""
import glob
import json
import os
import subprocess
import sys

target = sys.argv[1] if len(sys.argv) > 1 else "x86_64-pc-windows-gnu"
meta = json.loads(subprocess.run(
    ["cargo", "metadata", "--format-version", "1", "--locked", "--filter-platform", target],
    check=True, capture_output=True, text=True).stdout)
packages = {p["id"]: p for p in meta["packages"]}
nodes = {n["id"]: n for n in meta["resolve"]["nodes"]}
members = set(meta["workspace_members"])
roots = [i for i in members if packages[i]["name"] in ("csrbf-cli", "csrbf-studio")]
# Normal (not dev, not build-only) dependencies, followed from the two programs.
seen, todo = set(), list(roots)
while todo:
    i = todo.pop()
    if i in seen:
        continue
    seen.add(i)
    for d in nodes[i]["deps"]:
        if any(k["kind"] is None for k in d["dep_kinds"]):
            todo.append(d["pkg"])
if "windows" in target:
    out = ["Third-party code linked into csrbf.exe and csrbf-studio.exe",
           "(crates from crates.io; Rust's standard library is MIT OR Apache-2.0;",
           "mingw-w64's runtime start-up code and libwinpthread are under the ZPL 2.1 / MIT-style",
           "licences of the mingw-w64 project; libgcc under the GCC Runtime Library Exception).", ""]
else:
    out = ["Third-party code linked into csrbf and csrbf-studio",
           "(crates from crates.io; Rust's standard library is MIT OR Apache-2.0; the",
           "programs load the system's own glibc, libgcc_s, X11/Wayland and Vulkan libraries,",
           "which are not shipped here).", ""]
crates = sorted((packages[i] for i in seen - members), key=lambda p: (p["name"], p["version"]))
for p in crates:
    out.append(f"{p['name']} {p['version']}: {p.get('license') or 'see its licence file'}")
out.append("")
# Each distinct licence text once, under the crates that ship it.
texts = {}
for p in crates:
    folder = os.path.dirname(p["manifest_path"])
    files = sorted(f for pat in ("LICEN[CS]E*", "COPYING*", "NOTICE*", "COPYRIGHT*")
                   for f in glob.glob(os.path.join(folder, pat)) if os.path.isfile(f))
    for f in files:
        with open(f, encoding="utf-8", errors="replace") as fh:
            text = fh.read().strip()
        texts.setdefault(text, []).append(f"{p['name']} {p['version']} ({os.path.basename(f)})")
for text, owners in texts.items():
    out.append("=" * 72)
    out.append("From: " + ", ".join(owners))
    out.append("=" * 72)
    out.append(text)
    out.append("")
print("\n".join(out))
