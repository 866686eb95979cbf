#!/usr/bin/env python3
"""csrbf.exe under Wine against the Linux csrbf of the same commit (issue 22).

Run by scripts/test_windows.sh, which installs what this needs. Every check
fails loudly; nothing is skipped. Both programs get the same inputs, run in
folders laid out alike and named by the same relative paths, so their
outputs, standard output included, can be compared as they are:

- deform, fit + apply, info --json, pick --json: byte-identical, else every
  number within 1e-6 of the head's bounding-box diagonal (file paths and
  counts exact). Byte-identical is what we expect and see: both programs
  run the same Rust code with the same IEEE arithmetic (no fast-math, the
  same AVX2+FMA dispatch on the same CPU); the tolerance is there so a
  rounding difference in a libm function (mingw's against glibc's) would
  be reported as the size it is rather than as a failure. What each check
  got is printed.
- render and animate (GIF frames and PNG frames): pictures of the right
  size, and pixels match within PIXEL_FUZZ per channel except at most
  PIXEL_SHARE of them (both draw through Mesa's lavapipe, the exe through
  Wine's Vulkan; edges may round differently).
- The CLI's bad-input tests (crates/csrbf-cli/tests/bad_input.rs) run
  against csrbf.exe: the same exit code (1) and messages naming the same
  file and line as they demand of the Linux binary.
- Windows paths: a drive letter (Z:\\...) with backslashes, a folder with
  spaces and non-ASCII letters, a scene file written with backslashes
  (opened by both), an output over an existing file, and one over a file
  another program holds open (refused with a clear message, old file kept).
- The studio: csrbf-studio.exe opens the head and the face scene in a real
  window under Xvfb; the screenshot must show the head drawn; its recent
  files land in %APPDATA%\\csrbf-studio.
"""
import argparse
import json
import math
import os
import shutil
import struct
import subprocess
import sys
import time

PIXEL_FUZZ = 0.10  # per channel, of full scale
PIXEL_SHARE = 0.01  # of the pixels may differ by more than PIXEL_FUZZ
TOLERANCE = 1e-6  # of the head's bounding-box diagonal

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
failures = []


def say(msg):
    print(f"test-windows: {msg}", flush=True)


def check(ok, what, detail=""):
    if ok:
        say(f"ok   {what}{': ' + detail if detail else ''}")
    else:
        say(f"FAIL {what}{': ' + detail if detail else ''}")
        failures.append(what)
    return ok


def run(cmd, cwd, env=None, timeout=600, stdin=None):
    return subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, timeout=timeout,
                          input=stdin)


class Programs:
    """The Linux binary and the exe under Wine, run the same way."""

    def __init__(self, linux, exe_dir, env):
        self.linux = linux
        self.exe_dir = exe_dir
        self.env = env

    def lin(self, args, cwd, **kw):
        return run([self.linux] + args, cwd, **kw)

    def win(self, args, cwd, exe="csrbf.exe", **kw):
        return run(["wine", os.path.join(self.exe_dir, exe)] + args, cwd, env=self.env, **kw)


def drawn(run, args, cwd, out):
    """Runs a command that draws through the software Vulkan driver (the exe
    through Wine's). A run that exits non-zero without a word is run once
    more, its output removed first, and said: csrbf prints every error it
    refuses with, so a silent exit is the driver or Wine dying (seen once in
    many runs of `animate` to PNG frames, not reproduced in ten more)."""
    r = run(args, cwd)
    if r.returncode != 0 and not r.stderr.strip():
        say(f"note {' '.join(args[:2])} in {os.path.basename(cwd)}: exit {r.returncode} "
            "without a message; run once more")
        target = os.path.join(cwd, out)
        if os.path.isdir(target):
            shutil.rmtree(target)
        elif os.path.exists(target):
            os.remove(target)
        r = run(args, cwd)
    return r


def outcome(a, b):
    """The exit codes and messages of a Linux and a Windows run."""
    text = (a.stderr + b.stderr).decode(errors="replace").strip()[:400]
    return f"exit {a.returncode} (Linux), {b.returncode} (Windows)" + (f": {text}" if text else "")


# ---------------------------------------------------------------- comparisons

