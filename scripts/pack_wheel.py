"""Packs the Python package laid out by scripts/test_python.sh (python/csrbf
plus the cdylib cargo built, as _csrbf.abi3.so) into a wheel, the way maturin
lays it out, without a second cargo build:

    python scripts/pack_wheel.py target/py-test VERSION target/py-wheels

The tag is cp39-abi3-<this platform> (a local build, as `pip wheel` tags
one); releases are built by maturin (`pip install crates/csrbf-py`,
scripts/build-blender-extension.sh).
"""

import base64
import hashlib
import sys
import sysconfig
import zipfile
from pathlib import Path


def main(src: str, version: str, out_dir: str) -> None:
    root = Path(src)
    platform = sysconfig.get_platform().replace("-", "_").replace(".", "_")
    tag = f"cp39-abi3-{platform}"
    dist = f"csrbf-{version}.dist-info"
    files = {
        p.relative_to(root).as_posix(): p.read_bytes()
        for p in sorted(root.rglob("*"))
        if p.is_file() and "__pycache__" not in p.parts
    }
    files[f"{dist}/METADATA"] = (
        "Metadata-Version: 2.1\n"
        f"Name: csrbf\nVersion: {version}\n"
        "Summary: Real-time mesh deformation with compactly supported radial basis functions\n"
        "Requires-Python: >=3.9\nRequires-Dist: numpy>=1.26\n"
    ).encode()
    files[f"{dist}/WHEEL"] = (
        f"Wheel-Version: 1.0\nGenerator: csrbf scripts/pack_wheel.py\nRoot-Is-Purelib: false\nTag: {tag}\n"
    ).encode()
    record = []
    for name, data in files.items():
        digest = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
        record.append(f"{name},sha256={digest},{len(data)}")
    record.append(f"{dist}/RECORD,,")
    files[f"{dist}/RECORD"] = ("\n".join(record) + "\n").encode()
    out = Path(out_dir) / f"csrbf-{version}-{tag}.whl"
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_suffix(".tmp")
    with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as z:
        for name, data in files.items():
            info = zipfile.ZipInfo(name, date_time=(2020, 1, 1, 0, 0, 0))
            info.external_attr = (0o755 if name.endswith(".so") else 0o644) << 16
            info.compress_type = zipfile.ZIP_DEFLATED
            z.writestr(info, data)
    tmp.replace(out)
    print(out)


if __name__ == "__main__":
    main(*sys.argv[1:])
