#!/usr/bin/env python3
"""Packs the folder STAGE into the zip OUT, whole or not at all: written
beside OUT as OUT.tmp, then renamed. Paths in the zip are relative to STAGE.
Used by build-windows.sh."""
import os
import sys
import zipfile

stage, out = sys.argv[1], sys.argv[2]
tmp = out + ".tmp"
with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as z:
    for root, dirs, files in os.walk(stage):
        dirs.sort()
        for f in sorted(files):
            path = os.path.join(root, f)
            z.write(path, os.path.relpath(path, stage))
os.replace(tmp, out)