def ply_positions(data):
    """x, y, z of every vertex of a PLY csrbf wrote (binary little-endian)."""
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode("ascii").splitlines()
    sizes = {"float": 4, "float32": 4, "double": 8, "float64": 8, "uchar": 1, "uint8": 1,
             "int": 4, "int32": 4, "uint": 4, "uint32": 4, "short": 2, "ushort": 2}
    codes = {"float": "f", "float32": "f", "double": "d", "float64": "d", "uchar": "B",
             "uint8": "B", "int": "i", "int32": "i", "uint": "I", "uint32": "I",
             "short": "h", "ushort": "H"}
    count, props, in_vertex = 0, [], False
    for line in header:
        w = line.split()
        if w[:2] == ["element", "vertex"]:
            count, in_vertex = int(w[2]), True
        elif w[0] == "element":
            in_vertex = False
        elif w[0] == "property" and in_vertex:
            props.append((w[2], w[1]))
    fmt = "<" + "".join(codes[t] for _, t in props)
    stride = sum(sizes[t] for _, t in props)
    names = [n for n, _ in props]
    xi, yi, zi = names.index("x"), names.index("y"), names.index("z")
    out = []
    for k in range(count):
        v = struct.unpack_from(fmt, data, end + k * stride)
        out.append((v[xi], v[yi], v[zi]))
    return out


def numbers(value):
    """Flattens JSON into (path, leaf) pairs."""
    if isinstance(value, dict):
        for k, v in value.items():
            for p, x in numbers(v):
                yield (f"{k}.{p}" if p else k), x
    elif isinstance(value, list):
        for i, v in enumerate(value):
            for p, x in numbers(v):
                yield (f"[{i}].{p}" if p else f"[{i}]"), x
    else:
        yield "", value


def same_json(a, b, tol):
    """None when equal within tol (numbers) and exact (the rest), else why."""
    try:
        ja, jb = json.loads(a), json.loads(b)
    except ValueError as e:
        return f"not JSON: {e}"
    la, lb = list(numbers(ja)), list(numbers(jb))
    if [p for p, _ in la] != [p for p, _ in lb]:
        return "different keys"
    worst = 0.0
    for (p, x), (_, y) in zip(la, lb):
        if p.endswith("_ms"):
            continue  # a timing, not a result
        if isinstance(x, float) or isinstance(y, float):
            if not isinstance(x, (int, float)) or not isinstance(y, (int, float)):
                return f"{p}: {x!r} against {y!r}"
            worst = max(worst, abs(x - y))
            if abs(x - y) > tol:
                return f"{p}: {x!r} against {y!r}"
        elif x != y:
            return f"{p}: {x!r} against {y!r}"
    return None


def compare_bytes_or_numbers(what, a, b, tol, kind):
    if a == b:
        return check(True, what, f"byte-identical ({len(a)} bytes)")
    if kind == "ply":
        pa, pb = ply_positions(a), ply_positions(b)
        if len(pa) != len(pb):
            return check(False, what, f"{len(pa)} vertices against {len(pb)}")
        worst = max(max(abs(x - y) for x, y in zip(u, v)) for u, v in zip(pa, pb))
        return check(worst <= tol, what, f"not byte-identical; largest difference {worst:.3g} "
                     f"(allowed {tol:.3g})")
    if kind == "json":
        why = same_json(a, b, tol)
        return check(why is None, what,
                     why or f"not byte-identical; numbers within {tol:.3g} (timings, *_ms, not compared)")
    return check(False, what, f"differs ({len(a)} against {len(b)} bytes)")


def identify(path):
    out = subprocess.run(["identify", "-format", "%w %h\n", path], capture_output=True,
                         text=True, check=True).stdout.split()
    return int(out[0]), int(out[1])


def differing_pixels(a, b):
    r = subprocess.run(["compare", "-metric", "AE", "-fuzz", f"{PIXEL_FUZZ * 100:g}%", a, b,
                        "null:"], capture_output=True, text=True)
    if r.returncode > 1:
        raise RuntimeError(r.stderr)
    return int(float(r.stderr.split()[0]))


def compare_pictures(what, a, b, size):
    wa, wb = identify(a), identify(b)
    if not check(wa == size and wb == size, f"{what}: size", f"{wa} and {wb}, want {size}"):
        return
    n = differing_pixels(a, b)
    share = n / (size[0] * size[1])
    check(share <= PIXEL_SHARE, f"{what}: pixels",
          f"{n} of {size[0] * size[1]} differ by more than {PIXEL_FUZZ:.0%} ({share:.3%}, "
          f"allowed {PIXEL_SHARE:.0%})")


