# Sourced: headless Blender (the bpy module, about 375 MB, CPython 3.11 only)
# in a venv kept in the user's cache, made and filled only when missing or
# when blender/requirements.txt changed, so it is downloaded once per machine.
# Sets blender_python (the venv's Python, which imports bpy) and
# blender_ext_cli (Blender's own extension tool, blender_ext.py, shipped in
# bpy: it builds and validates extension zips as Blender does).
blender_py="${PYTHON:-python3}"
if ! "$blender_py" -c 'import sys; sys.exit(sys.version_info[:2] != (3, 11))'; then
  echo "blender: bpy 5.0.1 needs CPython 3.11, this is $("$blender_py" --version) (set PYTHON to a 3.11)" >&2
  exit 1
fi
blender_venv="${CSRBF_BLENDER_VENV:-${XDG_CACHE_HOME:-$HOME/.cache}/csrbf/venv-blender}"
[ -x "$blender_venv/bin/python" ] || { mkdir -p "$(dirname "$blender_venv")"; "$blender_py" -m venv "$blender_venv"; }
if ! cmp -s blender/requirements.txt "$blender_venv/.requirements"; then
  echo "blender: installing $(grep -v '^#' blender/requirements.txt | tr '\n' ' ')into $blender_venv"
  "$blender_venv/bin/python" -m pip install -q --disable-pip-version-check -r blender/requirements.txt
  cp blender/requirements.txt "$blender_venv/.requirements"
fi
blender_python="$blender_venv/bin/python"
blender_ext_cli=$(ls "$blender_venv"/lib/python3*/site-packages/bpy/*/scripts/addons_core/bl_pkg/cli/blender_ext.py)