def not_blank(path, what):
    """The picture has something other than its background drawn."""
    r = subprocess.run(["convert", path, "-format", "%[fx:standard_deviation]", "info:"],
                       capture_output=True, text=True, check=True)
    sd = float(r.stdout)
    return check(sd > 0.02, f"{what}: something is drawn", f"standard deviation {sd:.3f}")


# ---------------------------------------------------------------- the checks

def setup_side(base, name):
    d = os.path.join(base, name)
    os.makedirs(os.path.join(d, "out"))
    shutil.copy(os.path.join(ROOT, "assets/models/cgal_head.off"), os.path.join(d, "head.off"))
    shutil.copy(os.path.join(ROOT, "assets/controls/head_smile.json"), os.path.join(d, "smile.json"))
    return d


def numerics(p, base, tol):
    lin, win = setup_side(base, "lin"), setup_side(base, "win")
    steps = [
        ("deform (PLY)", ["deform", "--mesh", "head.off", "--controls", "smile.json", "--phase",
                          "0.8", "--out", "out/smile.ply", "-q"], "out/smile.ply", "ply"),
        ("deform --json (standard output)", ["deform", "--mesh", "head.off", "--controls",
                                             "smile.json", "--out", "out/smile2.ply", "--json",
                                             "-q"], None, "json"),
        ("fit (.csrbf)", ["fit", "--controls", "smile.json", "--out", "out/smile.csrbf", "-q"],
         "out/smile.csrbf", "bytes"),
        ("apply (PLY)", ["apply", "--mesh", "head.off", "--deformation", "out/smile.csrbf",
                         "--phase", "0.5", "--out", "out/applied.ply", "-q"], "out/applied.ply",
         "ply"),
        ("info --mesh --json", ["info", "--mesh", "head.off", "--json"], None, "json"),
        ("info --controls --mesh --json", ["info", "--controls", "smile.json", "--mesh",
                                           "head.off", "--json"], None, "json"),
        ("info --deformation --json", ["info", "--deformation", "out/smile.csrbf", "--json"],
         None, "json"),
        ("pick --json", ["pick", "--mesh", "head.off", "--controls", "smile.json", "--phase", "1",
                         "--pixel", "400,260", "--size", "800x600", "--json"], None, "json"),
        ("pick --json (front, orthographic)", ["pick", "--mesh", "head.off", "--view", "front",
                                               "--ortho", "--pixel", "330,200", "--size",
                                               "640x480", "--json"], None, "json"),
    ]
    for what, args, out, kind in steps:
        a, b = p.lin(args, lin), p.win(args, win)
        if not check(a.returncode == 0 and b.returncode == 0, f"{what}: both succeed",
                     f"exit {a.returncode} / {b.returncode}" if a.returncode == b.returncode == 0
                     else (a.stderr + b.stderr).decode(errors='replace').strip()[:400]):
            continue
        if out:
            with open(os.path.join(lin, out), "rb") as f:
                la = f.read()
            with open(os.path.join(win, out), "rb") as f:
                lb = f.read()
        else:
            la, lb = a.stdout, b.stdout
        compare_bytes_or_numbers(what, la, lb, tol, kind)
    # Each side's .csrbf replayed by the other program: the file moves between systems.
    a = p.lin(["apply", "--mesh", "head.off", "--deformation", "../win/out/smile.csrbf", "--phase",
               "0.5", "--out", "out/cross.ply", "-q"], lin)
    b = p.win(["apply", "--mesh", "head.off", "--deformation", "..\\lin\\out\\smile.csrbf",
               "--phase", "0.5", "--out", "out\\cross.ply", "-q"], win)
    if check(a.returncode == 0 and b.returncode == 0, "a .csrbf from the other system applies",
             (a.stderr + b.stderr).decode(errors="replace").strip()[:300]):
        for d in (lin, win):
            with open(os.path.join(d, "out/cross.ply"), "rb") as f, \
                    open(os.path.join(d, "out/applied.ply"), "rb") as g:
                compare_bytes_or_numbers(f"cross apply in {os.path.basename(d)}", f.read(),
                                         g.read(), tol, "ply")
    return lin, win


def pictures(p, lin, win):
    size = (320, 240)
    for what, extra in [("render", []), ("render --overlay --gizmo", ["--overlay", "--gizmo"])]:
        args = ["render", "--mesh", "head.off", "--controls", "smile.json", "--size", "320x240",
                "--out", "out/r.png", "-q"] + extra
        a, b = drawn(p.lin, args, lin, "out/r.png"), drawn(p.win, args, win, "out/r.png")
        if check(a.returncode == 0 and b.returncode == 0, f"{what}: both succeed",
                 outcome(a, b)):
            compare_pictures(what, os.path.join(lin, "out/r.png"), os.path.join(win, "out/r.png"),
                             size)
            not_blank(os.path.join(win, "out/r.png"), what)
    # The face scene, a short stretch of it, as a GIF and as PNG frames.
    scene = "scenes/face.scene.json"
    for d in (lin, win):
        os.makedirs(os.path.join(d, "scenes"))
        os.makedirs(os.path.join(d, "models"))
        os.makedirs(os.path.join(d, "controls"))
        shutil.copy(os.path.join(ROOT, "assets", scene), os.path.join(d, scene))
        shutil.copy(os.path.join(d, "head.off"), os.path.join(d, "models/cgal_head.off"))
        shutil.copy(os.path.join(d, "smile.json"), os.path.join(d, "controls/head_smile.json"))
    stretch = ["--size", "160x120", "--fps", "5", "--from", "0.8", "--to", "1.6", "-q"]
    for kind, out in [("GIF", "out/face.gif"), ("PNG frames", "out/frames/")]:
        args = ["animate", scene, "--out", out] + stretch
        a, b = drawn(p.lin, args, lin, out), drawn(p.win, args, win, out)
        if not check(a.returncode == 0 and b.returncode == 0, f"animate {kind}: both succeed",
                     outcome(a, b)):
            continue
        frames = {}
        for d in (lin, win):
            if kind == "GIF":
                split = os.path.join(d, "out/gif")
                os.makedirs(split)
                subprocess.run(["convert", os.path.join(d, out), "-coalesce",
                                os.path.join(split, "f%03d.png")], check=True)
            else:
                split = os.path.join(d, out)
            frames[d] = sorted(os.listdir(split))
        if check(frames[lin] == frames[win] and len(frames[lin]) == 5,
                 f"animate {kind}: frames", f"{len(frames[lin])} and {len(frames[win])}, want 5"):
            sub = "out/gif" if kind == "GIF" else out
            for f in frames[lin]:
                compare_pictures(f"animate {kind} {f}", os.path.join(lin, sub, f),
                                 os.path.join(win, sub, f), (160, 120))


def bad_inputs(env, cli_tests, work):
    """The CLI's bad-input tests, as they are, against csrbf.exe."""
    e = dict(env)
    e["CSRBF_TEST_EXE"] = os.path.join(e.pop("CSRBF_EXE_DIR"), "csrbf.exe")
    # Through scripts/windows/wine_run.sh: a run Wine ends silently is run
    # again (it says why), and every such retry is reported here.
    e["CSRBF_TEST_RUNNER"] = os.path.join(ROOT, "scripts", "windows", "wine_run.sh")
    retries = os.path.join(work, "wine-retries.txt")
    if os.path.exists(retries):
        os.remove(retries)
    e["CSRBF_WINE_RETRIES"] = retries
    r = subprocess.run([cli_tests, "bad_input::", "--test-threads", "2"], cwd=ROOT, env=e,
                       capture_output=True, text=True)
    summary = [line for line in r.stdout.splitlines() if line.startswith("test ")]
    check(r.returncode == 0 and any("bad_input::" in line for line in summary),
          "the CLI's bad-input tests on csrbf.exe",
          "; ".join(summary) if r.returncode == 0 else (r.stdout + r.stderr)[-3000:])
    if os.path.exists(retries):
        with open(retries) as f:
            lines = f.read().splitlines()
        say(f"note: Wine ended {len(lines)} run(s) silently, each run again: " + " | ".join(lines))


def windows_paths(p, base, lin, win, tol):
    with open(os.path.join(lin, "out/smile.ply"), "rb") as f:
        want = f.read()

    def same_as_linux(what, path):
        if not os.path.exists(path):
            return check(False, what, f"{path} was not written")
        with open(path, "rb") as f:
            return compare_bytes_or_numbers(what, want, f.read(), tol, "ply")

    deform = ["deform", "--phase", "0.8", "-q"]
    # A drive letter and backslashes (Wine maps / to Z:).
    z = lambda path: "Z:" + path.replace("/", "\\")
    r = p.win(deform + ["--mesh", z(os.path.join(win, "head.off")), "--controls",
                        z(os.path.join(win, "smile.json")), "--out",
                        z(os.path.join(win, "out/drive.ply"))], base)
    if check(r.returncode == 0, "a drive-letter path with backslashes",
             r.stderr.decode(errors="replace").strip()[:300]):
        same_as_linux("a drive-letter path: same mesh", os.path.join(win, "out/drive.ply"))
    # Spaces and non-ASCII letters in folder and file names.
    odd = os.path.join(base, "dossier à espaces", "tête ñ")
    os.makedirs(odd)
    shutil.copy(os.path.join(win, "head.off"), os.path.join(odd, "tête.off"))
    shutil.copy(os.path.join(win, "smile.json"), os.path.join(odd, "sourire ü.json"))
    r = p.win(deform + ["--mesh", os.path.join(odd, "tête.off"), "--controls",
                        z(os.path.join(odd, "sourire ü.json")), "--out",
                        os.path.join(odd, "résultat ø.ply")], base)
    if check(r.returncode == 0, "spaces and non-ASCII letters in paths",
             r.stderr.decode(errors="replace").strip()[:300]):
        same_as_linux("spaces and non-ASCII: same mesh", os.path.join(odd, "résultat ø.ply"))
    # An error about such a file names it as given.
    with open(os.path.join(odd, "cassé é.obj"), "w") as f:
        f.write("v 0 0 0\nv 1 0\n")
    r = p.win(["deform", "--mesh", z(os.path.join(odd, "cassé é.obj")), "--controls",
               "smile.json", "--out", "out\\never.ply"], win)
    msg = r.stderr.decode("utf-8", errors="replace")
    check(r.returncode == 1 and "cassé é.obj:2" in msg and "panicked" not in msg,
          "a bad file under a non-ASCII path is named with its line", msg.strip()[:300])
    # A scene written on Windows (backslashes) opens in both programs.
    scene_dir = os.path.join(base, "winscene")
    os.makedirs(os.path.join(scene_dir, "scenes"))
    os.makedirs(os.path.join(scene_dir, "models"))
    shutil.copy(os.path.join(win, "head.off"), os.path.join(scene_dir, "models/head.off"))
    shutil.copy(os.path.join(win, "smile.json"), os.path.join(scene_dir, "models/smile.json"))
    with open(os.path.join(ROOT, "assets/scenes/face.scene.json")) as f:
        text = f.read()
    text = text.replace('"../models/cgal_head.off"', '"..\\\\models\\\\head.off"')
    text = text.replace('"../controls/head_smile.json"', '"..\\\\models\\\\smile.json"')
    with open(os.path.join(scene_dir, "scenes/win.scene.json"), "w") as f:
        f.write(text)
    args = ["animate", "scenes/win.scene.json", "--size", "160x120", "--fps", "2", "--from", "1",
            "--to", "1.5", "-q"]
    a = p.lin(args + ["--out", "lin/"], scene_dir)
    b = p.win(args + ["--out", "win\\"], scene_dir)
    if check(a.returncode == 0 and b.returncode == 0,
             "a scene written with backslashes opens on Linux and Windows",
             (a.stderr + b.stderr).decode(errors="replace").strip()[:400]):
        for f in sorted(os.listdir(os.path.join(scene_dir, "lin"))):
            compare_pictures(f"backslash scene {f}", os.path.join(scene_dir, "lin", f),
                             os.path.join(scene_dir, "win", f), (160, 120))
    # An output over an existing file replaces it whole, leaving no temporary.
    target = os.path.join(win, "out/existing.ply")
    with open(target, "w") as f:
        f.write("old")
    r = p.win(deform + ["--mesh", "head.off", "--controls", "smile.json", "--out",
                        "out\\existing.ply"], win)
    if check(r.returncode == 0, "an output over an existing file",
             r.stderr.decode(errors="replace").strip()[:300]):
        same_as_linux("the existing file replaced whole", target)
    leftovers = [f for f in os.listdir(os.path.join(win, "out")) if f.startswith(".csrbf-")]
    check(not leftovers, "no temporary left beside the outputs", ", ".join(leftovers))
    # An output another program holds open: refused, said plainly, the old file kept.
    with open(target, "w") as f:
        f.write("old")
    hold = subprocess.Popen(["wine", os.path.join(base, "hold.exe"), "out\\existing.ply"],
                            cwd=win, env=p.env, stdin=subprocess.PIPE, stdout=subprocess.PIPE)
    try:
        first = hold.stdout.readline().decode().strip()
        if check(first == "held", "a Windows program holds the output open", first):
            r = p.win(deform + ["--mesh", "head.off", "--controls", "smile.json", "--out",
                                "out\\existing.ply"], win)
            msg = r.stderr.decode(errors="replace")
            check(r.returncode == 1 and "another program has it open" in msg
                  and "existing.ply" in msg,
                  "replacing a file held open fails with a clear message", msg.strip()[:300])
            with open(target) as f:
                check(f.read() == "old", "the held file is kept as it was")
            leftovers = [f for f in os.listdir(os.path.join(win, "out"))
                         if f.startswith(".csrbf-")]
            check(not leftovers, "no temporary left after the refusal", ", ".join(leftovers))
    finally:
        hold.stdin.close()
        hold.wait(timeout=60)


def ffmpeg_lookup(p, base, win):
    """ffmpeg.exe is found in a folder of the Windows PATH (a stand-in that
    writes a fixed file), and its absence is a clear message."""
    env = dict(p.env)
    env.pop("CSRBF_FFMPEG", None)
    # No Unix PATH for Wine to pass on (wine64 by its full path needs none).
    env["PATH"] = "/nonexistent"
    wine64 = "/usr/lib/wine/wine64"
    args = [wine64, os.path.join(p.exe_dir, "csrbf.exe"), "animate", "scenes/face.scene.json",
            "--size", "64x48", "--to", "0.2", "-q"]
    r = run(args + ["--out", "out/none.mp4"], win, env=env)
    msg = r.stderr.decode(errors="replace")
    check(r.returncode == 1 and "ffmpeg.exe" in msg and "PATH" in msg
          and not os.path.exists(os.path.join(win, "out/none.mp4")),
          "MP4 without ffmpeg.exe on the PATH: a clear message, no file", msg.strip()[:300])
    folder = os.path.join(base, "tools dir")
    os.makedirs(folder)
    shutil.copy(os.path.join(base, "fake_ffmpeg.exe"), os.path.join(folder, "ffmpeg.exe"))
    env["WINEPATH"] = "Z:\\nonexistent;Z:" + folder.replace("/", "\\")
    r = run(args + ["--out", "out/fake.mp4"], win, env=env)
    out = os.path.join(win, "out/fake.mp4")
    got = open(out, "rb").read() if os.path.exists(out) else b""
    check(r.returncode == 0 and got.startswith(b"fake ffmpeg.exe"),
          "ffmpeg.exe found in a folder of the PATH",
          r.stderr.decode(errors="replace").strip()[:300])


def studio(p, base, display):
    """csrbf-studio.exe in a real window under Xvfb: the head, then a scene."""
    user = os.environ.get("USER") or "root"
    appdata = os.path.join(p.env["WINEPREFIX"], "drive_c/users", user, "AppData/Roaming",
                           "csrbf-studio")
    shutil.rmtree(appdata, ignore_errors=True)
    for what, arg in [("head", os.path.join(ROOT, "assets/models/cgal_head.off")),
                      ("face scene", os.path.join(ROOT, "assets/scenes/face.scene.json"))]:
        log = open(os.path.join(base, f"studio-{what.replace(' ', '-')}.log"), "w")
        env = dict(p.env)
        env.pop("CSRBF_STUDIO_STATE", None)
        # Wine's Direct3D 12 (vkd3d) on lavapipe loses its device at once
        # ("Parent device is lost"); its Vulkan, as the CLI uses, works.
        env["WGPU_BACKEND"] = "vulkan"
        app = subprocess.Popen(["wine", os.path.join(p.exe_dir, "csrbf-studio.exe"), arg,
                                "--size", "1024x700"], cwd=base, env=env, stdout=log,
                               stderr=log)
        shot = os.path.join(base, f"studio-{what.replace(' ', '-')}.png")
        drawn = False
        # Wait for the window and its first frames (Wine and lavapipe start slowly).
        end = time.time() + 180
        while time.time() < end and app.poll() is None:
            time.sleep(5)
            r = subprocess.run(["import", "-display", display, "-window", "root", shot],
                               capture_output=True)
            if r.returncode == 0 and head_drawn(shot):
                drawn = True
                time.sleep(3)
                subprocess.run(["import", "-display", display, "-window", "root", shot])
                break
        alive = app.poll() is None
        app.terminate()
        try:
            app.wait(timeout=20)
        except subprocess.TimeoutExpired:
            app.kill()
            app.wait()
        subprocess.run(["wineserver", "-k"], env=p.env)
        log.close()
        check(alive, f"studio ({what}) runs", "" if alive else open(log.name).read()[-800:])
        check(drawn, f"studio ({what}) draws the head (screenshot {shot})")
    recent = os.path.join(appdata, "recent.txt")
    if check(os.path.isfile(recent), "the studio keeps its recent files in %APPDATA%\\csrbf-studio",
             recent):
        with open(recent, encoding="utf-8") as f:
            lines = f.read().splitlines()
        check(len(lines) == 2 and all(line.startswith("Z:\\") for line in lines),
              "the recent files are plain Windows paths (no \\\\?\\)", "; ".join(lines))


def head_drawn(png):
    """Skin-coloured pixels (the Picker's beige head, the face scene's skin:
    r > g > b; the UI is grey, the viewport's background bluish grey) cover
    at least 0.5 % of the screen (the scene's head covers about 2 %, the
    Picker's 10 %)."""
    r = subprocess.run(["convert", png, "-fx", "(r>g+0.04 && g>b && r>0.25) ? 1 : 0",
                        "-format", "%[fx:mean]", "info:"], capture_output=True, text=True)
    try:
        share = float(r.stdout)
    except ValueError:
        return False
    return share > 0.005


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--linux", required=True, help="the Linux csrbf of this commit")
    ap.add_argument("--cli-tests", required=True, help="the CLI's test binary (tests/tests.rs)")
    ap.add_argument("--exe-dir", required=True, help="folder of csrbf.exe and csrbf-studio.exe")
    ap.add_argument("--work", required=True, help="a scratch folder (emptied)")
    ap.add_argument("--prefix", required=True, help="the Wine prefix to use (made if missing)")
    ap.add_argument("--display", required=True, help="the X display (Xvfb)")
    ap.add_argument("--skip-studio", action="store_true")
    a = ap.parse_args()
    env = dict(os.environ, WINEPREFIX=a.prefix, WINEDEBUG="-all", DISPLAY=a.display,
               CSRBF_EXE_DIR=a.exe_dir)
    env.pop("WAYLAND_DISPLAY", None)
    p = Programs(a.linux, a.exe_dir, env)
    base = a.work
    for helper in ("hold.exe", "fake_ffmpeg.exe"):
        shutil.copy(os.path.join(os.path.dirname(a.prefix), helper), os.path.join(base, helper))
    with open(os.path.join(ROOT, "assets/models/cgal_head.off")) as f:
        f.readline()
        nv = int(f.readline().split()[0])
        pts = [tuple(map(float, f.readline().split()[:3])) for _ in range(nv)]
    diag = math.dist([min(c) for c in zip(*pts)], [max(c) for c in zip(*pts)])
    tol = TOLERANCE * diag
    say(f"tolerance {tol:.3g} (1e-6 of the head's diagonal {diag:.4g}); pictures: at most "
        f"{PIXEL_SHARE:.0%} of pixels off by more than {PIXEL_FUZZ:.0%}")
    lin, win = numerics(p, base, tol)
    pictures(p, lin, win)
    windows_paths(p, base, lin, win, tol)
    ffmpeg_lookup(p, base, win)
    bad_inputs(env, a.cli_tests, base)
    if not a.skip_studio:
        studio(p, base, a.display)
    if failures:
        say(f"{len(failures)} check(s) failed: " + "; ".join(failures))
        sys.exit(1)
    say("every check passed")


if __name__ == "__main__":
    main()
